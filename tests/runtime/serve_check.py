#!/usr/bin/python3
"""kata serve end to end over ipc: `kata send` plays a clip into it, samples/python_subscriber.py
and samples/c_subscriber.c print the scores, the csv-sink plugin writes them, SIGINT stops serve cleanly with every frame published. Also: a bad config is
refused with file:line. Unique paths per run; every wait bounded."""
import os, signal, subprocess, sys, tempfile, time

kata, source, python_dir, plugin_dir, c_subscriber = sys.argv[1:6]
sys.path.insert(0, os.path.join(source, "tests", "support"))
import accounting  # noqa: E402
with tempfile.TemporaryDirectory(prefix="kata_serve_test_") as tmp:
    bad = os.path.join(tmp, "bad.toml")
    open(bad, "w").write('[ingest]\nendpoints = ["bind:ipc://%s/a"]\n[publish]\nendpoints = ["ipc://%s/b"]\n'
                         '[runtime]\nworkers = "two"\n' % (tmp, tmp))
    r = subprocess.run([kata, "serve", "--config", bad], capture_output=True, text=True, timeout=30)
    assert r.returncode == 1 and (bad + ":6:") in r.stderr, r.stderr

    config = os.path.join(tmp, "serve.toml")
    open(config, "w").write(
        '[ingest]\nendpoints = ["bind:ipc://%s/in"]\nkind = "pull"\n[publish]\nendpoints = ["ipc://%s/out"]\n'
        '[scoring]\nmodel = "%s/models/default.kata"\nteacher = "%s/data/cmu/02_01.bvh"\n'
        '[[plugins]]\npath = "%s/csv-sink.so"\nconfig = "path=%s/scores.csv"\n'
        % (tmp, tmp, source, source, plugin_dir, tmp))
    counters = os.path.join(tmp, "counters.json")
    serve = subprocess.Popen([kata, "serve", "--config", config, "--counters", counters], stderr=subprocess.PIPE,
                             text=True)
    try:
        deadline = time.time() + 20
        while not os.path.exists(os.path.join(tmp, "out")) and time.time() < deadline:
            time.sleep(0.05)
        sub = subprocess.Popen(["/usr/bin/python3", os.path.join(source, "samples", "python_subscriber.py"),
                                "--endpoint", "ipc://%s/out" % tmp, "--stream", "7", "--count", "20",
                                "--timeout", "20", "--python-dir", python_dir], stdout=subprocess.PIPE, text=True)
        csub = subprocess.Popen([c_subscriber, "ipc://%s/out" % tmp, "7", "20"], stdout=subprocess.PIPE, text=True)
        time.sleep(0.5)  # the subscriber connects; the skeleton definition reaches it on its join
        subprocess.run([kata, "send", "--bvh", os.path.join(source, "data", "cmu", "07_01.bvh"), "--endpoint",
                        "ipc://%s/in" % tmp, "--stream-id", "7", "--frames", "120", "--speed", "2",
                        # definitions only for 3 s: both subscribers (a Python start takes over
                        # a second on a loaded machine) are connected before the first result
                        "--warmup", "3"],
                       check=True, timeout=60)
        out, _ = sub.communicate(timeout=60)
        assert sub.returncode == 0, out
        scores = [l for l in out.splitlines() if ": score " in l]
        assert len(scores) == 20, out
        assert "skeleton of 31 joints (layout cmu)" in out, out
        cout, _ = csub.communicate(timeout=60)
        assert csub.returncode == 0, cout
        cscores = [l for l in cout.splitlines() if ": score " in l]
        assert len(cscores) == 20 and cscores[0].startswith("stream 7 frame 0: score "), cout
        # Both subscribers read the same results: the same scores, printed to 0.1.
        assert [l.split(": score ")[1].split()[0] for l in scores] == \
               [l.split(": score ")[1].split()[0] for l in cscores], (out, cout)
        time.sleep(0.5)
    finally:
        serve.send_signal(signal.SIGINT)
        _, err = serve.communicate(timeout=30)
    assert serve.returncode == 0, err
    assert "stopped; 120 frames in, 120 results published, 0 ingest messages dropped" in err, err
    rows = open(os.path.join(tmp, "scores.csv")).read().splitlines()
    assert len(rows) == 121 and rows[0].startswith("stream_id,"), rows[:3]
    assert all(r.split(",")[7] == "1" for r in rows[1:]), "every row scored"
    # Every frame sent is a result the csv-sink received (it sees every result the runtime hands on).
    accounting.check({7: 120}, {7: len(rows) - 1}, accounting.load(counters), where="serve")
print("serve ok")
