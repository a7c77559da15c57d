// The little of Unity that KataCoach.cs uses, so the sample runs under Mono: a MonoBehaviour base,
// Debug.Log, and a player loop (Start, Update x N, OnDestroy). Not needed (and not copied) in Unity.
//   mono KataCoach.exe REPO_DIR [FRAMES]
using System;

namespace UnityEngine
{
    public class MonoBehaviour { }

    public static class Debug
    {
        public static void Log(object message) { Console.WriteLine(message); }
    }
}

static class PlayerLoop
{
    static int Main(string[] args)
    {
        KataCoach coach = new KataCoach();
        coach.dataRoot = args.Length > 0 ? args[0] : ".";
        int frames = args.Length > 1 ? int.Parse(args[1]) : 120;
        coach.Start();
        for (int i = 0; i < frames; ++i) coach.Update();
        coach.OnDestroy();
        return 0;
    }
}
