"""kata.mediapipe against the kata CLI (`kata score --student-layout mediapipe`, the C++ path) on a
MediaPipe recording made from a CMU clip by the converter of tests/api/test_anybody.cpp (landmarks
on the CMU joints, face and hand points at fixed offsets, origin at the hip midpoint, camera axes)."""
import csv
import os
import subprocess
import sys
from types import SimpleNamespace

import numpy as np
import pytest

import kata
import kata.mediapipe

METRES_PER_UNIT = 0.056444  # CMU BVH units (1/0.45 inch)


def to_mediapipe(ctx, path):
    """(frames, 33, 3) float32 world landmarks (metres, camera axes) of every frame of a CMU BVH."""
    with ctx.load_clip(path) as clip, clip.skeleton() as sk:
        p = clip.all_positions().astype(np.float64) * METRES_PER_UNIT
        ix = {n: i for i, n in enumerate(sk.names)}
        frame_time = clip.frame_time
    at = lambda name: p[:, ix[name]]  # noqa: E731
    ankle = min(at("LeftFoot")[1:, 1].min(), at("RightFoot")[1:, 1].min())
    face = np.array([[0, 0.02, 0.10], [0.02, 0.05, 0.09], [0.03, 0.05, 0.09], [0.04, 0.05, 0.08],
                     [-0.02, 0.05, 0.09], [-0.03, 0.05, 0.09], [-0.04, 0.05, 0.08], [0.07, 0, 0], [-0.07, 0, 0],
                     [0.02, -0.02, 0.09], [-0.02, -0.02, 0.09]])
    l = np.zeros((len(p), 33, 3))
    l[:, :11] = at("Head")[:, None, :] + face[None]
    for i, n in zip(range(11, 17), ["LeftArm", "RightArm", "LeftForeArm", "RightForeArm", "LeftHand", "RightHand"]):
        l[:, i] = at(n)
    l[:, 17] = l[:, 15] + [0.06, -0.02, -0.02]
    l[:, 18] = l[:, 16] + [-0.06, -0.02, -0.02]
    l[:, 19] = l[:, 15] + [0.08, 0, 0]
    l[:, 20] = l[:, 16] + [-0.08, 0, 0]
    l[:, 21] = l[:, 15] + [0.03, 0, 0.03]
    l[:, 22] = l[:, 16] + [-0.03, 0, 0.03]
    for i, n in zip(range(23, 29), ["LeftUpLeg", "RightUpLeg", "LeftLeg", "RightLeg", "LeftFoot", "RightFoot"]):
        l[:, i] = at(n)
    l[:, 29] = l[:, 27] + [0, -ankle, -0.05]
    l[:, 30] = l[:, 28] + [0, -ankle, -0.05]
    l[:, 31] = at("LeftToeBase")
    l[:, 32] = at("RightToeBase")
    l -= 0.5 * (l[:, 23:24] + l[:, 24:25])
    l[:, :, 1:] *= -1
    return l.astype(np.float32), frame_time


@pytest.fixture(scope="module")
def recording(data):
    with kata.Context() as ctx:
        lm, dt = to_mediapipe(ctx, os.path.join(data, "07_01.bvh"))
    lm = lm[1:]  # without the converter's T-pose frame
    return lm, np.arange(len(lm)) * dt * 1000.0


def test_the_ten_line_example_scores_a_recording_against_a_bvh_teacher(recording, data):
    landmarks, timestamps_ms = recording
    r = kata.mediapipe.score(landmarks, timestamps_ms, os.path.join(data, "07_01.bvh"), first_frame=1)
    # The student is its own teacher (landmarks on its CMU joints): only the synthesised spine
    # differs (test_anybody.cpp measured d ~ 0.0035 < delta*/2), so it scores near 100; another
    # motion (02_01 against 07_01 walking) scores lower.
    assert len(r.scored) > 0.9 * len(landmarks)
    assert r.mean_score > 90
    other = kata.mediapipe.score(landmarks, timestamps_ms, os.path.join(data, "02_01.bvh"), first_frame=1)
    assert other.mean_score < r.mean_score - 5


def test_scores_equal_the_cli_on_the_same_recording(cli, recording, data, model_path, tmp_path):
    landmarks, timestamps_ms = recording
    npy = tmp_path / "student.npy"
    np.save(npy, landmarks)
    fps = 1000.0 / (timestamps_ms[1] - timestamps_ms[0])
    out = tmp_path / "scores.csv"
    subprocess.run([cli, "score", "--model", model_path, "--teacher", os.path.join(data, "02_01.bvh"),
                    "--teacher-layout", "cmu", "--student", str(npy), "--student-layout", "mediapipe",
                    "--fps", repr(fps), "--out", str(out)], check=True, capture_output=True, text=True)
    with open(out) as f:
        rows = list(csv.DictReader(f))
    r = kata.mediapipe.score(landmarks, timestamps_ms, os.path.join(data, "02_01.bvh"), model=model_path)
    assert len(rows) == len(r.scores)
    cli_scores = np.array([float(row["score"]) for row in rows])
    np.testing.assert_allclose(r.scores["score"], cli_scores, atol=2e-3)


def test_result_objects_arrays_and_live_pushes_give_the_same_scores(recording, data):
    landmarks, timestamps_ms = recording
    n = 240
    lm, t = landmarks[:n], timestamps_ms[:n]
    vis = np.full((n, 33), 0.9, dtype=np.float32)
    # The Pose solution's result objects (.pose_world_landmarks.landmark[i]), one frame without a person.
    objects = [SimpleNamespace(pose_world_landmarks=SimpleNamespace(landmark=[
        SimpleNamespace(x=float(p[0]), y=float(p[1]), z=float(p[2]), visibility=0.9) for p in frame]))
        for frame in lm]
    objects[100] = SimpleNamespace(pose_world_landmarks=None)
    five = np.concatenate([lm, vis[:, :, None], np.ones((n, 33, 1), np.float32)], axis=2)
    five[100] = np.nan
    teacher = os.path.join(data, "07_01.bvh")
    from_objects = kata.mediapipe.score(objects, t, teacher, first_frame=1)
    from_arrays = kata.mediapipe.score(five, t, teacher, first_frame=1)
    with kata.mediapipe.Scorer(teacher, first_frame=1) as live:
        statuses = [live.push(o, ms) for o, ms in zip(objects, t)]
        from_live = live.read()
    assert statuses[100] == kata.Status.NO_DATA and from_objects.skipped_frames == 1
    np.testing.assert_array_equal(from_objects.scores["score"], from_arrays.scores["score"])
    np.testing.assert_array_equal(from_objects.scores["score"], from_live.scores["score"])
    assert len(from_objects) > 200


def test_low_visibility_loses_tracking_and_a_bad_shape_names_it(recording, data):
    landmarks, timestamps_ms = recording
    four = np.concatenate([landmarks[:120], np.full((120, 33, 1), 0.1, np.float32)], axis=2)
    r = kata.mediapipe.score(four, timestamps_ms[:120], os.path.join(data, "07_01.bvh"))
    assert r.lost_frames > 100 and len(r.scored) == 0
    with pytest.raises(ValueError, match=r"frames x 33 x 3, 4 or 5.*\(10, 31, 3\)"):
        kata.mediapipe.score(np.zeros((10, 31, 3)), np.arange(10), os.path.join(data, "07_01.bvh"))


def test_the_readme_example_runs_as_printed(recording, repo, tmp_path):
    """README.md's MediaPipe example, run as printed (its comment lines included) on a recording
    saved where it reads it; the mean it prints is the one score() gives."""
    text = open(os.path.join(repo, "README.md"), encoding="utf-8").read()
    start = text.index("```python\n# pip install --no-build-isolation ./bindings/python")
    code = text[start + len("```python\n"):text.index("```", start + 10)]
    assert len([line for line in code.splitlines() if line.strip()]) <= 10
    landmarks, timestamps_ms = recording
    four = np.concatenate([landmarks, np.full(landmarks.shape[:2] + (1,), 0.95, np.float32)], axis=2)
    np.save(tmp_path / "student_landmarks.npy", four)
    np.save(tmp_path / "student_timestamps_ms.npy", timestamps_ms)
    os.symlink(os.path.join(repo, "data"), tmp_path / "data")
    p = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True,
                       env=dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path)))
    assert p.returncode == 0, p.stderr
    expected = kata.mediapipe.score(four, timestamps_ms, os.path.join(repo, "data", "cmu", "02_01.bvh"), first_frame=1)
    assert "mean score %.1f over %d frames" % (expected.mean_score, len(expected.scored)) in p.stdout


def test_ghost_across_layouts_on_a_mediapipe_student(recording, data, model_path):
    """attach_teacher(ghost_across=True): a CMU clip teacher and a MediaPipe student get the
    pipeline's ghost across layouts (kata_teacher_desc.ghost_across, 1.1): 16 GPD joints in the
    student's camera axes, from when the stream has measured the student's bones; finite, and
    near the student's own landmarks (the student is the teacher's own motion)."""
    landmarks, timestamps_ms = recording
    n = 240
    with kata.Context() as ctx, ctx.load_model(model_path) as model, \
            ctx.load_clip(os.path.join(data, "07_01.bvh")) as clip, ctx.create_layout("mediapipe") as sk, \
            ctx.open_stream(sk, layout="mediapipe") as s:
        s.attach_teacher(model, clip, layout="cmu", first_frame=1, ghost_across=True)
        assert s.ghost_joint_count == 16
        r = s.push_and_read(timestamps_ms[:n] / 1000.0, landmarks[:n])
        has = r.results["ghost_joint_count"] > 0
        assert 0 < has.sum() < len(has) and not has[0] and has[-1]  # none until the bones are measured
        g = r.ghosts[has]
        assert np.isfinite(g).all()
        # The ghost lands on the student's own landmarks (the same motion): its hips (GPD LHip 10,
        # RHip 13; landmarks 23, 24) within 5 cm at the median (measured 0.8-0.9 cm), its left foot
        # and hand (GPD 12, 6; landmarks 27, 15) within 10 cm (4.6 and 3.1 cm).
        frames = r.results["frame_index"][has]
        for gpd, lm, within in ((10, 23, 0.05), (13, 24, 0.05), (12, 27, 0.10), (6, 15, 0.10)):
            assert np.median(np.linalg.norm(g[:, gpd] - landmarks[frames, lm], axis=1)) < within, gpd
        with pytest.raises(kata.KataError):
            s.attach_teacher(model, clip, layout="cmu", first_frame=1, ghost=False, ghost_across=True)
