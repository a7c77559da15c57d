#!/usr/bin/python3
"""Documentation that cannot go stale: every page the install carries (share/doc/kata: docs/*.md,
docs/*/*.md, README.md, CHANGELOG.md, bindings.md), read as installed, after `cmake --install` of
this build into a fresh ~/kata (HOME is a scratch folder).

The tutorials (README.md and quickstart.md) are run as a newcomer would: each document's blocks in
order in an empty folder of its own, with nothing of the checkout on PATH or PYTHONPATH.
Every block of every installed page is checked without running it:
  ```sh      bash -n parses it, and each `kata CMD --flag ...` names a command the installed kata
             has and only flags its `kata CMD --help` lists;
  ```python  compiles;
  ```toml    parses (tomllib), and a config with [ingest] or [transport] has only the sections
             kata serve reads.

Marks, an HTML comment on the line before a block:
  <!-- docs_blocks: skip: REASON -->   not run (needs a camera, a browser, the checkout...); the
                                        reason is printed, and a skip without one fails the test
                                        (the checks above still apply)
  <!-- docs_blocks: file NAME -->       the block is written to NAME (a C program the next block builds)
Unmarked ```sh / ```python blocks of the tutorials run (sh in one bash process per document, so
`export` and shell variables carry from block to block; python with /usr/bin/python3 and that
environment); ```c and other blocks are fragments, not run. The only text changed: the ports 5555 /
5556 become free ones, so two runs on one machine cannot collide.

  docs_blocks.py SOURCE_DIR BUILD_DIR WORK_DIR"""
import glob
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import time
import tomllib

source, build, work = sys.argv[1:4]
# The tutorials, run block by block (paths under share/doc/kata), and the fewest blocks each must
# run: a document whose blocks all went (or were all skipped) would otherwise pass in silence.
MINIMUM_RUN = {"README.md": 3, "quickstart.md": 10}
DOCS = list(MINIMUM_RUN)
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
doc_dir = os.path.join(prefix, "share", "doc", "kata")
kata = os.path.join(prefix, "bin", "kata")
pages = sorted(os.path.relpath(p, doc_dir) for p in glob.glob(os.path.join(doc_dir, "**", "*.md"), recursive=True))
for doc in DOCS:
    if doc not in pages:
        failures.append("%s is not installed in share/doc/kata" % doc)

# Every block of every installed page, checked without running it.
helps = {}


def kata_flags(command):
    """The flags `kata COMMAND --help` lists, or None when kata has no such command."""
    if command not in helps:
        r = subprocess.run([kata, command, "--help"], capture_output=True, text=True, env=env)
        helps[command] = set(re.findall(r"(?<![\w-])--[a-z0-9][a-z0-9-]*", r.stdout)) if r.returncode == 0 else None
    return helps[command]


def kata_calls(text):
    """(command, [flags]) of each `kata CMD ...` a shell block runs (continuation lines joined)."""
    out = []
    for line in text.replace("\\\n", " ").split("\n"):
        try:
            words = shlex.split(line, comments=True)
        except ValueError:
            continue
        call = []
        for w in words + [";"]:
            if w in (";", "&&", "||", "|", "&") or w.endswith(";"):
                if w.endswith(";") and w != ";":
                    call.append(w[:-1])
                if len(call) >= 2 and os.path.basename(call[0]) == "kata" and not call[1].startswith("-"):
                    out.append((call[1], [a.split("=")[0] for a in call[2:] if a.startswith("--")]))
                call = []
            else:
                call.append(w)
    return out


SERVE_SECTIONS = {"ingest", "publish", "runtime", "scoring", "status", "plugins", "shard", "security", "transport"}
checked = 0
for page in pages if not ONLY else []:
    for line, language, mark, argument, text in blocks(os.path.join(doc_dir, page)):
        where = "share/doc/kata/%s:%d" % (page, line)
        checked += 1
        if language in ("sh", "bash", "shell"):
            r = subprocess.run(["bash", "-n"], input=text, capture_output=True, text=True)
            if r.returncode != 0:
                failures.append("%s: the shell block does not parse: %s" % (where, r.stderr.strip()))
            for command, flags in kata_calls(text):
                known = kata_flags(command)
                if known is None:
                    failures.append("%s: `kata %s`: the installed kata has no such command" % (where, command))
                    continue
                for flag in flags:
                    if flag not in known and flag != "--help":
                        failures.append("%s: `kata %s %s`: no such option (kata %s --help)" % (where, command, flag, command))
        elif language == "python":
            try:
                compile(text, where, "exec")
            except SyntaxError as e:
                failures.append("%s: the Python block does not compile: %s" % (where, e))
        elif language == "toml":
            try:
                config = tomllib.loads(text)
            except tomllib.TOMLDecodeError as e:
                failures.append("%s: the TOML block does not parse: %s" % (where, e))
                continue
            if "ingest" in config or "transport" in config:
                for section in set(config) - SERVE_SECTIONS:
                    failures.append("%s: [%s] is not a section kata serve reads (docs/config.md)" % (where, section))
print("checked %d blocks of %d installed pages (%d kata commands' options)" % (checked, len(pages), len(helps)))

for doc in [d for d in DOCS if not ONLY or d == ONLY]:
    script = ["set -e"]
    ran, skipped = 0, []
    for line, language, mark, argument, text in blocks(os.path.join(doc_dir, doc)):
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
