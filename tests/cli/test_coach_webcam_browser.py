#!/usr/bin/python3
"""Browser test of `kata coach --webcam` in Debian's headless Chromium (selenium), with a camera
that Chromium fakes from a file (--use-file-for-fake-video-capture).

The fake camera plays a real photograph of a standing person from a Debian package: opencv-doc's
examples/data/basketball1.png (OpenCV's sample data; Debian's copyright file puts it under the
package's "Files: *" stanza, Apache-2.0 AND BSD-3-Clause), cropped to the man on the left
(standing, whole body in view) and written by Debian's ffmpeg as a .y4m. Another crop of the same
photograph, the wall and the door with nobody in it, is the camera with no person.

  1. With the person: MediaPipe Pose (lite, WebAssembly on the CPU: --disable-gpu, so WebGL is
     SwiftShader's) finds the 33 landmarks, the page sends them, kata's results arrive, the state
     goes from calibrating to scored, the ghost comes with the scores (once 60 frames have
     measured the student's bones), no console error; the
     page reloaded mid-lesson continues it (its frames are taken, none refused).
  2. The page adds nothing but transport: the landmarks kata received (--record-student, .npy +
     .times.npy) read back by `kata score` from the file give, frame by frame, the scores the page
     received.
  3. With nobody in view: the page and kata say "not in frame", and the lesson survives (the coach
     keeps answering, nothing is refused, it ends cleanly with its report).
  4. A teacher from the webcam: --record-teacher writes frames x 33 x 4 (.npy) and its frame times
     (.times.npy, seconds from 0, increasing), one frame per landmark frame kata received; a lesson
     loads it as its teacher (/webcam/setup says its frame count) and `kata score` scores the
     recorded student of 1. against it (the same photograph: the same pose, so the top scores).

With --people (a test of its own, coach_webcam_people_browser): several people in one camera
(kata coach --webcam --people N). The camera plays two, then three copies of the photograph's man
tiled side by side (ffmpeg's hstack), swaying left and right; one page session per video. The page
finds the people (MoveNet MultiPose) and each one's landmarks (MediaPipe on their crop); kata's
people tracker says who each pose is. Every person is scored on their own stream (each a stream
of their own in /webcam/status, results on it), nobody swaps (a person's hips stay in their tile
in every frame the page sent), no stray person appears, and the report has one section and one
summary row per person. The teacher is the man as the single-person page recorded him
(tests/data/webcam: MediaPipe on the whole picture): every person, found on their crop, scores a
median above 90 against it. The page's cost per frame and per person is printed.

Usage: test_coach_webcam_browser.py --kata build/bin/kata --source-dir . [--screenshot FILE.png] [--people]
Every wait is bounded; prints its wall time per phase.
"""
import argparse
import csv
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request

import numpy as np

from selenium import webdriver
from selenium.common.exceptions import TimeoutException
from selenium.webdriver.chrome.service import Service

PHOTO = "/usr/share/doc/opencv-doc/examples/data/basketball1.png"
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--no-first-run", "--window-size=1000,830",
                  "--use-fake-device-for-media-stream", "--use-fake-ui-for-media-stream",
                  # --disable-gpu leaves WebGL to SwiftShader (software); say so, or Chromium warns.
                  "--enable-unsafe-swiftshader"]


# The page's (kata coach --webcam's) state names -> `kata score`'s CSV column.
FILE_STATE = {"tracking": "scoring", "calibrating": "calibrating", "teacher finished": "teacher_finished",
              "tracking lost": "tracking_lost"}


def wait_for(what, predicate, timeout):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        value = predicate()
        if value:
            return value
        time.sleep(0.2)
    raise AssertionError(f"timed out after {timeout} s waiting for: {what}")


def make_video(path, crop):
    subprocess.run(["ffmpeg", "-loglevel", "error", "-y", "-loop", "1", "-i", PHOTO, "-vf",
                    f"crop={crop},scale=320:640,format=yuv420p", "-t", "2", "-r", "10", path], check=True)


def make_tiled_video(path, copies):
    """`copies` copies of the man side by side (320 x 640 each), the row swaying +-24 px over 2 s."""
    tiles = "".join(f"[t{k}]" for k in range(copies))
    graph = (f"[0]crop=240:480:0:0,scale=320:640,split={copies}{tiles};{tiles}hstack=inputs={copies},"
             f"pad=iw+48:ih:24:0,crop=iw-48:ih:'24+24*sin(PI*t)':0,format=yuv420p")
    subprocess.run(["ffmpeg", "-loglevel", "error", "-y", "-loop", "1", "-i", PHOTO, "-filter_complex", graph,
                    "-t", "2", "-r", "10", path], check=True)


def people_session(kata, source_dir, work, copies, started, screenshot=None):
    """A page session with `copies` people in view (kata coach --webcam --people copies)."""
    video = os.path.join(work, f"people{copies}.y4m")
    make_tiled_video(video, copies)
    tile = 320
    name = f"people{copies}"
    teacher = os.path.join(os.path.abspath(source_dir), "tests", "data", "webcam", "basketball_man.npy")
    coach, port, log = start_coach(kata, source_dir, work, name, ["--people", str(copies), "--teacher", teacher,
                                                                  "--time-units", "s"])
    driver = make_driver(os.path.join(work, "profile_" + name), video)
    try:
        driver.set_page_load_timeout(120)
        driver.set_script_timeout(120)
        driver.get(f"http://127.0.0.1:{port}/webcam.html")
        hook = lambda: page_hook(driver)
        wait_for("the people's first landmarks", lambda: (hook() or {}).get("personFrames", 0) > 0, 240)

        def everyone_scored():
            persons = (hook() or {}).get("persons") or {}
            return len(persons) >= copies and all(p["scored"] >= 2 for p in persons.values())
        wait_for(f"{copies} people scored", everyone_scored, 420)
        h = hook()
        assert not h["errors"], f"page errors: {h['errors']}"
        errors = severe(driver)
        assert not errors, f"console errors: {errors}"
        if screenshot:
            driver.save_screenshot(screenshot)
        s = status(port)
        assert s["refused"] == 0 and s["malformed"] == 0, s
        people = s["people"]
        persons = people["persons"]
        # Each person their own stream, scored on it; nobody else appeared.
        assert len(persons) == copies, f"{len(persons)} people for {copies} in view: {persons}"
        assert len({p["stream"] for p in persons}) == copies and all(p["stream"] for p in persons), persons
        assert all(p["scored"] >= 2 and p["results"] >= p["scored"] for p in persons), persons
        # Found on their crop, each is the man the single-person page recorded: high scores.
        medians = {int(k): float(np.median([e["score"] for e in p["scores"]])) for k, p in h["persons"].items()}
        assert all(m > 90 for m in medians.values()), f"median scores against the man's own recording: {medians}"
        assert sorted(int(k) for k in h["persons"]) == sorted(p["id"] for p in persons), (h["persons"], persons)
        # No swap: every pose the page sent with a person has its hips in that person's tile, the
        # same tile in every frame, and each person in a tile of their own.
        tile_of = {}
        for f in h["frames"]:
            for pid, (x, _) in zip(f["ids"], f["hips"]):
                if not pid:
                    continue
                k = int(x // tile)
                assert tile_of.setdefault(pid, k) == k, f"person {pid} moved from tile {tile_of[pid]} to {k} (frame {f['seq']})"
        assert sorted(tile_of.values()) == list(range(copies)), f"tiles of the people: {tile_of}"
        frames = len(h["frames"])
        cost = h.get("costSummary")
        print(f"{copies} people: median scores {medians}; {frames} frames, persons {[(p['id'], p['pushed'], p['scored'], round(p['mean_score'], 1)) for p in persons]} "
              f"(id, frames, scored, mean score), tiles {tile_of}, backend {h.get('backend')}, page cost {json.dumps(cost)}, "
              f"tracker {json.dumps({k: v for k, v in people.items() if k != 'persons'})} [{time.monotonic() - started:.0f} s]")
    finally:
        driver.quit()
    assert stop(coach) == 0, open(log).read()
    summary = open(log).read()
    report = open(os.path.join(work, name + ".html")).read()
    assert report.count('<section class="person"') == copies, "the report has not one section per person"
    assert report.count('<tr class="person"') == copies, "the report's summary has not one row per person"
    for p in persons:
        assert f"person {p['id']}:" in summary, f"the summary has no line for person {p['id']}: {summary}"


def start_coach(kata, source_dir, work, name, extra):
    log_path = os.path.join(work, name + ".log")
    log = open(log_path, "w")
    p = subprocess.Popen([kata, "coach", "--webcam", "--headless", "--port", "0", "--duration", "600",
                          "--first-frame", "0", "--report", os.path.join(work, name + ".html")] + extra,
                         cwd=source_dir, stdout=log, stderr=subprocess.STDOUT)

    def port():
        with open(log_path) as f:
            m = re.search(r"viewer: http://127\.0\.0\.1:(\d+)/", f.read())
        return int(m.group(1)) if m else 0
    return p, wait_for("the coach's port", port, 30), log_path


def make_driver(profile, video):
    options = webdriver.ChromeOptions()
    for f in CHROMIUM_FLAGS + [f"--user-data-dir={profile}", f"--use-file-for-fake-video-capture={video}"]:
        options.add_argument(f)
    if os.path.exists("/usr/bin/chromium"):
        options.binary_location = "/usr/bin/chromium"
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(shutil.which("chromedriver") or "/usr/bin/chromedriver"), options=options)


def page_hook(driver):
    """window.kata.webcam, or None while the page's main thread is busy (MediaPipe's first run
    compiles its graph and its WebAssembly: tens of seconds on a loaded machine)."""
    try:
        return driver.execute_script("return window.kata && window.kata.webcam")
    except TimeoutException:
        return None


def status(port):
    with urllib.request.urlopen(f"http://127.0.0.1:{port}/webcam/status", timeout=5) as r:
        return json.load(r)


def severe(driver):
    return [e for e in driver.get_log("browser") if e.get("level") == "SEVERE"]


def stop(p):
    p.send_signal(signal.SIGINT)
    p.wait(timeout=60)
    return p.returncode


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--kata", required=True)
    ap.add_argument("--source-dir", required=True)
    ap.add_argument("--screenshot", help="save the webcam page (scored, with the person) here")
    ap.add_argument("--people", action="store_true", help="the several-people sessions only (two, then three)")
    a = ap.parse_args()
    if not os.path.exists(PHOTO) or not shutil.which("ffmpeg"):
        print("SKIP: needs opencv-doc (the photograph) and ffmpeg (./build.sh deps installs them)")
        return 77
    kata = os.path.abspath(a.kata)
    work = tempfile.mkdtemp(prefix="kata_webcam_browser_")
    started = time.monotonic()
    procs, driver = [], None
    if a.people:
        try:
            for copies in (2, 3):
                people_session(kata, a.source_dir, work, copies, started, a.screenshot)
            print(f"wall time {time.monotonic() - started:.1f} s")
            return 0
        finally:
            shutil.rmtree(work, ignore_errors=True)
    try:
        person, nobody = os.path.join(work, "person.y4m"), os.path.join(work, "nobody.y4m")
        make_video(person, "240:480:0:0")      # the man on the left, head to feet
        make_video(nobody, "220:480:205:0")    # the wall and the door between the two men
        recorded = os.path.join(work, "student.npy")

        # 1. A person in front of the camera.
        # The ghost and the student also go out as VMC performers (--vmc, --vmc-student) to two UDP
        # sockets of the test's, read after the session: one OSC bundle a datagram.
        vmc_sockets = []
        for _ in range(2):
            u = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            u.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 8 << 20)
            u.bind(("127.0.0.1", 0))
            u.setblocking(False)
            vmc_sockets.append(u)
        coach, port, log = start_coach(kata, a.source_dir, work, "person",
                                       ["--record-student", recorded,
                                        "--vmc", f"127.0.0.1:{vmc_sockets[0].getsockname()[1]}",
                                        "--vmc-student", f"127.0.0.1:{vmc_sockets[1].getsockname()[1]}"])
        procs.append(coach)
        driver = make_driver(os.path.join(work, "profile1"), person)
        driver.set_page_load_timeout(120)
        driver.set_script_timeout(120)
        driver.get(f"http://127.0.0.1:{port}/webcam.html")
        hook = lambda: page_hook(driver)
        wait_for("MediaPipe's first landmarks", lambda: (hook() or {}).get("personFrames", 0) > 0, 180)
        t_first = time.monotonic()
        wait_for("scored results (after calibrating)", lambda: (hook() or {}).get("scored", 0) >= 12, 240)
        h = hook()
        assert not h["errors"], f"page errors: {h['errors']}"
        states = h["states"]
        assert "calibrating" in states and "scored" in states, f"states seen: {states}"
        assert states.index("calibrating") < states.index("scored"), f"states seen: {states}"
        # The ghost is the pipeline's, across layouts (the CMU teacher on the MediaPipe student's
        # bones): it comes once the stream has measured the student's bones (60 frames with the
        # whole body), then with every score.
        wait_for("a ghost with the scores (after 60 frames measure the bones)",
                 lambda: any(e["ghost"] for e in (hook() or {}).get("events", []) if e.get("score") is not None), 240)
        h = hook()
        errors = severe(driver)
        assert not errors, f"console errors: {errors}"
        time.sleep(1.0)
        if a.screenshot:
            driver.save_screenshot(a.screenshot)
        h = hook()
        per_frame = (time.monotonic() - t_first) / max(1, h["personFrames"])
        print(f"person: states {states}, {h['personFrames']} frames with landmarks, {h['results']} results, "
              f"{h['scored']} scored; {per_frame:.2f} s per camera frame; latency {json.dumps(h['latency'])}")
        # A reload continues the lesson: the page numbers and times its frames after the ones kata
        # has (a reloaded page's clock starts at 0 again; kata refused every frame as not increasing).
        before = status(port)
        driver.refresh()
        wait_for("scored results after a reload", lambda: (hook() or {}).get("scored", 0) >= 3, 240)
        s = status(port)
        assert s["refused"] == 0 and s["malformed"] == 0, s
        assert s["pushed"] > before["pushed"], (before, s)
        assert not hook()["errors"], f"page errors after the reload: {hook()['errors']}"
        print(f"reload: {s['pushed'] - before['pushed']} more frames pushed, none refused "
              f"[{time.monotonic() - started:.0f} s]")
        driver.quit()
        driver = None
        assert stop(coach) == 0, open(log).read()
        summary = open(log).read()
        assert "webcam:" in summary and "report:" in summary, summary
        # Item 4: the page's latency per stage reached kata and its report.
        assert "latency per stage (page)" in summary, summary
        # VMC out from the webcam lesson: every datagram one bundle with the root, the humanoid
        # bones and the frame's OK (tests/transport/vmc_peers_check.py reads the values themselves);
        # the student from the first landmarks on, the ghost once the ghost came (above).
        for who, u, least in (("ghost", vmc_sockets[0], 1), ("student", vmc_sockets[1], 12)):
            bundles = []
            while True:
                try:
                    bundles.append(u.recv(65536))
                except BlockingIOError:
                    break
            u.close()
            assert len(bundles) >= least, f"vmc {who}: {len(bundles)} bundles"
            for b in bundles:
                assert b.startswith(b"#bundle\0"), b[:16]
                for part in (b"/VMC/Ext/Root/Pos", b"/VMC/Ext/Bone/Pos", b"LeftUpperArm", b"RightLowerLeg", b"/VMC/Ext/OK"):
                    assert part in b, (who, part)
            print(f"vmc {who}: {len(bundles)} bundles")
        report = open(os.path.join(work, "person.html")).read()
        for stage in ("capture-&gt;landmarks", "landmarks-&gt;received", "received-&gt;result", "result-&gt;drawn",
                      "capture-&gt;drawn"):
            assert f"<td style=\"text-align:left\">{stage}</td>" in report, f"the report has no {stage} row"

        # 2. The page adds nothing but transport: the file kata recorded, scored by `kata score`.
        scores_csv = os.path.join(work, "scores.csv")
        subprocess.run([kata, "score", "--model", "models/default.kata", "--teacher", "data/cmu/05_18.bvh",
                        "--teacher-layout", "cmu", "--student", recorded, "--student-layout", "mediapipe",
                        "--time-units", "s", "--first-frame", "0", "--out", scores_csv],
                       cwd=a.source_dir, check=True, stdout=subprocess.DEVNULL)
        rows = list(csv.DictReader(open(scores_csv)))
        file_times = np.array([float(r["time"]) for r in rows])
        compared, worst = 0, 0.0
        for e in h["events"]:
            if e.get("score") is None:
                continue
            k = int(np.argmin(np.abs(file_times - e["time"])))
            assert abs(file_times[k] - e["time"]) < 1e-4, f"page frame {e['seq']} (t={e['time']}) is not in the recording"
            r = rows[k]
            assert FILE_STATE[e["state"]] == r["state"], f"frame {e['seq']}: page {e['state']}, file {r['state']}"
            worst = max(worst, abs(float(r["score"]) - e["score"]))
            compared += 1
        assert compared >= 10, f"only {compared} frames compared"
        assert worst < 1e-3, f"page and file scores differ by up to {worst}"
        print(f"page vs file: {compared} scored frames, worst score difference {worst:.2g} "
              f"[{time.monotonic() - started:.0f} s]")

        # 3. Nobody in front of the camera: "not in frame", and the lesson survives.
        coach, port, log = start_coach(kata, a.source_dir, work, "nobody", [])
        procs.append(coach)
        driver = make_driver(os.path.join(work, "profile2"), nobody)
        driver.set_page_load_timeout(120)
        driver.set_script_timeout(120)
        driver.get(f"http://127.0.0.1:{port}/webcam.html")
        wait_for("'not in frame'", lambda: (hook() or {}).get("state") == "not in frame", 180)
        wait_for("kata's 'not in frame' results", lambda: status(port)["not_in_frame"] >= 3, 120)
        s = status(port)
        h = hook()
        assert s["refused"] == 0 and s["malformed"] == 0, s
        assert not h["errors"], f"page errors: {h['errors']}"
        assert not severe(driver), "console errors with nobody in view"
        assert h["state"] == "not in frame", h["state"]
        assert coach.poll() is None, "the coach ended"
        driver.quit()
        driver = None
        assert stop(coach) == 0, open(log).read()
        assert os.path.exists(os.path.join(work, "nobody.html")), "no report after a lesson with nobody in view"
        print(f"nobody: page and kata say 'not in frame' ({s['not_in_frame']} frames), coach ended cleanly "
              f"[{time.monotonic() - started:.0f} s]")

        # 4. A teacher recorded from the webcam, then used as a lesson's teacher.
        taught = os.path.join(work, "teacher.npy")
        coach, port, log = start_coach(kata, a.source_dir, work, "record", ["--record-teacher", taught])
        procs.append(coach)
        driver = make_driver(os.path.join(work, "profile3"), person)
        driver.set_page_load_timeout(120)
        driver.set_script_timeout(120)
        driver.get(f"http://127.0.0.1:{port}/webcam.html")
        wait_for("frames recorded", lambda: status(port)["pushed"] >= 10, 240)
        h = hook()
        assert h["state"] == "recording" and not h["errors"], (h["state"], h["errors"])
        assert not severe(driver), "console errors while recording a teacher"
        driver.quit()
        driver = None
        pushed = status(port)["pushed"]
        assert stop(coach) == 0, open(log).read()
        values, times = np.load(taught), np.load(taught[:-4] + ".times.npy")
        assert values.dtype == np.float32 and values.ndim == 3 and values.shape[1:] == (33, 4), values.shape
        assert values.shape[0] == pushed == times.shape[0], (values.shape, pushed, times.shape)
        assert times[0] == 0.0 and np.all(np.diff(times) > 0), times
        assert np.all(np.isfinite(values)) and np.all((values[..., 3] >= 0) & (values[..., 3] <= 1))
        # A lesson takes it as its teacher.
        coach, port, log = start_coach(kata, a.source_dir, work, "taught", ["--teacher", taught, "--time-units", "s"])
        procs.append(coach)
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/webcam/setup", timeout=5) as r:
            setup = json.load(r)
        assert setup["mode"] == "lesson" and setup["teacher_frames"] == values.shape[0], setup
        assert stop(coach) == 0, open(log).read()
        taught_csv = os.path.join(work, "taught.csv")
        subprocess.run([kata, "score", "--model", "models/default.kata", "--teacher", taught, "--student", recorded,
                        "--layout", "mediapipe", "--time-units", "s", "--out", taught_csv],
                       cwd=a.source_dir, check=True, stdout=subprocess.DEVNULL)
        taught_rows = list(csv.DictReader(open(taught_csv)))
        assert not [r for r in taught_rows if r["state"] == "tracking_lost"], "frames lost against the recorded teacher"
        scored = [float(r["score"]) for r in taught_rows if r["state"] in ("scoring", "teacher_finished")]
        # The student's first frames calibrate (about 5 s of them: 3-6 frames at this rate).
        assert len(scored) >= 5, f"only {len(scored)} of {len(taught_rows)} frames scored against the recorded teacher"
        median = float(np.median(scored))
        assert median > 90, f"the same photograph scores a median {median:.1f} against its own recording"
        print(f"record-teacher: {values.shape[0]} frames x 33 x 4 with times 0..{times[-1]:.2f} s; a lesson loads it; "
              f"the student of 1. scores a median {median:.1f} against it [{time.monotonic() - started:.0f} s]")
        print(f"wall time {time.monotonic() - started:.1f} s")
        return 0
    finally:
        if driver:
            driver.quit()
        for p in procs:
            if p.poll() is None:
                p.kill()
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
