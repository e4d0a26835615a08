#!/usr/bin/env bash
# bench_stress.sh [BUILD]: the factorizer's numerical stress table (bench/stress_factor.py) for
# every method, printed and written to BUILD/bench-stress/stress.md and stress.csv
# (docs/benchmarks.md shows the last run).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:-$root/build}" && pwd)
python3 "$root/bench/stress_factor.py" --bin "$build/bin" --out "$build/bench-stress"
