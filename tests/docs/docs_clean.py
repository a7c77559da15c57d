#!/usr/bin/python3
"""The user docs as installed: complete, linked, current, and a manual rather than a lab notebook.
From `cmake --install` of this build into a scratch prefix:
- every page of docs/ (docs/*.md and docs/*/*.md, but docs/notes/) is installed unchanged under
  share/doc/kata, with README.md, CHANGELOG.md and the bindings' README (bindings.md), and the
  quickstart, the config reference and the CLI reference are among them;
- every relative link of an installed page reaches an installed file;
- docs/cli.md is what tests/docs/cli_reference.py writes from the installed `kata`'s --help;
- every `kata CMD --help` names documentation by an installed path that exists (no docs/*.md of
  a checkout the user does not have);
- no installed page, sample, header, schema, Python module, C# file or --help text carries an
  issue number ("issue 12", "#12"), development-session talk ("this session", "the lead",
  "other engineers' builds", "this branch", "main at 1a2b3c4"), a dated log entry (2026-12-04:
  dates belong to docs/notes/ and to the CHANGELOG's release headings) or a path of the machine a
  figure was taken on (/work/..., /root, /home/..., ../shared/...).

  docs_clean.py SOURCE_DIR BUILD_DIR WORK_DIR"""
import filecmp
import glob
import os
import re
import shutil
import subprocess
import sys

source, build, work = sys.argv[1:4]
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cli_reference import commands, reference  # noqa: E402

shutil.rmtree(work, ignore_errors=True)
prefix = os.path.join(work, "prefix")
r = subprocess.run(["cmake", "--install", build, "--prefix", prefix], capture_output=True, text=True)
assert r.returncode == 0, "cmake --install failed:\n" + r.stdout + r.stderr
doc = os.path.join(prefix, "share", "doc", "kata")
kata = os.path.join(prefix, "bin", "kata")
failures = []

# Installed, unchanged, and the pages a newcomer needs are among them.
pages = {}
for path in glob.glob(os.path.join(source, "docs", "*.md")) + glob.glob(os.path.join(source, "docs", "*", "*.md")):
    rel = os.path.relpath(path, os.path.join(source, "docs"))
    if not rel.startswith("notes" + os.sep):
        pages[rel] = path
pages.update({"README.md": os.path.join(source, "README.md"), "CHANGELOG.md": os.path.join(source, "CHANGELOG.md"),
              "bindings.md": os.path.join(source, "bindings", "README.md")})
for rel, path in sorted(pages.items()):
    installed = os.path.join(doc, rel)
    if not os.path.isfile(installed):
        failures.append("%s is not installed (share/doc/kata/%s; docs/CMakeLists.txt)" % (os.path.relpath(path, source), rel))
    elif not filecmp.cmp(path, installed, shallow=False):
        failures.append("share/doc/kata/%s differs from %s" % (rel, os.path.relpath(path, source)))
for needed in ("quickstart.md", "config.md", "cli.md", "runtime.md", "deploy.md", "performance.md", "bindings.md"):
    if needed not in pages:
        failures.append("no %s among the installed docs" % needed)
installed_md = sorted(os.path.relpath(p, doc) for p in glob.glob(os.path.join(doc, "**", "*.md"), recursive=True))
print("installed docs: %d pages under share/doc/kata" % len(installed_md))

# Links between the installed pages.
LINK = re.compile(r"\]\(([^)\s]+)\)")
for rel in installed_md:
    text = open(os.path.join(doc, rel), encoding="utf-8").read()
    for n, line in enumerate(text.split("\n"), 1):
        for target in LINK.findall(line):
            if re.match(r"^[a-z]+:", target) or target.startswith("#"):
                continue
            path = os.path.normpath(os.path.join(doc, os.path.dirname(rel), target.split("#")[0]))
            if not os.path.exists(path):
                failures.append("share/doc/kata/%s:%d: the link %s reaches no installed file" % (rel, n, target))

# The CLI reference is the CLI's own help, current.
generated = reference(kata)
if open(os.path.join(source, "docs", "cli.md"), encoding="utf-8").read() != generated:
    failures.append("docs/cli.md is not what `kata CMD --help` prints now: regenerate it with\n"
                    "  cmake --install build --prefix /tmp/k && /usr/bin/python3 tests/docs/cli_reference.py "
                    "/tmp/k/bin/kata > docs/cli.md")

# --help names installed documentation, and it exists.
helps = {}
top = subprocess.run([kata, "--help"], capture_output=True, text=True).stdout
if not commands(top):
    failures.append("kata --help lists no subcommands:\n" + top)
helps["kata --help"] = top
for name, _ in commands(top):
    r = subprocess.run([kata, name, "--help"], capture_output=True, text=True)
    helps["kata %s --help" % name] = r.stdout + r.stderr
for what, text in helps.items():
    for path in re.findall(re.escape(doc) + r"/[\w./-]*\w", text):
        if not os.path.isfile(path):
            failures.append("%s names %s, which the install does not have" % (what, path))
    for m in re.finditer(r"(?<![\w/])docs/[\w/.-]+\.md", text):
        failures.append("%s names %s, a page of the source tree, not the installed one" % (what, m.group(0)))

# A manual, not a lab notebook.
FORBIDDEN = [
    (re.compile(r"\bissues? #?[0-9]+", re.I), "an issue number"),
    (re.compile(r"(?<![\w&/#])#[0-9]{1,5}\b(?![0-9a-fA-F])"), "an issue reference (#N)"),
    (re.compile(r"\b(this|last|next|previous|that|the|a later|an earlier) session\b|\bsession [0-9]+\b|\bthe session's\b",
                re.I), "development-session talk"),
    (re.compile(r"\bthe lead\b|\bother engineers\b|\bengineers' (builds|compilers)\b|\bhelpers? building\b|"
                r"\bthis branch\b|\btoday's main\b|\bmain (at |\()?[0-9a-f]{7}\b", re.I), "development-process talk"),
    (re.compile(r"\b20[0-9]{2}-[01][0-9]-[0-3][0-9]\b"), "a dated log entry"),
    (re.compile(r"(?<![\w.])/(work|root|home)(/|\b)|\.\./shared/"), "a path of the development machine"),
]


def scan(what, text, dated_headings=False):
    for n, line in enumerate(text.split("\n"), 1):
        for pattern, name in FORBIDDEN:
            m = pattern.search(line)
            if not m:
                continue
            if name == "a dated log entry" and dated_headings and line.startswith("## ["):
                continue  # a release heading: ## [1.0.0] - 2026-12-01
            failures.append("%s:%d: %s (%r): %s" % (what, n, name, m.group(0), line.strip()[:160]))


shipped = []
for rel in installed_md:
    shipped.append(("share/doc/kata/" + rel, os.path.join(doc, rel)))
for folder, pattern in (("share/kata/samples", "**/*"), ("share/kata/schemas", "**/*.fbs"), ("include/kata", "**/*.h"),
                        ("share/kata/csharp", "*.cs"), ("share/kata/data/cmu", "*.md")):
    for path in glob.glob(os.path.join(prefix, folder, pattern), recursive=True):
        if os.path.isfile(path):
            shipped.append((os.path.relpath(path, prefix), path))
for path in glob.glob(os.path.join(prefix, "lib*", "python3*", "*-packages", "kata", "*.py")):
    shipped.append((os.path.relpath(path, prefix), path))
for what, path in shipped:
    try:
        text = open(path, encoding="utf-8").read()
    except UnicodeDecodeError:
        continue  # a binary (a built sample)
    scan(what, text, dated_headings=what.endswith("CHANGELOG.md"))
for what, text in helps.items():
    scan(what, text.replace(prefix, "PREFIX"))
print("scanned %d installed files and %d --help texts" % (len(shipped), len(helps)))

if failures:
    print("\n".join("FAILED " + f for f in failures))
    print("%d failures" % len(failures))
    sys.exit(1)
print("docs_clean: passed")
shutil.rmtree(work, ignore_errors=True)
