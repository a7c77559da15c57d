"""The 1.1 seams kata serve needs, in Python: a Teacher built once (Context.create_teacher) and
shared by streams (Stream.attach_shared_teacher), and create_runtime(on_stream_open=...). The
expected values come from the per-stream call: a stream given the shared teacher scores exactly as
one given the same clip by attach_teacher; the runtime scores a stream the hook set up as many
times as a stream set up the existing way computes results, and counts the stream it refused."""
import os

import numpy as np
import pytest

import kata


def test_a_shared_teacher_scores_as_attach_teacher_does_and_outlives_its_handle(data, model_path):
    with kata.Context() as ctx, ctx.load_model(model_path) as m, \
            ctx.load_clip(os.path.join(data, "02_01.bvh")) as teacher_clip, \
            ctx.load_clip(os.path.join(data, "02_02.bvh")) as student:
        p = student.all_positions(first=1)[:200]
        times = (1 + np.arange(len(p))) / 120.0
        t = ctx.create_teacher(m, clip=teacher_clip, first_frame=1)
        assert t.frame_count == teacher_clip.frame_count - 1
        assert t.frame_time == teacher_clip.frame_time
        # at least the joint positions: frames x joints x 3 float32
        with teacher_clip.skeleton() as tsk:
            assert t.memory_bytes >= t.frame_count * tsk.joint_count * 3 * 4
        with student.skeleton() as sk, ctx.open_stream(sk, stencil=m.stencil, result_capacity=256) as own, \
                ctx.open_stream(sk, stencil=m.stencil, result_capacity=256) as shared, \
                ctx.open_stream(sk, stencil=m.stencil, result_capacity=256) as scores_only:
            own.attach_teacher(m, clip=teacher_clip, first_frame=1)
            shared.attach_shared_teacher(t)
            scores_only.attach_shared_teacher(t, ghost=False)
            t.close()  # the streams keep the teacher
            a = own.push_and_read(times, p)
            b = shared.push_and_read(times, p)
            c = scores_only.push_and_read(times, p)
            assert scores_only.ghost_joint_count == 0 and shared.ghost_joint_count == own.ghost_joint_count > 0
        assert len(a) > 150 and (a.scores["scored"] == 1).all()
        for field in ("matched_teacher_frame", "distance", "score", "parts", "part_scores", "part_to_fix"):
            assert np.array_equal(a.scores[field], b.scores[field]), field
            assert np.array_equal(a.scores[field], c.scores[field]), field
        assert np.array_equal(a.ghosts, b.ghosts)
        with pytest.raises(kata.KataError) as e:
            ctx.create_teacher(m)  # no motion
        assert e.value.status == kata.Status.E_INVALID_ARGUMENT


def test_on_stream_open_attaches_the_teacher_and_a_refusal_is_counted(data, model_path):
    with kata.Context() as ctx, ctx.load_model(model_path) as m, \
            ctx.load_clip(os.path.join(data, "02_01.bvh")) as teacher_clip, \
            ctx.load_clip(os.path.join(data, "07_01.bvh")) as student, student.skeleton() as sk:
        joints = sk.joint_count
        p = student.all_positions(first=1)[:120]
        times = 10.0 + np.arange(len(p)) / 128.0
        with ctx.open_stream(sk, stencil=m.stencil, result_capacity=256) as direct:
            direct.attach_teacher(m, clip=teacher_clip, first_frame=1)
            expected = direct.push_and_read(times, p)
        t = ctx.create_teacher(m, clip=teacher_clip, first_frame=1)
        seen = []

        def on_open(info, stream):
            seen.append(info)
            if info["stream_id"] == 22:
                return False
            if info["stream_id"] == 23:
                raise RuntimeError("a hook that fails refuses its stream")
            stream.attach_shared_teacher(t)
            return True
        with ctx.create_runtime(workers=1, direct_ingest=True, max_frame_age_seconds=0.0, on_stream_open=on_open,
                                stream_stencil=m.stencil) as rt:
            for sid in (21, 22, 23):
                rt.offer(kata.write_skeleton(sid, sk, layout="cmu"))
            for i, frame in enumerate(p):
                for sid in (21, 22, 23):
                    rt.offer(kata.write_frame(sid, i, float(times[i]), frame))
            rt.stop()
            c = rt.counters()
        t.close()
    assert [s["stream_id"] for s in seen] == [21, 22, 23]
    assert all(s["joint_count"] == joints and s["layout"] == "cmu" and s["has_rest_pose"] for s in seen)
    assert c["streams_refused_by_app"] == 2
    assert c["frames_in"] == len(p)  # stream 21's only
    # The 1.1 counters by cause: three definitions handed on, two refused by the hook; the other
    # streams' frames dropped as an unknown stream's; every message has one outcome.
    assert c["ingest_skeletons"] == 1 and c["ingest_refused_skeletons"] == 2
    assert c["ingest_frames"] == len(p) and c["ingest_unknown_stream"] == 2 * len(p)
    assert c["ingest_received"] == 3 + 3 * len(p) == (c["ingest_frames"] + c["ingest_skeletons"]
                                                     + c["ingest_dropped"])
    assert len(expected) > 90 and c["results"] == len(expected)
