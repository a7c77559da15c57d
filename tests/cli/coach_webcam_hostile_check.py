#!/usr/bin/env python3
"""`kata coach --webcam` against hostile requests, on loopback only, bounded in count and time:

  1. A frame's sequence decides how far the frame table grows: sequences far ahead of the lesson
     (2e6, 2e7, 9e15 - 1) are refused with 400 at once, and the process's RSS stays within 64 MB
     of what it was (today's main grew to 9.4 GB on 2e7); a small gap is still accepted.
  2. Any web page in the user's browser can POST to 127.0.0.1 (a "simple" cross-origin request
     needs no preflight): a foreign Origin, and a foreign Host (DNS rebinding), are refused with
     403 and change nothing; the server's own origin (127.0.0.1 or localhost with its port) is
     served.

Usage: coach_webcam_hostile_check.py KATA SOURCE_DIR"""
import http.client
import json
import os
import re
import signal
import struct
import subprocess
import sys
import tempfile
import time

KATA, SOURCE = sys.argv[1], sys.argv[2]
failures = []
passes = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    (passes if ok else failures).append(what)


def frame(seq, capture_ms):
    # KWC1 header (48 bytes): magic, landmark count (0: nobody in frame), sequence, capture and
    # landmark times (doubles), the rest zero.
    return struct.pack("<IIddd", 0x3143574B, 0, float(seq), capture_ms, capture_ms) + bytes(16)


def rss_mb(pid):
    with open("/proc/%d/status" % pid) as f:
        return int(re.search(r"VmRSS:\s+(\d+)", f.read()).group(1)) / 1024.0


def request(port, method, path, body=None, headers=None):
    c = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    h = {"Host": "127.0.0.1:%d" % port}
    h.update(headers or {})
    c.request(method, path, body=body, headers=h)
    r = c.getresponse()
    data = r.read()
    c.close()
    return r.status, data


with tempfile.TemporaryDirectory() as work:
    # The server only checks that the page and MediaPipe are there; no browser runs here.
    viewer = os.path.join(work, "viewer")
    os.makedirs(os.path.join(viewer, "vendor", "mediapipe", "pose"))
    for name in ("webcam.html", "vendor/mediapipe/pose/pose.js"):
        open(os.path.join(viewer, name), "w").close()
    log_path = os.path.join(work, "coach.log")
    with open(log_path, "w") as log:
        p = subprocess.Popen([KATA, "coach", "--webcam", "--headless", "--port", "0", "--duration", "60",
                              "--viewer-dir", viewer], cwd=SOURCE, stdout=log, stderr=subprocess.STDOUT)
    try:
        port = None
        deadline = time.time() + 30
        while port is None and time.time() < deadline and p.poll() is None:
            m = re.search(r"viewer: http://127\.0\.0\.1:(\d+)/", open(log_path).read())
            port = int(m.group(1)) if m else None
            time.sleep(0.1)
        if port is None:
            print(open(log_path).read())
            sys.exit("kata coach --webcam did not start")
        own = {"Origin": "http://127.0.0.1:%d" % port}

        status, _ = request(port, "POST", "/webcam/frame", frame(0, 1.0), own)
        check(status == 200, "frame 0 from the server's own origin is accepted (%d)" % status)
        before = rss_mb(p.pid)
        for seq in (2e6, 2e7, 9e15 - 1, 602):
            start = time.time()
            status, body = request(port, "POST", "/webcam/frame", frame(seq, 2.0), own)
            took = time.time() - start
            check(status == 400 and b"sequence" in body and took < 5,
                  "sequence %.0f refused with 400 in %.2f s (%d %s)" % (seq, took, status, body[:100]))
        grew = rss_mb(p.pid) - before
        check(grew < 64, "RSS grew by %.1f MB after the hostile sequences (limit 64)" % grew)
        status, _ = request(port, "POST", "/webcam/frame", frame(500, 3.0), {"Origin": "http://localhost:%d" % port})
        check(status == 200, "a gap of 499 frames from localhost's origin is accepted (%d)" % status)

        for headers, what in (({"Origin": "http://evil.example"}, "a foreign Origin"),
                              ({"Origin": "http://127.0.0.1:%d" % (port + 1)}, "another port's Origin"),
                              ({"Origin": "null"}, "an opaque (null) Origin"),
                              ({"Host": "evil.example:%d" % port}, "a foreign Host (DNS rebinding)")):
            for method, path, body in (("POST", "/webcam/frame", frame(501, 4.0)), ("GET", "/webcam/setup", None)):
                status, _ = request(port, method, path, body, headers)
                check(status == 403, "%s %s with %s refused with 403 (%d)" % (method, path, what, status))
        status, body = request(port, "GET", "/webcam/status")
        s = json.loads(body)
        check(status == 200 and s["frames"] == 501 and s["not_in_frame"] == 2 and s["malformed"] == 4,
              "status: 501 frames, 2 received, 4 refused: nothing from the foreign requests (%s)" % body)
    finally:
        p.send_signal(signal.SIGINT)
        try:
            p.wait(timeout=30)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()

print("%d passed, %d failed" % (len(passes), len(failures)))
sys.exit(1 if failures else 0)
