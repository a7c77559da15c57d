#!/usr/bin/python3
"""The wheel as a user gets it: `pip wheel` of bindings/python (a copy, so the checkout stays
clean) with this build's libkata and FlatBuffers readers, installed into a fresh virtual
environment (Debian's numpy through --system-site-packages; no package index), and the binding's
tests run against the installed package, from a directory outside the checkout and without
KATA_LIBRARY, so libkata can only come from the package folder.

  wheel_test.py PYTHON SOURCE_DIR LIBKATA FB_DIR WORK_DIR   (environment: KATA_CLI, ... for pytest)"""
import os
import shutil
import subprocess
import sys
import time

python, source, libkata, fb_dir, work = sys.argv[1:6]
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
started = time.monotonic()
src = os.path.join(work, "src")
shutil.copytree(os.path.join(source, "bindings", "python"), src,
                ignore=shutil.ignore_patterns("build", "dist", "*.egg-info", "__pycache__", "tests"))
env = dict(os.environ, KATA_LIBRARY=libkata, KATA_PYTHON_FB=fb_dir,
           KATA_HEADER=os.path.join(source, "sdk", "include", "kata", "core.h"),
           KATA_MODEL=os.path.join(source, "models", "default.kata"), KATA_DATA=os.path.join(source, "data", "cmu"),
           PIP_NO_INDEX="1",
           PIP_DISABLE_PIP_VERSION_CHECK="1")
dist = os.path.join(work, "dist")
subprocess.run([python, "-m", "pip", "wheel", "-q", "--no-build-isolation", "--no-deps", "-w", dist, src],
               check=True, env=env, cwd=work)
wheels = [w for w in os.listdir(dist) if w.endswith(".whl")]
assert len(wheels) == 1 and wheels[0].startswith("kata-") and "linux" in wheels[0], wheels
venv = os.path.join(work, "venv")
subprocess.run([python, "-m", "venv", "--system-site-packages", venv], check=True)
vpython = os.path.join(venv, "bin", "python")
subprocess.run([vpython, "-m", "pip", "install", "-q", "--no-deps", os.path.join(dist, wheels[0])],
               check=True, env=dict(os.environ, PIP_NO_INDEX="1", PIP_DISABLE_PIP_VERSION_CHECK="1"), cwd=work)
built = time.monotonic()
# The clips the README's wheel examples load are in the package itself (not the checkout's, not an
# install's share/kata): find_data from an empty folder outside the checkout.
site = subprocess.run([vpython, "-c", "import kata, os; print(os.path.dirname(kata.__file__))"], cwd=work,
                      capture_output=True, text=True, check=True).stdout.strip()
for clip in ("data/cmu/02_01.bvh", "data/cmu/07_01.bvh", "data/cmu/05_18.bvh", "models/default.kata"):
    found = subprocess.run([vpython, "-c", "import kata; print(kata.find_data(%r))" % clip], cwd=work,
                           capture_output=True, text=True, env={"PATH": "/usr/bin:/bin", "HOME": work})
    assert found.returncode == 0 and found.stdout.strip() == os.path.join(site, clip), (clip, found.stdout, found.stderr)
test_env = {k: v for k, v in os.environ.items() if k not in ("KATA_LIBRARY", "PYTHONPATH")}
test_env.update(KATA_TEST_INSTALLED="1", PYTHONDONTWRITEBYTECODE="1")
rc = subprocess.run([vpython, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                     os.path.join(source, "bindings", "python", "tests")], env=test_env, cwd=work).returncode
print("wheel %s: built and installed in %.1f s, tests %.1f s" % (wheels[0], built - started, time.monotonic() - built))
sys.exit(rc)
