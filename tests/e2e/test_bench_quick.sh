#!/usr/bin/env bash
# test_bench_quick.sh - keeps bench/bench_methods.sh working: its quick mode (tiny datasets,
# every method, one run each, the paper-style scene rendered at 32 x 32 with every material)
# completes and writes its files. What the files say is checked by the report code's unit
# tests (tests/bench/test_report.py, run by test_bench_report.sh). Needs python3 only (numpy,
# scikit-learn and matplotlib parts run when present, else are skipped by the benchmark with a
# message). Exit 77 (skip) when python3 is absent.
set -euo pipefail
command -v python3 >/dev/null || { echo "python3 not installed: skipped"; exit 77; }
src=${OPALINE_SOURCE_DIR:-$(cd "$(dirname "$0")/../.." && pwd)}
bin=${OPALINE_BIN_DIR:?OPALINE_BIN_DIR must name the built binaries}
tmp=${OPALINE_TEST_TMP:-${TMPDIR:-/tmp}}
out=$(mktemp -d "$tmp/bench_quick.XXXXXX")
trap 'rm -rf "$out"' EXIT

bash "$src/bench/bench_methods.sh" --quick --build "$bin/.." --out "$out" > "$out/stdout.txt" ||
  { cat "$out/stdout.txt" "$out/commands.log" >&2; exit 1; }
for f in runs.csv results.json tables.md baselines.csv renders.csv; do
  [ -s "$out/$f" ] || { echo "FAIL: $f missing or empty" >&2; exit 1; }
done
# opaline-bench-rsvd refuses a matrix file of the wrong size, naming it.
head -c 100 /dev/zero > "$out/short.f32"
rc=0
"$bin/opaline-bench-rsvd" "$out/short.f32" 10 5 2 2> "$out/err.txt" || rc=$?
[ "$rc" = 2 ] && grep -q "short.f32: too short" "$out/err.txt" ||
  { echo "FAIL: opaline-bench-rsvd on a short file: exit $rc, $(cat "$out/err.txt")" >&2; exit 1; }
grep -q "^## Goals" "$out/stdout.txt" || { echo "FAIL: no goals in the output" >&2; exit 1; }
grep -q "^## Render time and image error per method" "$out/tables.md" ||
  { echo "FAIL: no render table in tables.md" >&2; exit 1; }
ls "$out"/images/*.pfm >/dev/null 2>&1 || { echo "FAIL: no rendered images" >&2; exit 1; }
echo "ok: the quick benchmark wrote $(cd "$out" && echo runs.csv results.json tables.md \
  baselines.csv renders.csv) and $(ls "$out"/images/*.pfm | wc -l) images"
