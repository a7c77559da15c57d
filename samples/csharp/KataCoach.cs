// KataCoach: a Unity-style component that scores a live student against a teacher clip and reads the
// teacher's pose on the student's body (the "ghost") every frame. Start opens, Update pushes one frame
// and reads score + ghost, OnDestroy releases. In Unity: put this file and Kata.cs under Assets/, the
// native library under Assets/Plugins/ (see README "C# and Unity"), and feed Update from your tracker.
// Here UnityStandIn.cs plays Unity's part so the same file runs under Mono (the ctest samples_csharp).
using System;
using System.IO;
using Kata;
using UnityEngine;

public class KataCoach : MonoBehaviour
{
    public string dataRoot = ".";            // where data/ and models/ are (StreamingAssets in a build)
    public string teacherClip = "data/cmu/02_01.bvh";
    public string studentClip = "data/cmu/07_01.bvh";  // stands in for a tracker: the student's frames
    public string modelFile = "models/default.kata";

    Context context;
    Model model;
    Clip teacher, student;
    Skeleton studentSkeleton;
    Kata.Stream stream;
    ResultBatch results;   // allocated once; Update allocates nothing
    float[] frame;
    uint nextFrame = 1;    // frame 0 of a CMU clip is the converter's T-pose
    double scoreSum;
    int scored;

    public float LastScore { get; private set; }
    public float[] Ghost { get; private set; }   // ghost joints x 3, student units, over the student

    public void Start()
    {
        context = new Context();  // refuses a libkata of another major version
        model = context.LoadModel(Path.Combine(dataRoot, modelFile));
        teacher = context.LoadClip(Path.Combine(dataRoot, teacherClip));
        student = context.LoadClip(Path.Combine(dataRoot, studentClip));
        // In a game: context.OpenStream on a skeleton built from your avatar (kata_skeleton_create).
        studentSkeleton = student.Skeleton();
        StreamDesc desc = Context.DefaultStreamDesc();
        desc.Stencil = model.Stencil;
        stream = context.OpenStream(studentSkeleton, "cmu", desc);
        stream.AttachTeacher(model, teacher, 1);
        results = stream.NewResultBatch(8);
        frame = new float[studentSkeleton.JointCount * 3];
        Ghost = new float[stream.GhostJointCount * 3];
    }

    public void Update()
    {
        // Your tracker's newest pose goes here (joints x 3, x y z interleaved) with its capture time.
        student.Positions(nextFrame, frame);
        stream.Push((nextFrame - 1) * student.FrameTime, frame);
        nextFrame = nextFrame + 1 < student.FrameCount ? nextFrame + 1 : 1;
        if (nextFrame == 1) { stream.Reset(); }

        int n = stream.ReadResults(results);   // everything since the last Update, oldest first
        for (int i = 0; i < n; ++i)
        {
            scoreSum += results.Scores[i].Score;
            ++scored;
        }
        if (n > 0)
        {
            LastScore = results.Scores[n - 1].Score;
            Array.Copy(results.Ghosts, (n - 1) * Ghost.Length, Ghost, 0, Ghost.Length);
            // In Unity: move the ghost avatar's bones to Ghost, colour the worst body part red.
        }
    }

    public void OnDestroy()
    {
        Debug.Log(string.Format("KataCoach: mean score {0:F1} over {1} frames, ghost of {2} joints",
                                scored > 0 ? scoreSum / scored : 0.0, scored, Ghost.Length / 3));
        if (stream != null) stream.Dispose();
        if (studentSkeleton != null) studentSkeleton.Dispose();
        if (student != null) student.Dispose();
        if (teacher != null) teacher.Dispose();
        if (model != null) model.Dispose();
        if (context != null) context.Dispose();
    }
}
