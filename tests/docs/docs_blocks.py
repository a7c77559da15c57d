#!/usr/bin/python3
"""Documentation that cannot go stale (issue 37): every shell and Python block of README.md and
docs/quickstart.md run as a newcomer would, from `cmake --install` of this build into a fresh
~/kata (HOME is a scratch folder), each document's blocks in order in an empty folder of its own,
with nothing of the checkout on PATH or PYTHONPATH.

Marks, an HTML comment on the line before a block:
  <!-- docs_blocks: skip: REASON -->   not run (needs a camera, a browser, the checkout...); the
                                        reason is printed, and a skip without one fails the test
  <!-- docs_blocks: file NAME -->       the block is written to NAME (a C program the next block builds)
Unmarked ```sh / ```python blocks run (sh in one bash process per document, so `export` and
shell variables carry from block to block; python with /usr/bin/python3 and that environment);
```c and other blocks are fragments, not run. The only text changed: the ports 5555 / 5556 become
free ones, so two runs on one machine cannot collide.

  docs_blocks.py SOURCE_DIR BUILD_DIR WORK_DIR"""
import os
import re
import shutil
import signal
import subprocess
import sys
import time

source, build, work = sys.argv[1:4]
DOCS = ["README.md", "docs/quickstart.md"]
# Fewest blocks each document must run: a document whose blocks all went (or were all skipped)
# would otherwise pass in silence.
MINIMUM_RUN = {"README.md": 3, "docs/quickstart.md": 10}
ONLY = os.environ.get("KATA_DOCS_ONLY")
FENCE = re.compile(r"^```([A-Za-z0-9_+-]*)\s*$")
MARK = re.compile(r"^<!--\s*docs_blocks:\s*(skip|file)\b:?\s*(.*?)\s*-->\s*$")


def blocks(path):
    """(line, language, mark, argument, text) of every fenced block of a Markdown file."""
    lines = open(path, encoding="utf-8").read().split("\n")
    out, i = [], 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m or not m.group(1):
            i += 1
            continue
        start, language = i, m.group(1)
        j = i + 1
        while j < len(lines) and lines[j].rstrip() != "```":
            j += 1
        mark = MARK.match(lines[start - 1]) if start > 0 else None
        out.append((start + 1, language, mark.group(1) if mark else None, mark.group(2) if mark else "",
                    "\n".join(lines[start + 1:j])))
        i = j + 1
    return out


sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from ports import free_port  # noqa: E402  below the ephemeral range (tests/support/ports.py)


started = time.monotonic()
shutil.rmtree(work, ignore_errors=True)
home = os.path.join(work, "home")
os.makedirs(home)
prefix = os.path.join(home, "kata")
r = subprocess.run(["cmake", "--install", build, "--prefix", prefix], capture_output=True, text=True)
assert r.returncode == 0, "cmake --install failed:\n" + r.stdout + r.stderr
ports = {"5555": str(free_port()), "5556": str(free_port())}
env = {"HOME": home, "PATH": "/usr/local/bin:/usr/bin:/bin", "LANG": "C.UTF-8", "TMPDIR": work,
       "PYTHONDONTWRITEBYTECODE": "1", "PIP_NO_INDEX": "1"}
failures = []
for doc in [d for d in DOCS if not ONLY or d == ONLY]:
    script = ["set -e"]
    ran, skipped = 0, []
    for line, language, mark, argument, text in blocks(os.path.join(source, doc)):
        text = re.sub("5555|5556", lambda m: ports[m.group(0)], text)  # one pass: a new port may contain 5556
        where = "%s:%d" % (doc, line)
        if mark == "skip":
            if not argument:
                failures.append("%s: a skipped block must say why (<!-- docs_blocks: skip: REASON -->)" % where)
            skipped.append("%s (%s): %s" % (where, language, argument))
            continue
        if mark == "file":
            if not re.fullmatch(r"[A-Za-z0-9_.-]+", argument):
                failures.append("%s: file name %r" % (where, argument))
                continue
            script += ["echo '@@ %s: writes %s' >&2" % (where, argument), "cat > %s <<'KATA_DOCS_FILE'" % argument,
                       text, "KATA_DOCS_FILE"]
            continue
        if language in ("sh", "bash", "shell"):
            script += ["echo '@@ %s: sh' >&2" % where, text]
        elif language == "python":
            script += ["echo '@@ %s: python' >&2" % where, "/usr/bin/python3 - <<'KATA_DOCS_PY'", text, "KATA_DOCS_PY"]
        else:
            continue
        ran += 1
    script.append("echo '@@ %s: every block ran' >&2" % doc)
    folder = os.path.join(work, re.sub(r"\W", "_", doc))
    os.makedirs(folder)
    open(os.path.join(folder, ".blocks.sh"), "w").write("\n".join(script) + "\n")
    t0 = time.monotonic()
    # Output to a file, not a pipe: a block's background process (a kata serve) would hold a pipe
    # open after a failed block ended the script.
    log_path = os.path.join(folder, ".blocks.log")
    with open(log_path, "w") as log:
        p = subprocess.Popen(["bash", ".blocks.sh"], cwd=folder, env=env, stdout=log, stderr=subprocess.STDOUT,
                             start_new_session=True)
        try:
            p.wait(timeout=150)
            timed_out = ""
        except subprocess.TimeoutExpired:
            timed_out = "\n(timed out after 150 s)"
        try:  # whatever a block left running in the background ends with the document
            os.killpg(p.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        p.wait()
    output = open(log_path, encoding="utf-8", errors="replace").read() + timed_out
    print("==== %s: %d blocks run in %.1f s, %d skipped" % (doc, ran, time.monotonic() - t0, len(skipped)))
    for s in skipped:
        print("  skipped %s" % s)
    if p.returncode != 0 or "@@ %s: every block ran" % doc not in output:
        last = [l for l in output.split("\n") if l.startswith("@@ ")]
        failures.append("%s: the block at %s failed (exit %s); its output:\n%s" % (
            doc, last[-1][3:] if last else "?", p.returncode, output[-4000:]))
    else:
        print(output[-3000:])
    if ran < MINIMUM_RUN[doc]:
        failures.append("%s: only %d blocks ran (at least %d expected)" % (doc, ran, MINIMUM_RUN[doc]))
print("docs_blocks: %.1f s" % (time.monotonic() - started))
if failures:
    print("\n".join("FAILED " + f for f in failures))
    sys.exit(1)
shutil.rmtree(work, ignore_errors=True)
