#!/usr/bin/python3
"""docs/cli.md, the CLI reference, written from the CLI itself: `kata --help` and `kata CMD --help`
for every command it lists, the install prefix written as PREFIX (the help names installed files,
e.g. PREFIX/share/doc/kata/config.md). Run it with an installed kata after changing a command:

  cmake --install build --prefix /tmp/k && /usr/bin/python3 tests/docs/cli_reference.py /tmp/k/bin/kata > docs/cli.md

docs_clean (tests/docs/docs_clean.py) fails when docs/cli.md differs from what this prints.

  cli_reference.py KATA"""
import os
import re
import subprocess
import sys

HEADER = """# The `kata` command line

Every command of `kata` with its options, as `kata CMD --help` prints them (this page is
generated from them). PREFIX is where kata is installed (`cmake --install build --prefix
PREFIX`); `kata` finds its shipped model, clips, viewer and plugins under PREFIX from any
directory. Each command exits 0 on success and 1 with a message naming the file, line or option
at fault otherwise.

| command | what it does |
|---|---|
"""


def run(kata, args, prefix):
    """`kata ARGS` as a user types it (found on PATH, so its usage line says `kata`)."""
    r = subprocess.run(["kata"] + args, capture_output=True, text=True,
                       env={"PATH": os.path.dirname(kata) + ":/usr/bin:/bin", "LANG": "C.UTF-8", "COLUMNS": "100"})
    out = (r.stdout + r.stderr).rstrip() + "\n"
    return out.replace(prefix + "/", "PREFIX/").replace(prefix, "PREFIX")


def commands(top):
    """(name, description) of every subcommand `kata --help` lists under SUBCOMMANDS."""
    out, inside = [], False
    for line in top.split("\n"):
        if line.strip().lower() == "subcommands:":
            inside = True
            continue
        if inside:
            m = re.match(r"^  ([a-z][a-z0-9-]*)\s+(.*)$", line)
            if m:
                out.append((m.group(1), m.group(2).strip()))
            elif out and line.startswith("    ") and line.strip():
                out[-1] = (out[-1][0], out[-1][1] + " " + line.strip())
            elif line.strip() and not line.startswith(" "):
                break
    return out


def reference(kata):
    kata = os.path.realpath(kata)
    prefix = os.path.dirname(os.path.dirname(kata))
    top = run(kata, ["--help"], prefix)
    cmds = commands(top)
    if not cmds:
        raise SystemExit("cli_reference: `%s --help` lists no SUBCOMMANDS:\n%s" % (kata, top))
    text = HEADER
    for name, what in cmds:
        text += "| [`kata %s`](#kata-%s) | %s |\n" % (name, name, what.replace("|", "\\|"))
    text += "\n## kata\n\n```text\n" + top + "```\n"
    for name, _ in cmds:
        text += "\n## kata %s\n\n```text\n%s```\n" % (name, run(kata, [name, "--help"], prefix))
    return text


if __name__ == "__main__":
    sys.stdout.write(reference(sys.argv[1]))
