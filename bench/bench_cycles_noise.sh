#!/usr/bin/env bash
# Time to equal error on the same exported scenes: opaline-render against Cycles (Debian's
# Blender, headless). See bench/bench_cycles_noise.py for the method and the scenes.
# Usage: bash bench/bench_cycles_noise.sh [BUILD_DIR] [THREADS] [OUT_DIR]   (a Release build)
# REPEAT=N (default 3) runs per sample count, timings are medians; SCENE=lambert (default),
# mixed, cbox, manylights or all; RES=N (default 128) the image width; results in
# OUT_DIR/SCENE/cycles_noise.json and a table on stdout
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
threads=${2:-$(nproc)}
out=${3:-$build/bench-cycles-noise}
render=$build/bin/opaline-render
[ -x "$render" ] || { echo "bench_cycles_noise: $render not built (cmake --build $build)" >&2; exit 2; }
command -v blender >/dev/null || { echo "skip: blender is absent (apt-get install blender)"; exit 0; }
mkdir -p "$out"
OPALINE_BIN_DIR=$build/bin blender --background --factory-startup --python-exit-code 1 \
  --python "$root/bench/bench_cycles_noise.py" -- --renderer "$render" --out "$out" \
  --threads "$threads" --repeats "${REPEAT:-3}" --scene "${SCENE:-lambert}" \
  --res "${RES:-128}" 2>&1 |
  grep -vE "^ *(Fra:|Blender quit|Read prefs|Saved:|Time:|Info:|$)"
