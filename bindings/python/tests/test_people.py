"""kata.People (kata/people.h) from Python: streams kept through a crossing with the poses
shuffled, the prediction against the centroid numpy computes, refusals counted."""
import numpy as np
import pytest

import kata

J = 17  # COCO keypoints


def figure(x, phase):
    """A 1.7 m stick figure standing at x, every third joint swinging."""
    h = np.linspace(0.0, 1.7, J)
    swing = np.where(np.arange(J) % 3 == 1, 0.2 * np.sin(phase + np.arange(J)), 0.0)
    return np.stack([x + swing, h, np.zeros(J)], axis=1).astype(np.float32)


def test_two_people_keep_their_streams_through_a_crossing_in_shuffled_order():
    rng = np.random.default_rng(3)
    with kata.Context() as ctx, kata.People(ctx, joint_count=J, max_people=4) as people:
        own = {}
        for k in range(150):
            t = k / 30.0
            xs = {0: -2.0 + 0.8 * t, 1: 2.0 - 0.8 * t}
            visible = [0] if abs(xs[0] - xs[1]) < 0.32 else [0, 1]  # 1 hidden 0.8 s
            order = rng.permutation(visible)
            poses = np.stack([figure(xs[a], 3 * t + a) for a in order])
            ids = people.track(t, poses, np.full((len(order), J), 0.9))
            for a, i in zip(order, ids):
                assert i != 0
                assert own.setdefault(int(a), int(i)) == i, "frame %d: person %d changed stream" % (k, a)
            if k == 0:
                assert sorted(people.opened_streams) == sorted(own.values())
        assert len(set(own.values())) == 2
        c = people.counters()
        assert c["opened"] == 2 and c["poses"] == c["assigned"] and c["open_streams"] == 2
        assert sorted(people.streams) == sorted(own.values())
        people.track(5.0 + 3.1, np.zeros((0, J, 3)))  # nobody for longer than forget_seconds (3)
        assert sorted(people.closed_streams) == sorted(own.values()) and people.streams == []


def test_the_prediction_is_the_centroid_of_the_confident_joints():
    with kata.Context() as ctx, kata.People(ctx, joint_count=J) as people:
        pose = figure(0.5, 1.0)
        conf = np.full(J, 0.9, np.float32)
        conf[[2, 5]] = 0.1  # below min_confidence (0.3): not part of the centroid
        pose[2] = np.nan    # and may be anything
        (i,) = people.track(10.0, pose[None], conf[None])
        expected = np.mean(pose[conf >= 0.3], axis=0)
        np.testing.assert_allclose(people.predicted(i, 10.0), expected, rtol=1e-6, atol=1e-6)
        # One step later, moved by d: the prediction a second on is the new centroid + velocity x 1 s.
        d = np.array([0.05, 0.0, 0.0], np.float32)
        people.track(10.1, (pose + d)[None], conf[None])
        np.testing.assert_allclose(people.predicted(i, 11.1), expected + d + d / 0.1 * 1.0, rtol=1e-5, atol=1e-5)
        with pytest.raises(kata.KataError) as e:
            people.predicted(12345, 11.0)
        assert e.value.status == kata.Status.E_NOT_FOUND


def test_bad_input_is_refused_and_counted():
    with kata.Context() as ctx, kata.People(ctx, joint_count=J, max_poses=2) as people:
        good = figure(0.0, 0.0)
        nan = figure(2.0, 0.0)
        nan[4, 1] = np.nan
        ids = people.track(1.0, np.stack([good, nan, figure(4.0, 0.0), figure(-4.0, 0.0)]))
        assert ids[0] != 0 and ids[1] == 0 and (ids != 0).sum() == 3 - 1  # 3 valid, max_poses 2
        assert len(people.track(1.1, np.zeros((0, J, 3)))) == 0  # an empty frame
        with pytest.raises(kata.KataError) as e:
            people.track(1.1, good[None])
        assert e.value.status == kata.Status.E_TIMESTAMP_NOT_INCREASING
        c = people.counters()
        assert (c["frames"], c["empty_frames"], c["refused_frames"]) == (2, 1, 1)
        assert (c["refused_non_finite"], c["refused_too_many_poses"], c["assigned"]) == (1, 1, 2)
        with pytest.raises(TypeError):
            kata.People(ctx, joint_count=J, no_such_option=1)
        with pytest.raises(kata.KataError) as e:
            kata.People(ctx, joint_count=J, max_people=0)
        assert "max_people" in e.value.message


def fnv1a64(*values):
    h = 14695981039346656037
    for v in values:
        for b in int(v).to_bytes(8, "little"):
            h = ((h ^ b) * 1099511628211) % (1 << 64)
    return h - 2 if h >= (1 << 64) - 2 else h


def test_people_stream_id_is_the_documented_hash():
    for group, person in [(500, 1), (500, 2), (0, 1), ((1 << 64) - 3, 7), (123456789, 4000000000)]:
        assert kata.people_stream_id(group, person) == fnv1a64(group, person)
    assert kata.people_stream_id(500, 1) != kata.people_stream_id(500, 2)


def test_write_people_frame_carries_the_poses_as_given():
    fb = pytest.importorskip("kata.fb.PeopleFrame")
    poses = np.stack([figure(0.5, 0.0), figure(-1.0, 1.0)])
    conf = np.full((2, J), 0.8, np.float32)
    poses[1, 3, 0] = np.nan  # written as given: the receiving tracker refuses it
    msg = kata.write_people_frame(77, 5, 12.5, poses, conf)
    assert msg[:16] == b"%016x" % 77
    f = fb.PeopleFrame.GetRootAs(msg[16:], 0)
    assert (f.StreamId(), f.Sequence(), f.CaptureTime().Nanoseconds()) == (77, 5, 12_500_000_000)
    assert (f.JointCount(), f.PoseCount(), f.PositionsLength(), f.ConfidenceLength()) == (J, 2, 2 * J, 2 * J)
    got = np.array([[f.Positions(i).X(), f.Positions(i).Y(), f.Positions(i).Z()] for i in range(2 * J)], np.float32)
    np.testing.assert_array_equal(got, poses.reshape(-1, 3))
    assert len(kata.write_people_frame(77, 6, 12.6, np.zeros((0, J, 3)))) > 16  # nobody in the picture
    with pytest.raises(kata.KataError) as e:
        kata.write_people_frame(77, 7, float("nan"), poses)
    assert e.value.status == kata.Status.E_NON_FINITE


def test_a_runtime_counts_its_people_frames_by_cause():
    """kata_runtime_counters' people_* (Runtime.counters()): a group stream's people frames through
    a runtime, with more people than the group's table holds (8), a NaN pose and an empty frame."""
    n = 33  # the group is a MediaPipe skeleton

    def person(i, k):
        h = np.linspace(0.0, 1.7, n)
        return np.stack([3.0 * i + 0.01 * k + 0.1 * np.sin(np.arange(n)), h, np.zeros(n)], axis=1).astype(np.float32)

    nan_pose = person(0, 2)
    nan_pose[5, 1] = np.nan
    frames = [np.stack([person(i, 0) for i in range(2)]),
              np.stack([person(i, 1) for i in range(10)]),  # 6 new people fill the 8, 2 more are refused
              np.stack([person(i, 2) for i in range(8)] + [nan_pose]),
              np.zeros((0, n, 3), np.float32)]
    with kata.Context() as ctx, ctx.create_layout("mediapipe") as mp, \
            ctx.create_runtime(workers=1, direct_ingest=True, max_frame_age_seconds=0.0) as rt:
        rt.offer(kata.write_skeleton(40, mp, layout="mediapipe"))
        for k, poses in enumerate(frames):
            rt.offer(kata.write_people_frame(40, k, 5.0 + k / 30.0, poses))
        rt.stop()
        c = rt.counters()
    sent = sum(len(p) for p in frames)
    assert (c["people_frames"], c["people_empty_frames"], c["people_refused_frames"]) == (4, 1, 0)
    assert c["people_poses"] == sent == 21
    assert c["people_refused_table_full"] == 2 and c["people_refused_non_finite"] == 1
    assert c["people_refused_out_of_range"] == c["people_refused_few_joints"] == c["people_refused_too_many_poses"] == 0
    assert c["people_poses_tracked"] == sent - 3 == c["frames_in"]
    assert c["people_streams_opened"] == 8 and c["people_streams_closed"] == c["people_streams_refused"] == 0
    assert c["people_poses_unopened"] == 0 and c["streams"] == 1 + 8
