#!/usr/bin/env bash
# Time to equal noise on the same exported Lambertian scene: opaline-render against Cycles
# (Debian's Blender, headless). See bench/bench_cycles_noise.py for the method.
# Usage: bash bench/bench_cycles_noise.sh [BUILD_DIR] [THREADS] [OUT_DIR]   (a Release build)
# REPEAT=N (default 3) runs per sample count, timings are medians; results in
# OUT_DIR/cycles_noise.json
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
  --threads "$threads" --repeats "${REPEAT:-3}" 2>&1 |
  grep -vE "^ *(Fra:|Blender quit|Read prefs|Saved:|Time:|Info:|$)"
