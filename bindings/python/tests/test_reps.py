"""Repetitions through the binding (kata_stream_read_repetitions, the record's repetition fields,
kata_message_read/write_repetition): a walk played twice against itself, looped, is one
repetition per play, each at the teacher's tempo, the last ended by the stream's flush."""
import os

import numpy as np
import pytest

import kata


def test_a_clip_played_twice_against_itself_is_two_repetitions(data, model_path):
    with kata.Context() as ctx, ctx.load_model(model_path) as model, \
            ctx.load_clip(os.path.join(data, "02_01.bvh")) as clip, clip.skeleton() as sk, \
            ctx.open_stream(sk, result_capacity=1024) as s:
        s.attach_teacher(model, clip=clip, first_frame=1, ghost=False)
        s.set_practice_section(0, -1, loop=True)
        p = clip.all_positions(first=1)
        n = len(p)
        both = np.concatenate([p, p])
        t = np.arange(len(both)) * clip.frame_time
        reps, progress, index = [], [], []
        for k in range(0, len(both), 64):
            s.push_many(t[k:k + 64], both[k:k + 64])
            r = s.read_results()
            index += list(r.results["repetition"])
            progress += list(r.results["repetition_progress"])
            reps += s.read_repetitions()
        s.flush()
        reps += s.read_repetitions()
        done = [r for r in reps if not r.partial]
        # The first play ends where the second begins (the wrap); the second with the take (the
        # flush: the end of the stream's clip).
        assert len(done) == 2, reps
        assert done[1].index == 2
        assert done[1].end_time == pytest.approx(2 * n * clip.frame_time, abs=0.05)
        assert done[1].tempo == pytest.approx(1.0, abs=0.05)
        first = done[0]
        assert first.index == 1 and first.stream_id == 0
        assert first.start_time == pytest.approx(0.0, abs=0.05)
        assert first.end_time == pytest.approx(n * clip.frame_time, abs=0.05)
        assert first.tempo == pytest.approx(1.0, abs=0.05)
        assert set(first.range) == set(kata.ROM_JOINTS)
        assert first.range["left_knee"] == pytest.approx(first.teacher_range["left_knee"], abs=3.0)
        assert first.score > 50
        # The records: repetition 1 through the first play, 2 after the wrap; progress 0..1.
        index, progress = np.array(index), np.array(progress)
        assert index[0] == 1 and index[-1] == 2
        assert np.all(np.diff(index) >= 0)
        assert progress.min() >= 0.0 and progress.max() <= 1.0 and progress.max() > 0.9


def test_a_repetition_message_round_trips():
    data = kata.write_repetition(7, 3, 1.5, 2.75, 1.04, 72.5, partial=False, part_to_fix=kata.BodyPart.LEFT_LEG,
                                 cue_joint=11, cue_degrees=31.0, cue_action=kata.CueAction.BEND,
                                 range=[60, 58, 40, 41, 20, 22, 30, 31], teacher_range=[65, 64, 42, 43, 21, 23, 30, 32],
                                 coverage=0.95)
    r = kata.read_repetition(data)
    assert (r.stream_id, r.index, r.partial) == (7, 3, False)
    assert (r.start_time, r.end_time, r.tempo) == (1.5, 2.75, pytest.approx(1.04))
    assert r.score == pytest.approx(72.5) and r.part_to_fix == kata.BodyPart.LEFT_LEG
    assert r.cue_joint == "LKnee" and r.cue.startswith("left knee: bend 31")
    assert r.range["left_knee"] == 60 and r.teacher_range["right_shoulder"] == 32
    assert r.coverage == pytest.approx(0.95)
    # Not a result; and a result message is not a repetition.
    assert kata.read_message(data) is None
    with pytest.raises(kata.KataError):
        kata.read_repetition(data[:20])
    with pytest.raises(kata.KataError):
        kata.write_repetition(7, 1, float("nan"), 1.0, 1.0, 50.0)
