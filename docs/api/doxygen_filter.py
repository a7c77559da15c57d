#!/usr/bin/python3
"""Doxygen's INPUT_FILTER for kata.h: the header is written as a manual in plain C comments (STYLE.md),
and Doxygen reads only its own markers, so this turns, on the fly (the header is not changed):
  - a comment that starts a line and is followed by a declaration -> a documentation comment (/**);
  - a comment after a member, enumerator or #define on the same line (and its continuation lines)
    -> a member comment (/**<).
Section banners (/* ==== ... */, /* ---- ... */) and the licence-style file header stay plain text,
except the file's first comment, which becomes the file's description (@file)."""
import re
import sys

TRAILING = re.compile(r"^(\s*(?:[^/\s].*?[;,]|#define\s+\w+(?:\([^)]*\))?\s+\S.*?|\w+\s*=\s*[^/]*?))(\s*)/\*(?!\*)")


def documents_next(lines, i):
    """True when the comment starting at lines[i] ends right before a declaration."""
    j = i
    while j < len(lines) and "*/" not in lines[j]:
        j += 1
    nxt = lines[j + 1].strip() if j + 1 < len(lines) else ""
    return bool(nxt) and not nxt.startswith(("/*", "#"))


def main(path):
    with open(path, encoding="utf-8") as f:
        lines = f.read().split("\n")
    out, first = [], True
    in_trailing = False
    for line in lines:
        if in_trailing:
            out.append(line)
            if "*/" in line:
                in_trailing = False
            continue
        stripped = line.lstrip()
        if first and stripped.startswith("/*"):
            out.append(line.replace("/*", "/** @file", 1))
            first = False
            continue
        if stripped.startswith(("/* ====", "/* ----", "/* ####", "/* (section")):
            # A banner documents what follows it directly (a group's only declaration, e.g.
            # kata_shard_of), else it is the text of its section.
            out.append(line.replace("/*", "/**", 1) if documents_next(lines, len(out)) else line)
            continue
        if stripped.startswith("/* ") or stripped == "/*":
            out.append(line.replace("/*", "/**", 1))
            continue
        m = TRAILING.match(line)
        if m and not stripped.startswith("*"):
            line = line[:m.end()] + "*<" + line[m.end():]
            if "*/" not in line[m.end():]:
                in_trailing = True
        out.append(line)
    sys.stdout.write("\n".join(out))


if __name__ == "__main__":
    main(sys.argv[1])
