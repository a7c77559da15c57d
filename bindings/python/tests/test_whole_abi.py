"""The parts of the C ABI added to the binding for any body (layouts, confidence, smoothing, bone
lengths, joint offsets, local rotations, the runtime and result messages), each against a value
computed independently of the call it tests."""
import os
import time

import numpy as np
import pytest

import kata


def cmu(ctx, data, name="07_01.bvh"):
    return ctx.load_clip(os.path.join(data, name))


def test_layouts_include_mediapipe_and_y_down():
    names = kata.layouts()
    assert "cmu" in names and "mediapipe" in names and "gpd" in names
    assert kata.UpAxis.Y_DOWN == 2 and kata.Status.TRACKING_LOST == 15
    with kata.Context() as ctx, ctx.create_layout("mediapipe") as mp, ctx.create_layout("gpd") as gpd:
        assert mp.joint_count == 33 and mp.names[0] == "nose" and mp.names[11] == "left_shoulder"
        assert mp.offsets is None  # no rest pose
        assert gpd.names[:4] == ["Hip", "Chest", "Neck", "Head"]
        with pytest.raises(kata.KataError) as e:
            ctx.create_layout("no-such-layout")
        assert e.value.status == kata.Status.E_NOT_FOUND


def test_y_down_reads_a_rotated_frame_as_the_same_pose(data):
    """(x, y, z) -> (x, -y, -z) is a rotation: features of the flipped clip read Y_DOWN equal
    the original's read Y up."""
    with kata.Context() as ctx, cmu(ctx, data) as clip, clip.skeleton() as sk:
        p = clip.all_positions(first=1)[:40]
        flipped = p * np.array([1, -1, -1], np.float32)
        t = np.arange(len(p)) * clip.frame_time
        with ctx.open_stream(sk, keep_features=True) as a, \
                ctx.open_stream(sk, up_axis=kata.UpAxis.Y_DOWN, keep_features=True) as b:
            a.push_many(t, p)
            b.push_many(t, flipped)
            fa, fb = a.read_results(features=True).features, b.read_results(features=True).features
    assert len(fa) > 20
    np.testing.assert_allclose(fa, fb, atol=2e-4)


def test_skeleton_offsets_rebuild_the_clip_rest_pose(data):
    with kata.Context() as ctx, cmu(ctx, data) as clip, clip.skeleton() as sk:
        off, parents = sk.offsets, sk.parents
        # Each joint's offset has the length of its bone in every frame of the clip.
        p = clip.all_positions()
    for j in range(1, len(parents)):
        bone = np.linalg.norm(p[:, j] - p[:, parents[j]], axis=1)
        np.testing.assert_allclose(bone, np.linalg.norm(off[j]), rtol=1e-4, atol=1e-4)


def test_confidence_holds_a_low_joint_and_too_many_lose_tracking(data):
    with kata.Context() as ctx, cmu(ctx, data) as clip, clip.skeleton() as sk:
        p = clip.all_positions(first=1)[:60]
        t = np.arange(len(p)) * clip.frame_time
        n = sk.joint_count
        with ctx.open_stream(sk) as s:
            assert s.push_many(t[:30], p[:30], np.ones((30, n))) == 0
            assert s.push(t[30], p[30], np.zeros(n)) == kata.Status.TRACKING_LOST
            assert s.lost_frames == 1
            s.set_confidence_gate(threshold=0.0)
            assert s.push(t[31], p[31], np.zeros(n)) == kata.Status.OK
            with pytest.raises(ValueError, match="one per joint"):
                s.push(t[32], p[32], np.ones(3))
            assert s.push(t[32], p[32]) == kata.Status.OK  # still usable


def test_smoothing_changes_the_features_and_off_restores_them(data):
    with kata.Context() as ctx, cmu(ctx, data) as clip, clip.skeleton() as sk:
        p = clip.all_positions(first=1)[:60]
        rng = np.random.default_rng(1)
        noisy = (p + rng.normal(0, 0.2, p.shape)).astype(np.float32)
        t = np.arange(len(p)) * clip.frame_time
        feats = []
        for smoothing in (None, True, False):
            with ctx.open_stream(sk, keep_features=True) as s:
                if smoothing is not None:
                    s.set_smoothing(smoothing, min_cutoff=1.0, beta=0.0)
                s.push_many(t, noisy)
                feats.append(s.read_results(features=True).features)
    assert np.abs(feats[0] - feats[1]).max() > 1e-2
    np.testing.assert_array_equal(feats[0], feats[2])


def test_bone_lengths_are_the_gpd_bones_of_the_clip(data):
    with kata.Context() as ctx, cmu(ctx, data) as clip, clip.skeleton() as sk, ctx.create_layout("gpd") as gpd:
        p = clip.all_positions(first=1)
        t = np.arange(len(p)) * clip.frame_time
        with ctx.open_stream(sk) as s:
            s.push_many(t[:30], p[:30])
            assert s.bone_lengths() is None
            s.push_many(t[30:90], p[30:90])
            lengths, spread = s.bone_lengths()
        ix = {n: i for i, n in enumerate(sk.names)}
        gpd_parents = gpd.parents
    # GPD joint g -> its cmu source: the arm/leg chains (shoulder..hand, hip..foot).
    src = {"LShoulder": "LeftArm", "LElbow": "LeftForeArm", "LHand": "LeftHand",
           "LHip": "LeftUpLeg", "LKnee": "LeftLeg", "LFoot": "LeftFoot"}
    names = ["Hip", "Chest", "Neck", "Head", "LShoulder", "LElbow", "LHand", "RShoulder", "RElbow", "RHand",
             "LHip", "LKnee", "LFoot", "RHip", "RKnee", "RFoot"]
    for g in (5, 6, 11, 12):  # elbow, hand, knee, foot: bones between two mapped limb joints
        parent = names[gpd_parents[g]]
        d = np.linalg.norm(p[:90, ix[src[names[g]]]] - p[:90, ix[src[parent]]], axis=1)
        assert lengths[g] == pytest.approx(np.median(d), rel=1e-3)
    assert lengths[0] == 0 and (spread >= 0).all()


def test_local_rotations_rebuild_the_ghost_by_forward_kinematics(data):
    with kata.Context() as ctx, cmu(ctx, data, "02_01.bvh") as teacher, cmu(ctx, data) as student_clip, \
            student_clip.skeleton() as student, ctx.create_retargeter(student) as rt:
        ghost, _ = rt.solve(teacher.positions(40))
        rotations, root, positions, residual = rt.local_rotations(ghost)
        off, parents = student.offsets, student.parents
    assert rotations.shape == (len(parents), 4)
    np.testing.assert_allclose(np.linalg.norm(rotations, axis=1), 1, atol=1e-5)

    def rot(q):
        x, y, z, w = q.astype(np.float64)
        return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                         [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                         [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    g = [None] * len(parents)
    x = np.zeros((len(parents), 3))
    for j, par in enumerate(parents):  # the FK kata.h documents, computed here
        if par < 0:
            g[j], x[j] = rot(rotations[j]), root
        else:
            g[j], x[j] = g[par] @ rot(rotations[j]), x[par] + g[par] @ off[j]
    np.testing.assert_allclose(x, positions, atol=1e-3 * np.abs(positions).max())
    assert residual < 1e-3 * np.abs(positions).max()


def test_a_runtime_publishes_results_a_subscriber_reads(data, model_path):
    pytest.importorskip("zmq")
    with kata.Context() as ctx, cmu(ctx, data) as clip, clip.skeleton() as sk, ctx.load_model(model_path) as m, \
            cmu(ctx, data, "02_01.bvh") as teacher:
        p = clip.all_positions(first=1)[:120]
        with ctx.open_stream(sk, stencil=m.stencil, result_capacity=256) as alone:  # the same frames scored without a runtime
            alone.attach_teacher(m, clip=teacher, first_frame=1, ghost=False)
            alone.push_many(np.arange(len(p)) * clip.frame_time, p)
            expected = alone.read_results().scores["score"].copy()
        with ctx.create_runtime(workers=1, publish="tcp://127.0.0.1:*") as rt:
            with kata.Subscriber(rt.publish_endpoint, stream=7) as sub:
                s = ctx.open_stream(sk, stencil=m.stencil)
                s.attach_teacher(m, clip=teacher, first_frame=1, ghost=False)
                time.sleep(0.3)  # the subscription reaches the publisher (ZeroMQ slow joiner)
                rt.add_stream(7, s)
                assert s.closed
                for i, frame in enumerate(p):
                    rt.push(7, i, i * clip.frame_time, frame)
                rt.stop()
                got = []
                while True:
                    msg = sub.receive(timeout=2.0)
                    if msg is None:
                        break
                    got.append(msg)
            counters = rt.counters()
    assert counters["frames_in"] == len(p) and counters["published"] == len(expected)
    assert [m.result_sequence for m in got] == list(range(len(expected)))
    assert all(m.stream_id == 7 and m.scored for m in got)
    np.testing.assert_allclose([m.score for m in got], expected, atol=1e-4)
    assert sub.refused == 0
    # Every message says the practice it was computed under (none set: the whole clip, revision 0)
    # and the matched teacher time inside it.
    assert all(m.practice is not None and m.practice.revision == 0 and not m.practice.loop and
               m.practice.start_time == 0.0 and 0.0 <= m.matched_teacher_time <= m.practice.end_time for m in got)
    with pytest.raises(kata.KataError) as e:
        kata.read_message(b"0" * 16 + b"garbage!")
    assert e.value.status == kata.Status.E_PARSE


def test_a_runtime_streams_practice_is_in_every_message(data):
    """Runtime.set_practice: a loop of teacher seconds 0.2..0.5, then "again from 0.8 s" mid-stream;
    every message says which it was computed under, its matched time inside it; bad settings refused."""
    with kata.Context() as ctx, ctx.load_model(kata.default_model_path()) as m, cmu(ctx, data) as clip, \
            clip.skeleton() as sk:
        p = clip.all_positions(first=1)[:200]
        ft = clip.frame_time
        with ctx.create_runtime(workers=1, publish="tcp://127.0.0.1:*") as rt:
            with kata.Subscriber(rt.publish_endpoint, stream=3) as sub:
                s = ctx.open_stream(sk, stencil=m.stencil)
                s.attach_teacher(m, clip=clip, first_frame=1, ghost=False)
                time.sleep(0.3)  # the subscription reaches the publisher (ZeroMQ slow joiner)
                rt.add_stream(3, s)
                with pytest.raises(kata.KataError) as e:
                    rt.set_practice(3, 1, loop=(0.5, 0.2))
                assert e.value.status == kata.Status.E_INVALID_ARGUMENT and "not after" in str(e.value)
                with pytest.raises(kata.KataError) as e:
                    rt.set_practice(4, 1, teacher_start=1.0)
                assert e.value.status == kata.Status.E_NOT_FOUND
                rt.set_practice(3, 1, loop=(0.2, 0.5))
                for i, frame in enumerate(p):
                    if i == 100:
                        rt.set_practice(3, 2, teacher_start=0.8)
                    rt.push(3, i, i * ft, frame)
                rt.stop()
                got = []
                while True:
                    msg = sub.receive(timeout=2.0)
                    if msg is None:
                        break
                    got.append(msg)
    assert len(got) == len(p)
    for msg in got:
        want = 1 if msg.frame_sequence < 99 else 2 if msg.frame_sequence >= 100 else msg.practice.revision
        assert msg.practice.revision == want, msg.frame_sequence
        assert msg.practice.loop == (want == 1)
        start = 0.2 if want == 1 else 0.8
        assert abs(msg.practice.start_time - start) <= ft / 2
        if msg.scored:
            assert msg.practice.start_time - 1e-9 <= msg.matched_teacher_time <= msg.practice.end_time + 1e-9
