#!/usr/bin/python3
"""kata proxy end to end on loopback: two publishers connect to the frontend, a subscriber with a
topic filter to the backend; every multi-part message of the subscribed topic arrives whole and in
order per publisher, the other topic does not; the proxy exits on SIGTERM. Bounded in time.
Usage: test_proxy.py KATA_BINARY  (Debian's python3-zmq)"""
import os, signal, subprocess, sys, tempfile, time
import zmq

kata = sys.argv[1]
d = tempfile.mkdtemp(prefix="kata_proxy_test_%d_" % os.getpid())
front, back = "ipc://%s/front" % d, "ipc://%s/back" % d
proxy = subprocess.Popen([kata, "proxy", "--frontend", front, "--backend", back, "--seconds", "30",
                          "--status-interval", "0"], stdout=subprocess.PIPE, text=True)
try:
    ctx = zmq.Context()
    sub = ctx.socket(zmq.SUB)
    sub.setsockopt(zmq.SUBSCRIBE, b"stream-a")
    sub.setsockopt(zmq.RCVTIMEO, 5000)
    sub.connect(back)
    pubs = []
    for _ in range(2):
        p = ctx.socket(zmq.PUB)
        p.connect(front)
        pubs.append(p)
    # Subscriptions travel upstream through the proxy: wait until a probe gets through.
    deadline = time.time() + 10
    got_probe = False
    while time.time() < deadline and not got_probe:
        for p in pubs:
            p.send_multipart([b"stream-a", b"probe"])
        try:
            if sub.poll(100):
                while sub.poll(0):
                    sub.recv_multipart()
                got_probe = True
        except zmq.Again:
            pass
    assert got_probe, "no message crossed the proxy within 10 s"
    time.sleep(0.2)
    while sub.poll(50):
        sub.recv_multipart()
    n = 500
    for i in range(n):
        for k, p in enumerate(pubs):
            p.send_multipart([b"stream-a", b"%d" % k, b"%d" % i])
            p.send_multipart([b"stream-b", b"%d" % k, b"%d" % i])
    seen = {0: [], 1: []}
    while len(seen[0]) + len(seen[1]) < 2 * n:
        topic, k, i = sub.recv_multipart()
        assert topic == b"stream-a", topic
        seen[int(k)].append(int(i))
    for k in (0, 1):
        assert seen[k] == list(range(n)), "publisher %d: out of order or lost" % k
    proxy.send_signal(signal.SIGTERM)
    out, _ = proxy.communicate(timeout=10)
    assert proxy.returncode == 0, proxy.returncode
    assert "stopped" in out, out
    print("ok: %d multi-part messages per publisher through kata proxy, topic filter kept" % n)
finally:
    if proxy.poll() is None:
        proxy.kill()
