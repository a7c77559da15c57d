#!/usr/bin/python3
"""Runs a short `kata replay` and checks its report: every frame of both phases received, the
per-stage split present and consistent (stage p50s no larger than the end-to-end max)."""
import json, os, subprocess, sys, tempfile

kata, source = sys.argv[1], sys.argv[2]
with tempfile.TemporaryDirectory(prefix="kata_replay_test_") as tmp:
    out = os.path.join(tmp, "report.json")
    for transport in ("tcp", "ipc"):
        subprocess.run([kata, "replay", "--streams", "3", "--seconds", "1", "--rate", "120", "--transport", transport,
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
print("replay report ok")
