#!/usr/bin/python3
"""The ABI guard (abi/README.md): compares a built libkata with every released ABI description in
abi/ (abidw XML) using libabigail's abidiff, and fails on an incompatible change.

  abi/check.py [--baseline FILE]... [--changelog FILE] [--version X.Y.Z] LIB

Defaults: every abi/libkata-*.abi.xz (abidw XML, xz-compressed; dumped with abi/kata.abignore:
the kata_* symbols only), CHANGELOG.md, the version of CMakeLists.txt's project().

The rule, per baseline. abidiff's report (added functions left out: --no-added-syms; new
enumerators are harmless to it already) is read line by line, and only these changes are allowed:
a struct growing by data members inserted at or past its old end (every kata_* struct starts with
struct_size: an older caller passes its smaller size), and the lines that lead to such a change
(which function, which parameter, which pointed-to type). Any other line is a break: a removed or
renamed function, a changed parameter or return type, a member moved, removed or retyped, an
enumerator's value changed, the soname changed. A break passes only when the library's soname major
is above the baseline's AND CHANGELOG.md's section for --version (or for the first release of its
major, X.0.0) names every kata_* function or type the report names (and says "soname" when it
moved).

Exit status: 0 compatible (or a break released as such), 1 a break, 2 a usage or tool error.
"""
import argparse
import glob
import lzma
import os
import re
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

# Report lines that only lead to a change (they name where it is), or summarise.
LEADING = [
    r"Functions changes summary: 0 Removed, \d+ Changed( \(\d+ filtered out\))?, \d+ Added( \(\d+ filtered out\))? functions?",
    r"Variables changes summary: 0 Removed, \d+ Changed( \(\d+ filtered out\))?, \d+ Added( \(\d+ filtered out\))? variables?",
    r"Function symbols changes summary: 0 Removed, \d+ Added function symbols? not referenced by debug info",
    r"Variable symbols changes summary: 0 Removed, \d+ Added variable symbols? not referenced by debug info",
    r"\d+ functions? with some indirect sub-type changes?:",
    r"\d+ variables? with some indirect sub-type changes?:",
    r"\[C\] '(function|method) .*' (at \S+ )?has some indirect sub-type changes:",
    r"parameter \d+ of type '.*' has sub-type changes:",
    r"in pointed to type '.*'( at \S+)?:",
    r"in unqualified underlying type '.*'( at \S+)?:",
    r"in referenced type '.*'( at \S+)?:",
    r"underlying type '.*'( at \S+)? changed:",
    r"type of '.*' changed:",
    r"'(struct|typedef) .*'( at \S+)? changed:",
    r"(type|struct|typedef) '.*' changed, as reported earlier",
    r"details (were|was) reported earlier",
    r"\d+ data member insertions?:",
]
LEADING = [re.compile("^" + p + "$") for p in LEADING]
SIZE = re.compile(r"^type size changed from (\d+) to (\d+) \(in bits\)$")
INSERTED = re.compile(r"^'.*', at offset (\d+) \(in bits\)( at \S+)?$")


def breaking_lines(report):
    """The report lines that are not an allowed change (empty: compatible)."""
    bad, old_size = [], None
    for raw in report.splitlines():
        line = raw.strip()
        if not line:
            continue
        m = SIZE.match(line)
        if m:
            old_size = int(m.group(1))
            if int(m.group(2)) < old_size:
                bad.append(raw)
            continue
        m = INSERTED.match(line)
        if m:
            if old_size is None or int(m.group(1)) < old_size:
                bad.append(raw)  # inserted inside the old struct: every later member moved
            continue
        if any(p.match(line) for p in LEADING):
            continue
        bad.append(raw)
    return bad


def changed_names(report, bad):
    """What a changelog entry must name: for each function entry ([C] changed, [D] removed) that
    holds a breaking line, the function and the kata_* types on its way to the change; and any
    kata_* name on a breaking line elsewhere."""
    bad = set(bad)
    names, block, block_bad = set(), set(), False

    def close():
        if block_bad:
            names.update(block)

    for raw in report.splitlines():
        line = raw.strip()
        if line.startswith(("[C]", "[D]")):
            close()
            block = set(re.findall(r"\b(kata_\w+)\(", line) or re.findall(r"\b(kata_\w+)", line)[:1])
            block_bad = raw in bad
            continue
        if not raw.startswith(" ") and line:
            close()
            block, block_bad = set(), False
        block.update(re.findall(r"(?:underlying type |type of |^)'(?:struct |enum |typedef )?(kata_\w+)'", line))
        if raw in bad:
            block_bad = True
            names.update(re.findall(r"\bkata_\w+", raw))
    close()
    return names


def soname_major(soname):
    m = re.search(r"\.so\.(\d+)", soname or "")
    return int(m.group(1)) if m else 0


def lib_soname(path):
    out = subprocess.run(["readelf", "-d", path], capture_output=True, text=True, check=True).stdout
    m = re.search(r"Library soname: \[(.*?)\]", out)
    return m.group(1) if m else ""


def open_abi(path):
    return lzma.open(path, "rt", encoding="utf-8") if path.endswith(".xz") else open(path, encoding="utf-8")


def abi_soname(path):
    with open_abi(path) as f:
        head = f.read(4096)
    m = re.search(r"<abi-corpus[^>]*\ssoname='([^']*)'", head)
    return m.group(1) if m else ""


def changelog_section(path, version):
    """The text under "## [version]" up to the next "## [" heading ("" when there is none)."""
    if not os.path.exists(path):
        return ""
    out, on = [], False
    with open(path, encoding="utf-8") as f:
        for line in f:
            if line.startswith("## ["):
                on = line.startswith("## [%s]" % version)
                continue
            if on:
                out.append(line)
    return "".join(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("lib")
    ap.add_argument("--baseline", action="append", default=[])
    ap.add_argument("--changelog", default=os.path.join(ROOT, "CHANGELOG.md"))
    ap.add_argument("--version", default="")
    a = ap.parse_args()
    if not os.path.isfile(a.lib):
        print("abi/check.py: no library at %s" % a.lib, file=sys.stderr)
        return 2
    baselines = a.baseline or sorted(glob.glob(os.path.join(HERE, "libkata-*.abi.xz")))
    if not baselines:
        print("abi/check.py: no abi/libkata-*.abi.xz baseline", file=sys.stderr)
        return 2
    version = a.version
    if not version:
        with open(os.path.join(ROOT, "CMakeLists.txt"), encoding="utf-8") as f:
            version = re.search(r"project\(kata VERSION ([0-9.]+)", f.read()).group(1)
    # A break against an older major's baseline is listed where that major was first released
    # (X.0.0), which later minors of it (a 1.1 build against the 0.x baseline) still are.
    section = changelog_section(a.changelog, version)
    first_of_major = "%s.0.0" % version.split(".")[0]
    listed_in = version
    if first_of_major != version:
        section += changelog_section(a.changelog, first_of_major)
        listed_in = "%s] or [%s" % (version, first_of_major)
    soname = lib_soname(a.lib)
    status = 0
    for base in baselines:
        base_soname = abi_soname(base)
        name = os.path.basename(base)
        xml = base
        if base.endswith(".xz"):  # abidiff reads plain XML
            tmp = tempfile.NamedTemporaryFile("w", suffix=".abi", delete=False)
            with open_abi(base) as f, tmp:
                tmp.write(f.read())
            xml = tmp.name
        # No suppression file here: abidiff then filters kata_* changes too (libabigail 2.2); the
        # baseline was dumped with abi/kata.abignore, so the C++ symbols are only "added" here.
        command = ["abidiff", "--no-added-syms", "--no-show-locs"]
        try:
            p = subprocess.run(command + [xml, a.lib], capture_output=True, text=True)
        except FileNotFoundError:
            print("abi/check.py: abidiff not found (Debian: apt-get install abigail-tools)", file=sys.stderr)
            return 2
        if xml != base:
            os.unlink(xml)
        if p.returncode & 3:
            print(p.stdout + p.stderr)
            print("abi/check.py: abidiff failed (exit %d) on %s" % (p.returncode, base), file=sys.stderr)
            return 2
        report = p.stdout
        bad = breaking_lines(report) if p.returncode else []
        if not bad:
            print("ABI: %s is compatible with %s (%s): additions only" % (soname, name, base_soname))
            continue
        names = sorted(changed_names(report, bad))
        missing = [n for n in names if not re.search(r"\b%s\b" % re.escape(n), section)]
        if soname != base_soname and "soname" not in section.lower():
            missing.append("the soname change")
        moved = soname_major(soname) > soname_major(base_soname)
        print("\n".join("  | " + line for line in report.splitlines()))
        print("  breaking lines:\n" + "\n".join("  ! " + line.strip() for line in bad))
        if moved and not missing:
            print("ABI: %s breaks %s (%s) as released: the soname's major moved and CHANGELOG.md [%s] "
                  "lists every change" % (soname, name, base_soname, listed_in))
            continue
        if not moved:
            print("ABI BREAK: %s is incompatible with %s (%s) within major version %d. Keep the old ABI (add, do "
                  "not change or remove), or move the major version (project(VERSION) in CMakeLists.txt, which "
                  "sets the soname) and list the change in CHANGELOG.md." % (soname, name, base_soname,
                                                                            soname_major(base_soname)),
                  file=sys.stderr)
        else:
            print("ABI BREAK: the major version moved, but CHANGELOG.md [%s] does not name: %s"
                  % (listed_in, ", ".join(missing)), file=sys.stderr)
        status = 1
    return status


if __name__ == "__main__":
    sys.exit(main())
