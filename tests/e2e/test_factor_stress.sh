#!/usr/bin/env bash
# The factorizer's numerical stress suite (bench/stress_factor.py): every method on constant,
# rank-deficient, one-hot, single-column, random and 1e-12..1e-1 data and on physically
# impossible values, at T = 1 to above the rank and P = 0 to 20. Each case must give finite
# output within its documented bound or a clear refusal; the table is written to stress.md.
set -euo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup factor_stress opaline-factor
# The table's header, any failing rows and the summary: a failure names its case in the log.
rc=0
python3 "$SRC/bench/stress_factor.py" --bin "$BIN" \
  --out "$T" >"$T/table.txt" || rc=$?
head -n 2 "$T/table.txt"
grep -F '| FAIL |' "$T/table.txt" || true
tail -n 1 "$T/table.txt"
exit "$rc"
