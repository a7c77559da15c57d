#!/usr/bin/python3
"""The install matches the docs, from `cmake --install` into a fresh prefix, each check
in an empty folder with nothing of the checkout on PATH or PYTHONPATH:
- installed executables carry a RUNPATH to the library folder; kata.pc says how to get an rpath;
- the samples are installed under share/kata/samples; the installed Python package finds
  share/kata (the model and the clips) and its python_subscriber.py needs no --python-dir;
- docs/config.md's minimal config and docs/deploy.md's stage config, as installed in
  share/doc/kata, start `kata serve` from the
  install (their model and teacher clip are installed; ports made free ones, deploy.md's 0.0.0.0
  bound as 127.0.0.1), and `kata replay` finds its clips;
- `kata serve`'s status line is one line per second into a file (no carriage returns), and a
  keyless sender against a CURVE ingest is named as such in its log;
- `kata coach` on a port in use says why and suggests --port 0;
- `--student-layout cmu` reads a (frames, 31, 3) array as the clip it came from;
- pip: a python without `wheel` gets a message naming it, and `pip wheel ./bindings/python`
  writes nothing into the source folder.

  install_check.py SOURCE_DIR BUILD_DIR WORK_DIR"""
import glob
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time

source, build, work = sys.argv[1:4]
started = time.monotonic()
shutil.rmtree(work, ignore_errors=True)
prefix = os.path.join(work, "prefix")
r = subprocess.run(["cmake", "--install", build, "--prefix", prefix], capture_output=True, text=True)
assert r.returncode == 0, r.stdout + r.stderr
kata = os.path.join(prefix, "bin", "kata")
share = os.path.join(prefix, "share", "kata")
site = glob.glob(os.path.join(prefix, "lib*", "python3*", "*-packages"))
assert len(site) == 1, site
env = {"HOME": work, "PATH": "/usr/local/bin:/usr/bin:/bin", "LANG": "C.UTF-8", "PYTHONDONTWRITEBYTECODE": "1"}
checks = []


def folder(name):
    d = os.path.join(work, name)
    os.makedirs(d)
    return d


sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from ports import free_port  # noqa: E402  below the ephemeral range (tests/support/ports.py)


def check(name):
    def wrap(f):
        t0 = time.monotonic()
        f()
        checks.append("%-60s %.1f s" % (name, time.monotonic() - t0))
    return wrap


def serve(config_dir, config, seconds, sender=None):
    """kata serve --config until it says it publishes (at most 30 s: a loaded machine takes longer
    to load the model and teacher than a fixed sleep allowed), then `seconds` more (stderr to a
    file), optionally running sender() meanwhile; the log after SIGINT."""
    log = open(os.path.join(config_dir, "serve.log"), "w")
    p = subprocess.Popen([kata, "serve", "--config", config], cwd=config_dir, env=env, stderr=log,
                         stdout=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 30
        while p.poll() is None and time.monotonic() < deadline and "publishing on" not in open(log.name).read():
            time.sleep(0.05)
        if sender:
            sender()
        time.sleep(seconds)
        assert p.poll() is None, open(log.name).read()
    finally:
        p.send_signal(signal.SIGINT)
        p.wait(timeout=30)
        log.close()
    return open(log.name).read()


@check("RUNPATH of bin/kata; kata.pc's rpath variable")
def _():
    r = subprocess.run(["readelf", "-d", kata], capture_output=True, text=True, check=True)
    assert re.search(r"RUNPATH.*\[\$ORIGIN/\.\./lib[^\]]*\]", r.stdout), r.stdout
    pc = glob.glob(os.path.join(prefix, "lib*", "pkgconfig"))[0]
    r = subprocess.run(["pkg-config", "--variable=rpath", "kata"], capture_output=True, text=True, check=True,
                       env=dict(env, PKG_CONFIG_PATH=pc))
    flag, _, path = r.stdout.strip().partition(",-rpath,")
    assert flag == "-Wl" and os.path.realpath(path) == os.path.realpath(os.path.dirname(pc)), r.stdout


@check("samples under share/kata/samples")
def _():
    for f in ("CMakeLists.txt", "stream_features.c", "c_subscriber.c", "python_subscriber.py",
              "python/score_landmarks.py", "csharp/KataCoach.cs"):
        assert os.path.isfile(os.path.join(share, "samples", f)), f


@check("installed Python: share/kata found, python_subscriber without --python-dir")
def _():
    d = folder("python")
    code = "import kata, os; print(os.path.realpath(kata.default_model_path())); print(kata.find_data('data/cmu/02_01.bvh'))"
    r = subprocess.run(["/usr/bin/python3", "-c", code], cwd=d, capture_output=True, text=True,
                       env=dict(env, PYTHONPATH=site[0]))
    assert r.returncode == 0, r.stderr
    model, clip = r.stdout.split()
    assert model == os.path.realpath(os.path.join(share, "models", "default.kata")), r.stdout
    assert os.path.realpath(clip) == os.path.realpath(os.path.join(share, "data", "cmu", "02_01.bvh")), r.stdout
    # No PYTHONPATH at all: the sample finds the package of the install it sits in.
    r = subprocess.run(["/usr/bin/python3", os.path.join(share, "samples", "python_subscriber.py"), "--endpoint",
                        "ipc://%s/nobody" % d, "--count", "1", "--timeout", "0.3"], cwd=d, capture_output=True,
                       text=True, env=env)
    assert r.returncode == 1 and "kata.fb" not in r.stderr and "Traceback" not in r.stderr, r.stderr


@check("docs/config.md's minimal config and docs/deploy.md's stage config serve (the installed pages)")
def _():
    text = open(os.path.join(prefix, "share", "doc", "kata", "config.md"), encoding="utf-8").read()
    minimal = re.search(r"Minimal:\n\n```toml\n(.*?)```", text, re.S).group(1)
    ports = {"5555": str(free_port()), "5556": str(free_port())}
    # One pass: a new port may itself contain "5556" (25556), which a second replace would change.
    port_re = re.compile("|".join(ports))
    minimal = port_re.sub(lambda m: ports[m.group(0)], minimal)
    d = folder("config_md")
    open(os.path.join(d, "stage.toml"), "w").write(minimal)
    log = serve(d, "stage.toml", 0.5)
    assert "publishing on tcp://127.0.0.1:%s" % ports["5556"] in log, log
    text = open(os.path.join(prefix, "share", "doc", "kata", "deploy.md"), encoding="utf-8").read()
    stage = re.search(r"```toml\n(# stage.toml.*?)```", text, re.S).group(1)
    stage = port_re.sub(lambda m: ports[m.group(0)], stage).replace("0.0.0.0", "127.0.0.1")
    d = folder("deploy_md")
    for name in ("server", "clients/stage", "clients/viewer"):
        subprocess.run([kata, "keygen", "--out", "keys/" + name], cwd=d, env=env, check=True, capture_output=True)
    open(os.path.join(d, "stage.toml"), "w").write(stage)
    log = serve(d, "stage.toml", 0.5)
    assert "publishing on tcp://127.0.0.1:%s" % ports["5556"] in log, log


@check("kata serve: status lines into a file; a keyless sender named as CURVE")
def _():
    d = folder("curve")
    subprocess.run([kata, "keygen", "--out", "keys/server"], cwd=d, env=env, check=True, capture_output=True)
    port = free_port()
    open(os.path.join(d, "s.toml"), "w").write(
        '[ingest]\nendpoints = ["bind:tcp://127.0.0.1:%d"]\nkind = "pull"\n[publish]\nendpoints = ["tcp://127.0.0.1:%d"]\n'
        '[security]\nkey = "keys/server.secret"\n[scoring]\nmodel = "models/default.kata"\nteacher = "data/cmu/02_01.bvh"\n'
        % (port, free_port()))

    def keyless():
        subprocess.run([kata, "send", "--bvh", "data/cmu/07_01.bvh", "--endpoint", "tcp://127.0.0.1:%d" % port,
                        "--frames", "10", "--connect-timeout", "1"], cwd=d, env=env, capture_output=True)
    log = serve(d, "s.toml", 1.2, keyless)
    assert "\r" not in log, repr(log[-500:])
    assert len(re.findall(r"^streams \d+ \| in ", log, re.M)) >= 2, log
    refused = [line for line in log.split("\n") if "refused at the handshake" in line]
    assert refused and "CURVE is set on one side only" in refused[0], log


@check("kata replay finds its clips and model from the install")
def _():
    d = folder("replay")
    r = subprocess.run([kata, "replay", "--streams", "1", "--rate", "30", "--seconds", "0.5", "--out", "r.json"], cwd=d,
                       env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and os.path.exists(os.path.join(d, "r.json")), r.stdout[-2000:] + r.stderr[-2000:]


@check("kata coach on a busy port: the reason and --port 0")
def _():
    if not os.path.isfile(os.path.join(share, "viewer", "index.html")):
        checks.append("  (no viewer built: skipped)")
        return
    d = folder("coach")
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        r = subprocess.run([kata, "coach", "--speed", "16", "--port", str(port)], cwd=d, env=env, capture_output=True,
                           text=True, timeout=60)
    assert r.returncode != 0, r.stdout
    assert "cannot listen on 127.0.0.1:%d: Address already in use" % port in r.stderr and "--port 0" in r.stderr, r.stderr


@check("--student-layout cmu reads a CMU array as its clip")
def _():
    d = folder("cmu_array")
    code = ("import kata, numpy as np\nwith kata.Context() as c, c.load_clip(kata.find_data('data/cmu/07_01.bvh')) as k:\n"
            "    np.save('cmu31.npy', k.all_positions(1)); print(1.0 / k.frame_time)")
    r = subprocess.run(["/usr/bin/python3", "-c", code], cwd=d, capture_output=True, text=True,
                       env=dict(env, PYTHONPATH=site[0]), check=True)
    fps = r.stdout.strip()
    common = [kata, "score", "--model", "models/default.kata", "--teacher", "data/cmu/02_01.bvh", "--layout", "cmu"]
    r = subprocess.run(common + ["--student", "cmu31.npy", "--student-layout", "cmu", "--fps", fps, "--out", "a.csv"],
                       cwd=d, env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    mean = re.search(r"mean score ([0-9.]+)", r.stdout)
    assert mean and float(mean.group(1)) > 50, r.stdout


@check("pip: no wheel named; nothing written into the source folder")
def _():
    d = folder("pip")
    src = os.path.join(d, "src")
    shutil.copytree(os.path.join(source, "bindings", "python"), src, ignore=shutil.ignore_patterns("tests", "__pycache__"))
    no_wheel = ("import sys; sys.modules['wheel'] = None; sys.modules['wheel.bdist_wheel'] = None; "
                "sys.argv = ['setup.py', '--version']; exec(open('setup.py').read())")
    r = subprocess.run(["/usr/bin/python3", "-c", no_wheel], cwd=src, capture_output=True, text=True, env=env)
    assert r.returncode != 0 and "neither the 'wheel' package" in (r.stdout + r.stderr), r.stdout + r.stderr
    before = sorted(os.listdir(src))
    r = subprocess.run(["/usr/bin/python3", "-m", "pip", "wheel", "-q", "--no-build-isolation", "--no-deps", "-w",
                        os.path.join(d, "dist"), src], cwd=d, capture_output=True, text=True,
                       env=dict(env, PIP_NO_INDEX="1", PIP_DISABLE_PIP_VERSION_CHECK="1",
                                KATA_LIBRARY=os.path.join(build, "lib", "libkata.so"),
                                KATA_PYTHON_FB=os.path.join(build, "python", "kata", "fb"),
                                KATA_HEADER=os.path.join(source, "sdk", "include", "kata", "core.h"),
                                KATA_MODEL=os.path.join(source, "models", "default.kata"),
                                KATA_DATA=os.path.join(source, "data", "cmu")))
    assert r.returncode == 0, r.stderr
    assert sorted(os.listdir(src)) == before, sorted(set(os.listdir(src)) - set(before))


print("\n".join(checks))
print("install_check: %.1f s" % (time.monotonic() - started))
shutil.rmtree(work, ignore_errors=True)
