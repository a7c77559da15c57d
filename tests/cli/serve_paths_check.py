#!/usr/bin/python3
"""kata serve run from a directory that is not the checkout: a config naming the shipped model and
clip by their relative names ("models/default.kata") and a plugin by its bare name ("csv-sink")
starts and scores; a missing model, teacher or plugin is refused with the config file, the key's
line and where it looked. Unique paths per run; every wait bounded."""
import os, signal, subprocess, sys, tempfile, time

kata = sys.argv[1]
CONFIG = ('[ingest]\nendpoints = ["bind:ipc://{d}/in"]\nkind = "pull"\n[publish]\nendpoints = ["ipc://{d}/out"]\n'
          '[scoring]\nmodel = "{model}"\nteacher = "{teacher}"\n'
          '[[plugins]]\npath = "{plugin}"\nconfig = "path={d}/scores.csv"\n')
GOOD = dict(model="models/default.kata", teacher="data/cmu/05_18.bvh", plugin="csv-sink")

with tempfile.TemporaryDirectory(prefix="kata_serve_paths_") as d:
    def write(name, **over):
        path = os.path.join(d, name)
        open(path, "w").write(CONFIG.format(d=d, **dict(GOOD, **over)))
        return path

    # Each missing file: exit 1, "FILE:LINE: what" on stderr, naming the path it could not find.
    for key, line, value in (("model", 7, "models/nope.kata"), ("teacher", 8, "data/cmu/nope.bvh"),
                             ("plugin", 10, "no-such-sink")):
        bad = write("bad_%s.toml" % key, **{key: value})
        r = subprocess.run([kata, "serve", "--config", bad], capture_output=True, text=True, timeout=30, cwd=d)
        assert r.returncode == 1, (key, r.returncode, r.stderr)
        assert ("%s:%d:" % (bad, line)) in r.stderr and value in r.stderr, (key, r.stderr)

    # An endpoint without a transport, and a key with a typo: FILE:LINE, the key, what to write.
    bad = os.path.join(d, "bad_endpoint.toml")
    open(bad, "w").write('[ingest]\nendpoints = ["bind:ipc://%s/in"]\n[publish]\nendpoints = [\n  "127.0.0.1:5556"]\n' % d)
    r = subprocess.run([kata, "serve", "--config", bad], capture_output=True, text=True, timeout=30, cwd=d)
    assert r.returncode == 1 and (bad + ":5: [publish] endpoints: '127.0.0.1:5556' has no ZeroMQ transport") in r.stderr, r.stderr
    bad = os.path.join(d, "bad_key.toml")
    open(bad, "w").write('[ingest]\nendpoints = ["bind:ipc://%s/in"]\nknd = "pull"\n' % d)
    r = subprocess.run([kata, "serve", "--config", bad], capture_output=True, text=True, timeout=30, cwd=d)
    assert r.returncode == 1 and (bad + ":3: unknown key 'knd' in [ingest]; did you mean 'kind'?") in r.stderr, r.stderr

    # The shipped files by name, from an empty working directory: kata send's frames are scored and
    # the csv-sink plugin (found by name) writes them.
    good = write("stage.toml")
    serve = subprocess.Popen([kata, "serve", "--config", good], cwd=d, stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.time() + 20
        while not os.path.exists(os.path.join(d, "in")) and time.time() < deadline:
            assert serve.poll() is None, serve.communicate()
            time.sleep(0.05)
        clip = os.path.join(os.path.dirname(os.path.abspath(kata)), "..", "share", "kata", "data", "cmu", "05_18.bvh")
        subprocess.run([kata, "send", "--bvh", clip, "--endpoint", "ipc://%s/in" % d, "--stream-id", "3",
                        "--frames", "60", "--speed", "4"], check=True, timeout=60, cwd=d, capture_output=True)
        time.sleep(1.0)  # the last frames are scored; SIGINT then stops serve with every frame published
    finally:
        serve.send_signal(signal.SIGINT)
        out, err = serve.communicate(timeout=30)
    assert serve.returncode == 0, (serve.returncode, err)
    rows = open(os.path.join(d, "scores.csv")).read().splitlines()[1:]
    assert len(rows) == 60, (len(rows), out, err)
print("ok")
