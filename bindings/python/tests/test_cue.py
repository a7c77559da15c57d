"""The correction cue on the Python surfaces, against values computed
independently: `kata score`'s CSV columns cue_joint, cue_degrees and cue for the same pair, and the
C record's own fields."""
import csv
import ctypes
import os
import subprocess

import numpy as np

import kata


def test_the_cue_equals_the_cli_csv(cli, data, model_path, tmp_path):
    teacher, student = os.path.join(data, "02_01.bvh"), os.path.join(data, "07_01.bvh")
    out = tmp_path / "scores.csv"
    subprocess.run([cli, "score", "--model", model_path, "--teacher", teacher, "--student", student, "--preset",
                    "cmu", "--first-frame", "1", "--out", str(out)], check=True, capture_output=True)
    with open(out, newline="") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0].keys())[-3:] == ["cue_joint", "cue_degrees", "cue"]
    with kata.Context() as ctx, ctx.load_model(model_path) as model, ctx.load_clip(teacher) as tclip, \
            ctx.load_clip(student) as sclip, sclip.skeleton() as sk:
        positions = sclip.all_positions(1)
        with ctx.open_stream(sk, layout="cmu", stencil=model.stencil, result_capacity=len(positions)) as s:
            s.attach_teacher(model, clip=tclip, first_frame=1, ghost=False)
            s.push_many(np.arange(len(positions)) * sclip.frame_time, positions)
            r = s.read_results()
    assert len(r) == len(rows)
    cued = 0
    for row, res in zip(rows, r.results):
        name = kata.gpd_joint_name(res["cue_joint"]) if res["cue_joint"] >= 0 else ""
        assert row["cue_joint"] == name
        assert (res["cue_joint"] >= 0) == (res["part_to_fix"] >= 0)
        text = kata.cue_text(res)
        assert row["cue"] == text
        if name:
            cued += 1
            assert row["cue_degrees"] == "%.2f" % res["cue_degrees"]
            assert kata.CueAction(res["cue_action"]).name.lower() in text
        else:
            assert row["cue_degrees"] == "" and res["cue_action"] == -1 and text == ""
    assert cued > len(rows) // 2


def test_score_record_and_result_message_carry_the_cue():
    rec = kata._native.ResultRecord()
    rec.struct_size = ctypes.sizeof(rec)
    rec.part_to_fix, rec.cue_joint, rec.cue_degrees, rec.cue_action = 3, 11, 29.6, int(kata.CueAction.BEND)
    for obj in (kata.ScoreRecord(rec), kata.ResultMessage(rec)):
        assert obj.cue_joint == "LKnee"
        assert abs(obj.cue_degrees - 29.6) < 1e-5
        assert obj.cue_action == kata.CueAction.BEND
        assert obj.cue == "left knee: bend 30 deg more"
    rec.part_to_fix, rec.cue_joint, rec.cue_degrees, rec.cue_action = -1, -1, 0.0, -1
    for obj in (kata.ScoreRecord(rec), kata.ResultMessage(rec)):
        assert (obj.cue_joint, obj.cue_degrees, obj.cue_action, obj.cue) == ("", 0.0, -1, "")
    assert kata.gpd_joint_name(16) == ""
