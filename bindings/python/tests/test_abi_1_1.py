"""The C ABI 1.1 additions in Python: Stream.gpd_joint_sources, gpd_joint_part, body_part_name,
gpd_joint_words, Runtime.latency_percentile, attach_teacher(alignment_window=, on_progress=),
Context.load_landmarks (Landmarks), Runtime.offer with create_runtime(direct_ingest=True). Each is
checked against values known without the function under test: the cmu layout's joint names
(sdk/src/skeleton/presets.cpp), kata/result.h's part table, a hand-written .npy + .times.npy, the
published results' own arrival and publish times, the frames a stream scores directly."""
import ctypes
import os
import time

import numpy as np
import pytest

import kata

# The cmu layout's joint read as each GPD joint (kata/stream.h "Layouts", presets.cpp).
CMU = ["Hips", "Spine1", "Neck1", "Head", "LeftArm", "LeftForeArm", "LeftHand", "RightArm", "RightForeArm",
       "RightHand", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg", "RightLeg", "RightFoot"]
# MediaPipe Pose's landmark indices of the GPD joints; Hip, Chest, Neck, Head are synthesised.
MEDIAPIPE = [-1, -1, -1, -1, 11, 13, 15, 12, 14, 16, 23, 25, 27, 24, 26, 28]
# kata/result.h kata_body_part: Hip, Chest, Neck, Head; LShoulder, LElbow, LHand; RShoulder, ...
PART = [0, 0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3, 4, 4, 4]
PART_NAMES = ["torso_head", "left_arm", "right_arm", "left_leg", "right_leg"]
END_JOINTS = {3, 6, 9, 12, 15}  # Head, LHand, RHand, LFoot, RFoot
WORDS = ["lower back", "chest", "neck", "left shoulder", "left elbow", "right shoulder", "right elbow", "left hip",
         "left knee", "right hip", "right knee"]


def clip_of(ctx, data, name):
    return ctx.load_clip(os.path.join(data, name))


def test_gpd_joint_sources_are_the_layouts_joints(data):
    with kata.Context() as ctx, clip_of(ctx, data, "02_01.bvh") as clip, clip.skeleton() as sk:
        with ctx.open_stream(sk, layout="cmu") as s:
            sources = s.gpd_joint_sources
        assert sources.shape == (kata.GPD_JOINTS,) and sources.dtype == np.int32
        assert [sk.names[j] for j in sources] == CMU
        with ctx.create_layout("mediapipe") as mp, ctx.open_stream(mp, layout="mediapipe", body_height=1.7) as m:
            assert m.gpd_joint_sources.tolist() == MEDIAPIPE


def test_gpd_joint_parts_and_names_are_result_h_s():
    assert [kata.gpd_joint_part(g) for g in range(kata.GPD_JOINTS)] == PART
    assert kata.gpd_joint_part(-1) == -1 and kata.gpd_joint_part(kata.GPD_JOINTS) == -1
    assert [kata.body_part_name(p) for p in range(5)] == PART_NAMES
    assert [kata.body_part_name(int(p)) for p in kata.BodyPart] == PART_NAMES[:len(kata.BodyPart)]
    assert kata.body_part_name(-1) == "" and kata.body_part_name(5) == ""
    assert kata.gpd_joint_words(11) == "left knee"
    assert kata.gpd_joint_words(-1) == "" and kata.gpd_joint_words(kata.GPD_JOINTS) == ""
    # teacher.h's list of the cue joints' words, in GPD order; the five end joints have none.
    assert [kata.gpd_joint_words(g) for g in range(kata.GPD_JOINTS) if g not in END_JOINTS] == WORDS
    assert all(kata.gpd_joint_words(g) == "" for g in END_JOINTS)
    # A cue's phrase starts with its joint's words (kata_cue_text).
    for g in range(kata.GPD_JOINTS):
        if g in END_JOINTS:
            continue
        rec = kata._native.ResultRecord()
        rec.struct_size = ctypes.sizeof(rec)
        rec.part_to_fix, rec.cue_joint, rec.cue_degrees, rec.cue_action = PART[g], g, 30.0, int(kata.CueAction.RAISE)
        assert kata.cue_text(rec) == WORDS[[x for x in range(kata.GPD_JOINTS) if x not in END_JOINTS].index(g)] + \
            ": raise 30 deg", g


def test_landmarks_load_reads_a_hand_written_npy_and_its_times(tmp_path):
    frames, joints = 6, 33
    values = np.zeros((frames, joints, 4), dtype=np.float32)
    for f in range(frames):
        for j in range(joints):
            for c in range(3):
                values[f, j, c] = 0.001 * (f * 100 + j) + 0.1 * c
    values[..., 3] = 0.9
    seconds = np.array([0.0, 0.030, 0.065, 0.100, 0.131, 0.165])  # steps 30 35 35 31 34 ms: median 34
    npy = str(tmp_path / "teacher.npy")
    np.save(npy, values)
    np.save(str(tmp_path / "teacher.times.npy"), seconds)
    with kata.Context() as ctx:
        with ctx.load_landmarks(npy, "mediapipe", time_units="s") as rec:
            assert rec.frame_count == frames and rec.joint_count == joints
            assert rec.frame_time == pytest.approx(0.034, abs=1e-12)
            np.testing.assert_allclose(rec.capture_times, seconds, atol=1e-12)
            assert rec.positions.shape == (frames, joints, 3)
            assert np.array_equal(rec.positions, values[..., :3])
        np.save(str(tmp_path / "teacher.times.npy"), 1000.0 * seconds)  # milliseconds, inferred
        with ctx.load_landmarks(npy, "mediapipe") as rec:
            assert rec.frame_time == pytest.approx(0.034, abs=1e-12)
            assert rec.capture_times[4] == pytest.approx(0.131, abs=1e-12)
        os.remove(str(tmp_path / "teacher.times.npy"))
        with pytest.raises(kata.KataError) as e:
            ctx.load_landmarks(npy, "mediapipe")
        assert e.value.status == kata.Status.E_INVALID_ARGUMENT
        with ctx.load_landmarks(npy, "mediapipe", fps=25.0) as rec:
            np.testing.assert_allclose(rec.capture_times, np.arange(frames) / 25.0, atol=1e-12)
        with pytest.raises(kata.KataError) as e:
            ctx.load_landmarks(npy, "no-such-layout", fps=25.0)
        assert e.value.status == kata.Status.E_NOT_FOUND
        with pytest.raises(ValueError):
            ctx.load_landmarks(npy, "mediapipe", fps=25.0, time_units="minutes")


def matched_frames(ctx, model, teacher, student, **options):
    """The matched teacher frames of student's frames 1..200 against teacher from its frame 1."""
    p = student.all_positions(first=1)[:200]
    with student.skeleton() as sk, ctx.open_stream(sk, stencil=model.stencil, result_capacity=256) as s:
        s.attach_teacher(model, clip=teacher, first_frame=1, ghost=False, **options)
        r = s.push_and_read((1 + np.arange(len(p))) / 120.0, p)
    return r.scores["matched_teacher_frame"].tolist()


def test_alignment_window_changes_the_matches_and_progress_ends_at_the_clips_frames(data, model_path):
    with kata.Context() as ctx, ctx.load_model(model_path) as m, clip_of(ctx, data, "02_01.bvh") as teacher, \
            clip_of(ctx, data, "02_02.bvh") as student:
        calls = []
        by_default = matched_frames(ctx, m, teacher, student, on_progress=lambda done, n: calls.append((done, n)))
        assert len(by_default) > 150
        assert calls and all(n == teacher.frame_count - 1 for _, n in calls)
        assert calls[-1][0] == teacher.frame_count - 1
        assert [d for d, _ in calls] == sorted(d for d, _ in calls)
        assert matched_frames(ctx, m, teacher, student, alignment_window=0.5) == by_default  # the default
        assert matched_frames(ctx, m, teacher, student, alignment_window=0.05) != by_default
        with teacher.skeleton() as sk, ctx.open_stream(sk) as s:
            for bad in (0.0, -0.5, 61.0, float("nan")):
                with pytest.raises(kata.KataError) as e:
                    s.attach_teacher(m, clip=teacher, first_frame=1, alignment_window=bad)
                assert e.value.status == kata.Status.E_INVALID_ARGUMENT


def test_latency_percentile_lies_within_the_published_latencies(data, model_path):
    pytest.importorskip("zmq")
    with kata.Context() as ctx, ctx.load_model(model_path) as m, clip_of(ctx, data, "07_01.bvh") as clip, \
            clip.skeleton() as sk, clip_of(ctx, data, "02_01.bvh") as teacher:
        p = clip.all_positions(first=1)[:120]
        with ctx.create_runtime(workers=1, publish="tcp://127.0.0.1:*") as rt:
            assert rt.latency_percentile(0.5) == 0.0  # nothing published yet
            with kata.Subscriber(rt.publish_endpoint, stream=5) as sub:
                s = ctx.open_stream(sk, stencil=m.stencil)
                s.attach_teacher(m, clip=teacher, first_frame=1, ghost=False)
                time.sleep(0.3)  # the subscription reaches the publisher (ZeroMQ slow joiner)
                rt.add_stream(5, s)
                for i, frame in enumerate(p):
                    rt.push(5, i, i * clip.frame_time, frame)
                rt.stop()
                got = []
                while True:
                    msg = sub.receive(timeout=2.0)
                    if msg is None:
                        break
                    got.append(msg)
            assert len(got) == rt.counters()["published"] > 0
            latencies = np.array([g.published_ns - g.arrival_ns for g in got], dtype=np.float64)
            p50, p99, p100 = (rt.latency_percentile(q) for q in (0.5, 0.99, 1.0))
            # The histogram's answer is the upper edge of a bucket 2^(1/8) (9 %) wide.
            edge = 2 ** 0.125
            for q, value in ((0.5, p50), (0.99, p99), (1.0, p100)):
                assert latencies.min() <= value <= latencies.max() * edge + 1, (q, value)
                exact = np.quantile(latencies, q, method="inverted_cdf")
                assert exact <= value * (1 + 1e-9) and value <= max(exact, 1.0) * edge + 1, (q, value, exact)
            assert p50 <= p99 <= p100
            assert rt.latency_percentile(1.5) == 0.0 and rt.latency_percentile(float("nan")) == 0.0


def test_offered_messages_open_and_feed_a_stream_as_a_socket_would(data, model_path):
    with kata.Context() as ctx, clip_of(ctx, data, "07_01.bvh") as clip, clip.skeleton() as sk:
        p = clip.all_positions(first=1)[:90]
        times = 10.0 + np.arange(len(p)) / 120.0
        with ctx.open_stream(sk, result_capacity=256) as direct:  # the same frames pushed directly
            direct.push_many(times, p)
            expected = direct.read_results(features=False)
        with ctx.create_runtime(workers=1) as rt, pytest.raises(kata.KataError) as e:
            rt.offer(kata.write_skeleton(21, sk, layout="cmu"))
        assert e.value.status == kata.Status.E_STATE  # no direct ingest
        with pytest.raises(kata.KataError) as e:
            ctx.create_runtime(workers=1, direct_ingest=True, ingest="tcp://127.0.0.1:1")
        assert e.value.status == kata.Status.E_INVALID_ARGUMENT
        with ctx.create_runtime(workers=1, direct_ingest=True, max_frame_age_seconds=0.0) as rt:
            rt.offer(kata.write_skeleton(21, sk, layout="cmu"))
            rt.offer(b"\0" * 32)  # taken, judged malformed by the ingest
            for i, frame in enumerate(p):
                rt.offer(kata.write_frame(21, i, float(times[i]), frame))
            rt.stop()
            with pytest.raises(kata.KataError) as e:
                rt.offer(kata.write_frame(21, len(p), 11.0, p[0]))
            assert e.value.status == kata.Status.E_QUEUE_FULL  # stop has begun
            with pytest.raises(TypeError):
                rt.offer("not bytes")  # type: ignore[arg-type]
            c = rt.counters()
    assert len(expected) > 60
    assert c["ingest_received"] == len(p) + 2 and c["ingest_dropped"] == 1
    assert c["frames_in"] == len(p) and c["results"] == len(expected)
