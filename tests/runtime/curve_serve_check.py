#!/usr/bin/python3
"""kata serve with CURVE keys end to end (docs/deploy.md, "A stage with keys"): `kata keygen` makes
the server's and two clients' keys, the config names them; `kata send` with a known key gets its
stream in and samples/python_subscriber.py with a known key reads every result; a sender and a
subscriber without keys get nothing; a config binding beyond this host without keys is refused
(and only warned with insecure = true); kata proxy binds this host by default. Unique paths and
free ports per run; every wait bounded."""
import os, shutil, signal, subprocess, sys, tempfile, time

kata, source, python_dir = sys.argv[1:4]
subscriber = os.path.join(source, "samples", "python_subscriber.py")
clip = os.path.join(source, "data", "cmu", "07_01.bvh")


sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from ports import free_port  # noqa: E402  below the ephemeral range (tests/support/ports.py)


with tempfile.TemporaryDirectory(prefix="kata_curve_test_") as tmp:
    keys = os.path.join(tmp, "keys")
    # The documented step: one key pair for the server, one per client (the .pub files in clients/
    # are the allow-list; each client takes its .secret and the server's .pub).
    for name in ("server", "clients/stage", "clients/viewer"):
        r = subprocess.run([kata, "keygen", "--out", os.path.join(keys, name)], capture_output=True, text=True, timeout=30)
        assert r.returncode == 0, r.stderr
    r = subprocess.run([kata, "keygen", "--out", os.path.join(keys, "server")], capture_output=True, text=True, timeout=30)
    assert r.returncode != 0 and "exists" in r.stderr, "keygen must not overwrite a key"
    assert oct(os.stat(os.path.join(keys, "server.secret")).st_mode & 0o777) == "0o600"
    subprocess.run([kata, "keygen", "--out", os.path.join(tmp, "stranger")], check=True, capture_output=True, timeout=30)

    # A key file kata keygen wrote, its secret cut short: refused with the config's line and key and
    # the key file's line and reason (kata_key_file_read, the reader kata_runtime_create uses).
    lines = open(os.path.join(keys, "server.secret")).read().split("\n")
    secret_line = next(i for i, l in enumerate(lines) if l.startswith("secret = "))
    lines[secret_line] = lines[secret_line][:-2] + '"'
    bad_secret = os.path.join(tmp, "bad.secret")
    open(bad_secret, "w").write("\n".join(lines))
    bad_config = os.path.join(tmp, "bad.toml")
    open(bad_config, "w").write('[ingest]\nendpoints = ["bind:tcp://127.0.0.1:%d"]\nkind = "pull"\n[publish]\n'
                                'endpoints = ["tcp://127.0.0.1:%d"]\n[security]\nkey = "%s"\n' % (free_port(), free_port(), bad_secret))
    r = subprocess.run([kata, "serve", "--config", bad_config], capture_output=True, text=True, timeout=30)
    expected = "%s:7: 'key': %s:%d: 'secret' is not a CURVE key (40 Z85 characters)" % (bad_config, bad_secret, secret_line + 1)
    assert r.returncode == 1 and expected in r.stderr, (expected, r.stderr)

    # Beyond this host without keys: refused, or warned with insecure = true.
    open_config = os.path.join(tmp, "open.toml")
    body = '[ingest]\nendpoints = ["bind:tcp://0.0.0.0:%d"]\nkind = "pull"\n[publish]\nendpoints = ["tcp://127.0.0.1:%d"]\n'
    open(open_config, "w").write(body % (free_port(), free_port()))
    r = subprocess.run([kata, "serve", "--config", open_config], capture_output=True, text=True, timeout=30)
    assert r.returncode == 1 and "reachable from other hosts without keys" in r.stderr, r.stderr
    r = subprocess.run([kata, "proxy", "--frontend", "tcp://*:%d" % free_port(), "--backend",
                        "tcp://127.0.0.1:%d" % free_port(), "--seconds", "0.2"], capture_output=True, text=True, timeout=30)
    assert r.returncode == 1 and "without keys" in r.stderr, r.stderr
    r = subprocess.run([kata, "proxy", "--help"], capture_output=True, text=True, timeout=30)
    assert "tcp://127.0.0.1:5560" in r.stdout and "tcp://127.0.0.1:5561" in r.stdout, r.stdout
    insecure = os.path.join(tmp, "insecure.toml")
    open(insecure, "w").write(body % (free_port(), free_port()) + "[security]\ninsecure = true\n")
    serve = subprocess.Popen([kata, "serve", "--config", insecure], stderr=subprocess.PIPE, text=True)
    time.sleep(1.0)
    serve.send_signal(signal.SIGINT)
    _, err = serve.communicate(timeout=30)
    assert serve.returncode == 0 and "warning:" in err and "without keys" in err, err

    # The stage with keys.
    ingest_port, publish_port = free_port(), free_port()
    config = os.path.join(tmp, "serve.toml")
    open(config, "w").write(
        '[ingest]\nendpoints = ["bind:tcp://127.0.0.1:%d"]\nkind = "pull"\n[publish]\nendpoints = ["tcp://127.0.0.1:%d"]\n'
        '[scoring]\nmodel = "%s/models/default.kata"\nteacher = "%s/data/cmu/02_01.bvh"\n'
        '[security]\nkey = "keys/server.secret"\nclients = "keys/clients"\n' % (ingest_port, publish_port, source, source))
    serve = subprocess.Popen([kata, "serve", "--config", config], stderr=subprocess.PIPE, text=True)
    try:
        time.sleep(1.0)
        out_ep = "tcp://127.0.0.1:%d" % publish_port
        in_ep = "tcp://127.0.0.1:%d" % ingest_port
        server_pub = os.path.join(keys, "server.pub")
        viewer = subprocess.Popen(["/usr/bin/python3", subscriber, "--endpoint", out_ep, "--stream", "7", "--count", "20",
                                   "--timeout", "20", "--python-dir", python_dir, "--key",
                                   os.path.join(keys, "clients", "viewer.secret"), "--server-key", server_pub],
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        plain = subprocess.Popen(["/usr/bin/python3", subscriber, "--endpoint", out_ep, "--count", "1", "--timeout", "6",
                                  "--python-dir", python_dir], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        stranger = subprocess.Popen(["/usr/bin/python3", subscriber, "--endpoint", out_ep, "--count", "1", "--timeout", "6",
                                     "--python-dir", python_dir, "--key", os.path.join(tmp, "stranger.secret"),
                                     "--server-key", server_pub], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        time.sleep(0.5)
        # A sender without keys and one with an unknown key: nothing gets in.
        for extra in ([], ["--key", os.path.join(tmp, "stranger.secret"), "--server-key", server_pub]):
            r = subprocess.run([kata, "send", "--bvh", clip, "--endpoint", in_ep, "--stream-id", "9", "--frames", "20",
                                "--speed", "4"] + extra, timeout=60, capture_output=True, text=True)
            assert r.returncode == 0 or "took nothing" in r.stderr, r.stderr
        subprocess.run([kata, "send", "--bvh", clip, "--endpoint", in_ep, "--stream-id", "7", "--frames", "120",
                        "--speed", "2", "--key", os.path.join(keys, "clients", "stage.secret"), "--server-key", server_pub],
                       check=True, timeout=60)
        out, err = viewer.communicate(timeout=60)
        assert viewer.returncode == 0, (out, err)
        scores = [l for l in out.splitlines() if ": score " in l]
        assert len(scores) == 20, out
        for name, p in (("no key", plain), ("unknown key", stranger)):
            out, err = p.communicate(timeout=60)
            assert p.returncode == 1 and "no message" in err and "result" not in out, (name, out, err)
        time.sleep(0.5)
    finally:
        serve.send_signal(signal.SIGINT)
        _, err = serve.communicate(timeout=30)
    assert serve.returncode == 0, err
    assert "stopped; 120 frames in, 120 results published, 0 ingest messages dropped" in err, err
print("curve serve ok")
