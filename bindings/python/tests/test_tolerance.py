"""The lesson's tolerance in Python (kata_teacher_desc.tolerance, 1.1): attach_teacher(tolerance=),
attach_shared_teacher and create_teacher. Checked against the documented part map evaluated here with
numpy: each part's angle recovered from the normal level's part score (100 / (1 + (a / 40)^5)),
mapped again with the level's a50 and slope (lenient 58, 5; a number: that angle, slope 5); the
matched frames are those of every level (the alignment does not read the map)."""
import os

import numpy as np
import pytest

import kata


def scores(ctx, model, teacher, student, shared=False, **options):
    p = student.all_positions(first=1)[:200]
    with student.skeleton() as sk, ctx.open_stream(sk, stencil=model.stencil, result_capacity=256) as s:
        if shared:
            with ctx.create_teacher(model, clip=teacher, first_frame=1, ghost=False, **options) as t:
                s.attach_shared_teacher(t)
        else:
            s.attach_teacher(model, clip=teacher, first_frame=1, ghost=False, **options)
        return s.push_and_read((1 + np.arange(len(p))) / 120.0, p).scores


def mapped(normal_part_scores, a50, slope):
    p = np.clip(normal_part_scores.astype(np.float64), 1e-6, 100.0)
    angle = 40.0 * np.maximum(100.0 / p - 1.0, 0.0) ** (1.0 / 5.0)
    return 100.0 / (1.0 + (angle / a50) ** slope)


def test_levels_and_degrees_follow_the_documented_map(data, model_path):
    with kata.Context() as ctx, ctx.load_model(model_path) as m, ctx.load_clip(os.path.join(data, "02_01.bvh")) as t, \
            ctx.load_clip(os.path.join(data, "07_01.bvh")) as s:
        base = scores(ctx, m, t, s)
        normal = scores(ctx, m, t, s, tolerance="normal")
        assert np.array_equal(base["score"], normal["score"])  # the default is normal
        for tolerance, a50, slope, shared in (("lenient", 58.0, 5.0, False), (33, 33.0, 5.0, False),
                                              ("lenient", 58.0, 5.0, True)):
            r = scores(ctx, m, t, s, shared=shared, tolerance=tolerance)
            assert np.array_equal(r["matched_teacher_frame"], base["matched_teacher_frame"])
            ok = base["part_scores"] > 1e-3  # an angle is recoverable from a score above float's floor
            want = mapped(base["part_scores"], a50, slope)
            assert np.abs(r["part_scores"][ok] - want[ok]).max() < 0.05, tolerance
        lenient = scores(ctx, m, t, s, tolerance="lenient")
        assert lenient["score"].mean() > base["score"].mean()


def test_a_bad_tolerance_is_refused_by_name(data, model_path):
    with kata.Context() as ctx, ctx.load_model(model_path) as m, ctx.load_clip(os.path.join(data, "02_01.bvh")) as t:
        with t.skeleton() as sk, ctx.open_stream(sk) as s:
            for bad in ("loose", "4", "121", ""):
                with pytest.raises(kata.KataError) as e:
                    s.attach_teacher(m, clip=t, first_frame=1, ghost=False, tolerance=bad)
                assert e.value.status == kata.Status.E_INVALID_ARGUMENT
                assert "tolerance" in str(e.value)
            with pytest.raises(TypeError):
                s.attach_teacher(m, clip=t, first_frame=1, ghost=False, tolerance=[40])
