#!/usr/bin/env bash
# bench_addon_export.sh [BEFORE [FACES [REPEAT]]] - the add-on's mesh export of a scene of FACES
# faces (default 2000000) by this checkout's add-on and by the add-on of revision BEFORE
# (default 012af13, the pure-Python exporter), each the median of REPEAT (default 3) runs in
# Blender headless (bench_addon_export.py). Prints each run and a line of medians per add-on,
# this checkout's first.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
before=${1:-012af13}
faces=${2:-2000000}
repeat=${3:-3}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
git -C "$root" archive "$before" blender_addon | tar -x -C "$tmp"
for addon in "$root/blender_addon" "$tmp/blender_addon"; do
  blender -b --factory-startup --python "$here/bench_addon_export.py" -- --addon "$addon" \
    --faces "$faces" --repeat "$repeat" 2>&1 | grep --line-buffered '^bench_addon_export:'
done
