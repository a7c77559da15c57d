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
     goes from calibrating to scored, the ghost comes with the scores, no console error.
  2. The page adds nothing but transport: the landmarks kata received (--record-student, .npy +
     .times.npy) read back by `kata score` from the file give, frame by frame, the scores the page
     received.
  3. With nobody in view: the page and kata say "not in frame", and the lesson survives (the coach
     keeps answering, nothing is refused, it ends cleanly with its report).

Usage: coach_webcam_browser_test.py --kata build/bin/kata --source-dir . [--screenshots DIR]
       [--photo PATH]. Every wait is bounded.
"""
import argparse
import csv
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import urllib.request

from selenium import webdriver
from selenium.common.exceptions import TimeoutException
from selenium.webdriver.chrome.service import Service

PHOTO = "/usr/share/doc/opencv-doc/examples/data/basketball1.png"
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--no-first-run", "--window-size=1100,760",
                  "--use-fake-device-for-media-stream", "--use-fake-ui-for-media-stream",
                  # --disable-gpu leaves WebGL to SwiftShader (software); say so, or Chromium warns.
                  "--enable-unsafe-swiftshader"]


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
    ap.add_argument("--screenshots")
    a = ap.parse_args()
    if not os.path.exists(PHOTO) or not shutil.which("ffmpeg"):
        print("SKIP: needs opencv-doc (the photograph) and ffmpeg")
        return 0
    kata = os.path.abspath(a.kata)
    work = tempfile.mkdtemp(prefix="kata_webcam_browser_")
    started = time.monotonic()
    procs, driver = [], None
    try:
        person, nobody = os.path.join(work, "person.y4m"), os.path.join(work, "nobody.y4m")
        make_video(person, "240:480:0:0")      # the man on the left, head to feet
        make_video(nobody, "220:480:205:0")    # the wall and the door between the two men
        recorded = os.path.join(work, "student.npy")

        # 1. A person in front of the camera.
        coach, port, log = start_coach(kata, a.source_dir, work, "person", ["--record-student", recorded])
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
        assert any(e["ghost"] for e in h["events"] if e["score"] is not None), "no ghost came with the scores"
        errors = severe(driver)
        assert not errors, f"console errors: {errors}"
        time.sleep(1.0)
        if a.screenshots:
            os.makedirs(a.screenshots, exist_ok=True)
            driver.save_screenshot(os.path.join(a.screenshots, "coach-webcam.png"))
        h = hook()
        per_frame = (time.monotonic() - t_first) / max(1, h["personFrames"])
        print(f"person: states {states}, {h['personFrames']} frames with landmarks, {h['results']} results, "
              f"{h['scored']} scored; {per_frame:.2f} s per camera frame; latency {json.dumps(h['latency'])}")
        driver.quit()
        driver = None
        assert stop(coach) == 0, open(log).read()
        summary = open(log).read()
        assert "webcam:" in summary and "report:" in summary, summary

        # 2. The page adds nothing but transport: the file kata recorded, scored by `kata score`.
        scores_csv = os.path.join(work, "scores.csv")
        subprocess.run([kata, "score", "--model", "models/default.kata", "--teacher", "data/cmu/05_18.bvh",
                        "--teacher-layout", "cmu", "--student", recorded, "--student-layout", "mediapipe",
                        "--time-units", "s", "--first-frame", "0", "--out", scores_csv],
                       cwd=a.source_dir, check=True, stdout=subprocess.DEVNULL)
        rows = list(csv.DictReader(open(scores_csv)))
        events = [e for e in h["events"] if e["capture_ms"] is not None]
        first_ms = min(e["capture_ms"] for e in events)
        by_time = {round(float(r["time"]), 3): r for r in rows}
        compared, worst = 0, 0.0
        for e in events:
            if e["score"] is None:
                continue
            r = by_time.get(round((e["capture_ms"] - first_ms) / 1000.0, 3))
            assert r is not None, f"page frame {e['seq']} is not in the recording"
            assert r["state"] in ("scoring", "teacher_finished"), f"frame {e['seq']}: page scored, file {r['state']}"
            worst = max(worst, abs(float(r["score"]) - e["score"]))
            compared += 1
        assert compared >= 10, f"only {compared} frames compared"
        assert worst < 1e-3, f"page and file scores differ by up to {worst}"
        print(f"page vs file: {compared} scored frames, worst score difference {worst:.2g}")

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
        print(f"nobody: page and kata say 'not in frame' ({s['not_in_frame']} frames), coach ended cleanly")
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
