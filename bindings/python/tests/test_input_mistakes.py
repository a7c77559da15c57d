"""The mistakes a newcomer makes in the second hour, each made here, each named by its message
instead of a plausible number: MediaPipe landmarks in pixels or y-up, frame numbers as timestamps,
milliseconds through Stream.push, a run that scores nothing, a landmark teacher, a message whose
bytes are not UTF-8, a shipped file named relative to the checkout, kata.mediapipe after a plain
`import kata`. Expected figures are computed here with numpy from the inputs."""
import os
import subprocess
import sys

import numpy as np
import pytest

import kata
import kata.mediapipe
from test_mediapipe import recording  # noqa: F401  (the fixture, by name)


def _nose_to_ankles(lm):
    """The median distance from the nose to the ankles' midpoint (the loader's body size)."""
    return float(np.median(np.linalg.norm(0.5 * (lm[:, 27] + lm[:, 28]) - lm[:, 0], axis=1)))


def test_pixel_landmarks_are_refused_naming_the_body_size_and_the_likely_cause(recording, data):  # noqa: F811
    lm, t = recording
    px = lm.copy()
    px[:, :, 0] *= 1920
    px[:, :, 1] *= 1080
    size = _nose_to_ankles(px)
    assert size > 100  # metres: not a person
    with pytest.raises(ValueError) as e:
        kata.mediapipe.score(px, t, os.path.join(data, "02_01.bvh"), first_frame=1)
    assert "the body measures %.4g from the nose to the ankles" % size in str(e.value)
    assert "not a person in metres" in str(e.value) and "Pixel coordinates" in str(e.value)
    # The live Scorer checks its first frame the same way.
    with kata.mediapipe.Scorer(os.path.join(data, "02_01.bvh")) as s, pytest.raises(ValueError, match="Pixel"):
        s.push(px[0], t[0])
    # The metres themselves pass (a person of about 1.5 m nose to ankles).
    assert 1.0 < _nose_to_ankles(lm) < 2.0


def test_y_up_landmarks_are_named_upside_down(recording, data, tmp_path):  # noqa: F811
    lm, t = recording
    up = lm * np.array([1, -1, -1], np.float32)  # MediaPipe's y down read as y up
    below = float(np.median(up[:, 0, 1] - 0.5 * (up[:, 27, 1] + up[:, 28, 1])))
    assert below > 1.0
    with pytest.raises(ValueError) as e:
        kata.mediapipe.score(up, t, os.path.join(data, "02_01.bvh"), first_frame=1)
    assert str(e.value).startswith("landmarks: the body is upside down: the nose is %.3g m below the ankles" % below)
    assert "negate y and z" in str(e.value)
    # The same file through the C loader (kata_landmarks_load, as kata score reads it).
    path = str(tmp_path / "up.npy")
    np.save(path, up)
    np.save(str(tmp_path / "up.times.npy"), t)
    with kata.Context() as ctx, pytest.raises(kata.KataError) as e:
        ctx.load_landmarks(path, "mediapipe")
    assert e.value.status == kata.Status.E_INVALID_ARGUMENT
    assert path + ": the body is upside down" in e.value.message


def test_frame_numbers_as_timestamps_are_named(recording, data):  # noqa: F811
    lm, _ = recording
    frames = np.arange(len(lm), dtype=np.float64)
    for units in ("auto", "ms", "s"):
        with pytest.raises(ValueError) as e:
            kata.mediapipe.score(lm, frames, os.path.join(data, "02_01.bvh"), first_frame=1, time_units=units)
        assert "the timestamps are 0, 1, 2, ... (every step exactly 1): frame numbers, not times" in str(e.value), units
    with pytest.raises(kata.KataError, match="frame numbers"):
        kata.detect_time_units(frames + 1)
    # Integer milliseconds of a 30 Hz camera are times, not frame numbers.
    assert kata.detect_time_units(np.arange(10) * 33.0) == "ms"


def test_milliseconds_through_stream_push_are_refused_as_the_landmark_path_refuses_them(data, model_path):
    with kata.Context() as ctx, ctx.load_model(model_path) as m, ctx.load_clip(os.path.join(data, "07_01.bvh")) as c, \
            c.skeleton() as sk, ctx.open_stream(sk, stencil=m.stencil) as s:
        frames = c.all_positions(1)
        step_ms = 1000.0 * c.frame_time
        assert s.push(0.0, frames[0]) == kata.Status.OK
        with pytest.raises(ValueError) as e:
            s.push(step_ms, frames[1])
        assert "the step between frames is %.6g: %.4g Hz if milliseconds" % (step_ms, 1000.0 / step_ms) in str(e.value)
        assert "Stream.push takes seconds" in str(e.value)
        # Nothing changed: the same frame in seconds is taken, and later pauses are not judged.
        assert s.push(c.frame_time, frames[1]) == kata.Status.OK
        assert s.push(c.frame_time + 60.0, frames[2]) == kata.Status.OK
    with kata.Context() as ctx, ctx.load_model(model_path) as m, ctx.load_clip(os.path.join(data, "07_01.bvh")) as c, \
            c.skeleton() as sk, ctx.open_stream(sk, stencil=m.stencil) as s:
        frames = c.all_positions(1)[:50]
        with pytest.raises(ValueError, match="fits milliseconds|if milliseconds"):
            s.push_many(np.arange(len(frames)) * 1000.0 * c.frame_time, frames)
        assert s.push_many(np.arange(len(frames)) * c.frame_time, frames) == 0  # in seconds: taken


def test_a_run_that_scores_nothing_says_why_and_prints_no_nan(recording, data):  # noqa: F811
    lm, t = recording
    teacher = os.path.join(data, "02_01.bvh")
    empty = kata.mediapipe.score(np.zeros((0, 33, 4), np.float32), np.zeros(0), teacher, time_units="ms")
    assert len(empty) == 0 and np.isnan(empty.mean_score)
    assert empty.unscored_reason == "no frames were pushed"
    assert "nan" not in repr(empty) and "no frames were pushed" in repr(empty)
    hidden = np.concatenate([lm, np.zeros(lm.shape[:2] + (1,), np.float32)], axis=2)  # visibility 0 everywhere
    lost = kata.mediapipe.score(hidden, t, teacher, first_frame=1)
    assert lost.lost_frames == len(lm) and len(lost.scored) == 0
    assert "%d frame(s) tracking lost" % len(lm) in lost.unscored_reason
    assert "nan" not in repr(lost) and "%d lost" % len(lm) in repr(lost)
    # 0.2 s at 120 Hz: every result still calibrating (the first 0.25 s).
    n = 24
    assert t[n - 1] / 1000.0 < 0.25
    short = kata.mediapipe.score(lm[:n], t[:n], teacher, first_frame=1)
    states = short.scores["state"]
    assert len(short) > 0 and (states == kata.ScoreState.CALIBRATING).all()
    assert "%d frame(s) calibrating" % len(short) in short.unscored_reason and "nan" not in repr(short)
    # A run that scores shows its mean and its lost frames.
    full = kata.mediapipe.score(lm, t, teacher, first_frame=1)
    assert full.unscored_reason == "" and "mean %.1f, %d lost" % (full.mean_score, full.lost_frames) in repr(full)


def test_a_landmark_teacher_is_accepted_where_a_bvh_one_is(recording, data, tmp_path):  # noqa: F811
    lm, t = recording
    path = str(tmp_path / "teacher.npy")
    np.save(path, lm)
    np.save(str(tmp_path / "teacher.times.npy"), t)
    # The student is the teacher's own recording: once calibrated, every frame matches its own.
    r = kata.mediapipe.score(lm, t, path)
    assert len(r.scored) > 0.8 * len(lm)
    assert r.mean_score > 95.0, r
    # A CSV teacher without timestamps, its rate given.
    csv = str(tmp_path / "teacher.csv")
    np.savetxt(csv, lm.reshape(len(lm), -1), delimiter=",")
    r2 = kata.mediapipe.score(lm, t, csv, teacher_fps=1000.0 / float(np.median(np.diff(t))))
    assert r2.mean_score > 95.0
    # The BVH teacher still works as before.
    assert kata.mediapipe.score(lm, t, os.path.join(data, "02_01.bvh"), first_frame=1).mean_score > 0


def test_a_message_whose_bytes_are_not_utf8_is_not_lost(recording, tmp_path):  # noqa: F811
    lm, _ = recording
    path = str(tmp_path / "teacher.npy")
    np.save(path, lm)  # starts with b"\x93NUMPY": not a BVH
    with kata.Context() as ctx, pytest.raises(kata.KataError) as e:
        ctx.load_clip(path)
    assert e.value.status == kata.Status.E_PARSE
    assert path + ":1: expected HIERARCHY" in e.value.message and "NUMPY" in e.value.message


def test_shipped_files_are_found_from_any_folder_or_the_places_looked_in_are_named(tmp_path, monkeypatch, repo):
    monkeypatch.chdir(tmp_path)  # no models/ here
    assert not os.path.exists("models/default.kata")
    with kata.Context() as ctx:
        with ctx.load_model("models/default.kata") as m:
            assert m.stencil is not None
        with ctx.load_clip("data/cmu/05_18.bvh") as c:
            assert c.frame_count > 100
        with pytest.raises(kata.KataError) as e:
            ctx.load_model("models/no-such.kata")
        assert e.value.status == kata.Status.E_IO
        assert "models/no-such.kata: no such file (looked in %s, " % str(tmp_path) in e.value.message
        assert "share/kata" in e.value.message


def test_kata_mediapipe_comes_with_a_plain_import():
    code = "import kata; print(kata.mediapipe.score.__name__, kata.mediapipe.Scorer.__name__)"
    env = dict(os.environ)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                         cwd=os.path.dirname(os.path.dirname(kata.__file__)), timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["score", "Scorer"]
