#!/usr/bin/env bash
# README command 1: installs what is missing, builds opaline and its presets, renders the demo
# scene and prints where the images are. Idempotent: a second run redoes only what changed.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build="$root/build"

bash "$root/scripts/install-deps.sh"
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" --parallel "$(nproc)"

mkdir -p "$root/out"
OPALINE_PRESETS_PATH="$build/presets" \
  "$build/bin/opaline-render" "$root/scenes/demo/demo.xml" -o "$root/out/demo.exr" -o "$root/out/demo.png"
echo "opaline: demo rendered:"
echo "  $root/out/demo.png"
echo "  $root/out/demo.exr"
