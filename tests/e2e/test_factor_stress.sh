#!/usr/bin/env bash
# The factorizer's numerical stress suite (bench/stress_factor.py): every method on constant,
# rank-deficient, one-hot, single-column, random and 1e-12..1e-1 data and on physically
# impossible values, at T = 1 to above the rank and P = 0 to 20. Each case must give finite
# output within its documented bound or a clear refusal; the table is written to stress.md.
set -euo pipefail
BIN=${OPALINE_BIN_DIR:?OPALINE_BIN_DIR is not set}
[ -x "$BIN/opaline-factor" ] || { echo "skip: $BIN/opaline-factor not built"; exit 77; }
command -v python3 >/dev/null || { echo "skip: python3 not found"; exit 77; }
T=$(mktemp -d "${OPALINE_TEST_TMP:-/tmp}/factor_stress.XXXXXX")
trap 'rm -rf "$T"' EXIT
# The table's header, any failing rows and the summary: a failure names its case in the log.
rc=0
python3 "${OPALINE_SOURCE_DIR:-$(dirname "$0")/../..}/bench/stress_factor.py" --bin "$BIN" \
  --out "$T" >"$T/table.txt" || rc=$?
head -n 2 "$T/table.txt"
grep -F '| FAIL |' "$T/table.txt" || true
tail -n 1 "$T/table.txt"
exit "$rc"
