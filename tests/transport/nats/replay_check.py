#!/usr/bin/python3
"""Runs a short `kata replay --transport nats --shards 2` (the same two kata serve shards over
ZeroMQ and over a 3-server NATS cluster the replay starts on loopback, then bare ZeroMQ) and checks
its report: every frame of every phase scored and received once (kata-replay itself exits non-zero
when the NATS path lost, repeated or refused anything), the per-hop split present for both paths,
CPU reported for every process (two shards each, three NATS servers), and the added figures equal
to the difference of the two paths' own. The latency target is not judged here (a loaded machine)."""
import json, os, subprocess, sys, tempfile

kata, source = sys.argv[1], sys.argv[2]
streams, seconds, rate = 6, 2, 60
with tempfile.TemporaryDirectory(prefix="kata_nats_replay_test_") as tmp:
    out = os.path.join(tmp, "report.json")
    subprocess.run([kata, "replay", "--transport", "nats", "--shards", "2", "--workers", "1", "--streams", str(streams),
                    "--seconds", str(seconds), "--rate", str(rate), "--data", os.path.join(source, "data", "cmu"),
                    "--model", os.path.join(source, "models", "default.kata"), "--out", out], check=True, timeout=180)
    r = json.load(open(out))
    for path in ("zmq", "nats"):
        k = r[path]
        assert k["sent"] == streams * seconds * rate, (path, k["sent"])
        assert k["received"] == k["sent"] and k["lost"] == 0 and k["streams_not_complete"] == 0, (path, k)
        lat = k["latency"]
        assert 0 < lat["p50_us"] <= lat["p99_us"] <= lat["max_us"], (path, lat)
        assert set(k["stages"]) == {"source_to_arrival", "arrival_to_computed", "computed_to_published",
                                    "published_to_received"}, (path, k["stages"])
        for stage in k["stages"].values():
            assert 0 <= stage["p50_us"] <= stage["p99_us"] <= lat["max_us"], (path, stage)
        cpu = k["cpu_percent_of_one_core_by_process"]
        shards = [v for name, v in cpu.items() if name.startswith("kata serve")]
        servers = [v for name, v in cpu.items() if name.startswith("nats-server")]
        assert len(shards) == 2 and sum(shards) > 0, (path, cpu)
        assert len(servers) == (3 if path == "nats" else 0), (path, cpu)
    assert r["nats"]["nats"]["stale_epoch"] == 0 and r["nats"]["nats"]["client_dropped"] == 0, r["nats"]["nats"]
    assert r["bare_zmq"]["lost"] == 0, r["bare_zmq"]
    for q in ("p50_us", "p99_us"):
        added = r["nats"]["latency"][q] - r["zmq"]["latency"][q]
        assert abs(r["nats_added_us"][q] - added) < 1e-6, (q, r["nats_added_us"], added)
print("nats replay report ok")
