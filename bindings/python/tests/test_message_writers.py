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


def test_a_frame_batch_carries_each_frame_as_write_frame_writes_it(data):
    """kata.write_frame_batch (since 1.1): read back with the schema's FrameBatch reader, every
    frame's table equal field by field to write_frame's for the same values; a refused frame named
    by its index; a runtime's ingest fed by batches scores every frame of two streams."""
    from kata.fb.Frame import Frame
    from kata.fb.FrameBatch import FrameBatch

    def fields(f):
        xyz = [(f.Positions(i).X(), f.Positions(i).Y(), f.Positions(i).Z()) for i in range(f.PositionsLength())]
        return (f.StreamId(), f.Sequence(), f.CaptureTime().Nanoseconds(), f.Checksum(), xyz,
                None if f.ConfidenceIsNone() else f.ConfidenceAsNumpy().tolist(),
                None if f.PresenceIsNone() else f.PresenceAsNumpy().tolist())

    with kata.Context() as ctx, ctx.load_clip(os.path.join(data, "07_01.bvh")) as clip, clip.skeleton() as sk:
        p = clip.all_positions(first=1)[:2]
        conf = np.linspace(0, 1, sk.joint_count, dtype=np.float32)
        frames = [(7, 3, 0.5, p[0]), (9, 4, 0.5, p[1], conf), (7, 4, 0.51, p[1], conf, conf[::-1].copy())]
        m = kata.write_frame_batch(frames)
        assert m[:16] == b"%016x" % (2**64 - 2) and m[20:24] == b"KFRB"
        b = FrameBatch.GetRootAs(m[16:], 0)
        assert b.FramesLength() == len(frames)
        for i, f in enumerate(frames):
            alone = Frame.GetRootAs(kata.write_frame(*f)[16:], 0)
            assert fields(b.Frames(i)) == fields(alone), i

        bad = p[1].copy()
        bad[2, 0] = np.inf
        with pytest.raises(kata.KataError) as e:
            kata.write_frame_batch([(7, 5, 0.6, p[0]), (9, 5, 0.6, bad)])
        assert e.value.status == kata.Status.E_NON_FINITE and "1" in e.value.message, e.value.message
        with pytest.raises(ValueError):
            kata.write_frame_batch([])

        zmq = pytest.importorskip("zmq")
        positions = clip.all_positions(first=1)[:40]
        with tempfile.TemporaryDirectory() as tmp:
            endpoint = "ipc://%s/in" % tmp
            with ctx.create_runtime(ingest="bind:" + endpoint, ingest_pull=True) as rt:
                push = zmq.Context.instance().socket(zmq.PUSH)
                push.setsockopt(zmq.LINGER, 1000)
                push.connect(endpoint)
                try:
                    for s in (11, 12):
                        push.send(kata.write_skeleton(s, sk, layout="cmu", frame_rate=1.0 / clip.frame_time))
                    for i, q in enumerate(positions):  # one message a tick, both streams in it
                        push.send(kata.write_frame_batch([(11, i, i * clip.frame_time, q),
                                                          (12, i, i * clip.frame_time, q)]))
                    deadline = time.time() + 20
                    while rt.counters()["frames_in"] < 2 * len(positions) and time.time() < deadline:
                        time.sleep(0.05)
                finally:
                    push.close()
                rt.stop()
                c = rt.counters()
        assert c["ingest_dropped"] == 0, c
        assert c["frames_in"] == 2 * len(positions) and c["refused"] == 0 and c["results"] > 0, c
