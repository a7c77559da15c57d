"""The Python binding against values computed independently: the `kata` CLI's files (features .npy,
score CSV, its error message), and the C ABI's own documented behaviour."""
import csv
import gc
import os
import subprocess
import sys
import tracemalloc

import numpy as np
import pytest

import kata


def run_cli(cli, *args):
    return subprocess.run([cli, *args], check=True, capture_output=True, text=True)


@pytest.mark.parametrize("stencil", ["backward", "central"])
def test_features_equal_the_cli_npy_exactly(cli, data, tmp_path, stencil):
    bvh = os.path.join(data, "05_02.bvh")
    npy = tmp_path / "features.npy"
    run_cli(cli, "features", "--bvh", bvh, "--preset", "cmu", "--stencil", stencil, "--out", str(npy))
    expected = np.load(npy)

    with kata.Context() as ctx, ctx.load_clip(bvh) as clip, clip.skeleton() as sk:
        positions = clip.all_positions()
        assert positions.shape == (clip.frame_count, sk.joint_count, 3)
        # Every vector kept in the result ring until read: capacity for the whole clip.
        with ctx.open_stream(sk, layout="cmu", stencil=kata.Stencil[stencil.upper()], keep_features=True,
                             result_capacity=clip.frame_count) as s:
            s.push_many(np.arange(clip.frame_count) * clip.frame_time, positions)
            s.flush()
            r = s.read_results(features=True)
            assert s.results_dropped == 0
    assert r.features.shape == expected.shape
    assert np.array_equal(r.results["frame_index"], np.arange(len(expected)))
    assert np.array_equal(r.features, expected)  # bit for bit


def test_single_push_and_features_match_the_bulk_read(data):
    with kata.Context() as ctx, ctx.load_clip(os.path.join(data, "02_01.bvh")) as clip, clip.skeleton() as sk:
        with ctx.open_stream(sk, keep_features=True) as s:
            assert s.features() is None
            out = np.empty(kata.GPD_DIMS, dtype=np.float32)
            for i in range(5):
                s.push(i * clip.frame_time, clip.positions(i))
                v, t, frame = s.features(out)
                assert v is out and frame == i and t == pytest.approx(i * clip.frame_time)
                r = s.read_results(features=True)
                assert len(r) == 1 and np.array_equal(r.features[0], out)
            assert s.feature_count == 5
            assert s.body_height > 0


def test_mediapipe_shapes_in_milliseconds_give_the_features_of_seconds(data):
    """MediaPipe's five channels (x y z visibility presence) with millisecond timestamps, far from 0,
    give the features of the same frames in seconds with 3 channels (all joints confident), the
    units inferred or stated; steps that fit neither unit are refused."""
    with kata.Context() as ctx, ctx.load_clip(os.path.join(data, "02_01.bvh")) as clip, clip.skeleton() as sk:
        pos = clip.all_positions()[1:61]  # within the result ring (64)
        n = len(pos)
        seconds = np.arange(n) * clip.frame_time
        five = np.concatenate([pos, np.full(pos.shape[:2] + (2,), 0.9, dtype=np.float32)], axis=2)
        feats = []
        for times, values, units in ((seconds, pos, None), (1e6 + 1000 * seconds, five, "ms"),
                                     (1e6 + 1000 * seconds, five, "auto")):
            with ctx.open_stream(sk, keep_features=True) as s:
                s.push_many(times, values, time_units=units)
                feats.append(s.read_results(features=True).features.copy())
        assert feats[0].shape == (n, kata.GPD_DIMS)
        for f in feats[1:]:
            assert f.shape == feats[0].shape
            np.testing.assert_allclose(f, feats[0], rtol=1e-4, atol=1e-4)
        assert kata.detect_time_units(1e6 + 1000 * seconds) == "ms"
        assert kata.detect_time_units(seconds) == "s"
        with pytest.raises(kata.KataError, match="ambiguous time units"):
            kata.detect_time_units(np.arange(n) * 0.7)


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_scores_equal_the_cli_csv(cli, data, model_path, tmp_path):
    teacher, student = os.path.join(data, "02_01.bvh"), os.path.join(data, "07_01.bvh")
    out = tmp_path / "scores.csv"
    run_cli(cli, "score", "--model", model_path, "--teacher", teacher, "--student", student, "--preset", "cmu",
            "--first-frame", "1", "--out", str(out))
    rows = read_csv(out)
    parts = ["torso_head", "left_arm", "right_arm", "left_leg", "right_leg"]
    # The first ten columns (then come the part distances, part scores, part to fix and state).
    assert list(rows[0].keys())[:10] == ["frame", "time", "distance", "score", *parts, "matched_teacher_frame"]

    with kata.Context() as ctx, ctx.load_model(model_path) as model, ctx.load_clip(teacher) as tclip, \
            ctx.load_clip(student) as sclip, sclip.skeleton() as sk:
        first = 1
        positions = sclip.all_positions(first)
        with ctx.open_stream(sk, layout="cmu", stencil=model.stencil, result_capacity=len(positions)) as s:
            s.attach_teacher(model, clip=tclip, first_frame=first, ghost=False)
            s.push_many(np.arange(len(positions)) * sclip.frame_time, positions)
            r = s.read_results()
    assert len(r) == len(rows)
    names = list(rows[0].keys())
    for row, res, sc in zip(rows, r.results, r.scores):
        assert res["scored"]
        assert int(row["frame"]) == res["frame_index"] + first
        assert row["time"] == "%.6f" % res["capture_time"]
        assert row["distance"] == "%.7g" % sc["distance"]
        assert row["score"] == "%.4f" % sc["score"]
        assert [row[n] for n in names[4:9]] == ["%.7g" % p for p in sc["parts"]]
        assert int(row["matched_teacher_frame"]) == res["matched_teacher_frame"] + first


def test_read_newest_is_the_last_entry_of_a_drain(data, model_path):
    with kata.Context() as ctx, ctx.load_model(model_path) as model, ctx.load_clip(os.path.join(data, "02_01.bvh")) as clip, \
            clip.skeleton() as sk, ctx.open_stream(sk) as a, ctx.open_stream(sk) as b:
        assert b.read_newest() is None
        with pytest.raises(kata.KataError) as e:
            b.restart_teacher()
        assert e.value.status == kata.Status.E_STATE
        for s in (a, b):
            s.attach_teacher(model, clip=clip, first_frame=1)
        for i in range(1, 8):
            a.push(i * clip.frame_time, clip.positions(i))
            b.push(i * clip.frame_time, clip.positions(i))
        ring = a.read_results()
        newest = b.read_newest()
        assert len(newest) == 1 and len(ring) > 1
        assert newest.results["result_sequence"][0] == ring.results["result_sequence"][-1]
        assert newest.scores["score"][0] == ring.scores["score"][-1]
        assert (newest.scores["parts"][0] == ring.scores["parts"][-1]).all()
        assert (newest.ghosts[0] == ring.ghosts[-1]).all()
        assert b.results_pending == 0 and b.results_dropped == 0 and b.read_newest() is None
        b.detach_teacher()
        b.push(9 * clip.frame_time, clip.positions(9))
        assert not b.read_newest().results["scored"][0]


def test_a_teacher_given_as_its_own_features_is_at_distance_zero(data, model_path):
    with kata.Context() as ctx, ctx.load_model(model_path) as model, ctx.load_clip(os.path.join(data, "02_01.bvh")) as clip, \
            clip.skeleton() as sk, ctx.open_stream(sk, stencil=model.stencil) as t, \
            ctx.open_stream(sk, stencil=model.stencil) as s:
        feats = []
        for i in range(1, 40):
            t.push(i * clip.frame_time, clip.positions(i))
            if t.feature_count > len(feats):
                feats.append(t.features()[0].copy())
        s.attach_teacher(model, features=np.array(feats), frame_time=clip.frame_time)
        for i in range(1, 40):
            s.push(i * clip.frame_time, clip.positions(i))
        r = s.read_results()
        assert len(r) == len(feats)
        assert (r.results["matched_teacher_frame"] == np.arange(len(feats))).all()
        assert (r.scores["distance"] < 1e-4).all()


def test_a_bad_model_file_raises_with_the_c_message(cli, tmp_path):
    bad = tmp_path / "bad.kata"
    bad.write_bytes(b"this is not a flatbuffer, only some bytes " * 4)
    with kata.Context() as ctx:
        with pytest.raises(kata.KataError) as e:
            ctx.load_model(str(bad))
    assert e.value.status == kata.Status.E_MODEL
    assert e.value.message  # the reason, not an empty string
    # The CLI (which does not go through the C ABI) reports the same reason.
    cli_run = subprocess.run([cli, "model-info", str(bad)], capture_output=True, text=True)
    assert cli_run.returncode != 0
    reason = e.value.message.split(": ", 1)[-1]
    assert reason in cli_run.stderr, (e.value.message, cli_run.stderr)
    with kata.Context() as ctx:
        with pytest.raises(kata.KataError) as e:
            ctx.load_model_bytes(b"\0" * 64)
        assert e.value.status == kata.Status.E_MODEL


def test_a_malformed_bvh_names_file_and_line(tmp_path):
    bad = tmp_path / "bad.bvh"
    bad.write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0\n")
    with kata.Context() as ctx, pytest.raises(kata.KataError) as e:
        ctx.load_clip(str(bad))
    assert e.value.status == kata.Status.E_PARSE
    assert str(bad) in e.value.message and ":4" in e.value.message


def test_a_bad_frame_raises_and_leaves_the_stream_usable(data):
    with kata.Context() as ctx, ctx.load_clip(os.path.join(data, "02_01.bvh")) as clip, clip.skeleton() as sk, \
            ctx.open_stream(sk) as s:
        s.push(0.0, clip.positions(0))
        p = clip.positions(1).copy()
        p[3, 1] = np.nan
        with pytest.raises(kata.KataError) as e:
            s.push(0.01, p)
        assert e.value.status == kata.Status.E_NON_FINITE and e.value.message
        with pytest.raises(kata.KataError) as e:
            s.push(0.0, clip.positions(1))
        assert e.value.status == kata.Status.E_TIMESTAMP_NOT_INCREASING
        with pytest.raises(kata.KataError) as e:
            s.push(0.01, clip.positions(1)[:5])
        assert e.value.status == kata.Status.E_WRONG_JOINT_COUNT
        s.push(0.01, clip.positions(1).astype(np.float64))  # converted, accepted
        assert s.feature_count == 2
        frames = np.stack([clip.positions(i) for i in range(2, 5)])
        frames[1, 0, 0] = np.inf
        with pytest.raises(kata.KataError, match="frame 1"):
            s.push_many([0.02, 0.03, 0.04], frames)
        assert s.feature_count == 3  # frame 0 of the chunk went in, the bad one did not


def test_ghosts_come_with_the_results(data, model_path):
    with kata.Context() as ctx, ctx.load_model(model_path) as model, ctx.load_clip(os.path.join(data, "02_01.bvh")) as t, \
            ctx.load_clip(os.path.join(data, "07_01.bvh")) as st, st.skeleton() as sk, ctx.open_stream(sk) as s:
        s.attach_teacher(model, clip=t, first_frame=1)
        g = s.ghost_joint_count
        assert g == 21 and len(s.ghost_joint_sources) == g
        buf = s.result_buffer(8)
        assert buf.ghosts.shape == (8, g, 3)
        pos = st.all_positions(1)[:20]
        s.push_many(np.arange(20) * st.frame_time, pos)
        r = s.read_results(buf)
        assert len(r) == 8 and s.results_pending == 12
        assert np.all(r.results["scored"] == 1) and np.all(r.results["ghost_joint_count"] > 0)
        # The ghost's root sits on the student's root (kata_retargeter_place).
        root = s.ghost_joint_sources[0]
        assert np.allclose(r.ghosts[:, 0, :], pos[:8, root, :], atol=1e-3)
        r2 = s.read_results(buf)
        assert len(r2) == 8 and r2.results["result_sequence"][0] == 8


def test_retargeter_matches_the_stream_ghost_joint_set(data):
    with kata.Context() as ctx, ctx.load_clip(os.path.join(data, "02_01.bvh")) as t, \
            ctx.load_skeleton_bvh(os.path.join(data, "07_01.bvh")) as student:
        with ctx.create_retargeter(student) as r:
            ghost, info = r.solve(t.positions(10))
            assert ghost.shape == (r.joint_count, 3) and r.joint_count == 21
            assert info["max_bone_error"] < 1e-3
            with pytest.raises(kata.KataError) as e:
                r.solve(t.positions(10)[:3])
            assert e.value.status == kata.Status.E_WRONG_JOINT_COUNT
        with ctx.create_retargeter(student, joint_set="gpd") as r:
            assert r.joint_count == 16


def test_skeleton_from_arrays_round_trips():
    with kata.Context() as ctx:
        with ctx.create_skeleton(["a", "b", "c"], [-1, 0, 1], [[0, 0, 0], [0, 1, 0], [0, 1, 0]]) as sk:
            assert sk.joint_count == 3 and sk.names == ["a", "b", "c"] and list(sk.parents) == [-1, 0, 1]
        with pytest.raises(kata.KataError) as e:
            ctx.create_skeleton(["a", "b"], [-1, 5])
        assert e.value.status == kata.Status.E_INVALID_ARGUMENT and e.value.message


def test_handles_close_once_and_the_context_closes_its_children(data):
    ctx = kata.Context()
    clip = ctx.load_clip(os.path.join(data, "02_01.bvh"))
    sk = clip.skeleton()
    s = ctx.open_stream(sk)
    clip.close()
    clip.close()  # a second close does nothing
    assert clip.closed
    with pytest.raises(ValueError):
        clip.frame_count
    ctx.close()  # closes the stream and the skeleton first, as kata.h requires
    assert s.closed and sk.closed
    ctx.close()


def test_no_reference_leaks_over_10000_push_read_cycles(data, model_path):
    with kata.Context() as ctx, ctx.load_model(model_path) as model, ctx.load_clip(os.path.join(data, "02_01.bvh")) as t, \
            ctx.load_clip(os.path.join(data, "07_01.bvh")) as st, st.skeleton() as sk, ctx.open_stream(sk) as s:
        s.attach_teacher(model, clip=t, first_frame=1)
        frame = np.ascontiguousarray(st.positions(1))
        buf = s.result_buffer(4)
        t_now = 0.0

        def cycles(n, reuse):
            nonlocal t_now
            for _ in range(n):
                t_now += 0.01
                s.push(t_now, frame)
                r = s.read_results(buf if reuse else None)
                assert len(r) == 1

        for reuse in (True, False):
            cycles(500, reuse)  # warm-up: caches, first allocations
            gc.collect()
            tracemalloc.start()
            before = tracemalloc.take_snapshot()
            cycles(10000, reuse)
            gc.collect()
            after = tracemalloc.take_snapshot()
            tracemalloc.stop()
            grown = sum(d.size_diff for d in after.compare_to(before, "filename"))
            assert grown < 4096, (reuse, grown, after.compare_to(before, "lineno")[:5])
            assert sys.getrefcount(frame) == 2  # no reference to the pushed array kept


def test_a_library_of_another_major_version_is_refused():
    shim = os.environ.get("KATA_WRONG_VERSION_LIBRARY")
    if not shim:
        pytest.skip("KATA_WRONG_VERSION_LIBRARY not set (ctest sets it)")
    env = dict(os.environ, KATA_LIBRARY=shim)
    p = subprocess.run([sys.executable, "-c", "import kata"], env=env, capture_output=True, text=True,
                       cwd=os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    assert p.returncode != 0
    assert "ImportError" in p.stderr and "version 7.0.0" in p.stderr and "needs 1.x" in p.stderr, p.stderr


def test_the_package_carries_its_library_and_message_readers():
    """Installed (wheel_test.py): libkata is the one inside the package; from a checkout, the
    build's. Either way kata.fb (the FlatBuffers readers) is importable beside the binding."""
    import kata
    import kata.fb.Result
    package = os.path.dirname(os.path.realpath(kata.__file__))
    if os.environ.get("KATA_TEST_INSTALLED") == "1":
        assert "site-packages" in package
        assert kata._native.found_by == "package folder"
        assert os.path.dirname(os.path.realpath(kata.library_path)) == package
        assert os.path.dirname(os.path.realpath(kata.fb.Result.__file__)) == os.path.join(package, "fb")
    assert hasattr(kata.fb.Result, "Result") and kata.version[0] == 1 and kata.__version__.startswith("1.")
