// The C# binding against values computed independently (the `kata` CLI's .npy and CSV), plus its own
// promises: handles released exactly once, a library of another major version refused.
//   mono KataTests.exe REPO_DIR KATA_CLI TMP_DIR          the suite (exit 0 = all passed)
//   mono KataTests.exe --expect-wrong-version             run against a libkata reporting 7.0.0
using System;
using System.Collections.Generic;
using System.Diagnostics;
using System.Globalization;
using System.IO;
using System.Text;
using Kata;

static class KataTests
{
    static int failures;

    static void Check(bool ok, string what)
    {
        if (!ok) { ++failures; Console.Error.WriteLine("FAILED: " + what); }
    }

    static void RunCli(string cli, string args)
    {
        ProcessStartInfo psi = new ProcessStartInfo(cli, args) { UseShellExecute = false, RedirectStandardOutput = true, RedirectStandardError = true };
        using (Process p = Process.Start(psi))
        {
            string err = p.StandardError.ReadToEnd();
            p.StandardOutput.ReadToEnd();
            p.WaitForExit();
            if (p.ExitCode != 0) throw new Exception(cli + " " + args + " failed: " + err);
        }
    }

    // A float32 2-D .npy (little-endian '<f4', C order) as written by `kata features`.
    static float[] ReadNpy(string path, out int rows, out int cols)
    {
        byte[] b = File.ReadAllBytes(path);
        int headerLen = b[8] | (b[9] << 8);
        string header = Encoding.ASCII.GetString(b, 10, headerLen);
        if (!header.Contains("'descr': '<f4'") || header.Contains("'fortran_order': True")) throw new Exception("unexpected npy " + header);
        int open = header.IndexOf("'shape': (") + 10, close = header.IndexOf(')', open);
        string[] dims = header.Substring(open, close - open).Split(new[] { ',' }, StringSplitOptions.RemoveEmptyEntries);
        rows = int.Parse(dims[0].Trim());
        cols = int.Parse(dims[1].Trim());
        float[] data = new float[rows * cols];
        Buffer.BlockCopy(b, 10 + headerLen, data, 0, data.Length * 4);
        return data;
    }

    static float[] Frame(Clip clip, uint i, int joints)
    {
        float[] xyz = new float[joints * 3];
        clip.Positions(i, xyz);
        return xyz;
    }

    static void FeaturesEqualTheCli(Context ctx, string repo, string cli, string tmp)
    {
        string bvh = Path.Combine(repo, "data/cmu/05_02.bvh"), npy = Path.Combine(tmp, "features.npy");
        RunCli(cli, "features --bvh " + bvh + " --preset cmu --out " + npy);
        int rows, cols;
        float[] expected = ReadNpy(npy, out rows, out cols);
        using (Clip clip = ctx.LoadClip(bvh))
        using (Skeleton sk = clip.Skeleton())
        {
            StreamDesc d = Context.DefaultStreamDesc();
            d.KeepFeatures = 1;
            d.ResultCapacity = clip.FrameCount;
            using (Kata.Stream s = ctx.OpenStream(sk, "cmu", d))
            {
                int joints = (int)sk.JointCount;
                for (uint i = 0; i < clip.FrameCount; ++i) s.Push(i * clip.FrameTime, Frame(clip, i, joints));
                s.Flush();
                ResultBatch batch = s.NewResultBatch((int)clip.FrameCount, true);
                int n = s.ReadResults(batch);
                Check(n == rows && cols == Gpd.Dims, "features: " + n + " rows vs the CLI's " + rows);
                int differing = 0;
                for (int k = 0; k < rows * cols; ++k)
                    if (BitConverter.SingleToInt32Bits(batch.Features[k]) != BitConverter.SingleToInt32Bits(expected[k])) ++differing;
                Check(differing == 0, "features: " + differing + " values differ from `kata features`");
                for (int r = 0; r < n; ++r) Check(batch.Results[r].FrameIndex == r, "features: frame index of row " + r);
            }
        }
    }

    // The CSV prints distance and parts with %.7g and the score with %.4f: each must be our value
    // rounded to that many digits (within half a unit of the last printed digit).
    static bool SameAsPrinted(double ours, string printed, bool fixed4)
    {
        double p = double.Parse(printed, CultureInfo.InvariantCulture);
        double halfUlp = fixed4 ? 0.5e-4 : (p == 0 ? 1e-45 : 0.5 * Math.Pow(10, Math.Floor(Math.Log10(Math.Abs(p))) - 6));
        return Math.Abs(ours - p) <= halfUlp * (1 + 1e-9);
    }

    static void ScoresEqualTheCli(Context ctx, string repo, string cli, string tmp)
    {
        string teacher = Path.Combine(repo, "data/cmu/02_01.bvh"), student = Path.Combine(repo, "data/cmu/07_01.bvh");
        string model = Path.Combine(repo, "models/default.kata"), csv = Path.Combine(tmp, "scores.csv");
        RunCli(cli, "score --model " + model + " --teacher " + teacher + " --student " + student +
                    " --preset cmu --first-frame 1 --out " + csv);
        string[] lines = File.ReadAllLines(csv);
        // The first ten columns (then come the part distances, part scores, part to fix and state).
        Check(lines[0].StartsWith("frame,time,distance,score,torso_head,left_arm,right_arm,left_leg,right_leg,matched_teacher_frame,"),
              "score: CSV header " + lines[0]);
        using (Model m = ctx.LoadModel(model))
        using (Clip t = ctx.LoadClip(teacher))
        using (Clip st = ctx.LoadClip(student))
        using (Skeleton sk = st.Skeleton())
        {
            StreamDesc d = Context.DefaultStreamDesc();
            d.Stencil = m.Stencil;
            d.ResultCapacity = st.FrameCount;
            using (Kata.Stream s = ctx.OpenStream(sk, "cmu", d))
            {
                s.AttachTeacher(m, t, 1, false);
                int joints = (int)sk.JointCount;
                for (uint i = 1; i < st.FrameCount; ++i) s.Push((i - 1) * st.FrameTime, Frame(st, i, joints));
                ResultBatch batch = s.NewResultBatch((int)st.FrameCount);
                int n = s.ReadResults(batch);
                Check(n == lines.Length - 1, "score: " + n + " results vs " + (lines.Length - 1) + " CSV rows");
                int bad = 0;
                // The correction cue's columns, by name (`kata score` appends them).
                int cueJoint = Array.IndexOf(lines[0].Split(','), "cue_joint"), cue = Array.IndexOf(lines[0].Split(','), "cue");
                Check(cueJoint > 0 && cue > 0, "score: no cue_joint / cue column in " + lines[0]);
                for (int r = 0; r < n && r + 1 < lines.Length; ++r)
                {
                    string[] f = lines[r + 1].Split(',');
                    ResultRecord res = batch.Results[r];
                    ResultRecord sc = batch.Scores[r];
                    bool ok = res.Scored != 0 && long.Parse(f[0]) == res.FrameIndex + 1 &&
                              SameAsPrinted(sc.Distance, f[2], false) && SameAsPrinted(sc.Score, f[3], true) &&
                              int.Parse(f[9]) == res.MatchedTeacherFrame + 1;
                    ok &= f[cueJoint] == (res.CueJoint >= 0 ? Native.GpdJointName(res.CueJoint) : "") &&
                          f[cue] == Native.CueText(res) && (res.CueJoint >= 0) == (res.PartToFix >= 0);
                    for (int q = 0; q < Gpd.PartCount; ++q) ok &= SameAsPrinted(sc.Part((BodyPart)q), f[4 + q], false);
                    if (!ok && bad++ < 3) Console.Error.WriteLine("row " + lines[r + 1] + " vs " + sc.Distance + " " + sc.Score + " " + res.MatchedTeacherFrame);
                }
                Check(bad == 0, "score: " + bad + " rows differ from `kata score`");
            }
        }
    }

    // A walk played twice against itself, looped: the first play is one repetition at the teacher's tempo,
    // and the records count 1 then 2 (docs/coach/repetitions.md).
    static void RepetitionsOfAWalkPlayedTwice(Context ctx, string repo)
    {
        using (Model m = ctx.LoadModel(Path.Combine(repo, "models/default.kata")))
        using (Clip c = ctx.LoadClip(Path.Combine(repo, "data/cmu/02_01.bvh")))
        using (Skeleton sk = c.Skeleton())
        {
            StreamDesc d = Context.DefaultStreamDesc();
            d.Stencil = m.Stencil;
            d.ResultCapacity = 2 * c.FrameCount;
            using (Kata.Stream s = ctx.OpenStream(sk, "cmu", d))
            {
                s.AttachTeacher(m, c, 1, false);
                s.SetPracticeSection(0, -1, true);
                int joints = (int)sk.JointCount;
                uint n = c.FrameCount - 1;
                for (uint k = 0; k < 2 * n; ++k) s.Push(k * c.FrameTime, Frame(c, 1 + k % n, joints));
                ResultBatch batch = s.NewResultBatch((int)(2 * n));
                int got = s.ReadResults(batch);
                Repetition[] reps = new Repetition[16];
                int count = s.ReadRepetitions(reps);
                Check(count >= 1 && reps[0].Index == 1 && reps[0].Partial == 0, "reps: the first play is repetition 1 (" + count + " read)");
                Check(Math.Abs(reps[0].Tempo - 1.0) < 0.05, "reps: its tempo " + reps[0].Tempo + " is the teacher's");
                Check(Math.Abs(reps[0].EndTime - n * c.FrameTime) < 0.05, "reps: it ends where the second play starts: " + reps[0].EndTime);
                Check(got > 0 && batch.Results[0].Repetition == 1 && batch.Results[got - 1].Repetition == 2,
                      "reps: the records count 1 then 2");
            }
        }
    }

    static void ErrorsCarryTheCMessage(Context ctx, string repo, string tmp)
    {
        string bad = Path.Combine(tmp, "bad.kata");
        File.WriteAllText(bad, "not a model");
        try { ctx.LoadModel(bad).Dispose(); Check(false, "a bad model file was accepted"); }
        catch (KataException e) { Check(e.Status == Status.Model && e.NativeMessage.Contains("model refused"), "bad model: " + e.Message); }
        using (Clip clip = ctx.LoadClip(Path.Combine(repo, "data/cmu/02_01.bvh")))
        using (Skeleton sk = clip.Skeleton())
        using (Kata.Stream s = ctx.OpenStream(sk))
        {
            float[] xyz = Frame(clip, 0, (int)sk.JointCount);
            s.Push(0.0, xyz);
            xyz[4] = float.NaN;
            try { s.Push(0.01, xyz); Check(false, "a NaN frame was accepted"); }
            catch (KataException e) { Check(e.Status == Status.NonFinite && e.NativeMessage.Length > 0, "NaN frame: " + e.Message); }
            s.Push(0.01, Frame(clip, 1, (int)sk.JointCount));
            Check(s.FeatureCount == 2, "the stream stays usable after a refused frame");
        }
    }

    static void SkeletonsAndRetargeting(Context ctx, string repo)
    {
        using (Skeleton sk = ctx.CreateSkeleton(new[] { "hips", "spine", "h\u00e9ad" }, new[] { -1, 0, 1 },
                                                new double[] { 0, 0, 0, 0, 1, 0, 0, 1, 0 }))
            Check(sk.JointCount == 3 && sk.JointName(2) == "h\u00e9ad" && sk.JointParent(2) == 1, "skeleton from arrays (UTF-8 name)");
        try { ctx.CreateSkeleton(new[] { "a", "b" }, new[] { -1, 5 }, null).Dispose(); Check(false, "a bad parent was accepted"); }
        catch (KataException e) { Check(e.Status == Status.InvalidArgument && e.NativeMessage.Length > 0, "bad parent: " + e.Message); }
        using (Clip teacher = ctx.LoadClip(Path.Combine(repo, "data/cmu/02_01.bvh")))
        using (Skeleton student = ctx.LoadSkeletonBvh(Path.Combine(repo, "data/cmu/07_01.bvh")))
        using (Retargeter r = ctx.CreateRetargeter(student))
        using (Retargeter g = ctx.CreateRetargeter(student, "gpd"))
        {
            Check(r.JointCount == 21 && g.JointCount == 16, "retargeter joint sets: " + r.JointCount + ", " + g.JointCount);
            float[] ghost = new float[r.JointCount * 3];
            RetargetInfo info = r.Solve(Frame(teacher, 10, (int)student.JointCount), ghost);
            Check(info.MaxBoneError < 1e-3 && info.Iterations > 0, "retarget: bone error " + info.MaxBoneError);
            try { r.Solve(new float[9], ghost); Check(false, "a 3-joint teacher frame was accepted"); }
            catch (KataException e) { Check(e.Status == Status.WrongJointCount, "wrong joint count: " + e.Message); }
        }
    }

    static void LoadAndDrop(Context ctx, string model) { ctx.LoadModel(model); }

    static void HandlesReleasedOnce(string repo)
    {
        long before = KataHandle.ReleasedCount;
        Context ctx = new Context();
        Clip clip = ctx.LoadClip(Path.Combine(repo, "data/cmu/02_01.bvh"));
        Skeleton sk = clip.Skeleton();
        Kata.Stream s = ctx.OpenStream(sk);
        LoadAndDrop(ctx, Path.Combine(repo, "models/default.kata"));  // left to the finalizer
        // The context goes first: its destroy waits for the objects made from it (SafeHandle refs).
        ctx.Dispose();
        ctx.Dispose();
        Check(KataHandle.ReleasedCount == before, "the context was destroyed before its objects");
        s.Push(0.0, Frame(clip, 0, (int)sk.JointCount));  // still usable
        s.Dispose(); s.Dispose();
        sk.Dispose(); clip.Dispose(); clip.Dispose();
        Check(KataHandle.ReleasedCount == before + 3, "release count after stream, skeleton, clip: " + (KataHandle.ReleasedCount - before));
        GC.Collect();
        GC.WaitForPendingFinalizers();
        GC.Collect();
        GC.WaitForPendingFinalizers();
        Check(KataHandle.ReleasedCount == before + 5, "model (finalizer) and context released once each: " + (KataHandle.ReleasedCount - before));
        try { s.Push(0.1, new float[93]); Check(false, "a disposed stream was used"); }
        catch (ObjectDisposedException) { }
    }

    static void StructSizesMatchTheLibrary()
    {
        // The library sets struct_size to the smaller of the binding's size and its own: equal when they agree.
        StreamDesc sd = new StreamDesc(); Native.kata_stream_desc_init_sized(ref sd, (uint)System.Runtime.InteropServices.Marshal.SizeOf(typeof(StreamDesc)));
        RetargetDesc rd = new RetargetDesc(); Native.kata_retarget_desc_init_sized(ref rd, (uint)System.Runtime.InteropServices.Marshal.SizeOf(typeof(RetargetDesc)));
        TeacherDesc td = new TeacherDesc(); Native.kata_teacher_desc_init_sized(ref td, (uint)System.Runtime.InteropServices.Marshal.SizeOf(typeof(TeacherDesc)));
        Check(sd.StructSize == System.Runtime.InteropServices.Marshal.SizeOf(typeof(StreamDesc)), "sizeof kata_stream_desc " + sd.StructSize);
        Check(rd.StructSize == System.Runtime.InteropServices.Marshal.SizeOf(typeof(RetargetDesc)), "sizeof kata_retarget_desc " + rd.StructSize);
        Check(td.StructSize == System.Runtime.InteropServices.Marshal.SizeOf(typeof(TeacherDesc)), "sizeof kata_teacher_desc " + td.StructSize);
        Check(sd.HistoryCapacity == 16 && sd.CalibrationFrames == 8 && sd.ResultCapacity == 64 && sd.MaxGap == 0.25,
              "kata_stream_desc defaults read through the struct");
        Check(td.PoseFrame == -1 && td.Ghost == 1 && td.GhostAcross == 0 && td.AlignmentWindow == 0.5 &&
              td.OnProgress == IntPtr.Zero, "kata_teacher_desc defaults read through the struct");
        Check(rd.MaxIterations == 200 && rd.WarmStart == 1 && rd.RestoreBoneLengths == 1, "kata_retarget_desc defaults");
    }

    // A teacher given as a stream's own features: distance 0 and matched frame for frame (d = |W^T (x - x)|);
    // the newest result is the last entry a drain returns; detached, nothing is scored.
    static void TeacherAsFeaturesAndTheNewestResult(Context ctx, string repo)
    {
        using (Model model = ctx.LoadModel(Path.Combine(repo, "models/default.kata")))
        using (Clip clip = ctx.LoadClip(Path.Combine(repo, "data/cmu/02_01.bvh")))
        using (Skeleton sk = clip.Skeleton())
        using (Kata.Stream t = ctx.OpenStream(sk))
        using (Kata.Stream s = ctx.OpenStream(sk))
        using (Kata.Stream u = ctx.OpenStream(sk))
        {
            int joints = (int)sk.JointCount;
            List<float> feats = new List<float>();
            float[] f = new float[Gpd.Dims];
            double ts; long fi; long seen = 0;
            for (uint i = 1; i <= 40; ++i)
            {
                t.Push(i * clip.FrameTime, Frame(clip, i, joints));
                if (t.FeatureCount == seen) continue;
                seen = t.FeatureCount;
                t.Features(f, out ts, out fi);
                feats.AddRange(f);
            }
            int vectors = feats.Count / Gpd.Dims;
            s.AttachTeacherFeatures(model, feats.ToArray(), clip.FrameTime);
            u.AttachTeacherFeatures(model, feats.ToArray(), clip.FrameTime);
            for (uint i = 1; i <= 40; ++i) { s.Push(i * clip.FrameTime, Frame(clip, i, joints)); u.Push(i * clip.FrameTime, Frame(clip, i, joints)); }
            ResultBatch all = s.NewResultBatch(64), one = u.NewResultBatch(1);
            int n = s.ReadResults(all);
            Check(n == vectors, "features teacher: " + n + " results for " + vectors + " vectors");
            int bad = 0;
            for (int k = 0; k < n; ++k)
                if (all.Results[k].MatchedTeacherFrame != k || !(all.Scores[k].Distance < 1e-4f) || all.Results[k].Scored == 0) ++bad;
            Check(bad == 0, "features teacher: " + bad + " results not at distance 0 on their own frame");
            Check(u.ReadNewest(one) && one.Count == 1 && one.Results[0].ResultSequence == all.Results[n - 1].ResultSequence &&
                  one.Scores[0].Score == all.Scores[n - 1].Score, "ReadNewest is the last entry of a drain");
            Check(!u.ReadNewest(one) && u.ResultsPending == 0 && u.ResultsDropped == 0, "ReadNewest: nothing new, nothing dropped");
            u.DetachTeacher();
            u.Push(41 * clip.FrameTime, Frame(clip, 41, joints));
            Check(u.ReadNewest(one) && one.Results[0].Scored == 0, "detached: not scored");
            try { u.RestartTeacher(); Check(false, "restart without a teacher was accepted"); }
            catch (KataException e) { Check(e.Status == Status.State, "restart without a teacher: " + e.Message); }
        }
    }

    // 1.1: the ghost across layouts, the alignment window, which joint each GPD joint reads and
    // each GPD joint's part, against the documented values (kata/result.h, the cmu layout's names).
    static void OnePointOneTeacherAndJoints(Context ctx, string repo)
    {
        string[] cmu = { "Hips", "Spine1", "Neck1", "Head", "LeftArm", "LeftForeArm", "LeftHand", "RightArm", "RightForeArm",
                         "RightHand", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg", "RightLeg", "RightFoot" };
        int[] part = { 0, 0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3, 4, 4, 4 };
        using (Model model = ctx.LoadModel(Path.Combine(repo, "models/default.kata")))
        using (Clip teacher = ctx.LoadClip(Path.Combine(repo, "data/cmu/02_01.bvh")))
        using (Clip student = ctx.LoadClip(Path.Combine(repo, "data/cmu/07_01.bvh")))
        using (Skeleton sk = student.Skeleton())
        using (Kata.Stream across = ctx.OpenStream(sk))
        using (Kata.Stream own = ctx.OpenStream(sk))
        {
            int wrong = 0;
            for (uint g = 0; g < 16; ++g)
            {
                int j = across.GpdJointSource(g);
                if (j < 0 || sk.JointName((uint)j) != cmu[g]) ++wrong;
                if (Native.GpdJointPart((int)g) != part[g]) ++wrong;
            }
            Check(wrong == 0, "GpdJointSource / GpdJointPart: " + wrong + " joints differ from the documented ones");
            Check(across.GpdJointSource(16) == -1 && Native.GpdJointPart(16) == -1, "out of range: -1");
            Check(Native.BodyPartName(1) == "left_arm" && Native.BodyPartName(5) == "", "BodyPartName");
            Check(Native.GpdJointWords(11) == "left knee" && Native.GpdJointWords(3) == "", "GpdJointWords");
            across.AttachTeacher(model, teacher, 1, true, "cmu", -1, true, 0.5);
            own.AttachTeacher(model, teacher, 1);
            // Across: the 16 GPD joints, each the student joint its layout maps there; on the student's
            // own joints: the retargeter's joint set ("cmu": more than the 16).
            int sources = 0;
            for (uint g = 0; g < across.GhostJointCount; ++g) if (across.GhostJointSource(g) == across.GpdJointSource(g)) ++sources;
            Check(across.GhostJointCount == 16 && sources == 16 && own.GhostJointCount > 16,
                  "ghost across: 16 GPD joints (" + across.GhostJointCount + ", " + sources + " on their GPD sources), own: " +
                  own.GhostJointCount);
            try { own.AttachTeacher(model, teacher, 1, true, "cmu", -1, false, 0.0); Check(false, "alignment window 0 was accepted"); }
            catch (KataException e) { Check(e.Status == Status.InvalidArgument, "alignment window 0: " + e.Message); }
        }
    }

    // kata_teacher (1.1): a stream given the shared teacher scores, frame for frame, exactly as one given the same
    // clip by AttachTeacher; the teacher outlives its Dispose in the stream.
    static StreamDesc StencilDesc(Model model)
    {
        StreamDesc d = Context.DefaultStreamDesc();
        d.Stencil = model.Stencil;
        return d;
    }

    static void SharedTeacherScoresAsAttachTeacher(Context ctx, string repo)
    {
        using (Model model = ctx.LoadModel(Path.Combine(repo, "models/default.kata")))
        using (Clip teacher = ctx.LoadClip(Path.Combine(repo, "data/cmu/02_01.bvh")))
        using (Clip student = ctx.LoadClip(Path.Combine(repo, "data/cmu/02_02.bvh")))
        using (Skeleton sk = student.Skeleton())
        using (Kata.Stream own = ctx.OpenStream(sk, "cmu", StencilDesc(model)))
        using (Kata.Stream shared = ctx.OpenStream(sk, "cmu", StencilDesc(model)))
        {
            own.AttachTeacher(model, teacher, 1);
            using (Teacher t = ctx.CreateTeacher(model, teacher, 1))
            {
                Check(t.FrameCount == teacher.FrameCount - 1 && t.MemoryBytes > 0, "Teacher.FrameCount " + t.FrameCount);
                shared.AttachSharedTeacher(t);
            }
            float[] xyz = new float[3 * (int)sk.JointCount];
            ResultBatch a = own.NewResultBatch(64), b = shared.NewResultBatch(64);
            int compared = 0, differing = 0;
            for (uint f = 1; f <= 150; ++f)
            {
                student.Positions(f, xyz);
                own.Push(f / 120.0, xyz);
                shared.Push(f / 120.0, xyz);
                int n = own.ReadResults(a), m = shared.ReadResults(b);
                if (n != m) { ++differing; continue; }
                for (int i = 0; i < n; ++i, ++compared)
                    if (a.Results[i].Score != b.Results[i].Score || a.Results[i].MatchedTeacherFrame != b.Results[i].MatchedTeacherFrame ||
                        a.Results[i].Distance != b.Results[i].Distance || a.Results[i].Scored != 1) ++differing;
            }
            Check(compared > 100 && differing == 0, "shared teacher: " + differing + " of " + compared + " results differ");
        }
    }

    // Forward kinematics of a humanoid pose, written here: G_b = G_parent R_b, X_b = X_parent + G_parent offset_b.
    static double[] HumanoidJoints(HumanoidPose p)
    {
        int n = HumanoidPose.BoneCount;
        double[] g = new double[4 * n], x = new double[3 * n];
        for (int b = 0; b < n; ++b)
        {
            int q = HumanoidPose.BoneParent((HumanoidBone)b);
            double rx = p.Rotation[4 * b], ry = p.Rotation[4 * b + 1], rz = p.Rotation[4 * b + 2], rw = p.Rotation[4 * b + 3];
            if (q < 0)
            {
                g[0] = rx; g[1] = ry; g[2] = rz; g[3] = rw;
                for (int k = 0; k < 3; ++k) x[k] = p.HipsPosition[k];
                continue;
            }
            double px = g[4 * q], py = g[4 * q + 1], pz = g[4 * q + 2], pw = g[4 * q + 3];
            // v' = v + 2 u x (u x v + w v), u = (px, py, pz)
            double vx = p.Offset[3 * b], vy = p.Offset[3 * b + 1], vz = p.Offset[3 * b + 2];
            double cx = py * vz - pz * vy + pw * vx, cy = pz * vx - px * vz + pw * vy, cz = px * vy - py * vx + pw * vz;
            x[3 * b] = x[3 * q] + vx + 2 * (py * cz - pz * cy);
            x[3 * b + 1] = x[3 * q + 1] + vy + 2 * (pz * cx - px * cz);
            x[3 * b + 2] = x[3 * q + 2] + vz + 2 * (px * cy - py * cx);
            g[4 * b] = pw * rx + px * rw + py * rz - pz * ry;
            g[4 * b + 1] = pw * ry - px * rz + py * rw + pz * rx;
            g[4 * b + 2] = pw * rz + px * ry - py * rx + pz * rw;
            g[4 * b + 3] = pw * rw - px * rx - py * ry - pz * rz;
        }
        return x;
    }

    // kata/humanoid.h: FK of a CMU clip's humanoid poses puts every bone's joint back; Unity's frame mirrors.
    static void HumanoidRigOfAClip(Context ctx, string repo)
    {
        string[] boneJoint = { "Hips", "Hips", "Spine", "Spine1", "Neck1", "Head", "Spine1", "LeftArm", "LeftForeArm",
                               "LeftHand", "Spine1", "RightArm", "RightForeArm", "RightHand", "LeftUpLeg", "LeftLeg",
                               "LeftFoot", "LeftToeBase", "RightUpLeg", "RightLeg", "RightFoot", "RightToeBase" };
        Check(HumanoidPose.BoneName(HumanoidBone.LeftUpperArm) == "LeftUpperArm" && HumanoidPose.FindBone("RightToes") == 21 &&
              HumanoidPose.BoneParent(HumanoidBone.Neck) == (int)HumanoidBone.UpperChest, "humanoid bone names and tree");
        using (Clip clip = ctx.LoadClip(Path.Combine(repo, "data/cmu/02_01.bvh")))
        using (Skeleton sk = clip.Skeleton())
        using (HumanoidRig rig = ctx.CreateHumanoidRig(sk))
        {
            Check(rig.Placed == (1u << 22) - 1 && rig.Calibrated && Math.Abs(rig.MetresPerUnit - 0.056444) < 1e-12,
                  "humanoid rig of a CMU clip: placed " + rig.Placed);
            int[] index = new int[22];
            for (int b = 0; b < 22; ++b)
                for (uint j = 0; j < sk.JointCount; ++j)
                    if (sk.JointName(j) == boneJoint[b]) index[b] = (int)j;
            float[] xyz = new float[3 * (int)sk.JointCount];
            HumanoidPose p = new HumanoidPose(), u = new HumanoidPose();
            double worst = 0, worstMirror = 0, worstNorm = 0;
            for (uint f = 1; f < clip.FrameCount; ++f)
            {
                clip.Positions(f, xyz);
                rig.Pose(xyz, HumanoidFrame.RightHanded, p);
                rig.Pose(xyz, HumanoidFrame.Unity, u);
                double[] x = HumanoidJoints(p), xu = HumanoidJoints(u);
                for (int b = 0; b < 22; ++b)
                {
                    for (int k = 0; k < 3; ++k)
                    {
                        worst = Math.Max(worst, Math.Abs(x[3 * b + k] - 0.056444 * xyz[3 * index[b] + k]));
                        worstMirror = Math.Max(worstMirror, Math.Abs(xu[3 * b + k] - (k == 0 ? -x[3 * b] : x[3 * b + k])));
                    }
                    double n = 0;
                    for (int k = 0; k < 4; ++k) n += (double)p.Rotation[4 * b + k] * p.Rotation[4 * b + k];
                    worstNorm = Math.Max(worstNorm, Math.Abs(Math.Sqrt(n) - 1));
                }
            }
            Check(worst < 1.7e-4 && worstMirror < 1e-5 && worstNorm < 1e-6,
                  "humanoid FK: " + worst + " m, Unity mirror " + worstMirror + " m, |q| - 1 " + worstNorm);
            try { rig.PoseGhost(xyz); Check(false, "a rig without a ghost posed one"); }
            catch (KataException e) { Check(e.Status == Status.State && e.NativeMessage.Length > 0, "PoseGhost without a ghost: " + e.Message); }
        }
    }

    // ---- the people tracker (kata/people.h) ----
    const int PJ = 17;  // COCO keypoints

    // A 1.7 m stick figure standing at x, every third joint swinging; written at pose slot `slot` of `into`.
    static void Figure(float[] into, int slot, double x, double phase)
    {
        for (int j = 0; j < PJ; ++j)
        {
            double swing = j % 3 == 1 ? 0.2 * Math.Sin(phase + j) : 0.0;
            into[(slot * PJ + j) * 3] = (float)(x + swing);
            into[(slot * PJ + j) * 3 + 1] = (float)(1.7 * j / (PJ - 1));
            into[(slot * PJ + j) * 3 + 2] = 0f;
        }
    }

    // Two people walking past each other (one hidden 0.8 s), their poses in a random order every frame:
    // each keeps their stream; nobody for longer than the forget time closes both; the prediction is
    // the centroid of the confident joints (computed here) moved on at the measured velocity.
    static void PeopleKeepTheirStreams(Context ctx)
    {
        PeopleDesc d = People.DefaultDesc(PJ);
        d.MaxPeople = 4;
        Random rng = new Random(3);
        using (People people = ctx.CreatePeople(d))
        {
            float[] poses = new float[2 * PJ * 3], conf = new float[2 * PJ];
            for (int k = 0; k < conf.Length; ++k) conf[k] = 0.9f;
            uint[] ids = new uint[2], own = new uint[2];
            bool kept = true;
            for (int k = 0; k < 150; ++k)
            {
                double t = k / 30.0;
                double[] xs = { -2.0 + 0.8 * t, 2.0 - 0.8 * t };
                int[] order = Math.Abs(xs[0] - xs[1]) < 0.32 ? new[] { 0 } : rng.Next(2) == 0 ? new[] { 0, 1 } : new[] { 1, 0 };
                for (int i = 0; i < order.Length; ++i) Figure(poses, i, xs[order[i]], 3 * t + order[i]);
                people.Track(t, poses, conf, (uint)order.Length, ids);
                for (int i = 0; i < order.Length; ++i)
                {
                    if (own[order[i]] == 0) own[order[i]] = ids[i];
                    kept = kept && ids[i] != 0 && ids[i] == own[order[i]];
                }
                if (k == 0) Check(people.Opened.Length == 2, "people: the first frame opens two streams");
            }
            Check(kept && own[0] != own[1], "people: each kept their stream through the crossing, shuffled (" + own[0] + ", " + own[1] + ")");
            PeopleCounters c = people.Counters;
            Check(c.Opened == 2 && c.Poses == c.Assigned && c.OpenStreams == 2, "people: counters " + c.Opened + " opened, " + c.Assigned + " of " + c.Poses + " assigned");
            Check(people.Streams.Length == 2, "people: two streams open");
            uint[] none = people.Track(5.0 + 3.1, new float[0]);
            uint[] closed = people.Closed;
            Array.Sort(closed);
            Check(none.Length == 0 && closed.Length == 2 && closed[0] == Math.Min(own[0], own[1]) && closed[1] == Math.Max(own[0], own[1]) &&
                  people.Streams.Length == 0, "people: nobody for longer than the forget time closes both");
        }
        using (People people = ctx.CreatePeople(People.DefaultDesc(PJ)))
        {
            float[] pose = new float[PJ * 3], conf = new float[PJ];
            Figure(pose, 0, 0.5, 1.0);
            for (int j = 0; j < PJ; ++j) conf[j] = j == 2 || j == 5 ? 0.1f : 0.9f;  // below min_confidence: not counted
            pose[2 * 3] = float.NaN;  // and may be anything
            double[] expected = new double[3];
            int n = 0;
            for (int j = 0; j < PJ; ++j)
                if (conf[j] >= 0.3f) { ++n; for (int a = 0; a < 3; ++a) expected[a] += pose[3 * j + a]; }
            for (int a = 0; a < 3; ++a) expected[a] /= n;
            uint id = people.Track(10.0, pose, conf)[0];
            double[] at = people.Predicted(id, 10.0);
            Check(Math.Abs(at[0] - expected[0]) < 1e-5 && Math.Abs(at[1] - expected[1]) < 1e-5 && Math.Abs(at[2]) < 1e-6,
                  "people: the prediction is the centroid of the confident joints (" + at[0] + ", " + at[1] + ")");
            for (int j = 0; j < PJ; ++j) pose[3 * j] += 0.05f;
            people.Track(10.1, pose, conf);
            at = people.Predicted(id, 11.1);  // the new centroid + 0.5 m/s x 1 s
            Check(Math.Abs(at[0] - (expected[0] + 0.05 + 0.5)) < 1e-4, "people: predicted a second on at the measured velocity: " + at[0]);
            try { people.Predicted(12345, 11.0); Check(false, "people: an unknown stream was predicted"); }
            catch (KataException e) { Check(e.Status == Status.NotFound, "people: unknown stream: " + e.Message); }
        }
    }

    // More poses than max_poses, a NaN pose, an empty frame, a time that does not increase: refused or
    // handled and counted by cause; a bad desc refused with the field named.
    static void PeopleBadInputIsCounted(Context ctx)
    {
        PeopleDesc d = People.DefaultDesc(PJ);
        d.MaxPoses = 2;
        using (People people = ctx.CreatePeople(d))
        {
            float[] poses = new float[4 * PJ * 3];
            Figure(poses, 0, 0.0, 0.0);
            Figure(poses, 1, 2.0, 0.0);
            Figure(poses, 2, 4.0, 0.0);
            Figure(poses, 3, -4.0, 0.0);
            poses[(1 * PJ + 4) * 3 + 1] = float.NaN;
            uint[] ids = people.Track(1.0, poses);
            int placed = 0;
            foreach (uint i in ids) if (i != 0) ++placed;
            Check(ids[0] != 0 && ids[1] == 0 && placed == 2, "people: the NaN pose refused, two of three valid taken (max_poses 2)");
            Check(people.Track(1.1, new float[0]).Length == 0, "people: an empty frame");
            try { people.Track(1.1, poses); Check(false, "people: a repeated time was accepted"); }
            catch (KataException e) { Check(e.Status == Status.TimestampNotIncreasing, "people: repeated time: " + e.Message); }
            PeopleCounters c = people.Counters;
            Check(c.Frames == 2 && c.EmptyFrames == 1 && c.RefusedFrames == 1 && c.RefusedNonFinite == 1 &&
                  c.RefusedTooManyPoses == 1 && c.Assigned == 2, "people: refusals counted by cause");
        }
        PeopleDesc bad = People.DefaultDesc(PJ);
        bad.MaxPeople = 0;
        try { ctx.CreatePeople(bad).Dispose(); Check(false, "people: max_people 0 was accepted"); }
        catch (KataException e) { Check(e.Status == Status.InvalidArgument && e.NativeMessage.Contains("max_people"), "people: bad desc: " + e.Message); }
        PeopleDesc dd = People.DefaultDesc(PJ);
        Check(dd.StructSize == System.Runtime.InteropServices.Marshal.SizeOf(typeof(PeopleDesc)) && dd.MaxPeople == 8 && dd.MaxPoses == 16 &&
              dd.ForgetSeconds == 3 && dd.CoastSeconds == 1 && dd.MinConfidence == 0.3, "kata_people_desc size and defaults read through the struct");
    }

    // kata_people_stream_id is FNV-1a 64 over the group and the person (8 bytes each, little-endian),
    // skipping the two top values: computed here.
    static void PeopleStreamIdIsTheDocumentedHash()
    {
        ulong[][] cases = { new ulong[] { 500, 1 }, new ulong[] { 500, 2 }, new ulong[] { 0, 1 }, new ulong[] { ulong.MaxValue - 2, 7 },
                            new ulong[] { 123456789, 4000000000 } };
        foreach (ulong[] g in cases)
        {
            ulong h = 14695981039346656037UL;
            foreach (ulong v in g)
                for (int b = 0; b < 8; ++b) { h ^= (v >> (8 * b)) & 0xff; h = unchecked(h * 1099511628211UL); }
            if (h >= ulong.MaxValue - 1) h -= 2;
            Check(People.StreamId(g[0], (uint)g[1]) == h, "people: stream id of (" + g[0] + ", " + g[1] + ")");
        }
    }

    // OSC 1.0 read here (big-endian; written from the spec, not kata's or liblo's reader): one bundle's
    // messages as (address, type tags, arguments).
    static List<Tuple<string, string, object[]>> OscBundle(byte[] b, int n)
    {
        Func<int, int> be32 = i => (b[i] << 24) | (b[i + 1] << 16) | (b[i + 2] << 8) | b[i + 3];
        Func<int, int> pad = len => (len + 4) & ~3;  // a string, its NUL and the padding to 4
        var out_ = new List<Tuple<string, string, object[]>>();
        Check(n >= 16 && Encoding.ASCII.GetString(b, 0, 8) == "#bundle\0", "VMC: an OSC bundle");
        int at = 16;  // after "#bundle\0" and the timetag
        while (at + 4 <= n)
        {
            int size = be32(at), m = at + 4;
            at = m + size;
            int end = Array.IndexOf(b, (byte)0, m);
            string address = Encoding.ASCII.GetString(b, m, end - m);
            m += pad(end - m);
            end = Array.IndexOf(b, (byte)0, m);
            string tags = Encoding.ASCII.GetString(b, m + 1, end - m - 1);
            m += pad(end - m);
            var args = new List<object>();
            foreach (char t in tags)
            {
                if (t == 's') { end = Array.IndexOf(b, (byte)0, m); args.Add(Encoding.UTF8.GetString(b, m, end - m)); m += pad(end - m); }
                else if (t == 'i') { args.Add(be32(m)); m += 4; }
                else if (t == 'f') { args.Add(BitConverter.ToSingle(BitConverter.GetBytes(be32(m)), 0)); m += 4; }
            }
            out_.Add(Tuple.Create(address, tags, args.ToArray()));
        }
        return out_;
    }

    // The VMC protocol from C#: HumanoidRig.WriteVmc's bundle read with the OSC reader above (the pose's numbers
    // in Unity's frame), and a VmcReader reading it back onto the clip's GPD joints; bad datagrams counted.
    static void VmcOfAClip(Context ctx, string repo)
    {
        string[] gpdCmu = { "Hips", "Spine1", "Neck1", "Head", "LeftArm", "LeftForeArm", "LeftHand", "RightArm",
                            "RightForeArm", "RightHand", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg", "RightLeg", "RightFoot" };
        int[] gpdVrm = { 0, 3, 4, 5, 7, 8, 9, 11, 12, 13, 14, 15, 16, 18, 19, 20 };  // the vrm layout's joints (kata/vmc.h)
        using (Clip clip = ctx.LoadClip(Path.Combine(repo, "data/cmu/07_01.bvh")))
        using (Skeleton sk = clip.Skeleton())
        using (HumanoidRig rig = ctx.CreateHumanoidRig(sk))
        using (VmcReader reader = ctx.CreateVmcReader())
        {
            float[] xyz = new float[3 * (int)sk.JointCount];
            clip.Positions(40, xyz);
            HumanoidPose p = rig.Pose(xyz);
            byte[] buffer = new byte[2048];
            int n = rig.WriteVmc(p, 1.25, buffer);
            var msgs = OscBundle(buffer, n);
            Check(msgs[0].Item1 == "/VMC/Ext/Root/Pos" && msgs[0].Item2 == "sfffffff" && (string)msgs[0].Item3[0] == "root",
                  "VMC: Root/Pos first");
            Check(msgs[msgs.Count - 2].Item1 == "/VMC/Ext/OK" && (int)msgs[msgs.Count - 2].Item3[0] == 1, "VMC: OK 1");
            Check(msgs[msgs.Count - 1].Item1 == "/VMC/Ext/T" && (float)msgs[msgs.Count - 1].Item3[0] == 1.25f, "VMC: T 1.25");
            int bones = 0, wrong = 0;
            foreach (var m in msgs)
            {
                if (m.Item1 != "/VMC/Ext/Bone/Pos") continue;
                Check(m.Item2 == "sfffffff", "VMC: Bone/Pos types " + m.Item2);
                int b = HumanoidPose.FindBone((string)m.Item3[0]);
                if (b < 0 || !p.IsPlaced((HumanoidBone)b)) { ++wrong; continue; }
                ++bones;
                float[] at = b == 0 ? p.HipsPosition : new[] { p.Offset[3 * b], p.Offset[3 * b + 1], p.Offset[3 * b + 2] };
                float[] want = { -at[0], at[1], at[2], p.Rotation[4 * b], -p.Rotation[4 * b + 1], -p.Rotation[4 * b + 2], p.Rotation[4 * b + 3] };
                for (int k = 0; k < 7; ++k)
                    if ((float)m.Item3[1 + k] != want[k]) ++wrong;
            }
            Check(bones == 22 && wrong == 0, "VMC: every bone in Unity's frame (" + bones + " bones, " + wrong + " values differ)");
            try { rig.WriteVmc(p, 0.0, new byte[64]); Check(false, "a 64-byte buffer took a bundle"); }
            catch (KataException e) { Check(e.Status == Status.BufferTooSmall, "VMC: small buffer: " + e.Message); }

            // Read back: the vrm joints on the clip's GPD joints (metres) within 1 mm.
            float[] got = new float[3 * VmcReader.Joints];
            double t;
            Check(!reader.Positions(got, out t), "VmcReader: no frame before the first");
            Check(reader.Read(buffer, n, 100.0), "VmcReader: the bundle ends a frame");
            Check(reader.Positions(got, out t) && Math.Abs(t - 1.25) < 1e-6, "VmcReader: its time " + t);
            double worst = 0;
            for (int g = 0; g < 16; ++g)
            {
                uint j = 0;
                while (sk.JointName(j) != gpdCmu[g]) ++j;
                for (int k = 0; k < 3; ++k) worst = Math.Max(worst, Math.Abs(got[3 * gpdVrm[g] + k] - 0.056444 * xyz[3 * j + k]));
            }
            Check(worst < 1e-3, "VmcReader: GPD joints within " + worst + " m of the clip's");
            Check(!reader.Read(buffer, n - 5) && !reader.Read(Encoding.ASCII.GetBytes("not osc at all!!"), 16), "VmcReader: bad datagrams end no frame");
            VmcCounters c = reader.Counters;
            Check(c.Packets == 3 && c.Frames == 1 && c.Malformed == 2, "VmcReader counters: " + c.Packets + " packets, " + c.Malformed + " malformed");
        }
    }

    static int Main(string[] args)
    {
        if (args.Length == 1 && args[0] == "--expect-wrong-version")
        {
            try { new Context().Dispose(); Console.Error.WriteLine("FAILED: a 7.0.0 library was accepted"); return 1; }
            catch (KataVersionException e)
            {
                bool ok = e.Message.Contains("7.0.0") && e.Message.Contains("needs 1.x");
                Console.WriteLine((ok ? "refused as expected: " : "FAILED, wrong message: ") + e.Message);
                return ok ? 0 : 1;
            }
        }
        string repo = args[0], cli = args[1], tmp = args[2];
        Directory.CreateDirectory(tmp);
        Console.WriteLine("libkata " + Library.LoadedVersion);
        StructSizesMatchTheLibrary();
        using (Context ctx = new Context())
        {
            FeaturesEqualTheCli(ctx, repo, cli, tmp);
            ScoresEqualTheCli(ctx, repo, cli, tmp);
            ErrorsCarryTheCMessage(ctx, repo, tmp);
            SkeletonsAndRetargeting(ctx, repo);
            TeacherAsFeaturesAndTheNewestResult(ctx, repo);
            OnePointOneTeacherAndJoints(ctx, repo);
            SharedTeacherScoresAsAttachTeacher(ctx, repo);
            HumanoidRigOfAClip(ctx, repo);
            VmcOfAClip(ctx, repo);
            RepetitionsOfAWalkPlayedTwice(ctx, repo);
            PeopleKeepTheirStreams(ctx);
            PeopleBadInputIsCounted(ctx);
        }
        PeopleStreamIdIsTheDocumentedHash();
        HandlesReleasedOnce(repo);
        Console.WriteLine(failures == 0 ? "all C# binding checks passed" : failures + " checks failed");
        return failures == 0 ? 0 : 1;
    }
}
