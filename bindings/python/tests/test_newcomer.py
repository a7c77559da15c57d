"""What a newcomer relies on (README's example): no result lost without a count the caller sees, time
units checked or inferred in kata.mediapipe as in the CLI, and a package surface that reads like
a library (__all__, __version__, plain attributes, type hints, TypeErrors, help led by an
overview). The expected values come from a stream whose ring holds the whole clip, read once."""
import inspect
import os
import pydoc
import subprocess
import sys
import warnings

import numpy as np
import pytest

import kata
import kata.mediapipe
from test_mediapipe import recording  # noqa: F401  (the fixture, by name)


def _readme_stream(ctx, data, model, **options):
    """README's first Python example: 07_01 (317 frames) scored against 02_01."""
    t = ctx.load_clip(os.path.join(data, "02_01.bvh"))
    student = ctx.load_clip(os.path.join(data, "07_01.bvh"))
    sk = student.skeleton()
    s = ctx.open_stream(sk, stencil=model.stencil, **options)
    s.attach_teacher(model, clip=t, first_frame=1)
    frames = student.all_positions()
    return s, np.arange(len(frames)) * student.frame_time, frames


@pytest.fixture(scope="module")
def everything(data, model_path):
    """Every result of the README example, from a ring that holds the whole clip."""
    with kata.Context() as ctx, ctx.load_model(model_path) as m:
        s, times, frames = _readme_stream(ctx, data, m, result_capacity=1000)
        s.push_many(times, frames)
        r = s.read_results()
        assert s.results_dropped == 0
        return r.results.copy(), r.scores.copy(), len(frames)


def test_the_readme_pattern_with_a_small_ring_says_how_many_were_dropped(data, model_path, everything):
    results, _, frames = everything
    assert frames > 300 and len(results) > 250
    with kata.Context() as ctx, ctx.load_model(model_path) as m:
        s, times, positions = _readme_stream(ctx, data, m)
        s.push_many(times, positions)
        with pytest.warns(kata.ResultsDroppedWarning, match=r"%d results were overwritten" % (len(results) - 64)) as w:
            r = s.read_results()
        assert w[0].message.count == len(results) - 64
        assert len(r) == 64 and r.dropped == len(results) - 64 == s.results_dropped
        # The 64 kept are the newest: the tail of the whole run.
        assert np.array_equal(r.results["result_sequence"], results["result_sequence"][-64:])
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            assert s.read_results().dropped == 0  # counted once, not again


def test_push_and_read_loses_nothing_whatever_the_ring(data, model_path, everything):
    results, scores, _ = everything
    with kata.Context() as ctx, ctx.load_model(model_path) as m:
        s, times, positions = _readme_stream(ctx, data, m, result_capacity=16)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            r = s.push_and_read(times, positions)
        assert r.dropped == 0 and s.results_dropped == 0
    assert np.array_equal(r.results["result_sequence"], results["result_sequence"])
    assert np.array_equal(r.scores["score"], scores["score"])
    assert r.ghosts is not None and len(r.ghosts) == len(results)


def test_on_drop_raise_keeps_what_was_read_and_count_is_silent(data, model_path, everything):
    results, _, _ = everything
    with kata.Context() as ctx, ctx.load_model(model_path) as m:
        s, times, positions = _readme_stream(ctx, data, m, on_drop="raise")
        s.push_many(times, positions)
        with pytest.raises(kata.ResultsDroppedError) as e:
            s.read_results()
        assert e.value.count == len(results) - 64 and len(e.value.results) == 64
        s.on_drop = "count"
        s.push_many(times[-1] + 1 + times, positions)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            assert s.read_results().dropped > 0
        with pytest.raises(ValueError, match="on_drop"):
            s.on_drop = "ignore"


def test_mediapipe_seconds_are_inferred_and_score_as_milliseconds_do(recording, data):  # noqa: F811
    landmarks, timestamps_ms = recording  # 120 Hz
    teacher = os.path.join(data, "02_01.bvh")
    expected = kata.mediapipe.score(landmarks, timestamps_ms, teacher, first_frame=1, time_units="ms")
    assert len(expected.scored) > 100
    for ts in (timestamps_ms / 1000.0, timestamps_ms):
        got = kata.mediapipe.score(landmarks, ts, teacher, first_frame=1)  # units inferred
        assert np.array_equal(got.scores["score"], expected.scores["score"])
    # At 30 Hz (every 4th frame) in seconds: scored, not "0 scored, mean nan".
    thirty = kata.mediapipe.score(landmarks[::4], timestamps_ms[::4] / 1000.0, teacher, first_frame=1)
    assert len(thirty.scored) > 20 and np.isfinite(thirty.mean_score)


def test_mediapipe_units_stated_wrong_are_refused_naming_them(recording, data):  # noqa: F811
    landmarks, timestamps_ms = recording
    teacher = os.path.join(data, "02_01.bvh")
    with pytest.raises(ValueError, match=r"timestamps are in seconds .* not milliseconds"):
        kata.mediapipe.score(landmarks[::4], timestamps_ms[::4] / 1000.0, teacher, time_units="ms")
    with kata.mediapipe.Scorer(teacher) as live:  # live frames: milliseconds unless told
        live.push(landmarks[0], 0.0)
        with pytest.raises(ValueError, match=r"look like seconds: make the Scorer with time_units=\"s\""):
            live.push(landmarks[1], 1 / 120.0)
    with kata.mediapipe.Scorer(teacher, time_units="s") as live:
        for i in range(60):
            live.push(landmarks[i], i / 120.0)
        assert len(live.read()) > 0


def test_the_package_surface_reads_like_a_library():
    assert isinstance(kata.__version__, str) and kata.__version__ == "%d.%d.%d" % kata.version
    assert isinstance(kata.version, tuple) and isinstance(kata.library_path, str)  # both plain values
    public = {n for n in dir(kata) if not n.startswith("_")}
    modules = {"errors", "objects", "stream", "retarget", "messages", "runtime", "mediapipe", "humanoid", "people", "vmc", "fb"}
    assert public - modules == set(kata.__all__), sorted(public - modules ^ set(kata.__all__))
    assert not {"np", "os", "time", "ctypes", "enum"} & public
    for name in kata.__all__:
        assert hasattr(kata, name), name
    # Every public function and method has hints on every parameter and its return.
    unhinted = []
    for name in kata.__all__ + ["mediapipe"]:
        obj = getattr(kata, name)
        members = [(name, obj)] if inspect.isfunction(obj) else [
            ("%s.%s" % (name, n), f) for n, f in vars(obj).items()
            if inspect.isfunction(f) and (not n.startswith("_") or n == "__init__")] if inspect.isclass(obj) else []
        if inspect.ismodule(obj):
            members = [("mediapipe." + n, f) for n, f in vars(obj).items() if inspect.isfunction(f) and not n.startswith("_")]
        for qual, f in members:
            sig = inspect.signature(f)
            missing = [p for p in sig.parameters if p not in ("self", "cls") and p not in f.__annotations__]
            if missing or "return" not in f.__annotations__:
                unhinted.append("%s%s" % (qual, missing))
    assert not unhinted


def test_a_wrong_argument_type_is_a_typeerror_naming_it(data):
    with kata.Context() as ctx, ctx.load_clip(os.path.join(data, "07_01.bvh")) as clip, clip.skeleton() as sk, \
            ctx.open_stream(sk) as s:
        xyz = clip.positions(0)
        with pytest.raises(TypeError, match=r"Stream.push: timestamp must be a number, not str"):
            s.push("0.1", xyz)
        with pytest.raises(TypeError, match=r"Stream.set_smoothing: min_cutoff must be a number, not str"):
            s.set_smoothing(True, "2")
        with pytest.raises(TypeError, match=r"Clip.positions: frame must be a integer|Clip.positions: frame must be"):
            clip.positions("3")
        assert s.push(0.1, xyz) == kata.Status.OK  # the stream was left as it was


def test_help_is_led_by_a_short_overview():
    text = pydoc.render_doc(kata, renderer=pydoc.plaintext)
    head = text[:text.index("PACKAGE CONTENTS")]
    assert "push_and_read" in head and "ResultsDroppedWarning" in head
    assert len(head.splitlines()) < 45
    assert "no bulk push" not in text


def test_the_installed_model_and_clips_are_found(tmp_path):
    """find_data looks in the package, the install's share/kata (_install_paths.DATADIR_FROM_PACKAGE),
    a build tree and the checkout: a package copied beside a share/kata finds it there."""
    package = os.path.dirname(kata.__file__)
    prefix = tmp_path / "prefix"
    site = prefix / "lib" / "python3" / "site-packages" / "kata"
    share = prefix / "share" / "kata" / "models"
    share.mkdir(parents=True)
    (share / "default.kata").write_bytes(b"not read")
    site.mkdir(parents=True)
    for f in os.listdir(package):
        if f.endswith(".py") or f == "py.typed":
            (site / f).write_bytes(open(os.path.join(package, f), "rb").read())
    (site / "_install_paths.py").write_text('LIBDIR_FROM_PACKAGE = "../../../lib"\nDATADIR_FROM_PACKAGE = "../../../../share/kata"\n')
    code = "import kata, os; print(os.path.realpath(kata.default_model_path()))"
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path,
                       env=dict(os.environ, PYTHONPATH=str(site.parent), KATA_LIBRARY=kata.library_path))
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == os.path.realpath(share / "default.kata")


def test_the_landmarks_sample_scores_mediapipe_arrays_as_kata_mediapipe_does(recording, data, repo, tmp_path):  # noqa: F811
    """samples/python/score_landmarks.py on MediaPipe's (frames, 33, 4) (x, y, z, visibility) with
    its timestamps in milliseconds beside it: the mean kata.mediapipe.score gives."""
    landmarks, timestamps_ms = recording
    four = np.concatenate([landmarks, np.full(landmarks.shape[:2] + (1,), 0.95, np.float32)], axis=2)
    np.save(tmp_path / "webcam.npy", four)
    np.save(tmp_path / "webcam.times.npy", timestamps_ms)
    teacher = os.path.join(data, "02_01.bvh")
    expected = kata.mediapipe.score(four, timestamps_ms, teacher, first_frame=1)
    p = subprocess.run([sys.executable, os.path.join(repo, "samples", "python", "score_landmarks.py"), "--landmarks",
                        str(tmp_path / "webcam.npy"), "--teacher", teacher], capture_output=True, text=True,
                       env=dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path)))
    assert p.returncode == 0, p.stderr
    assert "%d scored" % len(expected.scored) in p.stdout and "mean score %.1f" % expected.mean_score in p.stdout, p.stdout
