"""The ingest message writers (kata_message_write_*, since 1.1) from Python: the messages read back
with the schema's own readers (kata.fb, flatc's) to the values written, refusals as KataError, and
a runtime's ingest fed by nothing but written messages."""
import os
import tempfile
import time

import numpy as np
import pytest

import kata


def test_written_messages_read_back_with_the_schema_readers(data):
    from kata.fb.Frame import Frame
    from kata.fb.Practice import Practice
    from kata.fb.SkeletonDefinition import SkeletonDefinition
    with kata.Context() as ctx, ctx.load_clip(os.path.join(data, "07_01.bvh")) as clip, clip.skeleton() as sk:
        m = kata.write_skeleton(0x2a, sk, layout="cmu", frame_rate=120.0)
        assert m[:16] == b"%016x" % 0x2a and m[20:24] == b"KSKL"
        d = SkeletonDefinition.GetRootAs(m[16:], 0)
        assert (d.StreamId(), d.Revision(), d.Layout(), d.FrameRate(), d.Closed()) == (0x2a, 1, b"cmu", 120.0, False)
        assert [d.JointNames(i).decode() for i in range(d.JointNamesLength())] == sk.names
        assert [d.Parents(i) for i in range(d.ParentsLength())] == list(sk.parents)
        assert kata.read_message(m) is None  # a valid kata message, not a result

        p = clip.all_positions(first=1)[0]
        conf = np.linspace(0, 1, sk.joint_count, dtype=np.float32)
        m = kata.write_frame(0x2a, 7, 1.25, p, conf)
        f = Frame.GetRootAs(m[16:], 0)
        assert (f.StreamId(), f.Sequence(), f.CaptureTime().Nanoseconds()) == (0x2a, 7, 1250000000)
        xyz = np.array([[f.Positions(i).X(), f.Positions(i).Y(), f.Positions(i).Z()] for i in range(f.PositionsLength())],
                       dtype=np.float32)
        np.testing.assert_array_equal(xyz, p)
        np.testing.assert_array_equal(f.ConfidenceAsNumpy(), conf)
        assert f.PresenceIsNone()
        presence = conf[::-1].copy()
        f = Frame.GetRootAs(kata.write_frame(0x2a, 8, 1.5, p, conf, presences=presence)[16:], 0)
        np.testing.assert_array_equal(f.ConfidenceAsNumpy(), conf)
        np.testing.assert_array_equal(f.PresenceAsNumpy(), presence)
        with pytest.raises(ValueError):
            kata.write_frame(0x2a, 9, 1.6, p, conf, presences=presence[:-1])

    m = kata.write_practice(0x2a, revision=2, loop=(1.0, 2.5))
    q = Practice.GetRootAs(m[16:], 0)
    assert (q.StreamId(), q.Revision(), q.Loop(), q.LoopStart(), q.LoopEnd(), q.TeacherStart()) == (0x2a, 2, True, 1.0, 2.5, 0.0)


def test_refusals_raise_with_the_reason():
    p = np.zeros((3, 3), np.float32)
    p[1, 2] = np.nan
    with pytest.raises(kata.KataError) as e:
        kata.write_frame(1, 0, 0.0, p)
    assert e.value.status == kata.Status.E_NON_FINITE and "joint 1" in e.value.message
    with pytest.raises(kata.KataError) as e:
        kata.write_practice(1, loop=(2.0, 1.0))
    assert e.value.status == kata.Status.E_INVALID_ARGUMENT and "loop_end" in e.value.message
    with kata.Context() as ctx, ctx.create_layout("gpd") as sk:
        with pytest.raises(kata.KataError) as e:
            kata.write_skeleton(1, sk)  # neither a layout nor a name map
        assert e.value.status == kata.Status.E_INVALID_ARGUMENT
        with pytest.raises(kata.KataError) as e:
            kata.write_skeleton(1, sk, layout="gpd", up_axis=kata.UpAxis.Y_DOWN)
        assert e.value.status == kata.Status.E_INVALID_ARGUMENT
        assert kata.write_skeleton(1, sk, name_map=sk.names)[20:24] == b"KSKL"


def test_a_runtime_ingest_scores_written_messages(data):
    zmq = pytest.importorskip("zmq")
    with tempfile.TemporaryDirectory() as tmp, kata.Context() as ctx, \
            ctx.load_clip(os.path.join(data, "07_01.bvh")) as clip, clip.skeleton() as sk:
        frames = clip.all_positions(first=1)[:60]
        endpoint = "ipc://%s/in" % tmp
        with ctx.create_runtime(ingest="bind:" + endpoint, ingest_pull=True) as rt:
            push = zmq.Context.instance().socket(zmq.PUSH)
            push.setsockopt(zmq.LINGER, 1000)
            push.connect(endpoint)
            try:
                push.send(kata.write_skeleton(5, sk, layout="cmu", frame_rate=1.0 / clip.frame_time))
                for i, p in enumerate(frames):
                    push.send(kata.write_frame(5, i, i * clip.frame_time, p))
                deadline = time.time() + 20
                while rt.counters()["frames_in"] < len(frames) and time.time() < deadline:
                    time.sleep(0.05)
            finally:
                push.close()
            rt.stop()
            c = rt.counters()
    assert c["ingest_dropped"] == 0, c
    assert c["frames_in"] == len(frames) and c["refused"] == 0 and c["results"] > 0, c
