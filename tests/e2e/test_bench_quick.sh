#!/usr/bin/env bash
# test_bench_quick.sh - keeps bench/bench_methods.sh working: its quick mode (tiny datasets,
# every method, one run each, the paper-style scene rendered at 32 x 32 with every material)
# completes and writes its files. What the files say is checked by the report code's unit
# tests (tests/bench/test_report.py, run by test_bench_report.sh). Needs python3 only (numpy,
# scikit-learn and matplotlib parts run when present, else are skipped by the benchmark with a
# message). Exit 77 (skip) when python3 is absent.
set -euo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup bench_quick opaline-factor opaline-render opaline-bench-rsvd

bash "$SRC/bench/bench_methods.sh" --quick --build "$BIN/.." --out "$T" > "$T/stdout.txt" ||
  { cat "$T/stdout.txt" "$T/commands.log" >&2; exit 1; }
for f in runs.csv results.json tables.md baselines.csv renders.csv; do
  [ -s "$T/$f" ] || { echo "FAIL: $f missing or empty" >&2; exit 1; }
done
# opaline-bench-rsvd refuses a matrix file of the wrong size, naming it.
head -c 100 /dev/zero > "$T/short.f32"
rc=0
"$BIN/opaline-bench-rsvd" "$T/short.f32" 10 5 2 2> "$T/err.txt" || rc=$?
[ "$rc" = 2 ] && grep -q "short.f32: too short" "$T/err.txt" ||
  { echo "FAIL: opaline-bench-rsvd on a short file: exit $rc, $(cat "$T/err.txt")" >&2; exit 1; }
grep -q "^## Goals" "$T/stdout.txt" || { echo "FAIL: no goals in the output" >&2; exit 1; }
grep -q "^## Render time and image error per method" "$T/tables.md" ||
  { echo "FAIL: no render table in tables.md" >&2; exit 1; }
ls "$T"/images/*.pfm >/dev/null 2>&1 || { echo "FAIL: no rendered images" >&2; exit 1; }
echo "ok: the quick benchmark wrote $(cd "$T" && echo runs.csv results.json tables.md \
  baselines.csv renders.csv) and $(ls "$T"/images/*.pfm | wc -l) images"
