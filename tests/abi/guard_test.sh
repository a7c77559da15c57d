#!/usr/bin/env bash
# abi/check.py against fixture libraries (tests/abi/fixture.c): what a release may add passes,
# each kind of break fails, a break passes only with the soname's major moved and a CHANGELOG.md
# entry naming it. Arguments: CHECK_PY SOURCE_DIR TMP_DIR then the libraries in the order of
# tests/abi/CMakeLists.txt (v1 append moved removed retyped enum_value moved_major).
set -uo pipefail
check=$1 tmp=$3
shift 3
v1=$1 append=$2 moved=$3 removed=$4 retyped=$5 enum_value=$6 moved_major=$7
rm -rf "$tmp" && mkdir -p "$tmp"
abidw --no-show-locs --suppressions "$(dirname "$check")/kata.abignore" --out-file "$tmp/released.abi" "$v1" || { echo "abidw failed"; exit 1; }
failures=0
expect() {  # expect RC WHAT LIB [CHANGELOG [VERSION]]
  local want=$1 what=$2 lib=$3 log=${4:-/dev/null} version=${5:-1.0.0}
  /usr/bin/python3 "$check" --baseline "$tmp/released.abi" --changelog "$log" --version "$version" \
    "$lib" >"$tmp/out.txt" 2>&1
  local rc=$?
  if [ "$rc" -ne "$want" ]; then
    echo "FAILED: $what: exit $rc, expected $want"; sed 's/^/    /' "$tmp/out.txt"; failures=$((failures + 1))
  else
    echo "ok: $what (exit $rc): $(tail -n 1 "$tmp/out.txt")"
  fi
}
expect 0 "the released library against itself" "$v1"
expect 0 "a new function, a new enumerator, a field appended at the end" "$append"
expect 1 "two struct members swapped" "$moved"
expect 1 "a function removed" "$removed"
expect 1 "a return type changed" "$retyped"
expect 1 "an enumerator renumbered" "$enum_value"
# The same break as a new major version: it passes only when CHANGELOG.md's section names it.
cat >"$tmp/CHANGELOG.md" <<'LOG'
# Changelog

## [1.0.0] - 2026-12-01
### Changed
- kata_fx_desc: scale before count (kata_fx_run, kata_fx_count, kata_fx_scale read it); the soname is libkata_fx.so.1.

## [0.2.0] - 2026-11-01
### Added
- kata_fx_desc
LOG
expect 0 "members swapped, major moved, the change listed" "$moved_major" "$tmp/CHANGELOG.md"
expect 1 "members swapped, major moved, nothing listed" "$moved_major"
# A later minor of the new major (1.1.0) still passes by the first release's (1.0.0) entry.
expect 0 "members swapped, major moved, listed under 1.0.0, built as 1.1.0" "$moved_major" "$tmp/CHANGELOG.md" 1.1.0
sed -i 's/ (kata_fx_run, kata_fx_count, kata_fx_scale read it)//' "$tmp/CHANGELOG.md"
expect 1 "members swapped, major moved, the functions not named" "$moved_major" "$tmp/CHANGELOG.md"
expect 1 "members swapped within the same major, even when listed" "$moved" "$tmp/CHANGELOG.md"
echo "$((11 - failures)) passed, $failures failed"
[ "$failures" -eq 0 ]
