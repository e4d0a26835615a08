#!/usr/bin/env bash
# The film's view transform (viewTransform and its companions, docs/scene-format.md) through
# OpenColorIO, on a test config written here whose view "Root" is the power 1/2 and whose look
# "Double" doubles: a constant environment of radiance L seen by every pixel.
#  - the PNG holds (2^viewExposure L (x2 with the look))^(1/2) ^ (1/viewGamma), to the nearest
#    of 255 levels: exposure in scene linear before the view, gamma after it, as Blender does;
#    the PFM written beside it stays scene-linear (L);
#  - a view, look or display the config lacks, a config that is not there (without $OCIO), a
#    view parameter without viewTransform: exit 2 with a message naming it, no output written,
#    from --check too; a config that is not there with $OCIO set: $OCIO's, with a warning.
set -uo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup render_view_transform opaline-render
FAILS=0
fail() { echo "FAIL: $*"; FAILS=$((FAILS + 1)); }
cat >"$T/test.ocio" <<'OCIO'
ocio_profile_version: 1
search_path: ""
roles:
  default: linear
  scene_linear: linear
displays:
  sRGB:
    - !<View> {name: Root, colorspace: root}
    - !<View> {name: Raw, colorspace: linear}
looks:
  - !<Look>
    name: Double
    process_space: linear
    transform: !<MatrixTransform> {matrix: [2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 1]}
colorspaces:
  - !<ColorSpace>
    name: linear
    bitdepth: 32f
    isdata: false
  - !<ColorSpace>
    name: root
    bitdepth: 32f
    isdata: false
    from_reference: !<ExponentTransform> {value: [0.5, 0.5, 0.5, 1]}
OCIO
# scene NAME FILM_PARAMETERS: a 4 x 3 hdrfilm under a constant environment (0.1, 0.3, 0.02)
scene() {
  cat >"$T/$1.xml" <<XML
<scene version="0.6.0">
  <integrator type="path"/>
  <sensor type="perspective">
    <sampler type="independent"><integer name="sampleCount" value="1"/></sampler>
    <film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="3"/>
      $2
    </film>
  </sensor>
  <emitter type="constant"><rgb name="radiance" value="0.1, 0.3, 0.02"/></emitter>
  <shape type="sphere"><point name="center" x="0" y="0" z="-50"/></shape>
</scene>
XML
}
# check PNG PFM EXPOSURE GAMMA LOOK_SCALE: the pixels against the formula above
check() {
  python3 - "$@" <<'PY' || fail "$1: wrong pixels"
import struct, sys, zlib
import pfm
png, pfm_path, e, g, k = sys.argv[1], sys.argv[2], *map(float, sys.argv[3:])
data = open(png, "rb").read()
pos, idat, ihdr = 8, b"", None
while pos < len(data):
    n, kind = struct.unpack(">I4s", data[pos:pos + 8])
    body = data[pos + 8:pos + 8 + n]
    ihdr = body if kind == b"IHDR" else ihdr
    idat += body if kind == b"IDAT" else b""
    pos += 12 + n
w, h, depth, ctype = struct.unpack(">IIBB", ihdr[:10])
c = {2: 3, 6: 4}[ctype]
raw, rows, stride = zlib.decompress(idat), [], w * c
for y in range(h):  # PNG's row filters
    f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
    prev = rows[-1] if rows else bytearray(stride)
    for i in range(stride):
        a = line[i - c] if i >= c else 0
        b, d = prev[i], prev[i - c] if i >= c else 0
        p = a + b - d
        pred = [0, a, b, (a + b) // 2,
                a if abs(p - a) <= abs(p - b) and abs(p - a) <= abs(p - d)
                else b if abs(p - b) <= abs(p - d) else d][f]
        line[i] = (line[i] + pred) & 255
    rows.append(line)
L = (0.1, 0.3, 0.02)
want = [round(255 * min(1.0, (k * 2 ** e * v) ** 0.5) ** (1 / g)) for v in L]
got = [rows[y][x * c + i] for y in range(h) for x in range(w) for i in range(3)]
bad = [(i, v) for i, v in enumerate(got) if abs(v - want[i % 3]) > 1]
print("%s: pixel %s, expected %s" % (png, got[:3], want))
lin = pfm.read(pfm_path)
flat = [v for row in lin.rows() for v in row]
off = max(abs(v - L[i % 3]) for i, v in enumerate(flat))
print("%s: scene-linear within %.2g" % (pfm_path, off))
sys.exit(1 if bad or off > 1e-5 else 0)
PY
}
CFG="$T/test.ocio"
scene plain "<string name=\"viewConfig\" value=\"$CFG\"/><string name=\"viewTransform\" value=\"Root\"/>"
scene exposed "<string name=\"viewConfig\" value=\"test.ocio\"/><string name=\"viewDisplay\" value=\"sRGB\"/>
  <string name=\"viewTransform\" value=\"Root\"/><float name=\"viewExposure\" value=\"1.5\"/>
  <float name=\"viewGamma\" value=\"1.7\"/>"
scene looked "<string name=\"viewConfig\" value=\"$CFG\"/><string name=\"viewTransform\" value=\"Root\"/>
  <string name=\"viewLook\" value=\"Double\"/><float name=\"viewExposure\" value=\"-0.5\"/>"
for s in plain exposed looked; do
  "$R" -q -t 1 -o "$T/$s.png" -o "$T/$s.pfm" "$T/$s.xml" || fail "$s.xml: exit $?"
done
check "$T/plain.png" "$T/plain.pfm" 0 1 1
check "$T/exposed.png" "$T/exposed.pfm" 1.5 1.7 1
check "$T/looked.png" "$T/looked.pfm" -0.5 1 2

# refused: exit 2, the name in the message, nothing written
refuse() { # NAME WORD FILM_PARAMETERS
  scene "$1" "$3"
  for run in check render; do
    rm -f "$T/$1.png"
    if [ $run = check ]; then
      env -u OCIO "$R" --check "$T/$1.xml" >"$T/err" 2>&1
    else
      env -u OCIO "$R" -q -t 1 -o "$T/$1.png" "$T/$1.xml" >"$T/err" 2>&1
    fi
    rc=$?
    [ $rc = 2 ] || fail "$1 ($run): exit $rc, expected 2: $(cat "$T/err")"
    grep -q -- "$2" "$T/err" || fail "$1 ($run): the message does not name $2: $(cat "$T/err")"
    [ ! -e "$T/$1.png" ] || fail "$1 ($run): an output was written"
  done
  echo "$1: $(head -c 300 "$T/err")"
}
refuse noview '"Nope".*"Root", "Raw"' "<string name=\"viewConfig\" value=\"$CFG\"/><string name=\"viewTransform\" value=\"Nope\"/>"
refuse nolook '"Sharp".*"Double"' "<string name=\"viewConfig\" value=\"$CFG\"/><string name=\"viewTransform\" value=\"Root\"/><string name=\"viewLook\" value=\"Sharp\"/>"
refuse nodisplay '"HDR".*"sRGB"' "<string name=\"viewConfig\" value=\"$CFG\"/><string name=\"viewDisplay\" value=\"HDR\"/><string name=\"viewTransform\" value=\"Root\"/>"
refuse noconfig 'missing.ocio' "<string name=\"viewConfig\" value=\"missing.ocio\"/><string name=\"viewTransform\" value=\"Root\"/>"
refuse unset 'OCIO' "<string name=\"viewTransform\" value=\"Root\"/>"
refuse alone 'viewGamma without viewTransform' "<float name=\"viewGamma\" value=\"2\"/>"
refuse gamma 'gamma' "<string name=\"viewConfig\" value=\"$CFG\"/><string name=\"viewTransform\" value=\"Root\"/><float name=\"viewGamma\" value=\"0\"/>"

# a config that is not there, with $OCIO set: $OCIO's config, with a warning
scene farm "<string name=\"viewConfig\" value=\"/nonexistent/config.ocio\"/><string name=\"viewTransform\" value=\"Root\"/>"
OCIO="$CFG" "$R" -t 1 -o "$T/farm.png" -o "$T/farm.pfm" "$T/farm.xml" 2>"$T/err" ||
  fail "farm.xml with \$OCIO: exit $?: $(cat "$T/err")"
grep -q 'using \$OCIO' "$T/err" || fail "farm.xml: no warning that \$OCIO's config is used"
check "$T/farm.png" "$T/farm.pfm" 0 1 1

[ $FAILS = 0 ] && echo "PASS" || echo "$FAILS failure(s)"
[ $FAILS = 0 ]
