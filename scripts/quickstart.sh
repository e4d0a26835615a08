#!/usr/bin/env bash
# README command 1: installs what is missing, builds opaline and its presets, renders the demo
# scene and prints where the images are. Idempotent: a second run redoes only what changed.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build="$root/build"

bash "$root/scripts/install-deps.sh"
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release -DOPALINE_BUILD_TESTS=OFF >/dev/null
cmake --build "$build" --parallel "$(nproc)"

mkdir -p "$root/out"
scene="$root/scenes/demo/demo.xml"
png="$root/out/demo.png" exr="$root/out/demo.exr"
# Re-render only when the renderer, the scene or the preset it uses is newer than the images.
inputs=("$build/bin/opaline-render" "$scene" "$build/presets/SVD_S10_Chess4x4.opm")
stale=0
for f in "$png" "$exr"; do
  [ -f "$f" ] || stale=1
  for i in "${inputs[@]}"; do
    [ -f "$f" ] && [ "$i" -nt "$f" ] && stale=1
  done
done
if [ "$stale" = 1 ]; then
  OPALINE_PRESETS_PATH="$build/presets" "$build/bin/opaline-render" "$scene" -o "$exr" -o "$png"
  echo "opaline: demo rendered:"
else
  echo "opaline: demo image is up to date:"
fi
echo "  $png"
echo "  $exr"
