// Kata.cs - C# binding of kata's C ABI (sdk/include/kata/kata.h, which is the manual: units, ownership
// and thread rules are the C functions'). One file, no unsafe code, no dependency beyond mscorlib:
// drop it into a Unity project's Assets/ next to the native library (Assets/Plugins/...).
//
// Layers:
//   Kata.Native    one [DllImport] per C function (Cdecl, blittable arguments, UTF-8 strings as byte[]).
//   *Handle        a SafeHandle per C handle type: released exactly once, by Dispose or the finalizer.
//                  Objects made from a context hold a reference on its handle, so the context is
//                  destroyed only after them (kata.h requires that order).
//   Context, Stream, ...   thin objects over the handles; a failed call throws KataException with
//                  the status and the C message (kata_*_last_error).
// No delegate is ever passed to native code. The first Context checks kata_version() against
// ExpectedMajor and refuses another major with KataVersionException.
using System;
using System.Runtime.InteropServices;
using System.Text;
using System.Threading;
using Microsoft.Win32.SafeHandles;

namespace Kata
{
    public enum Status
    {
        Ok = 0, NoData = 1, InvalidArgument = 2, NullPointer = 3, WrongJointCount = 4, NonFinite = 5,
        TimestampNotIncreasing = 6, Parse = 7, Io = 8, Model = 9, NotFound = 10, OutOfMemory = 11,
        BufferTooSmall = 12, Internal = 13, State = 14, TrackingLost = 15, Stopped = 16, QueueFull = 17,
        NoClipTeacher = 18
    }

    public enum Stencil { Backward = 0, Central = 1 }
    public enum UpAxis { Y = 0, Z = 1 }
    public enum BodyPart { TorsoHead = 0, LeftArm = 1, RightArm = 2, LeftLeg = 3, RightLeg = 4 }

    // kata_humanoid_bone (kata/humanoid.h): the VRM humanoid bones, in the C ABI's order.
    public enum HumanoidBone
    {
        Hips = 0, Spine = 1, Chest = 2, UpperChest = 3, Neck = 4, Head = 5,
        LeftShoulder = 6, LeftUpperArm = 7, LeftLowerArm = 8, LeftHand = 9,
        RightShoulder = 10, RightUpperArm = 11, RightLowerArm = 12, RightHand = 13,
        LeftUpperLeg = 14, LeftLowerLeg = 15, LeftFoot = 16, LeftToes = 17,
        RightUpperLeg = 18, RightLowerLeg = 19, RightFoot = 20, RightToes = 21
    }

    // kata_humanoid_frame: the rig's own right-handed Y-up metres, or Unity's left-handed mirror (as VMC sends).
    public enum HumanoidFrame { RightHanded = 0, Unity = 1 }

    public static class Gpd
    {
        public const int Dims = 1683;   // KATA_GPD_DIMS
        public const int Joints = 16;   // KATA_GPD_JOINTS
        public const int PartCount = 5; // KATA_PART_COUNT
    }

    // ---- structs: field for field as in kata.h (x86-64 and arm64 natural alignment) -------------------

    [StructLayout(LayoutKind.Sequential)]
    public struct StreamDesc
    {
        public uint StructSize;
        public IntPtr Layout;          // const char*: set by Context.OpenStream from a string
        public IntPtr NameMapPath;     // const char*
        public Stencil Stencil;
        public UpAxis UpAxis;
        public double MaxGap;
        public uint HistoryCapacity;
        public double BodyHeight;
        public uint CalibrationFrames;
        public uint ResultCapacity;
        public int KeepFeatures;
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct RetargetDesc
    {
        public uint StructSize;
        public IntPtr JointSet;        // const char*
        public double GradientTolerance;
        public uint MaxIterations;
        public int WarmStart;
        public int RestoreBoneLengths;
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct RetargetInfo
    {
        public uint StructSize;
        public uint Iterations;
        public int Converged;
        public int Warm;
        public double Stress;
        public double MaxBoneErrorSolved;
        public double MaxBoneError;
    }

    // kata_humanoid_desc (kata/humanoid.h).
    [StructLayout(LayoutKind.Sequential)]
    public struct HumanoidDesc
    {
        public uint StructSize;
        public IntPtr Layout;          // const char*
        public UpAxis UpAxis;
        public double MetresPerUnit;   // 0: the layout's
    }

    // kata_vmc_counters (kata/vmc.h): what a VmcReader counted; a refused datagram once more by its cause.
    [StructLayout(LayoutKind.Sequential)]
    public struct VmcCounters
    {
        public uint StructSize;
        public uint Reserved;
        public ulong Packets, Frames, Malformed, Oversized, WrongType, UnknownBone, BadValue, OutOfOrder, Ignored;
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct TeacherDesc
    {
        public uint StructSize;
        public IntPtr Model;           // kata_model
        public IntPtr Clip;            // kata_clip
        public IntPtr Skeleton;        // kata_skeleton
        public IntPtr Positions;       // const float*
        public uint Frames;
        public double FrameTime;
        public IntPtr Layout;          // const char*
        public uint FirstFrame;
        public int PoseFrame;
        public int Ghost;
        public IntPtr Retarget;        // const kata_retarget_desc*
        public IntPtr Features;        // const float*: Frames x Gpd.Dims
        public IntPtr Joints;          // const float*: the 16 GPD joints x 3, one held pose
        public double BodyHeight;
        // ---- 1.1 ----
        public int GhostAcross;        // 1: the ghost across layouts (16 GPD joints in the student stream's axes)
        public double AlignmentWindow; // the alignment's window, teacher seconds (default 0.5)
        public IntPtr OnProgress;      // kata_progress_callback, or IntPtr.Zero (not set from C#)
        public IntPtr OnProgressUser;
    }

    // kata_result_record (kata/result.h): one result of a stream (or a runtime message), its score included.
    [StructLayout(LayoutKind.Sequential)]
    public struct ResultRecord
    {
        public uint StructSize;
        public int Scored;                 // 1: a teacher scored the frame
        public ulong StreamId;
        public ulong ResultSequence;
        public ulong FrameSequence;
        public long FrameIndex;
        public double CaptureTime;         // seconds, the source's clock
        public long ArrivalNs;
        public long ComputedNs;
        public long PublishedNs;
        public int MatchedTeacherFrame;
        public int State;                  // a ScoreState
        public double MatchedTeacherTime;
        public float Distance;
        public float Score;
        // float parts[KATA_PART_COUNT] and part_scores[] as five fields each: blittable without unsafe code.
        public float PartTorsoHead, PartLeftArm, PartRightArm, PartLeftLeg, PartRightLeg;
        public float PartScoreTorsoHead, PartScoreLeftArm, PartScoreRightArm, PartScoreLeftLeg, PartScoreRightLeg;
        public int PartToFix;
        public uint GhostJointCount;
        public IntPtr Ghost;               // NULL for a stream's results (ghosts go to the batch's array)
        public int HasPractice;
        public uint PracticeRevision;
        public double PracticeStartTime;
        public double PracticeEndTime;
        public int PracticeLoop;
        public uint Reserved0;
        // The correction cue (kata.h "Score calibration and feedback"), present iff PartToFix >= 0:
        // the GPD joint to move (-1: none; Native.GpdJointName), the angle at it in degrees, the
        // kata_cue_action (0 bend, 1 straighten, 2 raise, 3 lower, 4 turn; -1: none). Native.CueText
        // gives the phrase ("left knee: bend 30 deg more").
        public int CueJoint;
        public float CueDegrees;
        public int CueAction;
        public uint Reserved1;
        // ---- 1.1, later: repetitions (docs/coach/repetitions.md) ----
        public int Repetition;             // the repetition in progress: 1 + the complete ones (0 without a clip teacher)
        public float RepetitionProgress;   // where the match is in the teacher's section, 0..1

        public float Part(BodyPart p)
        {
            switch (p)
            {
                case BodyPart.TorsoHead: return PartTorsoHead;
                case BodyPart.LeftArm: return PartLeftArm;
                case BodyPart.RightArm: return PartRightArm;
                case BodyPart.LeftLeg: return PartLeftLeg;
                default: return PartRightLeg;
            }
        }
    }

    // kata_repetition (kata/result.h, 1.1): one repetition of the teacher's section, complete or partial.
    // The eight ranges (degrees, kata_rom_joint order) as named fields: blittable without unsafe code.
    [StructLayout(LayoutKind.Sequential)]
    public struct Repetition
    {
        public uint StructSize;
        public int Index;                  // 1, 2, 3...; a partial one: the index the attempt would have had
        public ulong StreamId;             // 0 for a stream's
        public double StartTime;           // student seconds
        public double EndTime;
        public double Tempo;               // duration / the teacher section's (1.2: 20 % slower)
        public float Score;                // mean total score
        public int Partial;                // 1: abandoned before the end, not counted
        public int PartToFix;              // a BodyPart, -1 for none
        public int CueJoint;               // GPD joint, -1 for none
        public float CueDegrees;
        public int CueAction;              // kata_cue_action, -1 for none
        public float RangeLeftKnee, RangeRightKnee, RangeLeftHip, RangeRightHip,
                     RangeLeftElbow, RangeRightElbow, RangeLeftShoulder, RangeRightShoulder;
        public float TeacherRangeLeftKnee, TeacherRangeRightKnee, TeacherRangeLeftHip, TeacherRangeRightHip,
                     TeacherRangeLeftElbow, TeacherRangeRightElbow, TeacherRangeLeftShoulder, TeacherRangeRightShoulder;
        public float Coverage;             // the fraction of the section gone through, 0..1
        public uint Reserved0;
    }

    // kata_people_desc (kata/people.h, 1.1): how a people tracker tracks. Fill with People.DefaultDesc.
    [StructLayout(LayoutKind.Sequential)]
    public struct PeopleDesc
    {
        public uint StructSize;
        public uint JointCount;            // joints per pose (1..4096); no default
        public uint MaxPeople;             // streams open at once (1..64); 8
        public uint MaxPoses;              // poses of a frame taken, the most confident first (1..64); 16
        public double ForgetSeconds;       // a stream unseen for longer closes; 3
        public double CoastSeconds;        // a hidden person's predicted motion runs this long; 1
        public double Gate;                // body sizes a pose may lie from a stream seen the frame before; 1
        public double GateGrowth;          // body sizes per second unseen the gate widens by; 2
        public double SizeGate;            // a pose's size within [1/SizeGate, SizeGate] x the stream's; 1.5
        public double ShapeWeight;         // weight of the shape term in the cost; 1
        public double MinConfidence;       // joints less confident are ignored; 0.3
    }

    // kata_people_counters (1.1): what a tracker did since it was created, refusals by cause.
    [StructLayout(LayoutKind.Sequential)]
    public struct PeopleCounters
    {
        public uint StructSize;
        public uint OpenStreams;           // streams open now (seen or hidden)
        public ulong Frames;               // frames accepted
        public ulong EmptyFrames;          // accepted frames without a pose
        public ulong RefusedFrames;        // time not finite or not after the previous frame's
        public ulong Poses;                // poses in accepted frames
        public ulong Assigned;             // poses given a stream
        public ulong Opened;               // streams opened
        public ulong Closed;               // streams closed (unseen for longer than ForgetSeconds)
        public ulong RefusedNonFinite;     // a NaN or infinite confident joint or confidence
        public ulong RefusedOutOfRange;    // a confident joint beyond KATA_MAX_COORDINATE
        public ulong RefusedFewJoints;     // fewer than 3 confident joints, or all on one point
        public ulong RefusedTooManyPoses;  // beyond MaxPoses in a frame (the least confident)
        public ulong RefusedTableFull;     // new people while MaxPeople streams were open
    }

    // ---- errors ------------------------------------------------------------------------------------------

    public class KataException : Exception
    {
        public readonly Status Status;
        public readonly string NativeMessage;
        public KataException(Status status, string message, string call)
            : base(call + ": " + Native.StatusName(status) + ": " + message)
        {
            Status = status;
            NativeMessage = message;
        }
    }

    public class KataVersionException : Exception
    {
        public KataVersionException(string message) : base(message) { }
    }

    // ---- the C functions ---------------------------------------------------------------------------------

    public static class Native
    {
        // "kata": libkata.so on Linux/Android, kata.dll on Windows, libkata.dylib on macOS. iOS links
        // native plugins statically into the player, where P/Invoke must name "__Internal".
#if UNITY_IOS && !UNITY_EDITOR
        public const string Lib = "__Internal";
#else
        public const string Lib = "kata";
#endif
        private const CallingConvention CC = CallingConvention.Cdecl;

        [DllImport(Lib, CallingConvention = CC)] public static extern uint kata_version();
        [DllImport(Lib, CallingConvention = CC)] public static extern IntPtr kata_status_string(Status status);
        [DllImport(Lib, CallingConvention = CC)] public static extern IntPtr kata_gpd_joint_name(int joint);
        [DllImport(Lib, CallingConvention = CC)] public static extern int kata_gpd_joint_part(int joint);
        [DllImport(Lib, CallingConvention = CC)] public static extern IntPtr kata_body_part_name(int part);
        [DllImport(Lib, CallingConvention = CC)] public static extern IntPtr kata_gpd_joint_words(int joint);
        [DllImport(Lib, CallingConvention = CC)] public static extern int kata_stream_gpd_joint_source(StreamHandle stream, uint gpdJoint);
        [DllImport(Lib, CallingConvention = CC)]
        public static extern UIntPtr kata_cue_text(ref ResultRecord record, byte[] buf, UIntPtr size);

        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_context_create(out ContextHandle ctx);
        [DllImport(Lib, CallingConvention = CC)] public static extern void kata_context_destroy(IntPtr ctx);
        [DllImport(Lib, CallingConvention = CC)] public static extern IntPtr kata_context_last_error(ContextHandle ctx);

        [DllImport(Lib, CallingConvention = CC)]
        public static extern Status kata_skeleton_create(ContextHandle ctx, uint jointCount, IntPtr[] names,
                                                         int[] parents, double[] restOffsets, out SkeletonHandle skeleton);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_skeleton_load_bvh(ContextHandle ctx, byte[] path, out SkeletonHandle skeleton);
        [DllImport(Lib, CallingConvention = CC)] public static extern void kata_skeleton_destroy(IntPtr skeleton);
        [DllImport(Lib, CallingConvention = CC)] public static extern uint kata_skeleton_joint_count(SkeletonHandle skeleton);
        [DllImport(Lib, CallingConvention = CC)] public static extern IntPtr kata_skeleton_joint_name(SkeletonHandle skeleton, uint i);
        [DllImport(Lib, CallingConvention = CC)] public static extern int kata_skeleton_joint_parent(SkeletonHandle skeleton, uint i);

        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_clip_load_bvh(ContextHandle ctx, byte[] path, out ClipHandle clip);
        [DllImport(Lib, CallingConvention = CC)] public static extern void kata_clip_destroy(IntPtr clip);
        [DllImport(Lib, CallingConvention = CC)] public static extern uint kata_clip_frame_count(ClipHandle clip);
        [DllImport(Lib, CallingConvention = CC)] public static extern double kata_clip_frame_time(ClipHandle clip);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_clip_skeleton(ClipHandle clip, out SkeletonHandle skeleton);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_clip_positions(ClipHandle clip, uint frame, [Out] float[] xyz, UIntPtr capacity);

        [DllImport(Lib, CallingConvention = CC)] public static extern void kata_stream_desc_init_sized(ref StreamDesc desc, uint structSize);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_stream_open(ContextHandle ctx, SkeletonHandle skeleton, ref StreamDesc desc, out StreamHandle stream);
        [DllImport(Lib, CallingConvention = CC)] public static extern void kata_stream_destroy(IntPtr stream);
        [DllImport(Lib, CallingConvention = CC)] public static extern IntPtr kata_stream_last_error(StreamHandle stream);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_stream_push(StreamHandle stream, double timestamp, float[] xyz, uint jointCount);
        [DllImport(Lib, CallingConvention = CC, EntryPoint = "kata_stream_push")]
        public static extern Status kata_stream_push_ptr(StreamHandle stream, double timestamp, IntPtr xyz, uint jointCount);  // NativeArray etc.
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_stream_flush(StreamHandle stream);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_stream_reset(StreamHandle stream);
        [DllImport(Lib, CallingConvention = CC)]
        public static extern Status kata_stream_features(StreamHandle stream, [Out] float[] features, UIntPtr capacity,
                                                         out double timestamp, out long frameIndex);
        [DllImport(Lib, CallingConvention = CC)] public static extern long kata_stream_feature_count(StreamHandle stream);
        [DllImport(Lib, CallingConvention = CC)] public static extern double kata_stream_body_height(StreamHandle stream);

        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_model_load(ContextHandle ctx, byte[] path, out ModelHandle model);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_model_load_memory(ContextHandle ctx, byte[] data, UIntPtr size, out ModelHandle model);
        [DllImport(Lib, CallingConvention = CC)] public static extern void kata_model_destroy(IntPtr model);
        [DllImport(Lib, CallingConvention = CC)] public static extern uint kata_model_rank(ModelHandle model);
        [DllImport(Lib, CallingConvention = CC)] public static extern double kata_model_delta_star(ModelHandle model);
        [DllImport(Lib, CallingConvention = CC)] public static extern Stencil kata_model_stencil(ModelHandle model);
        [DllImport(Lib, CallingConvention = CC)] public static extern IntPtr kata_model_metadata(ModelHandle model, byte[] key);

        [DllImport(Lib, CallingConvention = CC)] public static extern void kata_retarget_desc_init_sized(ref RetargetDesc desc, uint structSize);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_retargeter_create(ContextHandle ctx, SkeletonHandle student, ref RetargetDesc desc, out RetargeterHandle r);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_retargeter_create_for_stream(ContextHandle ctx, StreamHandle student, ref RetargetDesc desc, out RetargeterHandle r);
        [DllImport(Lib, CallingConvention = CC)] public static extern void kata_retargeter_destroy(IntPtr r);
        [DllImport(Lib, CallingConvention = CC)] public static extern IntPtr kata_retargeter_last_error(RetargeterHandle r);
        [DllImport(Lib, CallingConvention = CC)] public static extern uint kata_retargeter_joint_count(RetargeterHandle r);
        [DllImport(Lib, CallingConvention = CC)] public static extern int kata_retargeter_joint_source(RetargeterHandle r, uint i);
        [DllImport(Lib, CallingConvention = CC)]
        public static extern Status kata_retargeter_solve(RetargeterHandle r, float[] teacher, uint teacherJointCount, [Out] float[] ghost,
                                                          UIntPtr capacity, ref RetargetInfo info);
        [DllImport(Lib, CallingConvention = CC)]
        public static extern Status kata_retargeter_place(RetargeterHandle r, float[] student, uint studentJointCount, [In, Out] float[] ghost, UIntPtr capacity);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_retargeter_reset(RetargeterHandle r);

        [DllImport(Lib, CallingConvention = CC)] public static extern void kata_teacher_desc_init_sized(ref TeacherDesc desc, uint structSize);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_stream_attach_teacher(StreamHandle stream, ref TeacherDesc desc);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_stream_detach_teacher(StreamHandle stream);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_teacher_create(ContextHandle context, ref TeacherDesc desc, out TeacherHandle teacher);
        [DllImport(Lib, CallingConvention = CC)] public static extern void kata_teacher_destroy(IntPtr teacher);
        [DllImport(Lib, CallingConvention = CC)] public static extern uint kata_teacher_frame_count(TeacherHandle teacher);
        [DllImport(Lib, CallingConvention = CC)] public static extern double kata_teacher_frame_time(TeacherHandle teacher);
        [DllImport(Lib, CallingConvention = CC)] public static extern ulong kata_teacher_memory_bytes(TeacherHandle teacher);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_stream_attach_shared_teacher(StreamHandle stream, TeacherHandle teacher, IntPtr options);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_stream_restart_teacher(StreamHandle stream);
        [DllImport(Lib, CallingConvention = CC)]
        public static extern Status kata_stream_set_practice_section(StreamHandle stream, int firstFrame, int lastFrame, int loop);
        [DllImport(Lib, CallingConvention = CC)]
        public static extern Status kata_stream_read_newest(StreamHandle stream, [In, Out] ResultRecord[] result,
                                                            [Out] float[] ghost, UIntPtr ghostCapacity, [Out] float[] features,
                                                            UIntPtr featureCapacity);
        [DllImport(Lib, CallingConvention = CC)]
        public static extern Status kata_stream_read_repetitions(StreamHandle stream, [In, Out] Repetition[] repetitions,
                                                                 uint capacity, out uint count);
        [DllImport(Lib, CallingConvention = CC)]
        public static extern Status kata_message_read_repetition(byte[] message, UIntPtr size, ref Repetition repetition);
        [DllImport(Lib, CallingConvention = CC)]
        public static extern Status kata_stream_read_results(StreamHandle stream, [In, Out] ResultRecord[] results,
                                                             [Out] float[] ghosts, UIntPtr ghostCapacity, [Out] float[] features,
                                                             UIntPtr featureCapacity, uint capacity, out uint count);
        [DllImport(Lib, CallingConvention = CC)] public static extern ulong kata_stream_results_dropped(StreamHandle stream);
        [DllImport(Lib, CallingConvention = CC)] public static extern uint kata_stream_results_pending(StreamHandle stream);
        [DllImport(Lib, CallingConvention = CC)] public static extern uint kata_stream_ghost_joint_count(StreamHandle stream);
        [DllImport(Lib, CallingConvention = CC)] public static extern int kata_stream_ghost_joint_source(StreamHandle stream, uint i);

        // the humanoid (VRM) rig, kata/humanoid.h; poses go through unmanaged memory (HumanoidRig holds it)
        [DllImport(Lib, CallingConvention = CC)] public static extern IntPtr kata_humanoid_bone_name(int bone);
        [DllImport(Lib, CallingConvention = CC)] public static extern int kata_humanoid_bone_find(byte[] name);
        [DllImport(Lib, CallingConvention = CC)] public static extern int kata_humanoid_bone_parent(int bone);
        [DllImport(Lib, CallingConvention = CC)] public static extern void kata_humanoid_desc_init_sized(ref HumanoidDesc desc, uint structSize);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_humanoid_rig_create(ContextHandle ctx, SkeletonHandle skeleton, ref HumanoidDesc desc, out HumanoidRigHandle rig);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_humanoid_rig_create_for_stream(ContextHandle ctx, StreamHandle stream, ref HumanoidDesc desc, out HumanoidRigHandle rig);
        [DllImport(Lib, CallingConvention = CC)] public static extern void kata_humanoid_rig_destroy(IntPtr rig);
        [DllImport(Lib, CallingConvention = CC)] public static extern IntPtr kata_humanoid_rig_last_error(HumanoidRigHandle rig);
        [DllImport(Lib, CallingConvention = CC)] public static extern uint kata_humanoid_rig_joint_count(HumanoidRigHandle rig);
        [DllImport(Lib, CallingConvention = CC)] public static extern uint kata_humanoid_rig_ghost_joint_count(HumanoidRigHandle rig);
        [DllImport(Lib, CallingConvention = CC)] public static extern uint kata_humanoid_rig_placed(HumanoidRigHandle rig);
        [DllImport(Lib, CallingConvention = CC)] public static extern double kata_humanoid_rig_metres_per_unit(HumanoidRigHandle rig);
        [DllImport(Lib, CallingConvention = CC)] public static extern int kata_humanoid_rig_bone_source(HumanoidRigHandle rig, int bone);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_humanoid_rig_calibrate(HumanoidRigHandle rig, float[] positions, uint jointCount, uint frames);
        [DllImport(Lib, CallingConvention = CC)] public static extern int kata_humanoid_rig_calibrated(HumanoidRigHandle rig);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_humanoid_rig_rest_pose(HumanoidRigHandle rig, int frame, IntPtr pose);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_humanoid_rig_pose(HumanoidRigHandle rig, float[] positions, uint jointCount, int frame, IntPtr pose);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_humanoid_rig_pose_ghost(HumanoidRigHandle rig, float[] ghost, uint ghostJointCount, int frame, IntPtr pose);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_humanoid_pose_joints(IntPtr pose, [Out] float[] positions, UIntPtr capacity, [Out] float[] rotations, UIntPtr rotationCapacity);
        // the VMC protocol, kata/vmc.h
        [DllImport(Lib, CallingConvention = CC, EntryPoint = "kata_context_last_error")] public static extern IntPtr kata_thread_last_error(IntPtr ctx);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_vmc_write_pose(IntPtr pose, double time, float metresPerUnit, [Out] byte[] buffer, UIntPtr capacity, out UIntPtr size);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_vmc_reader_create(ContextHandle ctx, uint maxPacketBytes, out VmcReaderHandle reader);
        [DllImport(Lib, CallingConvention = CC)] public static extern void kata_vmc_reader_destroy(IntPtr reader);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_vmc_reader_read(VmcReaderHandle reader, byte[] packet, UIntPtr size, double arrivalTime, out int frame);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_vmc_reader_positions(VmcReaderHandle reader, [Out] float[] positions, UIntPtr capacity, out double captureTime);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_vmc_reader_get_counters(VmcReaderHandle reader, ref VmcCounters counters);
        [DllImport(Lib, CallingConvention = CC)] public static extern IntPtr kata_vmc_reader_last_error(VmcReaderHandle reader);

        // the people tracker, kata/people.h
        [DllImport(Lib, CallingConvention = CC)] public static extern void kata_people_desc_init_sized(ref PeopleDesc desc, uint structSize);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_people_create(ContextHandle ctx, ref PeopleDesc desc, out PeopleHandle people);
        [DllImport(Lib, CallingConvention = CC)] public static extern void kata_people_destroy(IntPtr people);
        [DllImport(Lib, CallingConvention = CC)] public static extern IntPtr kata_people_last_error(PeopleHandle people);
        [DllImport(Lib, CallingConvention = CC)]
        public static extern Status kata_people_track(PeopleHandle people, double time, float[] xyz, float[] confidence, uint poseCount,
                                                      [Out] uint[] ids, UIntPtr capacity);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_people_opened(PeopleHandle people, [Out] uint[] ids, UIntPtr capacity, out uint count);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_people_closed(PeopleHandle people, [Out] uint[] ids, UIntPtr capacity, out uint count);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_people_streams(PeopleHandle people, [Out] uint[] ids, UIntPtr capacity, out uint count);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_people_predicted(PeopleHandle people, uint id, double time, [Out] double[] centroid);
        [DllImport(Lib, CallingConvention = CC)] public static extern Status kata_people_get_counters(PeopleHandle people, ref PeopleCounters counters);
        [DllImport(Lib, CallingConvention = CC)] public static extern ulong kata_people_stream_id(ulong group, uint person);

        // ---- helpers: UTF-8 both ways (no reliance on CharSet, which differs between runtimes) ----
        public static byte[] Utf8(string s)
        {
            if (s == null) return null;
            byte[] text = Encoding.UTF8.GetBytes(s);
            byte[] z = new byte[text.Length + 1];
            Buffer.BlockCopy(text, 0, z, 0, text.Length);
            return z;
        }

        public static string FromUtf8(IntPtr p)
        {
            if (p == IntPtr.Zero) return null;
            int n = 0;
            while (Marshal.ReadByte(p, n) != 0) ++n;
            byte[] bytes = new byte[n];
            Marshal.Copy(p, bytes, 0, n);
            return Encoding.UTF8.GetString(bytes);
        }

        public static string StatusName(Status s) { return FromUtf8(kata_status_string(s)); }
        // The GPD joint name of 0..15 ("LKnee"), e.g. of ResultRecord.CueJoint; "" out of range.
        public static string GpdJointName(int joint) { return FromUtf8(kata_gpd_joint_name(joint)) ?? ""; }
        // The body part (0..4, ResultRecord.PartToFix's numbering) of GPD joint 0..15; -1 out of range.
        public static int GpdJointPart(int joint) { return kata_gpd_joint_part(joint); }
        // A body part's name ("left_arm"); "" out of range.
        public static string BodyPartName(int part) { return FromUtf8(kata_body_part_name(part)) ?? ""; }
        // GPD joint 0..15 in a cue's words ("left knee"; "" for the end joints and out of range).
        public static string GpdJointWords(int joint) { return FromUtf8(kata_gpd_joint_words(joint)) ?? ""; }
        // A record's correction cue phrase ("left knee: bend 30 deg more"); "" without one.
        public static string CueText(ResultRecord record)
        {
            byte[] buf = new byte[64];
            int n = (int)kata_cue_text(ref record, buf, (UIntPtr)buf.Length);
            return Encoding.UTF8.GetString(buf, 0, Math.Min(n, buf.Length - 1));
        }
    }

    // ---- versions ------------------------------------------------------------------------------------

    public static class Library
    {
        public const int ExpectedMajor = 1; // KATA_VERSION_MAJOR this binding is written against
        public const int MinimumMinor = 1;  // 1.1: the teacher fields and the joint / part calls this file declares
        private static int checkedOk;

        public static Version LoadedVersion
        {
            get { uint v = Native.kata_version(); return new Version((int)(v / 10000), (int)(v / 100 % 100), (int)(v % 100)); }
        }

        // Called before the first object is made: refuses a library of another major version.
        public static void EnsureCompatible()
        {
            if (Volatile.Read(ref checkedOk) != 0) return;
            Version v = LoadedVersion;
            if (v.Major != ExpectedMajor || v.Minor < MinimumMinor)
                throw new KataVersionException(string.Format(
                    "kata: the loaded native library is version {0}.{1}.{2}; this binding needs {3}.x with x >= {4} " +
                    "(major versions differ in their ABI). Put a matching libkata next to the binding.",
                    v.Major, v.Minor, v.Build, ExpectedMajor, MinimumMinor));
            Volatile.Write(ref checkedOk, 1);
        }
    }

    // ---- handles -----------------------------------------------------------------------------------------

    public abstract class KataHandle : SafeHandleZeroOrMinusOneIsInvalid
    {
        private static long released;
        // Native release calls made by every KataHandle so far (tests check "exactly once" with it).
        public static long ReleasedCount { get { return Interlocked.Read(ref released); } }

        private ContextHandle parent;

        protected KataHandle() : base(true) { }

        // Keeps the context's handle alive (and its destroy call waiting) until this handle is released.
        internal void HoldContext(ContextHandle context)
        {
            if (IsInvalid || context == null) return;
            bool added = false;
            context.DangerousAddRef(ref added);
            if (added) parent = context;
        }

        protected abstract void Destroy(IntPtr h);

        protected override bool ReleaseHandle()
        {
            Destroy(handle);
            Interlocked.Increment(ref released);
            ContextHandle p = parent;
            parent = null;
            if (p != null) p.DangerousRelease();
            return true;
        }
    }

    public sealed class ContextHandle : KataHandle { protected override void Destroy(IntPtr h) { Native.kata_context_destroy(h); } }
    public sealed class SkeletonHandle : KataHandle { protected override void Destroy(IntPtr h) { Native.kata_skeleton_destroy(h); } }
    public sealed class ClipHandle : KataHandle { protected override void Destroy(IntPtr h) { Native.kata_clip_destroy(h); } }
    public sealed class StreamHandle : KataHandle { protected override void Destroy(IntPtr h) { Native.kata_stream_destroy(h); } }
    public sealed class ModelHandle : KataHandle { protected override void Destroy(IntPtr h) { Native.kata_model_destroy(h); } }
    public sealed class TeacherHandle : KataHandle { protected override void Destroy(IntPtr h) { Native.kata_teacher_destroy(h); } }
    public sealed class RetargeterHandle : KataHandle { protected override void Destroy(IntPtr h) { Native.kata_retargeter_destroy(h); } }
    public sealed class HumanoidRigHandle : KataHandle { protected override void Destroy(IntPtr h) { Native.kata_humanoid_rig_destroy(h); } }
    public sealed class PeopleHandle : KataHandle { protected override void Destroy(IntPtr h) { Native.kata_people_destroy(h); } }
    public sealed class VmcReaderHandle : KataHandle { protected override void Destroy(IntPtr h) { Native.kata_vmc_reader_destroy(h); } }

    // ---- objects ------------------------------------------------------------------------------------------

    public sealed class Context : IDisposable
    {
        public readonly ContextHandle Handle;

        public Context()
        {
            Library.EnsureCompatible();
            Status s = Native.kata_context_create(out Handle);
            if (s != Status.Ok) throw new KataException(s, "cannot create a context", "kata_context_create");
        }

        public void Dispose() { Handle.Dispose(); }

        internal T Check<T>(Status s, T handle, string call) where T : KataHandle
        {
            if (s != Status.Ok)
            {
                string message = Native.FromUtf8(Native.kata_context_last_error(Handle));
                if (handle != null) handle.Dispose();
                throw new KataException(s, message, call);
            }
            handle.HoldContext(Handle);
            return handle;
        }

        public Skeleton LoadSkeletonBvh(string path)
        {
            SkeletonHandle h;
            Status s = Native.kata_skeleton_load_bvh(Handle, Native.Utf8(path), out h);
            return new Skeleton(Check(s, h, "kata_skeleton_load_bvh"));
        }

        public Clip LoadClip(string path)
        {
            ClipHandle h;
            Status s = Native.kata_clip_load_bvh(Handle, Native.Utf8(path), out h);
            return new Clip(Check(s, h, "kata_clip_load_bvh"), this);
        }

        // kata_people_create (1.1): a people tracker (desc from People.DefaultDesc, then changed).
        public People CreatePeople(PeopleDesc desc)
        {
            PeopleHandle h;
            Status s = Native.kata_people_create(Handle, ref desc, out h);
            return new People(Check(s, h, "kata_people_create"), desc.JointCount);
        }

        public Model LoadModel(string path)
        {
            ModelHandle h;
            Status s = Native.kata_model_load(Handle, Native.Utf8(path), out h);
            return new Model(Check(s, h, "kata_model_load"));
        }

        // kata_teacher_create (1.1): a clip teacher built once, for Stream.AttachSharedTeacher (ghost: the
        // default of the streams it is attached to).
        public Teacher CreateTeacher(Model model, Clip clip, uint firstFrame = 0, bool ghost = true)
        {
            TeacherDesc d = new TeacherDesc();
            Native.kata_teacher_desc_init_sized(ref d, (uint)Marshal.SizeOf(typeof(TeacherDesc)));
            bool modelRef = false, clipRef = false;
            try
            {
                model.Handle.DangerousAddRef(ref modelRef);
                clip.Handle.DangerousAddRef(ref clipRef);
                d.Model = model.Handle.DangerousGetHandle();
                d.Clip = clip.Handle.DangerousGetHandle();
                d.FirstFrame = firstFrame;
                d.Ghost = ghost ? 1 : 0;
                TeacherHandle h;
                Status s = Native.kata_teacher_create(Handle, ref d, out h);
                return new Teacher(Check(s, h, "kata_teacher_create"));
            }
            finally
            {
                if (clipRef) clip.Handle.DangerousRelease();
                if (modelRef) model.Handle.DangerousRelease();
            }
        }

        public Model LoadModel(byte[] data)
        {
            ModelHandle h;
            Status s = Native.kata_model_load_memory(Handle, data, (UIntPtr)data.Length, out h);
            return new Model(Check(s, h, "kata_model_load_memory"));
        }

        // kata_skeleton_create: names, parents (-1 for the root, topological order), rest offsets
        // (joints x 3, parent-relative) or null for a bare live source.
        public Skeleton CreateSkeleton(string[] names, int[] parents, double[] restOffsets)
        {
            GCHandle[] pins = new GCHandle[names.Length];
            IntPtr[] pointers = new IntPtr[names.Length];
            try
            {
                for (int i = 0; i < names.Length; ++i)
                {
                    pins[i] = GCHandle.Alloc(Native.Utf8(names[i]), GCHandleType.Pinned);
                    pointers[i] = pins[i].AddrOfPinnedObject();
                }
                SkeletonHandle h;
                Status s = Native.kata_skeleton_create(Handle, (uint)names.Length, pointers, parents, restOffsets, out h);
                return new Skeleton(Check(s, h, "kata_skeleton_create"));
            }
            finally
            {
                foreach (GCHandle pin in pins) if (pin.IsAllocated) pin.Free();
            }
        }

        // kata_retargeter_create with kata_retarget_desc_init's defaults and the given joint set ("cmu", "gpd").
        public Retargeter CreateRetargeter(Skeleton student, string jointSet = "cmu")
        {
            RetargetDesc d = new RetargetDesc();
            Native.kata_retarget_desc_init_sized(ref d, (uint)Marshal.SizeOf(typeof(RetargetDesc)));
            GCHandle pin = GCHandle.Alloc(Native.Utf8(jointSet), GCHandleType.Pinned);
            try
            {
                d.JointSet = pin.AddrOfPinnedObject();
                RetargeterHandle h;
                Status s = Native.kata_retargeter_create(Handle, student.Handle, ref d, out h);
                return new Retargeter(Check(s, h, "kata_retargeter_create"));
            }
            finally { pin.Free(); }
        }

        // A StreamDesc with kata_stream_desc_init's defaults (struct_size set by the library).
        public static StreamDesc DefaultStreamDesc()
        {
            StreamDesc d = new StreamDesc();
            Native.kata_stream_desc_init_sized(ref d, (uint)Marshal.SizeOf(typeof(StreamDesc)));
            if (d.StructSize != Marshal.SizeOf(typeof(StreamDesc)))
                throw new KataVersionException("kata_stream_desc is " + d.StructSize + " bytes in the library, " +
                                               Marshal.SizeOf(typeof(StreamDesc)) + " in this binding");
            return d;
        }

        // kata_stream_open; desc's Layout/NameMapPath are replaced by the strings given here.
        public Stream OpenStream(Skeleton skeleton, string layout, StreamDesc desc, string nameMapPath = null)
        {
            GCHandle layoutPin = default(GCHandle), mapPin = default(GCHandle);
            try
            {
                byte[] p = Native.Utf8(nameMapPath == null ? layout : null), m = Native.Utf8(nameMapPath);
                if (p != null) { layoutPin = GCHandle.Alloc(p, GCHandleType.Pinned); desc.Layout = layoutPin.AddrOfPinnedObject(); }
                else desc.Layout = IntPtr.Zero;
                if (m != null) { mapPin = GCHandle.Alloc(m, GCHandleType.Pinned); desc.NameMapPath = mapPin.AddrOfPinnedObject(); }
                else desc.NameMapPath = IntPtr.Zero;
                StreamHandle h;
                Status s = Native.kata_stream_open(Handle, skeleton.Handle, ref desc, out h);
                return new Stream(Check(s, h, "kata_stream_open"), (int)skeleton.JointCount);
            }
            finally
            {
                if (layoutPin.IsAllocated) layoutPin.Free();
                if (mapPin.IsAllocated) mapPin.Free();
            }
        }

        public Stream OpenStream(Skeleton skeleton, string layout = "cmu") { return OpenStream(skeleton, layout, DefaultStreamDesc()); }

        // kata_humanoid_rig_create: frames of `skeleton` read through `layout` in `upAxis`; metresPerUnit 0
        // takes the layout's (CMU 0.056444, azure-kinect 0.001, else 1).
        public HumanoidRig CreateHumanoidRig(Skeleton skeleton, string layout = "cmu", UpAxis upAxis = UpAxis.Y,
                                             double metresPerUnit = 0)
        {
            HumanoidDesc d = new HumanoidDesc();
            Native.kata_humanoid_desc_init_sized(ref d, (uint)Marshal.SizeOf(typeof(HumanoidDesc)));
            GCHandle pin = GCHandle.Alloc(Native.Utf8(layout), GCHandleType.Pinned);
            try
            {
                d.Layout = pin.AddrOfPinnedObject();
                d.UpAxis = upAxis;
                d.MetresPerUnit = metresPerUnit;
                HumanoidRigHandle h;
                Status s = Native.kata_humanoid_rig_create(Handle, skeleton.Handle, ref d, out h);
                return new HumanoidRig(Check(s, h, "kata_humanoid_rig_create"));
            }
            finally { pin.Free(); }
        }

        // kata_vmc_reader_create: datagrams above maxPacketBytes (0: VmcReader.DefaultMaxPacket; at most 1 MiB)
        // are counted as oversized.
        public VmcReader CreateVmcReader(uint maxPacketBytes = 0)
        {
            VmcReaderHandle h;
            Status s = Native.kata_vmc_reader_create(Handle, maxPacketBytes, out h);
            return new VmcReader(Check(s, h, "kata_vmc_reader_create"));
        }

        // kata_humanoid_rig_create_for_stream: the stream's skeleton, layout and axes, and its ghost (attach
        // the teacher first).
        public HumanoidRig CreateHumanoidRig(Stream stream, double metresPerUnit = 0)
        {
            HumanoidDesc d = new HumanoidDesc();
            Native.kata_humanoid_desc_init_sized(ref d, (uint)Marshal.SizeOf(typeof(HumanoidDesc)));
            d.MetresPerUnit = metresPerUnit;
            HumanoidRigHandle h;
            Status s = Native.kata_humanoid_rig_create_for_stream(Handle, stream.Handle, ref d, out h);
            return new HumanoidRig(Check(s, h, "kata_humanoid_rig_create_for_stream"));
        }
    }

    public sealed class Skeleton : IDisposable
    {
        public readonly SkeletonHandle Handle;
        internal Skeleton(SkeletonHandle h) { Handle = h; }
        public void Dispose() { Handle.Dispose(); }
        public uint JointCount { get { return Native.kata_skeleton_joint_count(Handle); } }
        public string JointName(uint i) { return Native.FromUtf8(Native.kata_skeleton_joint_name(Handle, i)); }
        public int JointParent(uint i) { return Native.kata_skeleton_joint_parent(Handle, i); }
    }

    public sealed class Clip : IDisposable
    {
        public readonly ClipHandle Handle;
        private readonly Context context;
        internal Clip(ClipHandle h, Context c) { Handle = h; context = c; }
        public void Dispose() { Handle.Dispose(); }
        public uint FrameCount { get { return Native.kata_clip_frame_count(Handle); } }
        public double FrameTime { get { return Native.kata_clip_frame_time(Handle); } }

        public Skeleton Skeleton()
        {
            SkeletonHandle h;
            Status s = Native.kata_clip_skeleton(Handle, out h);
            if (s != Status.Ok) { h.Dispose(); throw new KataException(s, "cannot copy the clip's skeleton", "kata_clip_skeleton"); }
            h.HoldContext(context.Handle);
            return new Skeleton(h);
        }

        // World positions (joints x 3) of one frame into xyz.
        public void Positions(uint frame, float[] xyz)
        {
            Status s = Native.kata_clip_positions(Handle, frame, xyz, (UIntPtr)xyz.Length);
            if (s != Status.Ok) throw new KataException(s, "frame " + frame + " (buffer " + xyz.Length + " floats)", "kata_clip_positions");
        }
    }

    public sealed class Model : IDisposable
    {
        public readonly ModelHandle Handle;
        internal Model(ModelHandle h) { Handle = h; }
        public void Dispose() { Handle.Dispose(); }
        public uint Rank { get { return Native.kata_model_rank(Handle); } }
        public double DeltaStar { get { return Native.kata_model_delta_star(Handle); } }
        public Stencil Stencil { get { return Native.kata_model_stencil(Handle); } }
        public string Metadata(string key) { return Native.FromUtf8(Native.kata_model_metadata(Handle, Native.Utf8(key))); }
    }

    // A teacher built once and shared by any number of streams (kata_teacher, 1.1); streams keep it after Dispose.
    public sealed class Teacher : IDisposable
    {
        public readonly TeacherHandle Handle;
        internal Teacher(TeacherHandle h) { Handle = h; }
        public void Dispose() { Handle.Dispose(); }
        public uint FrameCount { get { return Native.kata_teacher_frame_count(Handle); } }
        public double FrameTime { get { return Native.kata_teacher_frame_time(Handle); } }
        public ulong MemoryBytes { get { return Native.kata_teacher_memory_bytes(Handle); } }
    }

    // Arrays kata_stream_read_results fills in place; allocate once, read every frame.
    public sealed class ResultBatch
    {
        public readonly ResultRecord[] Results;
        public readonly ResultRecord[] Scores;   // the same array as Results: each record carries its score
        public readonly float[] Ghosts;      // Capacity x GhostJoints x 3, or null
        public readonly float[] Features;    // Capacity x 1683, or null
        public readonly int GhostJoints;
        public int Count;                    // entries filled by the last read

        public ResultBatch(int capacity, int ghostJoints, bool features = false)
        {
            Results = new ResultRecord[capacity];
            Scores = Results;
            for (int i = 0; i < capacity; ++i) Results[i].StructSize = (uint)Marshal.SizeOf(typeof(ResultRecord));
            GhostJoints = ghostJoints;
            Ghosts = ghostJoints > 0 ? new float[capacity * ghostJoints * 3] : null;
            Features = features ? new float[capacity * Gpd.Dims] : null;
        }

        public int Capacity { get { return Results.Length; } }
    }

    public sealed class Stream : IDisposable
    {
        public readonly StreamHandle Handle;
        public readonly int JointCount;
        internal Stream(StreamHandle h, int joints) { Handle = h; JointCount = joints; }
        public void Dispose() { Handle.Dispose(); }

        private void Throw(Status s, string call) { throw new KataException(s, Native.FromUtf8(Native.kata_stream_last_error(Handle)), call); }

        // kata_stream_push: xyz holds JointCount x 3 floats (pinned for the call, not copied).
        public void Push(double timestamp, float[] xyz)
        {
            Status s = Native.kata_stream_push(Handle, timestamp, xyz, (uint)(xyz.Length / 3));
            if (s != Status.Ok) Throw(s, "kata_stream_push");
        }

        public void Flush() { Status s = Native.kata_stream_flush(Handle); if (s != Status.Ok) Throw(s, "kata_stream_flush"); }
        public void Reset() { Status s = Native.kata_stream_reset(Handle); if (s != Status.Ok) Throw(s, "kata_stream_reset"); }
        public long FeatureCount { get { return Native.kata_stream_feature_count(Handle); } }
        public double BodyHeight { get { return Native.kata_stream_body_height(Handle); } }

        // kata_stream_features: false before the first vector.
        public bool Features(float[] out1683, out double timestamp, out long frameIndex)
        {
            Status s = Native.kata_stream_features(Handle, out1683, (UIntPtr)out1683.Length, out timestamp, out frameIndex);
            if (s == Status.NoData) return false;
            if (s != Status.Ok) Throw(s, "kata_stream_features");
            return true;
        }

        // kata_stream_attach_teacher with GPD features (frames x Gpd.Dims, frameTime apart; poseFrame >= 0: that
        // vector alone). Scores only: a teacher given as features has no ghost.
        public void AttachTeacherFeatures(Model model, float[] features, double frameTime, int poseFrame = -1)
        {
            if (features == null || features.Length == 0 || features.Length % Gpd.Dims != 0)
                throw new ArgumentException("features must hold frames x " + Gpd.Dims + " floats");
            AttachPinned(model, features, (uint)(features.Length / Gpd.Dims), frameTime, poseFrame, false, 0.0);
        }

        // kata_stream_attach_teacher with one held pose of the 16 GPD joints (GPD order, x, y, z) and its body height.
        public void AttachTeacherJoints(Model model, float[] joints, double bodyHeight)
        {
            if (joints == null || joints.Length != 3 * Gpd.Joints) throw new ArgumentException("joints must hold 16 x 3 floats");
            AttachPinned(model, joints, 1, 0.0, -1, true, bodyHeight);
        }

        void AttachPinned(Model model, float[] data, uint frames, double frameTime, int poseFrame, bool joints, double bodyHeight)
        {
            TeacherDesc d = new TeacherDesc();
            Native.kata_teacher_desc_init_sized(ref d, (uint)Marshal.SizeOf(typeof(TeacherDesc)));
            GCHandle pin = GCHandle.Alloc(data, GCHandleType.Pinned);
            bool modelRef = false;
            try
            {
                model.Handle.DangerousAddRef(ref modelRef);
                d.Model = model.Handle.DangerousGetHandle();
                if (joints) { d.Joints = pin.AddrOfPinnedObject(); d.BodyHeight = bodyHeight; }
                else d.Features = pin.AddrOfPinnedObject();
                d.Frames = frames;
                d.FrameTime = frameTime;
                d.PoseFrame = poseFrame;
                d.Ghost = 0;
                Status s = Native.kata_stream_attach_teacher(Handle, ref d);
                if (s != Status.Ok) Throw(s, "kata_stream_attach_teacher");
            }
            finally
            {
                pin.Free();
                if (modelRef) model.Handle.DangerousRelease();
            }
        }

        // kata_stream_attach_shared_teacher (1.1): the teacher without a copy, with the options it was created with.
        public void AttachSharedTeacher(Teacher teacher)
        {
            Status s = Native.kata_stream_attach_shared_teacher(Handle, teacher.Handle, IntPtr.Zero);
            if (s != Status.Ok) Throw(s, "kata_stream_attach_shared_teacher");
        }

        // kata_stream_detach_teacher: later results are not scored and carry no ghost.
        public void DetachTeacher() { Status s = Native.kata_stream_detach_teacher(Handle); if (s != Status.Ok) Throw(s, "kata_stream_detach_teacher"); }
        // kata_stream_restart_teacher: the next frame is matched from the teacher's first frame.
        public void RestartTeacher() { Status s = Native.kata_stream_restart_teacher(Handle); if (s != Status.Ok) Throw(s, "kata_stream_restart_teacher"); }
        // kata_stream_set_practice_section: follow teacher frames first..last (-1: the end), looped when loop
        // (the repetition ReadRepetitions counts).
        public void SetPracticeSection(int firstFrame, int lastFrame, bool loop)
        {
            Status s = Native.kata_stream_set_practice_section(Handle, firstFrame, lastFrame, loop ? 1 : 0);
            if (s != Status.Ok) Throw(s, "kata_stream_set_practice_section");
        }

        // kata_stream_read_newest: the newest unread result into batch entry 0 (older unread ones are passed
        // over); false (batch.Count = 0) when nothing is unread.
        public bool ReadNewest(ResultBatch batch)
        {
            Status s = Native.kata_stream_read_newest(Handle, batch.Results, batch.Ghosts,
                                                      (UIntPtr)(batch.Ghosts == null ? 0 : batch.Ghosts.Length), batch.Features,
                                                      (UIntPtr)(batch.Features == null ? 0 : batch.Features.Length));
            batch.Count = s == Status.Ok ? 1 : 0;
            if (s == Status.NoData) return false;
            if (s != Status.Ok) Throw(s, "kata_stream_read_newest");
            return true;
        }

        // kata_stream_attach_teacher with a recorded clip (ghost: 1 to make ghosts).
        // ghostAcross: the ghost across layouts (a CMU teacher on a MediaPipe student: 16 GPD joints);
        // alignmentWindow: the alignment's window in teacher seconds (1.1's fields).
        public void AttachTeacher(Model model, Clip clip, uint firstFrame = 0, bool ghost = true, string layout = null, int poseFrame = -1,
                                  bool ghostAcross = false, double alignmentWindow = 0.5)
        {
            TeacherDesc d = new TeacherDesc();
            Native.kata_teacher_desc_init_sized(ref d, (uint)Marshal.SizeOf(typeof(TeacherDesc)));
            GCHandle layoutPin = default(GCHandle);
            bool modelRef = false, clipRef = false;
            try
            {
                // The raw handles go into a struct, so hold them explicitly for the call.
                model.Handle.DangerousAddRef(ref modelRef);
                clip.Handle.DangerousAddRef(ref clipRef);
                d.Model = model.Handle.DangerousGetHandle();
                d.Clip = clip.Handle.DangerousGetHandle();
                d.FirstFrame = firstFrame;
                d.PoseFrame = poseFrame;
                d.Ghost = ghost ? 1 : 0;
                d.GhostAcross = ghostAcross ? 1 : 0;
                d.AlignmentWindow = alignmentWindow;
                if (layout != null) { layoutPin = GCHandle.Alloc(Native.Utf8(layout), GCHandleType.Pinned); d.Layout = layoutPin.AddrOfPinnedObject(); }
                Status s = Native.kata_stream_attach_teacher(Handle, ref d);
                if (s != Status.Ok) Throw(s, "kata_stream_attach_teacher");
            }
            finally
            {
                if (layoutPin.IsAllocated) layoutPin.Free();
                if (clipRef) clip.Handle.DangerousRelease();
                if (modelRef) model.Handle.DangerousRelease();
            }
        }

        public uint GhostJointCount { get { return Native.kata_stream_ghost_joint_count(Handle); } }
        public int GhostJointSource(uint i) { return Native.kata_stream_ghost_joint_source(Handle, i); }
        // The stream skeleton's joint read as GPD joint 0..15 (-1: synthesised by the layout, or out of range).
        public int GpdJointSource(uint gpdJoint) { return Native.kata_stream_gpd_joint_source(Handle, gpdJoint); }
        public uint ResultsPending { get { return Native.kata_stream_results_pending(Handle); } }
        public ulong ResultsDropped { get { return Native.kata_stream_results_dropped(Handle); } }

        public ResultBatch NewResultBatch(int capacity, bool features = false) { return new ResultBatch(capacity, (int)GhostJointCount, features); }

        // kata_stream_read_repetitions (1.1): the repetitions that ended since the last call (at most
        // into.Length), oldest first; returns the count. The stream keeps the newest 16.
        public int ReadRepetitions(Repetition[] into)
        {
            if (into.Length == 0) return 0;
            into[0].StructSize = (uint)Marshal.SizeOf(typeof(Repetition));
            uint n;
            Status s = Native.kata_stream_read_repetitions(Handle, into, (uint)into.Length, out n);
            if (s != Status.Ok) Throw(s, "kata_stream_read_repetitions");
            return (int)n;
        }

        // kata_stream_read_results: moves every unread result (at most batch.Capacity) into batch; returns the count.
        public int ReadResults(ResultBatch batch)
        {
            uint n;
            Status s = Native.kata_stream_read_results(Handle, batch.Results, batch.Ghosts,
                                                       (UIntPtr)(batch.Ghosts == null ? 0 : batch.Ghosts.Length), batch.Features,
                                                       (UIntPtr)(batch.Features == null ? 0 : batch.Features.Length),
                                                       (uint)batch.Capacity, out n);
            if (s != Status.Ok) Throw(s, "kata_stream_read_results");
            batch.Count = (int)n;
            return (int)n;
        }
    }

    public sealed class Retargeter : IDisposable
    {
        public readonly RetargeterHandle Handle;
        internal Retargeter(RetargeterHandle h) { Handle = h; }
        public void Dispose() { Handle.Dispose(); }
        private void Throw(Status s, string call) { throw new KataException(s, Native.FromUtf8(Native.kata_retargeter_last_error(Handle)), call); }

        public uint JointCount { get { return Native.kata_retargeter_joint_count(Handle); } }
        public int JointSource(uint i) { return Native.kata_retargeter_joint_source(Handle, i); }

        // kata_retargeter_solve: teacher (skeleton joints x 3) -> ghost (JointCount x 3).
        public RetargetInfo Solve(float[] teacher, float[] ghost)
        {
            RetargetInfo info = new RetargetInfo();
            info.StructSize = (uint)Marshal.SizeOf(typeof(RetargetInfo));
            Status s = Native.kata_retargeter_solve(Handle, teacher, (uint)(teacher.Length / 3), ghost, (UIntPtr)ghost.Length, ref info);
            if (s != Status.Ok) Throw(s, "kata_retargeter_solve");
            return info;
        }

        // kata_retargeter_place: moves ghost over the student's posture (every skeleton joint x 3).
        public void Place(float[] student, float[] ghost)
        {
            Status s = Native.kata_retargeter_place(Handle, student, (uint)(student.Length / 3), ghost, (UIntPtr)ghost.Length);
            if (s != Status.Ok) Throw(s, "kata_retargeter_place");
        }

        public void Reset() { Status s = Native.kata_retargeter_reset(Handle); if (s != Status.Ok) Throw(s, "kata_retargeter_reset"); }
    }

    // One frame of a humanoid (kata_humanoid_pose, kata/humanoid.h): Rotation[4 b .. 4 b + 3] is bone b's
    // local rotation x, y, z, w relative to the T-pose; Offset[3 b ..] its joint's offset from its parent's
    // in the parent's frame (metres). Reused from frame to frame: HumanoidRig.Pose fills it in place.
    public sealed class HumanoidPose
    {
        public const int BoneCount = 22;                  // KATA_BONE_COUNT
        public HumanoidFrame Frame;
        public uint Placed;                               // bit b: bone b is placed
        public uint Degenerate;                           // bit b: bone b's direction or turn was degenerate
        public readonly float[] HipsPosition = new float[3];
        public readonly float[] Rotation = new float[4 * BoneCount];
        public readonly float[] Offset = new float[3 * BoneCount];
        public bool IsPlaced(HumanoidBone bone) { return (Placed >> (int)bone & 1) != 0; }

        public static string BoneName(HumanoidBone bone) { return Native.FromUtf8(Native.kata_humanoid_bone_name((int)bone)); }
        public static int BoneParent(HumanoidBone bone) { return Native.kata_humanoid_bone_parent((int)bone); }
        public static int FindBone(string name) { return Native.kata_humanoid_bone_find(Native.Utf8(name)); }
    }

    // A layout's joints on the VRM humanoid bones with the student's bone lengths (kata_humanoid_rig);
    // one thread at a time. Pose and PoseGhost allocate nothing (the pose crosses through a buffer the rig holds).
    public sealed class HumanoidRig : IDisposable
    {
        // kata_humanoid_pose's layout (x86-64 and arm64): struct_size, placed, frame, hips[3], rotation[22][4],
        // offset[22][3], degenerate, reserved.
        private const int HipsAt = 12, RotationAt = 24, OffsetAt = 376, DegenerateAt = 640, PoseSize = 648;
        public readonly HumanoidRigHandle Handle;
        private IntPtr pose;
        internal HumanoidRig(HumanoidRigHandle h)
        {
            Handle = h;
            pose = Marshal.AllocHGlobal(PoseSize);
        }
        public void Dispose()
        {
            Handle.Dispose();
            if (pose != IntPtr.Zero) { Marshal.FreeHGlobal(pose); pose = IntPtr.Zero; }
        }
        ~HumanoidRig() { if (pose != IntPtr.Zero) { Marshal.FreeHGlobal(pose); pose = IntPtr.Zero; } }
        private void Throw(Status s, string call) { throw new KataException(s, Native.FromUtf8(Native.kata_humanoid_rig_last_error(Handle)), call); }

        public uint JointCount { get { return Native.kata_humanoid_rig_joint_count(Handle); } }
        public uint GhostJointCount { get { return Native.kata_humanoid_rig_ghost_joint_count(Handle); } }
        public uint Placed { get { return Native.kata_humanoid_rig_placed(Handle); } }
        public double MetresPerUnit { get { return Native.kata_humanoid_rig_metres_per_unit(Handle); } }
        public bool Calibrated { get { return Native.kata_humanoid_rig_calibrated(Handle) != 0; } }
        public int BoneSource(HumanoidBone bone) { return Native.kata_humanoid_rig_bone_source(Handle, (int)bone); }

        // kata_humanoid_rig_calibrate: rest bone lengths as medians over `frames` frames (frames x joints x 3).
        public void Calibrate(float[] positions, uint frames)
        {
            Status s = Native.kata_humanoid_rig_calibrate(Handle, positions, frames == 0 ? 0 : (uint)(positions.Length / 3 / frames), frames);
            if (s != Status.Ok) Throw(s, "kata_humanoid_rig_calibrate");
        }

        private HumanoidPose Read(HumanoidPose into)
        {
            HumanoidPose p = into ?? new HumanoidPose();
            p.Placed = (uint)Marshal.ReadInt32(pose, 4);
            p.Frame = (HumanoidFrame)Marshal.ReadInt32(pose, 8);
            p.Degenerate = (uint)Marshal.ReadInt32(pose, DegenerateAt);
            Marshal.Copy(pose + HipsAt, p.HipsPosition, 0, 3);
            Marshal.Copy(pose + RotationAt, p.Rotation, 0, 4 * HumanoidPose.BoneCount);
            Marshal.Copy(pose + OffsetAt, p.Offset, 0, 3 * HumanoidPose.BoneCount);
            return p;
        }

        private void Begin() { Marshal.WriteInt32(pose, 0, PoseSize); }

        // kata_humanoid_rig_pose: one frame (every skeleton joint x 3, input units and axes) into `into`
        // (a new pose when null).
        public HumanoidPose Pose(float[] positions, HumanoidFrame frame = HumanoidFrame.RightHanded, HumanoidPose into = null)
        {
            Begin();
            Status s = Native.kata_humanoid_rig_pose(Handle, positions, (uint)(positions.Length / 3), (int)frame, pose);
            if (s != Status.Ok) Throw(s, "kata_humanoid_rig_pose");
            return Read(into);
        }

        // kata_humanoid_rig_pose_ghost: a ghost of the rig's stream (GhostJointCount x 3).
        public HumanoidPose PoseGhost(float[] ghost, HumanoidFrame frame = HumanoidFrame.RightHanded, HumanoidPose into = null)
        {
            Begin();
            Status s = Native.kata_humanoid_rig_pose_ghost(Handle, ghost, (uint)(ghost.Length / 3), (int)frame, pose);
            if (s != Status.Ok) Throw(s, "kata_humanoid_rig_pose_ghost");
            return Read(into);
        }

        // kata_humanoid_rig_rest_pose: the T-pose (identity rotations, rest offsets).
        public HumanoidPose RestPose(HumanoidFrame frame = HumanoidFrame.RightHanded)
        {
            Begin();
            Status s = Native.kata_humanoid_rig_rest_pose(Handle, (int)frame, pose);
            if (s != Status.Ok) Throw(s, "kata_humanoid_rig_rest_pose");
            return Read(null);
        }

        // kata_vmc_write_pose: `p` (a pose of any rig) as one VMC bundle into buffer, for the caller to send as
        // one UDP datagram; returns its size in bytes. Its timetag the wall clock now; /VMC/Ext/Root/Pos,
        // /VMC/Ext/Bone/Pos per placed bone in Unity's frame (a RightHanded pose is mirrored), /VMC/Ext/OK 1,
        // /VMC/Ext/T `time` (seconds, the caller's clock). metresPerUnit scales positions (1 for a rig's poses).
        // A buffer of 2048 bytes holds every bone; a smaller one throws BufferTooSmall with the size needed.
        // Allocates nothing in C# (the pose crosses through the rig's buffer; liblo allocates inside).
        public int WriteVmc(HumanoidPose p, double time, byte[] buffer, float metresPerUnit = 1.0f)
        {
            Begin();
            Marshal.WriteInt32(pose, 4, (int)p.Placed);
            Marshal.WriteInt32(pose, 8, (int)p.Frame);
            Marshal.WriteInt32(pose, DegenerateAt, (int)p.Degenerate);
            Marshal.WriteInt32(pose, DegenerateAt + 4, 0);
            Marshal.Copy(p.HipsPosition, 0, pose + HipsAt, 3);
            Marshal.Copy(p.Rotation, 0, pose + RotationAt, 4 * HumanoidPose.BoneCount);
            Marshal.Copy(p.Offset, 0, pose + OffsetAt, 3 * HumanoidPose.BoneCount);
            UIntPtr size;
            Status s = Native.kata_vmc_write_pose(pose, time, metresPerUnit, buffer, (UIntPtr)(buffer == null ? 0 : buffer.Length), out size);
            if (s == Status.BufferTooSmall)
                throw new KataException(s, "the bundle needs " + size + " bytes", "kata_vmc_write_pose");
            if (s != Status.Ok) throw new KataException(s, Native.FromUtf8(Native.kata_thread_last_error(IntPtr.Zero)), "kata_vmc_write_pose");
            return (int)size;
        }
    }

    // A VMC performer's datagrams into the joints of the "vrm" layout (kata_vmc_reader; kata/vmc.h); one thread
    // at a time. Bad input is never an error: it is counted (Counters) and changes nothing.
    public sealed class VmcReader : IDisposable
    {
        public const int Joints = 22;               // KATA_VMC_JOINTS: the "vrm" layout's
        public const int DefaultPort = 39539;        // KATA_VMC_PORT
        public const int DefaultMaxPacket = 65536;   // KATA_VMC_DEFAULT_MAX_PACKET
        public readonly VmcReaderHandle Handle;
        internal VmcReader(VmcReaderHandle h) { Handle = h; }
        public void Dispose() { Handle.Dispose(); }
        private void Throw(Status s, string call) { throw new KataException(s, Native.FromUtf8(Native.kata_vmc_reader_last_error(Handle)), call); }

        // kata_vmc_reader_read: one datagram (the first `length` bytes of packet, as received); true when it
        // ended a frame (then read it with Positions). arrivalTime: seconds on the caller's clock, the frame's
        // time when the datagram carries neither /VMC/Ext/T nor a bundle timetag.
        public bool Read(byte[] packet, int length, double arrivalTime = 0.0)
        {
            if (packet == null || length < 0 || length > packet.Length) throw new ArgumentException("length must be within packet");
            int frame;
            Status s = Native.kata_vmc_reader_read(Handle, packet, (UIntPtr)length, arrivalTime, out frame);
            if (s != Status.Ok) Throw(s, "kata_vmc_reader_read");
            return frame != 0;
        }

        // kata_vmc_reader_positions: the newest frame's joints (Joints x 3 floats into `into`, metres, kata's
        // right-handed frame: Unity's x negated) and its time; false before the first frame.
        public bool Positions(float[] into, out double captureTime)
        {
            Status s = Native.kata_vmc_reader_positions(Handle, into, (UIntPtr)(into == null ? 0 : into.Length), out captureTime);
            if (s == Status.NoData) return false;
            if (s != Status.Ok) Throw(s, "kata_vmc_reader_positions");
            return true;
        }

        // kata_vmc_reader_get_counters.
        public VmcCounters Counters
        {
            get
            {
                VmcCounters c = new VmcCounters();
                c.StructSize = (uint)Marshal.SizeOf(typeof(VmcCounters));
                Status s = Native.kata_vmc_reader_get_counters(Handle, ref c);
                if (s != Status.Ok) Throw(s, "kata_vmc_reader_get_counters");
                return c;
            }
        }
    }

    // Several people in one picture (kata_people, kata/people.h): which stream each unlabeled pose of a
    // multi-person detector belongs to. Ids count up from 1 and are not reused; 0: the pose was refused
    // (Counters says why). One thread at a time; Track into a caller's ids array allocates nothing.
    public sealed class People : IDisposable
    {
        public readonly PeopleHandle Handle;
        public readonly uint JointCount;
        private readonly uint[] list = new uint[64];  // at most max_people (64) ids
        internal People(PeopleHandle h, uint jointCount) { Handle = h; JointCount = jointCount; }
        public void Dispose() { Handle.Dispose(); }
        private void Throw(Status s, string call) { throw new KataException(s, Native.FromUtf8(Native.kata_people_last_error(Handle)), call); }

        // kata_people_desc_init with joint_count set: the defaults (kata/people.h) for poses of `jointCount` joints.
        public static PeopleDesc DefaultDesc(uint jointCount)
        {
            PeopleDesc d = new PeopleDesc();
            Native.kata_people_desc_init_sized(ref d, (uint)Marshal.SizeOf(typeof(PeopleDesc)));
            d.JointCount = jointCount;
            return d;
        }

        // kata_people_stream_id: the stream a runtime (kata serve) scores person `person` of group stream `group` on.
        public static ulong StreamId(ulong group, uint person) { return Native.kata_people_stream_id(group, person); }

        // kata_people_track: one frame's poses (poseCount x JointCount x 3, in any order; poseCount may be 0)
        // with their confidences (poseCount x JointCount in [0, 1], or null: all confident) -> each pose's
        // stream id into ids[0 .. poseCount) (0: refused). Allocates nothing.
        public void Track(double time, float[] poses, float[] confidences, uint poseCount, uint[] ids)
        {
            if (poses == null || ids == null) throw new ArgumentNullException(poses == null ? "poses" : "ids");
            if (poses.Length < poseCount * JointCount * 3 || (confidences != null && confidences.Length < poseCount * JointCount))
                throw new ArgumentException("poses must hold poseCount x " + JointCount + " x 3 floats, confidences poseCount x " + JointCount);
            Status s = Native.kata_people_track(Handle, time, poses, confidences, poseCount, ids, (UIntPtr)ids.Length);
            if (s != Status.Ok) Throw(s, "kata_people_track");
        }

        // Track for a frame of poses.Length / (JointCount x 3) poses; a new ids array.
        public uint[] Track(double time, float[] poses, float[] confidences = null)
        {
            uint n = (uint)(poses.Length / (3 * JointCount));
            uint[] ids = new uint[n];
            Track(time, poses, confidences, n, ids);
            return ids;
        }

        private uint[] List(Status s, uint count, string call)
        {
            if (s != Status.Ok) Throw(s, call);
            uint[] ids = new uint[count];
            Array.Copy(list, ids, (int)count);
            return ids;
        }

        // The streams the last Track opened (new people), closed (unseen for longer than ForgetSeconds),
        // and the streams open now (seen or hidden).
        public uint[] Opened { get { uint n; Status s = Native.kata_people_opened(Handle, list, (UIntPtr)list.Length, out n); return List(s, n, "kata_people_opened"); } }
        public uint[] Closed { get { uint n; Status s = Native.kata_people_closed(Handle, list, (UIntPtr)list.Length, out n); return List(s, n, "kata_people_closed"); } }
        public uint[] Streams { get { uint n; Status s = Native.kata_people_streams(Handle, list, (UIntPtr)list.Length, out n); return List(s, n, "kata_people_streams"); } }

        // kata_people_predicted: where stream `id`'s person is predicted at `time` (their centroid, 3 values).
        public double[] Predicted(uint id, double time)
        {
            double[] c = new double[3];
            Status s = Native.kata_people_predicted(Handle, id, time, c);
            if (s != Status.Ok) Throw(s, "kata_people_predicted");
            return c;
        }

        public PeopleCounters Counters
        {
            get
            {
                PeopleCounters c = new PeopleCounters();
                c.StructSize = (uint)Marshal.SizeOf(typeof(PeopleCounters));
                Status s = Native.kata_people_get_counters(Handle, ref c);
                if (s != Status.Ok) Throw(s, "kata_people_get_counters");
                return c;
            }
        }
    }
}
