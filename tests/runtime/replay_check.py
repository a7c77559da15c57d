#!/usr/bin/python3
"""Runs a short `kata replay` (in-process push over tcp and ipc, and --ingest: frames from a sender
process through Ingest, and that with CURVE on every socket) and checks its report: every frame of both phases received, the per-stage
split present and consistent (stage p50s no larger than the end-to-end max), the burst bound equal
to bare p99 + streams x push / workers from the same report."""
import json, os, subprocess, sys, tempfile

kata, source = sys.argv[1], sys.argv[2]
with tempfile.TemporaryDirectory(prefix="kata_replay_test_") as tmp:
    out = os.path.join(tmp, "report.json")
    for transport, extra in (("tcp", []), ("ipc", []), ("tcp", ["--ingest"]), ("tcp", ["--ingest", "--curve"])):
        subprocess.run([kata, "replay", "--streams", "3", "--seconds", "1", "--rate", "120", "--transport", transport] + extra + [
                        "--data", os.path.join(source, "data", "cmu"), "--model", os.path.join(source, "models", "default.kata"),
                        "--out", out], check=True, timeout=120)
        r = json.load(open(out))
        for side in ("kata", "bare_zmq"):
            assert r[side]["sent"] == 3 * 120, (side, r[side]["sent"])
            assert r[side]["received"] == r[side]["sent"] and r[side]["lost"] == 0, (transport, side, r[side])
            lat = r[side]["latency"]
            assert 0 < lat["p50_us"] <= lat["p99_us"] <= lat["p999_us"] <= lat["max_us"], lat
        assert r["kata"]["runtime_drops"] == 0
        for stage in r["kata"]["stages"].values():
            assert 0 <= stage["p50_us"] <= r["kata"]["latency"]["max_us"], stage
        assert abs(r["kata"]["mean_message_bytes"] - r["bare_zmq"]["mean_message_bytes"]) < 1.0
        stages = set(r["kata"]["stages"])
        assert ("source_to_arrival" in stages) == ("--ingest" in extra), stages  # send -> arrival: the ingest path only
        assert r["curve"] == ("--curve" in extra), r["curve"]  # CURVE keys on both sides, or nothing would arrive
        if "--ingest" in extra:
            assert r["kata"]["ingest_dropped"] == 0 and r["kata"]["path"].startswith("ingest"), r["kata"]["path"]
        assert r["push_us"] > 0
        bound = r["bare_zmq"]["latency"]["p99_us"] + 3 * r["push_us"] / r["workers"]
        assert abs(r["burst_bound_us"] - bound) < 1e-6 * bound, (r["burst_bound_us"], bound)
        assert abs(r["p99_ratio_kata_over_burst_bound"] - r["kata"]["latency"]["p99_us"] / bound) < 1e-6
print("replay report ok")
