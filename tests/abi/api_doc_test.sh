#!/usr/bin/env bash
# The API reference check (docs/api/Doxyfile): the shipped headers have no undocumented public
# symbol, and the check really fails on one (kata.h with an undocumented function and an
# undocumented struct member appended). Arguments: SOURCE_DIR TMP_DIR.
set -uo pipefail
src=$1 tmp=$2
rm -rf "$tmp" && mkdir -p "$tmp/out"
cd "$src" || exit 1
run() {  # run OUTPUT_LOG INPUT...: doxygen with the project's Doxyfile on other inputs
  local log=$1; shift
  { cat docs/api/Doxyfile; echo "INPUT = $*"; echo "OUTPUT_DIRECTORY = $tmp/out"; echo "WARN_LOGFILE = $log"; } | doxygen - >/dev/null 2>&1
}
failures=0
if run "$tmp/shipped.txt" sdk/include/kata/kata.h sdk/include/kata/kata_plugin.h; then
  echo "ok: the shipped headers: every public symbol documented"
else
  echo "FAILED: the shipped headers have undocumented symbols:"; cat "$tmp/shipped.txt"; failures=$((failures + 1))
fi
sed 's|^#endif /\* KATA_KATA_H \*/|typedef struct kata_probe { uint32_t struct_size; int32_t nobody_wrote_this; } kata_probe;\nKATA_API int kata_probe_undocumented(void);\n&|' \
  sdk/include/kata/kata.h >"$tmp/kata.h"
if run "$tmp/probe.txt" "$tmp/kata.h"; then
  echo "FAILED: an undocumented function and member passed the check"; failures=$((failures + 1))
elif grep -q "kata_probe_undocumented" "$tmp/probe.txt" && grep -q "nobody_wrote_this" "$tmp/probe.txt"; then
  echo "ok: an undocumented function and member fail the check, named: $(wc -l <"$tmp/probe.txt") warnings"
else
  echo "FAILED: the check failed without naming the undocumented symbols:"; cat "$tmp/probe.txt"; failures=$((failures + 1))
fi
echo "$((2 - failures)) passed, $failures failed"
[ "$failures" -eq 0 ]
