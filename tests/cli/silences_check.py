#!/usr/bin/python3
"""No silences: every "nothing arrived" case of kata send / kata serve says why.
- kata send to an endpoint where nobody listens fails naming that, instead of "sent" and exit 0;
- kata send (push) into a serve whose ingest is left at its default kind (sub): both sides say the
  socket kinds cannot talk, naming the config's kind and what to write;
- a skeleton that does not fit its layout: serve says why the definition was refused and counts
  the drops by cause; kata send says how many frames a peer took;
- a serve nobody sends to says so after 10 s;
- kata send slower than recorded (--speed 0.5) with the clip's capture times says, before it
  sends, that an ingest judging age will drop the frames as stale (it does, and its log says why).
Unique ipc paths per run; every wait bounded; no timing asserted."""
import os, signal, subprocess, sys, tempfile, time

kata, source = sys.argv[1:3]
clip = os.path.join(source, "data", "cmu", "07_01.bvh")


def serve(tmp, name, kind):
    config = os.path.join(tmp, name + ".toml")
    text = '[ingest]\nendpoints = ["bind:ipc://%s/%s.in"]\n' % (tmp, name)
    if kind:
        text += 'kind = "%s"\n' % kind
    text += '[publish]\nendpoints = ["ipc://%s/%s.out"]\n' % (tmp, name)
    open(config, "w").write(text)
    p = subprocess.Popen([kata, "serve", "--config", config], stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 20
    while not os.path.exists(os.path.join(tmp, name + ".in")) and time.time() < deadline:
        time.sleep(0.05)
    return p, config, "ipc://%s/%s.in" % (tmp, name)


def stop(p):
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=30)
    assert p.returncode == 0, err
    return err.replace("\r", "\n")


def send(endpoint, *extra):
    return subprocess.run([kata, "send", "--bvh", clip, "--endpoint", endpoint, "--frames", "60", "--speed", "8"] +
                          list(extra), capture_output=True, text=True, timeout=60)


with tempfile.TemporaryDirectory(prefix="kata_silences_") as tmp:
    started = time.time()
    quiet, _, _ = serve(tmp, "quiet", "pull")  # nobody ever sends to it

    # 1. Nobody listens: an error naming it, not "sent".
    r = send("ipc://%s/nobody" % tmp, "--connect-timeout", "1")
    assert r.returncode == 1, r.stderr
    assert ("ipc://%s/nobody took nothing: no peer in 1 s (--connect-timeout): nobody listens there" % tmp) in r.stderr, r.stderr
    assert "sent" not in r.stderr, r.stderr

    # 2. push into a sub ingest (its default kind): both sides say the kinds cannot talk.
    sub, sub_config, sub_in = serve(tmp, "sub", None)
    r = send(sub_in, "--connect-timeout", "3")
    err = stop(sub)
    assert r.returncode == 1, r.stderr
    assert "closed during the handshake: most likely the peer's socket kind cannot talk to --socket push" in r.stderr, r.stderr
    assert "a SUB ingest needs --socket pub" in r.stderr, r.stderr
    assert "was refused at the handshake: most likely its socket kind cannot talk to this ingest's (%s: [ingest] has no " \
           'kind: "sub" by default): a SUB ingest takes PUB senders (kata send --socket pub); kata send\'s default, ' \
           '--socket push, needs kind = "pull"' % sub_config in err, err
    assert "handshakes refused)" in err, err

    # 3. The right kinds, a skeleton that does not fit its layout: the reason, drops by cause.
    pull, _, pull_in = serve(tmp, "pull", "pull")
    r = send(pull_in, "--preset", "mediapipe", "--stream-id", "4")
    assert r.returncode == 0, r.stderr
    assert "kata send: 60 of 60 frames (1 stream(s) from 4) taken by a peer at " + pull_in in r.stderr, r.stderr
    time.sleep(2.5)
    err = stop(pull)
    assert "stream 4's skeleton definition (layout 'mediapipe') refused: layout mediapipe: skeleton has no landmark " \
           "'nose'" in err, err
    status = [l for l in err.splitlines() if l.startswith("streams ")]
    assert any("| drops 61 (definitions refused 1, unknown stream 60) |" in l for l in status), status[-3:]

    # 5. Slower than recorded: the frames fall behind their capture times; said before the run, and
    # the serve's PULL ingest (default max_frame_age_ms 250) drops them as stale from 0.5 s on.
    slow, _, slow_in = serve(tmp, "slow", "pull")
    r = subprocess.run([kata, "send", "--bvh", clip, "--endpoint", slow_in, "--frames", "120", "--speed", "0.5"],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert "kata send: --speed 0.5 with the clip's capture times: the frames fall 0.50 s further behind their " \
           "capture times every second" in r.stderr, r.stderr
    assert "drops every frame after 0.50 s; --live-clock stamps this host's time" in r.stderr, r.stderr
    err = stop(slow)
    stale = [l for l in err.splitlines() if "ingest messages dropped" in l or " dropped (" in l]
    assert any(" stale " in l and " stale 0," not in l for l in stale), stale
    # ...and says why, once: frames ever later, the rate, the likely cause.
    assert err.count("sends frames ever later behind their capture times") == 1, err
    assert "60 in a row dropped as stale" in err and "x this host's, or a source falling behind" in err, err
    r = subprocess.run([kata, "send", "--bvh", clip, "--endpoint", "ipc://%s/nobody" % tmp, "--frames", "10",
                        "--speed", "0.5", "--live-clock", "--connect-timeout", "0.5"],
                       capture_output=True, text=True, timeout=60)
    assert "further behind" not in r.stderr, r.stderr

    # 4. A serve nobody sends to says so (after 10 s).
    time.sleep(max(0.0, 11.5 - (time.time() - started)))
    err = stop(quiet)
    assert ("nothing received on ipc://%s/quiet.in in 10 s: no sender has connected" % tmp) in err, err
print("silences ok")
