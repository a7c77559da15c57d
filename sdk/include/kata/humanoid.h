/* kata/humanoid.h: a humanoid (VRM) rig for any layout: the student and the ghost as the local
 * rotations of named humanoid bones relative to a T-pose, and the hips' position, which is what
 * a game engine animates (Unity's Humanoid, Unreal's Mannequin, VRM avatars, Godot) and what the
 * VMC protocol sends.
 *
 * Part of the C ABI; include "kata/kata.h" (all of it) or this header alone: it includes what it
 * needs. kata.h states the conventions every function here follows. docs/humanoid.md is the
 * long form of what follows (what is exact, what is chosen, the frames, the bone list).
 *
 * kata_humanoid_rig rig;  kata_humanoid_pose pose;  pose.struct_size = sizeof pose;
 * kata_humanoid_rig_create_for_stream(ctx, stream, NULL, &rig);  -- after attaching the teacher
 * kata_stream_push(stream, t, xyz, joints);
 * kata_humanoid_rig_pose(rig, xyz, joints, KATA_HUMANOID_UNITY, &pose);         -- the student
 * kata_stream_read_newest(stream, &r, ghost, ghost_capacity, NULL, 0);
 * kata_humanoid_rig_pose_ghost(rig, ghost, ghost_joints, KATA_HUMANOID_UNITY, &pose);  -- the ghost
 * kata_humanoid_rig_destroy(rig);
 *
 * ---- The rig (section: humanoid) ----
 * Bones: the VRM humanoid bones below (VRM 1.0 "humanoid.humanBones", named as Unity's
 * HumanBodyBones and the VMC protocol name them: kata_humanoid_bone_name), a fixed tree
 * (kata_humanoid_bone_parent). Each bone has a joint (where it turns) and points from it to its
 * child's joint. A layout places the bones it can (kata_humanoid_rig_placed):
 *   every layout: Hips, Spine, Chest, Neck, Head, and per side Shoulder, UpperArm, LowerArm, Hand,
 *     UpperLeg, LowerLeg, Foot, from the 16 GPD joints the layout maps (kata/stream.h "Layouts"):
 *     Hips at GPD Hip; Spine's joint on the hips' (its bone runs from the hips to the chest);
 *     Chest at GPD Chest; Neck at GPD Neck; Head at GPD Head; each Shoulder (the clavicle) on the
 *     topmost chest joint, its bone running to the upper arm's joint; UpperArm, LowerArm, Hand at
 *     GPD LShoulder, LElbow, LHand (the same on the right); UpperLeg, LowerLeg, Foot at GPD LHip,
 *     LKnee, LFoot;
 *   more where the layout has them: "cmu" UpperChest (CMU's Spine1, Chest then being CMU's
 *     Spine), Toes (LeftToeBase) and the hand's direction (to LeftHandIndex1); "mediapipe" Toes
 *     (foot_index), the hand's direction and turn (index and pinky landmarks) and the head's turn
 *     (ears and nose); "kinect2" and "azure-kinect" Toes (FootLeft, FOOT_LEFT) and the hand's
 *     direction (HandTipLeft, HANDTIP_LEFT) and turn (ThumbLeft, THUMB_LEFT), "azure-kinect" the
 *     head's turn (EAR_LEFT, EAR_RIGHT, NOSE); "xsens" Toes (LeftToe). A ghost places what its
 *     joints have of these (a ghost across layouts, the 16 GPD joints: the bones of every layout).
 *   A bone the layout does not place has the identity rotation and a zero offset in every pose,
 *   so forward kinematics over the fixed tree passes through it.
 * Rest: a T-pose facing +Z with +Y up (VRM 1.0's): the spine and neck straight up, the arms
 * straight out (the left arm along +X, the right along -X), the legs straight down, the feet
 * forward (+Z), every bone as long as the student's (measured: kata_humanoid_rig_calibrate).
 * The hip joints' offsets from the hips are the student's own pelvis, measured in the hips' rest
 * frame (the hip line +X, the spine, hips to chest, straight up +Y), and the hips stand so that the
 * ankles are on the floor (Y = 0).
 * Per frame: each placed bone's rotation relative to that T-pose, local (relative to its parent),
 * and each bone joint's offset from its parent's joint in the parent's frame:
 *   G_hips = R_hips,  X_hips = hips_position;  G_b = G_parent R_b,  X_b = X_parent + G_parent offset_b
 * (quaternions act on column vectors; G is the bone's rotation in the world).
 * Exact (to float rounding, tested on every frame of a CMU clip and of MediaPipe landmarks made
 * from one): every bone whose two ends the layout gives points exactly where the pose has it:
 * its offset in the pose is its rest offset scaled by the frame's bone length. Forward
 * kinematics of the rotations over the pose's offsets puts every placed joint where the pose has
 * it; over the rest offsets too (offset = rest offset) whenever the input keeps the rig's bone
 * lengths and pelvis shape (a BVH clip on its own layout: "cmu" on a CMU clip, every frame).
 * Where it does not (landmark trackers: bone lengths that vary from frame to frame, synthesised
 * joints), the rotations still give every bone's direction and the offsets carry the rest.
 * Chosen (the input says nothing about them):
 *   - the twist about a bone (its turn about its own axis): a bone with a bent child takes the
 *     turn that puts the bend on its hinge (the upper arm: the forearm in the upper arm's XZ plane,
 *     elbow bending forward; the upper leg: the shin bending back), fading to the smallest rotation
 *     as the limb straightens (bend below 20 degrees, none below 5); the forearm (LowerArm) and
 *     the Hand take the hand's turn from the hand's points where the layout has them (the thumb's
 *     side is their +Z: MediaPipe's index minus pinky, Kinect's thumb minus wrist), else the
 *     smallest rotation; every other bone the smallest rotation from its parent (a swing);
 *   - the hips' orientation from the hip line (left hip joint minus right: the hips' +X) and the
 *     pelvis (the hips' joint against the hip joints, taken to turn rigidly with the hips, its lean
 *     against the spine measured at rest), or, where the hips' joint lies on the hip line (within 5%
 *     of the hip width at rest, 2% in a frame), the hip line and the spine (hips to chest: +Y);
 *   - the topmost chest bone's from the line between the upper arms' joints (its +X) and its
 *     bone; the head's from the ears and the nose where the layout has them (the ear line +X, the
 *     nose +Z), else the neck's (identity rotation);
 *   - a bone whose direction is degenerate (two joints at one point, or its parent's) keeps the
 *     identity rotation (its bit is set in kata_humanoid_pose.degenerate). No finite input gives
 *     a NaN.
 * Frames (kata_humanoid_frame): KATA_HUMANOID_RIGHT_HANDED, the rig's own (+Y up, right-handed,
 * metres: the input turned to +Y up as its layout or up_axis reads it, scaled by
 * metres_per_unit), or KATA_HUMANOID_UNITY, Unity's left-handed Y-up, as the VMC protocol sends:
 * every position (x, y, z) -> (-x, y, z) and every rotation (x, y, z, w) -> (x, -y, -z, w) (a
 * mirror through the YZ plane: forward kinematics in Unity's frame gives the mirrored joints, and
 * an avatar shows the same pose, its left side on Unity's -X).
 * Memory: creating a rig allocates; the per-frame calls never do. Threads: a rig is used by one
 * thread at a time (different rigs in parallel); it is independent of the stream it was made
 * from (which may be destroyed first). */
#ifndef KATA_HUMANOID_H
#define KATA_HUMANOID_H

#include "stream.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The VRM humanoid bones kata places, in this order (values are never reassigned; bones added
 * later, fingers or eyes, take new values). Parents: kata_humanoid_bone_parent. */
typedef enum kata_humanoid_bone {
  KATA_BONE_HIPS = 0,         /* "Hips": the root; its joint is the pelvis */
  KATA_BONE_SPINE = 1,        /* "Spine": its joint on the hips', its bone up to the chest */
  KATA_BONE_CHEST = 2,        /* "Chest" */
  KATA_BONE_UPPER_CHEST = 3,  /* "UpperChest" (where the layout has it: "cmu") */
  KATA_BONE_NECK = 4,         /* "Neck" */
  KATA_BONE_HEAD = 5,         /* "Head" */
  KATA_BONE_LEFT_SHOULDER = 6,      /* "LeftShoulder": the clavicle */
  KATA_BONE_LEFT_UPPER_ARM = 7,     /* "LeftUpperArm" */
  KATA_BONE_LEFT_LOWER_ARM = 8,     /* "LeftLowerArm": the forearm */
  KATA_BONE_LEFT_HAND = 9,          /* "LeftHand": its joint the wrist */
  KATA_BONE_RIGHT_SHOULDER = 10,    /* "RightShoulder" */
  KATA_BONE_RIGHT_UPPER_ARM = 11,   /* "RightUpperArm" */
  KATA_BONE_RIGHT_LOWER_ARM = 12,   /* "RightLowerArm" */
  KATA_BONE_RIGHT_HAND = 13,        /* "RightHand" */
  KATA_BONE_LEFT_UPPER_LEG = 14,    /* "LeftUpperLeg": its joint the hip joint */
  KATA_BONE_LEFT_LOWER_LEG = 15,    /* "LeftLowerLeg": its joint the knee */
  KATA_BONE_LEFT_FOOT = 16,         /* "LeftFoot": its joint the ankle */
  KATA_BONE_LEFT_TOES = 17,         /* "LeftToes" (where the layout has them) */
  KATA_BONE_RIGHT_UPPER_LEG = 18,   /* "RightUpperLeg" */
  KATA_BONE_RIGHT_LOWER_LEG = 19,   /* "RightLowerLeg" */
  KATA_BONE_RIGHT_FOOT = 20,        /* "RightFoot" */
  KATA_BONE_RIGHT_TOES = 21,        /* "RightToes" */
  KATA_BONE_COUNT = 22              /* the number of bones above (array sizes) */
} kata_humanoid_bone;

/* The bone's name as Unity's HumanBodyBones and the VMC protocol spell it ("Hips", "Spine",
 * "Chest", "UpperChest", "Neck", "Head", "LeftShoulder", "LeftUpperArm", "LeftLowerArm",
 * "LeftHand", ..., "LeftUpperLeg", "LeftLowerLeg", "LeftFoot", "LeftToes", ...); NULL out of
 * range. A static string. [any thread] */
KATA_API const char* kata_humanoid_bone_name(int bone);
/* The bone kata_humanoid_bone_name names `name` (exact, case-sensitive), or -1. [any thread] */
KATA_API int kata_humanoid_bone_find(const char* name);
/* The bone's parent in the VRM tree (Spine: Hips; Chest: Spine; UpperChest: Chest; Neck and both
 * Shoulders: UpperChest; Head: Neck; UpperArm: Shoulder; LowerArm: UpperArm; Hand: LowerArm;
 * UpperLeg: Hips; LowerLeg: UpperLeg; Foot: LowerLeg; Toes: Foot); -1 for the hips, -2 out of
 * range. Parents come before their children. [any thread] */
KATA_API int kata_humanoid_bone_parent(int bone);

/* The axes a pose's numbers are in (the section above). Values are never reused. */
typedef enum kata_humanoid_frame {
  KATA_HUMANOID_RIGHT_HANDED = 0, /* the rig's own: +Y up, right-handed, metres; the T-pose faces +Z */
  KATA_HUMANOID_UNITY = 1         /* Unity's left-handed Y-up (x mirrored), as VMC sends */
} kata_humanoid_frame;

/* One frame of a humanoid: the rotations and offsets of the section above. Written by the
 * library; the caller sets struct_size (its sizeof; at least the size this struct first shipped with) before the call, and a
 * writer fills only that many bytes. */
typedef struct kata_humanoid_pose {
  uint32_t struct_size;                /* the caller's sizeof(kata_humanoid_pose); kept */
  uint32_t placed;                     /* bit b set: bone b is placed (rotation and offset valid);
                                          the others are identity and zero */
  int32_t frame;                       /* kata_humanoid_frame the numbers below are in */
  float hips_position[3];              /* the hips joint's position (metres) */
  float rotation[KATA_BONE_COUNT][4];  /* local rotation relative to the T-pose rest, x y z w,
                                          unit, w >= 0 (the hips': in the world) */
  float offset[KATA_BONE_COUNT][3];    /* this frame's offset of the bone's joint from its
                                          parent's joint in the parent's frame (metres; the hips':
                                          the rest hips position); FK of rotation over offset
                                          places the joints. The rest offset scaled by the frame's
                                          bone length where the layout gives the bone's direction */
  uint32_t degenerate;                 /* bit b set: bone b's direction or turn was degenerate this
                                          frame (its rotation is the identity, or its twist the
                                          smallest rotation) */
  uint32_t reserved;                   /* 0 */
} kata_humanoid_pose;

/* A humanoid rig: a layout's joints mapped onto the VRM bones, with the student's bone lengths. */
typedef struct kata_humanoid_rig_s* kata_humanoid_rig;

/* How a rig reads its input. Fill with kata_humanoid_desc_init, then change fields. */
typedef struct kata_humanoid_desc {
  uint32_t struct_size;     /* sizeof(kata_humanoid_desc) */
  /* The input's layout: a built-in layout's name (kata_layout_name). NULL: "cmu". Ignored by
   * kata_humanoid_rig_create_for_stream (the stream's layout or name map is used). */
  const char* layout;
  /* How the input's axes are read (kata_up_axis), as kata_stream_desc.up_axis; ignored for a
   * layout that fixes its axes ("mediapipe") and by kata_humanoid_rig_create_for_stream (the
   * stream's). Default KATA_UP_Y. */
  kata_up_axis up_axis;
  /* Metres per input unit (> 0), or 0 (default): the layout's, 1 unless listed: "cmu",
   * "cmu-3dsmax", "daz" 0.056444 (the CMU BVH unit, 1/0.45 inch), "azure-kinect" 0.001. */
  double metres_per_unit;
} kata_humanoid_desc;

/* Fills the first struct_size bytes of desc with the defaults above and sets desc->struct_size
 * to the smaller of struct_size and sizeof(kata_humanoid_desc), as kata_stream_desc_init_sized
 * does. [any thread] */
KATA_API void kata_humanoid_desc_init_sized(kata_humanoid_desc* desc, uint32_t struct_size);
/* Fills *desc with the defaults for the caller's own struct. */
#define kata_humanoid_desc_init(desc) kata_humanoid_desc_init_sized((desc), (uint32_t)sizeof *(desc))

/* Builds a rig for frames of `skeleton` (every joint per frame, as kata_stream_push takes them)
 * read through desc->layout. A skeleton with rest offsets gives the rest bone lengths; one
 * without (a bare landmark source) is measured by kata_humanoid_rig_calibrate, or else by the
 * first frame posed. desc may be NULL for the defaults. Errors (unknown layout, a joint the
 * layout needs missing, bad values) are reported on the context. *out is owned by the caller.
 * [any thread] */
KATA_API kata_status kata_humanoid_rig_create(kata_context context, kata_skeleton skeleton,
                                              const kata_humanoid_desc* desc, kata_humanoid_rig* out);
/* The same for a stream's frames: its skeleton, layout or name map and axes; desc (may be NULL)
 * gives metres_per_unit only (a name map's default is 1). When the stream has a ghost (a teacher
 * attached with ghost = 1) the rig also reads its ghosts (kata_humanoid_rig_pose_ghost), with the
 * student's bone lengths: create the rig after attaching the teacher. [stream owner] */
KATA_API kata_status kata_humanoid_rig_create_for_stream(kata_context context, kata_stream stream,
                                                         const kata_humanoid_desc* desc, kata_humanoid_rig* out);
/* Releases a rig. NULL is ignored. [rig owner] */
KATA_API void kata_humanoid_rig_destroy(kata_humanoid_rig rig);
/* The message of the last failed call on this rig, or "". Valid until the next call on it.
 * [rig owner] */
KATA_API const char* kata_humanoid_rig_last_error(kata_humanoid_rig rig);
/* Joints per input frame (the skeleton's); 0 for NULL. [rig owner] */
KATA_API uint32_t kata_humanoid_rig_joint_count(kata_humanoid_rig rig);
/* Joints per ghost frame the rig reads (kata_stream_ghost_joint_count of its stream when it was
 * created), 0 when it reads no ghost or for NULL. [rig owner] */
KATA_API uint32_t kata_humanoid_rig_ghost_joint_count(kata_humanoid_rig rig);
/* The bones the layout places: bit b for bone b (as kata_humanoid_pose.placed); 0 for NULL.
 * [rig owner] */
KATA_API uint32_t kata_humanoid_rig_placed(kata_humanoid_rig rig);
/* The metres per input unit the rig scales by; 0 for NULL. [rig owner] */
KATA_API double kata_humanoid_rig_metres_per_unit(kata_humanoid_rig rig);
/* The input joint bone `bone`'s joint is (an index into the skeleton), or -1 for a joint the
 * layout synthesises (GPD Hip, Chest, Neck, Head of "mediapipe"; Spine's and each Shoulder's,
 * which sit on another bone's joint), a bone not placed, out of range or NULL. [rig owner] */
KATA_API int32_t kata_humanoid_rig_bone_source(kata_humanoid_rig rig, int32_t bone);
/* Measures the rest bone lengths from `frames` frames (frames x joint_count x 3 floats, input
 * units and axes): each bone's length and the pelvis's shape are the median over the frames
 * whose bone is not degenerate. Replaces the rest taken from the skeleton or an earlier
 * calibration (the ghost's rest too). KATA_E_WRONG_JOINT_COUNT, KATA_E_NON_FINITE (nothing
 * changed); KATA_E_INVALID_ARGUMENT for frames 0 or above 65536. Allocates. [rig owner] */
KATA_API kata_status kata_humanoid_rig_calibrate(kata_humanoid_rig rig, const float* positions,
                                                 uint32_t joint_count, uint32_t frames);
/* 1 when the rig has its rest bone lengths (from the skeleton, kata_humanoid_rig_calibrate or a
 * first frame posed), else 0 (also for NULL). [rig owner] */
KATA_API int32_t kata_humanoid_rig_calibrated(kata_humanoid_rig rig);
/* The rest T-pose (identity rotations, rest offsets, the rest hips position) in `frame` into
 * *out (out->struct_size set by the caller): what a receiver builds its rig from. KATA_E_STATE
 * before the rig has its rest. Does not allocate. [rig owner] */
KATA_API kata_status kata_humanoid_rig_rest_pose(kata_humanoid_rig rig, int32_t frame, kata_humanoid_pose* out);

/* One frame of the input (joint_count x 3 floats: every skeleton joint, input units and axes, as
 * pushed to a stream) as a humanoid pose in `frame` (kata_humanoid_frame) into *out
 * (out->struct_size set by the caller). An uncalibrated rig takes its rest from this frame first.
 * KATA_E_NULL_POINTER, KATA_E_WRONG_JOINT_COUNT, KATA_E_NON_FINITE (a joint the rig reads is NaN
 * or infinite: the message names it), KATA_E_INVALID_ARGUMENT (frame unknown, a struct_size
 * below the first release's) leave *out unwritten. Does not allocate. [rig owner] */
KATA_API kata_status kata_humanoid_rig_pose(kata_humanoid_rig rig, const float* positions, uint32_t joint_count,
                                            int32_t frame, kata_humanoid_pose* out);
/* The same for a ghost of the rig's stream (kata_stream_read_results / _read_newest's ghost
 * array entry, or a result record's ghost: ghost_joint_count x 3 floats, the student's units and
 * axes), on the student's bone lengths. KATA_E_STATE when the rig reads no ghost (its stream had
 * none when it was created); else as kata_humanoid_rig_pose. Does not allocate. [rig owner] */
KATA_API kata_status kata_humanoid_rig_pose_ghost(kata_humanoid_rig rig, const float* ghost,
                                                  uint32_t ghost_joint_count, int32_t frame,
                                                  kata_humanoid_pose* out);

/* Converts a pose to `frame` in place (a no-op when it is in it already): the mirror of the
 * section above. KATA_E_NULL_POINTER, KATA_E_INVALID_ARGUMENT (an unknown frame on either side).
 * Does not allocate. [any thread] */
KATA_API kata_status kata_humanoid_pose_convert(kata_humanoid_pose* pose, int32_t frame);
/* Forward kinematics of a pose (the section above) in the pose's own frame: every bone's joint
 * position (metres) into positions (KATA_BONE_COUNT x 3 floats, bone order; an unplaced bone's is
 * its parent's), each bone's world rotation into rotations (KATA_BONE_COUNT x 4 floats, x y z w;
 * may be NULL). capacity: floats in positions. KATA_E_BUFFER_TOO_SMALL, KATA_E_NULL_POINTER.
 * Does not allocate. [any thread] */
KATA_API kata_status kata_humanoid_pose_joints(const kata_humanoid_pose* pose, float* positions, size_t capacity,
                                               float* rotations, size_t rotation_capacity);

#ifdef __cplusplus
}
#endif

#endif /* KATA_HUMANOID_H */
