#!/usr/bin/env bash
# test_bench_report.sh - the method benchmark's report code (bench/methods_bench/report.py) on
# synthetic records: tests/bench/test_*.py, Python unittest, standard library only (seconds).
# The quick run itself is tests/e2e/test_bench_quick.sh. Exit 77 (skip) when python3 is absent.
set -euo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup bench_report
cd "$SRC"
python3 -m unittest discover -s tests/bench -p "test_*.py" -v
