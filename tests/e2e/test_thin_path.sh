#!/usr/bin/env bash
# The thin path end to end: simulate a small chess4x4 dataset, factor it with SVD, render a
# scene that uses the factored material on a sphere over a floor under a spot light, and check
# the image (object and floor lit, nothing NaN). Needs only the built commands and python3.
set -euo pipefail
. "$(dirname "$0")/e2e_support.sh"
BIN=${OPALINE_BIN_DIR:?OPALINE_BIN_DIR is not set}
for exe in opaline-factor opaline-render; do
  [ -x "$BIN/$exe" ] || { echo "skip: $BIN/$exe not built"; exit 77; }
done
command -v python3 >/dev/null || { echo "skip: python3 not found"; exit 77; }
T=$(mktemp -d "${OPALINE_TEST_TMP:-/tmp}/thin_path.XXXXXX")
trap 'rm -rf "$T"' EXIT

"$BIN/opaline-factor" dataset chess4x4 --pixels 24x24 --kernel 9 -o "$T/d.opm"
"$BIN/opaline-factor" factor "$T/d.opm" --method svd -T 4 -o "$T/m.opm"

sphere_scene "$T/scene.xml" 64 48 4 \
  '<subsurface type="svd"><string name="material" value="m.opm"/><float name="scale" value="5"/><integer name="irrSamples" value="2"/></subsurface>'

"$BIN/opaline-render" --check "$T/scene.xml"
"$BIN/opaline-render" -q -t 2 -o "$T/out.pfm" "$T/scene.xml"

python3 - "$T/out.pfm" <<'PY'
import math, struct, sys
data = open(sys.argv[1], "rb").read()
header, dims, scale, rest = data.split(b"\n", 3)
assert header == b"PF", header
w, h = map(int, dims.split())
px = struct.unpack("<%df" % (w * h * 3), rest[: w * h * 12])
def at(x, y):  # y from the top; PFM rows run bottom to top
    i = ((h - 1 - y) * w + x) * 3
    return px[i:i + 3]
assert all(math.isfinite(v) for v in px), "NaN or inf in the image"
assert min(px) >= 0.0, "negative radiance"
obj = sum(sum(at(x, y)) for x in range(w // 2 - 3, w // 2 + 3) for y in range(h // 2 - 8, h // 2 - 2))
floor = sum(sum(at(x, y)) for x in range(2, 10) for y in range(h - 6, h - 1))
print("object %.4f floor %.4f" % (obj, floor))
assert obj > 0.05, "the translucent object is dark"
assert floor > 0.05, "the floor is dark"
PY
echo "thin path OK"
