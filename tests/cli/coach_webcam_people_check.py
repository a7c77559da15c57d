#!/usr/bin/env python3
"""`kata coach --webcam --people 2` fed people frames ("KWP1", sdk/tools/coach/webcam.hpp) over
HTTP on loopback, no browser: which person each pose is, and bad input handled and counted.

  1. Two people (two copies of one pose, 300 px apart in the image) get two persons; the next
     frame's poses in the other order keep their persons (the answer names each pose's person).
  2. Bad input, each counted by cause in /webcam/status's "people" and disturbing nothing else:
     a third pose while two people are open (more poses than --people: refused, table full); a
     pose with a NaN landmark in the image (refused by the tracker, non-finite) and one with a NaN
     world landmark (refused by the coach before tracking); an empty frame (nobody in view: "not in
     frame"); 17 poses (more than a frame may carry) and a single-person "KWC1" frame (malformed,
     400). The two people keep their persons throughout and every frame of theirs is pushed to
     their own stream.
  3. Each person's results on the page's event stream: once their stream has measured their
     bones, every scored result carries their ghost (the teacher's 16 GPD joints) in their own
     proportions (the right person is 1.25 times the left in the world: so are their ghost's limbs).
  4. The report has one section and one summary row per person.

Usage: coach_webcam_people_check.py KATA SOURCE_DIR"""
import http.client
import json
import math
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
LANDMARKS = 33
GOES_ON = 70  # frames of both people after the bad input (the ghost comes once 60 measured the bones)
TALL = 1.25  # the right person's body, in the world, against the left's


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    (passes if ok else failures).append(what)


def pose(x_px, y_px=240.0, t=0.0, size=1.0):
    """A standing person's 33 MediaPipe landmarks: world (metres, hips at 0, y down; `size` times
    the standard body) with visibility, and their place in a 640 x 480 image (pixels), the body
    300 px tall."""
    world, image = [], []
    for j in range(LANDMARKS):
        # Head (0-10) on top, shoulders (11, 12), elbows, wrists, hands (13-22), hips (23, 24),
        # knees, ankles, feet (25-32); left (odd) and right (even) 0.2 m apart.
        side = -1.0 if j % 2 else 1.0
        if j <= 10:
            y, x = -0.6 - 0.01 * j, 0.02 * (j - 5)
        elif j <= 22:
            y, x = -0.45 + 0.1 * ((j - 11) // 2), side * (0.2 + 0.05 * ((j - 11) // 2))
        else:
            y, x = 0.0 + 0.2 * ((j - 23) // 2), side * 0.1
        x += 0.02 * math.sin(t + j)  # a little motion
        world.append((size * x, size * y, size * 0.05 * side, 0.95))
        image.append((x_px + 250.0 * x, y_px + 250.0 * y))
    return world, image


def people_frame(seq, capture_ms, poses):
    body = struct.pack("<IIddd", 0x3150574B, len(poses), float(seq), capture_ms, capture_ms) + bytes(16)
    for world, image in poses:
        body += b"".join(struct.pack("<ffff", *w) for w in world)
        body += b"".join(struct.pack("<ff", *i) for i in image)
    return body


def request(port, method, path, body=None):
    c = http.client.HTTPConnection("127.0.0.1", port, timeout=20)
    c.request(method, path, body=body, headers={"Host": "127.0.0.1:%d" % port})
    r = c.getresponse()
    data = r.read()
    c.close()
    return r.status, data


def post(port, body):
    status, data = request(port, "POST", "/webcam/frame", body)
    return status, (json.loads(data) if status == 200 else data)


with tempfile.TemporaryDirectory() as work:
    # The server only checks that the page, MediaPipe, TensorFlow.js and MoveNet are there.
    viewer = os.path.join(work, "viewer")
    for name in ("webcam.html", "vendor/mediapipe/pose/pose.js", "vendor/tfjs/tf.min.js",
                 "vendor/movenet/movenet-multipose.json"):
        os.makedirs(os.path.dirname(os.path.join(viewer, name)), exist_ok=True)
        open(os.path.join(viewer, name), "w").close()
    log_path = os.path.join(work, "coach.log")
    report = os.path.join(work, "report.html")
    with open(log_path, "w") as log:
        p = subprocess.Popen([KATA, "coach", "--webcam", "--people", "2", "--headless", "--port", "0", "--duration",
                              "120", "--first-frame", "0", "--viewer-dir", viewer, "--report", report],
                             cwd=SOURCE, stdout=log, stderr=subprocess.STDOUT)
    try:
        port = None
        deadline = time.time() + 60
        while port is None and time.time() < deadline and p.poll() is None:
            m = re.search(r"viewer: http://127\.0\.0\.1:(\d+)/", open(log_path).read())
            port = int(m.group(1)) if m else None
            time.sleep(0.1)
        if port is None:
            print(open(log_path).read())
            sys.exit("kata coach --webcam --people 2 did not start")
        status, setup = request(port, "GET", "/webcam/setup")
        check(status == 200 and json.loads(setup)["people"] == 2, "setup says --people 2 (%s)" % setup[:200])

        # 1. Two people, then in the other order.
        seq, ms = 0, 1000.0
        status, ack = post(port, people_frame(seq, ms, [pose(150), pose(450, size=TALL)]))
        check(status == 200 and sorted(ack["people"]) == [1, 2], "two poses -> two persons %s" % ack)
        left, right = ack["people"]
        seq, ms = seq + 1, ms + 100
        status, ack = post(port, people_frame(seq, ms, [pose(452, t=0.1, size=TALL), pose(151, t=0.1)]))
        check(status == 200 and ack["people"] == [right, left], "the other order keeps each person %s" % ack)

        # 2. Bad input.
        seq, ms = seq + 1, ms + 100
        status, ack = post(port, people_frame(seq, ms, [pose(150, t=0.2), pose(450, t=0.2, size=TALL), pose(600, t=0.2)]))
        check(status == 200 and ack["people"] == [left, right, 0], "a third pose with --people 2 is refused %s" % ack)
        nan_image, nan_world = pose(450, t=0.3, size=TALL), pose(150, t=0.3)
        nan_image[1][11] = (float("nan"), 100.0)
        nan_world[0][12] = (float("nan"), 0.0, 0.0, 0.9)
        seq, ms = seq + 1, ms + 100
        status, ack = post(port, people_frame(seq, ms, [nan_image, pose(150, t=0.3)]))
        check(status == 200 and ack["people"] == [0, left], "a pose with a NaN image landmark is refused %s" % ack)
        seq, ms = seq + 1, ms + 100
        status, ack = post(port, people_frame(seq, ms, [nan_world, pose(450, t=0.4, size=TALL)]))
        check(status == 200 and ack["people"] == [0, right], "a pose with a NaN world landmark is refused %s" % ack)
        seq, ms = seq + 1, ms + 100
        status, ack = post(port, people_frame(seq, ms, []))
        check(status == 200 and ack["people"] == [], "an empty frame is taken %s" % ack)
        status, body = post(port, people_frame(seq + 1, ms + 100, [pose(100 + 30 * k) for k in range(17)]))
        check(status == 400 and b"16 poses" in body, "17 poses: 400 %s" % body)
        status, body = post(port, struct.pack("<IIddd", 0x3143574B, 0, float(seq + 1), ms + 100, ms + 100) + bytes(16))
        check(status == 400 and b"magic" in body, "a single-person KWC1 frame: 400 %s" % body)
        for k in range(GOES_ON):  # the lesson goes on: both people, each on their stream
            seq, ms = seq + 1, ms + 100
            status, ack = post(port, people_frame(seq, ms, [pose(450 + k, t=0.5 + 0.1 * k, size=TALL), pose(150 - k, t=0.5 + 0.1 * k)]))
            check(status == 200 and ack["people"] == [right, left], "frame %d: each pose keeps its person %s" % (seq, ack))

        time.sleep(1.0)
        status, body = request(port, "GET", "/webcam/status")
        s = json.loads(body)
        pp = s["people"]
        print(json.dumps(s))
        check(s["frames"] == seq + 1 and s["malformed"] == 2 and s["refused"] == 0 and s["not_in_frame"] == 1,
              "status: %d frames, 2 malformed, none refused, 1 not in frame" % (seq + 1))
        check(pp["refused_table_full"] == 1, "the third pose counted: table full (%d)" % pp["refused_table_full"])
        check(pp["refused_non_finite"] == 1, "the NaN image pose counted: non-finite (%d)" % pp["refused_non_finite"])
        check(pp["refused_world_non_finite"] == 1, "the NaN world pose counted (%d)" % pp["refused_world_non_finite"])
        check(pp["empty_frames"] == 1, "the empty frame counted (%d)" % pp["empty_frames"])
        by_id = {q["id"]: q for q in pp["persons"]}
        check(sorted(by_id) == [1, 2] and len({q["stream"] for q in pp["persons"]}) == 2 and
              all(q["stream"] != 0 for q in pp["persons"]), "two persons, each their own stream %s" % pp["persons"])
        # each: frames 0-2, one of 3 and 4 (the other's pose there had a NaN), the last GOES_ON
        check(by_id[left]["pushed"] == 4 + GOES_ON and by_id[right]["pushed"] == 4 + GOES_ON,
              "every good pose pushed to its person's stream (left %d of %d, right %d of %d)" %
              (by_id[left]["pushed"], 4 + GOES_ON, by_id[right]["pushed"], 4 + GOES_ON))
        check(s["pushed"] == 2 * (4 + GOES_ON), "%d poses pushed in all (%d)" % (2 * (4 + GOES_ON), s["pushed"]))

        # 3. The page's events (from=0: every one so far): once a person's stream has measured
        # their bones (60 frames) each of their scored results carries the ghost, 16 GPD joints in
        # that person's own proportions: the right person's limbs TALL times the left's.
        scored = {left: [], right: []}  # per person, in order: the ghost of each scored result (or None)
        c = http.client.HTTPConnection("127.0.0.1", port, timeout=5)
        c.request("GET", "/webcam/events?from=0", headers={"Host": "127.0.0.1:%d" % port})
        r = c.getresponse()
        expected_events = s["events"]
        seen = 0
        try:
            while seen < expected_events:
                line = r.readline()
                if not line:
                    break
                if not line.startswith(b"data:"):
                    continue
                seen += 1
                e = json.loads(line[5:])
                if e.get("person") in scored and "score" in e:
                    scored[e["person"]].append(e.get("ghost"))
        except (OSError, http.client.HTTPException) as error:
            print("events: %s after %d of %d" % (error, seen, expected_events))
        c.close()
        limbs = ((4, 5), (5, 6), (7, 8), (8, 9), (10, 11), (11, 12), (13, 14), (14, 15))  # GPD arms, legs
        length = {}
        for who, name in ((left, "left"), (right, "right")):
            g = scored[who]
            first = next((i for i, q in enumerate(g) if q is not None), len(g))
            ghosts = g[first:]
            check(len(ghosts) >= 10 and all(q is not None and len(q) == 3 * 16 and all(math.isfinite(v) for v in q)
                                            for q in ghosts),
                  "the %s person's ghost: on each of their %d scored results from result %d on" % (name, len(ghosts), first))
            if ghosts:
                length[who] = sum(math.dist(ghosts[-1][3 * i:3 * i + 3], ghosts[-1][3 * j:3 * j + 3]) for i, j in limbs)
        if len(length) == 2:
            ratio = length[right] / length[left]
            check(abs(ratio - TALL) < 0.05 * TALL, "each ghost is its person's: limbs %.3f x (the bodies: %.2f x)" %
                  (ratio, TALL))
    finally:
        p.send_signal(signal.SIGINT)
        try:
            p.wait(timeout=60)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()
    out = open(log_path).read()
    check(p.returncode == 0, "the coach ended cleanly (%s)" % p.returncode)
    check("person 1:" in out and "person 2:" in out, "the summary has a line per person")
    html = open(report).read() if os.path.exists(report) else ""
    check(html.count('<section class="person"') == 2 and html.count('<tr class="person"') == 2,
          "the report has a section and a summary row per person")

print("%d passed, %d failed" % (len(passes), len(failures)))
sys.exit(1 if failures else 0)
