// Per-frame cost of the C# binding (Stopwatch loop), the same loops as bindings/bench/push_read_c.c:
// "single": push one frame + read one result; "chunked": push CHUNK frames, read them in one call.
//   mono KataBench.exe REPO_DIR [REPS] [FRAMES] [CHUNK]     prints "single NS" and "chunked NS" (median)
using System;
using System.Diagnostics;
using System.IO;
using Kata;

static class KataBench
{
    static double Median(double[] v) { Array.Sort(v); return v[v.Length / 2]; }

    static int Main(string[] args)
    {
        string repo = args[0];
        int reps = args.Length > 1 ? int.Parse(args[1]) : 7;
        int frames = args.Length > 2 ? int.Parse(args[2]) : 3000;
        int chunk = args.Length > 3 ? int.Parse(args[3]) : 64;
        using (Context ctx = new Context())
        using (Clip clip = ctx.LoadClip(Path.Combine(repo, "data/cmu/02_01.bvh")))
        using (Skeleton sk = clip.Skeleton())
        using (Kata.Stream s = ctx.OpenStream(sk))
        {
            int joints = (int)sk.JointCount, clipFrames = (int)clip.FrameCount;
            float[][] xyz = new float[clipFrames][];
            for (int f = 0; f < clipFrames; ++f) { xyz[f] = new float[joints * 3]; clip.Positions((uint)f, xyz[f]); }
            ResultBatch one = new ResultBatch(1, 0), many = new ResultBatch(chunk, 0);
            double dt = clip.FrameTime, t = 0;
            double[] single = new double[reps], chunked = new double[reps];
            int fi = 0;
            for (int r = 0; r < reps; ++r)
            {
                Stopwatch sw = Stopwatch.StartNew();
                for (int i = 0; i < frames; ++i)
                {
                    t += dt;
                    s.Push(t, xyz[fi]);
                    s.ReadResults(one);
                    fi = fi + 1 < clipFrames ? fi + 1 : 0;
                }
                single[r] = sw.Elapsed.TotalMilliseconds * 1e6 / frames;
                int rounds = (frames + chunk - 1) / chunk;
                sw.Restart();
                for (int i = 0; i < rounds; ++i)
                {
                    for (int k = 0; k < chunk; ++k)
                    {
                        t += dt;
                        s.Push(t, xyz[fi]);
                        fi = fi + 1 < clipFrames ? fi + 1 : 0;
                    }
                    s.ReadResults(many);
                }
                chunked[r] = sw.Elapsed.TotalMilliseconds * 1e6 / (rounds * chunk);
            }
            Console.WriteLine("single {0:F1}", Median(single));
            Console.WriteLine("chunked {0:F1}", Median(chunked));
        }
        return 0;
    }
}
