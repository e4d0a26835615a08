#!/usr/bin/env bash
# bench_methods.sh - every factorization method side by side, run time against error.
#
# usage: bash bench/bench_methods.sh [--quick] [--out DIR] [--build DIR] [--repeats N]
#                                    [--datasets a,b] [--skip CONFIGS] [--no-baselines] [--no-plots]
#                                    [--renderer-only] [--render-size N] [--render-spp N]
#                                    [--no-render]
#   --build DIR   a Release build holding bin/opaline-factor (default build-bench-rel)
#   --out DIR     results folder (default BUILD/bench-methods[-quick]); datasets made there are
#                 reused by later runs while their arguments are unchanged
#   --quick       tiny datasets (24 x 24 pixels, K = 9) and a short sweep: the test suite's mode
#   --repeats N   runs per configuration, timings are medians (default 3, quick 1; a
#                 configuration whose first run is slow runs fewer times, at least once)
#   --datasets    subset of chess4x4, chess8x8, veined-marble, chess4x4-mc
#   --skip LIST   configurations to leave out, as labelled in the output, e.g. "nmf T=40,nmf T=20"
#   --render-size N, --render-spp N  the renders of the paper-style scene (Spot on a floor under
#                 a spot light, bench/paper_scene.py; a sphere when ../shared is absent) with raw
#                 and every factored material: image side and samples per pixel (default 256 and
#                 16; quick 32 and 2); render time against image RMSE versus raw, renders.csv
#   --no-render   skip those renders
#   --renderer-only  only the renderer goals (a minute or so): opaline-render against Embree's
#                 pathtracer tutorial (bench_render_peers.sh, needs ../shared and embree-tools) and
#                 against Cycles (bench_cycles_noise.sh, needs blender); the full mode runs them
#                 too, the quick mode skips them with a message
# The full mode takes long (tens of minutes per dataset: K-CTA and NMF at paper size; the
# renders add a few seconds per material).
# Needs python3; numpy, scikit-learn and matplotlib (Debian python3-numpy python3-sklearn
# python3-matplotlib) add the baselines and plots; the full run installs them with
# scripts/install-deps.sh --bench, quick mode skips what is missing and names it.
# OPALINE_BENCH_PYTHON picks the interpreter; otherwise the first python3 that has numpy
# (Debian's /usr/bin/python3 first), else any python3.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=$root/build-bench-rel
out=
quick=
args=()
while [ $# -gt 0 ]; do
  case $1 in
    --build) build=${2:?--build needs a folder}; shift 2 ;;
    --out) out=${2:?--out needs a folder}; shift 2 ;;
    --quick) quick=1; args+=(--quick); shift ;;
    --repeats|--datasets|--render-size|--render-spp) args+=("$1" "${2:?$1 needs a value}"); shift 2 ;;
    --no-baselines|--no-plots|--renderer-only|--no-render) args+=("$1"); shift ;;
    --skip) args+=("$1" "${2:?--skip needs a list}"); shift 2 ;;
    -h|--help) sed -n '2,/^set -euo/p' "$0" | sed '$d'; exit 0 ;;
    *) echo "bench_methods: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
# The full run installs its peers (scikit-learn, matplotlib, embree-tools); quick mode, run by
# the tests, only skips what is missing.
[ -n "$quick" ] || bash "$root/scripts/install-deps.sh" --bench
tool=$build/bin/opaline-factor
[ -x "$tool" ] || { echo "bench_methods: $tool not built (cmake --build $build)" >&2; exit 2; }
out=${out:-$build/bench-methods${quick:+-quick}}
py=${OPALINE_BENCH_PYTHON:-}
if [ -z "$py" ]; then
  for c in /usr/bin/python3 python3; do
    if command -v "$c" >/dev/null && "$c" -c 'import numpy' 2>/dev/null; then py=$c; break; fi
  done
fi
py=${py:-python3}
command -v "$py" >/dev/null || { echo "bench_methods: python3 is required" >&2; exit 2; }
export PYTHONPATH="$root/bench${PYTHONPATH:+:$PYTHONPATH}"  # the methods_bench package
exec "$py" -m methods_bench --tool "$tool" --out "$out" "${args[@]}"
