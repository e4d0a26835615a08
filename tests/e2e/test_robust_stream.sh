#!/usr/bin/env bash
# opaline-render --stream when its standard output fails: a full disk (/dev/full), a reader that
# goes away (| head -c 100: a broken pipe, not a silent death by SIGPIPE), a closed stdout. Each
# must exit 1 with a message naming stdout and the system's reason, and stop rendering early.
# Also: the stream of a good run ends with an END record holding exit status 0.
set -uo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup robust_stream opaline-render
[ -w /dev/full ] || e2e_skip "no /dev/full"

# 256 x 256 pixels: 64 tiles of 16 KiB each, far more than a pipe holds.
cat > "$T/scene.xml" <<'XML'
<scene version="0.6.0">
  <integrator type="path"><integer name="maxDepth" value="3"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="toWorld"><lookat origin="0, -4, 2" target="0, 0, 0.5" up="0, 0, 1"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="16"/></sampler>
    <film type="hdrfilm"><integer name="width" value="256"/><integer name="height" value="256"/></film>
  </sensor>
  <emitter type="point">
    <point name="position" x="0" y="-1" z="4"/>
    <spectrum name="intensity" value="20"/>
  </emitter>
  <shape type="sphere">
    <point name="center" x="0" y="0" z="0.5"/>
    <float name="radius" value="0.5"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.5, 0.3"/></bsdf>
  </shape>
  <shape type="rectangle">
    <transform name="toWorld"><scale value="3"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>
  </shape>
</scene>
XML

# A good run: the stream parses and its END record says 0.
"$R" --stream -t 2 "$T/scene.xml" >"$T/stream" 2>"$T/err" || fail "the good run exited $?"
python3 - "$T/stream" <<'PY' || fail "the good run's stream"
import struct, sys
data = open(sys.argv[1], "rb").read()
pos, tiles, end = 0, 0, None
while pos < len(data):
    magic, typ, n = struct.unpack_from("<4sIQ", data, pos)
    assert magic == b"OPTS", magic
    pos += 16
    if typ == 2:
        tiles += 1
    if typ == 4:
        end = struct.unpack_from("<I", data, pos)[0]
    pos += n
assert pos == len(data) and tiles == 64 and end == 0, (pos, len(data), tiles, end)
PY

# "stopped after N of 64 tiles" (or before any): the render stopped early.
stopped_early() {
  grep -q "stopped before any tile was finished" "$T/err" && return 0
  n=$(sed -n 's/.*stopped after \([0-9]*\) of 64 tiles.*/\1/p' "$T/err" | head -1)
  [ -n "$n" ] && [ "$n" -lt 64 ]
}

# A full disk.
"$R" --stream -t 2 "$T/scene.xml" >/dev/full 2>"$T/err"
rc=$?
[ "$rc" -eq 1 ] || fail "> /dev/full: exit $rc, expected 1"
grep -q "stdout: cannot write the tile stream (No space left on device)" "$T/err" ||
  fail "> /dev/full: no message naming stdout and the reason"
stopped_early || fail "> /dev/full: rendering did not stop early"
echo "ok: > /dev/full exits 1: $(grep -m1 'error' "$T/err")"

# A reader that reads 100 bytes and goes away.
"$R" --stream -t 2 "$T/scene.xml" 2>"$T/err" | head -c 100 >"$T/head"
rc=${PIPESTATUS[0]}
[ "$rc" -eq 1 ] || fail "| head -c 100: exit $rc, expected 1 (141 is a death by SIGPIPE)"
[ "$(wc -c <"$T/head")" -eq 100 ] || fail "| head -c 100: head got $(wc -c <"$T/head") bytes"
grep -q "stdout: cannot write the tile stream (Broken pipe)" "$T/err" ||
  fail "| head -c 100: no message naming stdout and the reason"
stopped_early || fail "| head -c 100: rendering did not stop early"
echo "ok: | head -c 100 exits 1: $(grep -m1 'error' "$T/err")"

# A closed stdout.
"$R" --stream -t 2 "$T/scene.xml" >&- 2>"$T/err"
rc=$?
[ "$rc" -eq 1 ] || fail ">&-: exit $rc, expected 1"
grep -q "stdout: cannot write the tile stream (Bad file descriptor)" "$T/err" ||
  fail ">&-: no message naming stdout and the reason"
echo "ok: >&- exits 1"

# The usage on a full disk is a write error too.
"$R" --help >/dev/full 2>"$T/err"
rc=$?
[ "$rc" -eq 1 ] || fail "--help > /dev/full: exit $rc, expected 1"
grep -q "stdout: cannot write" "$T/err" || fail "--help > /dev/full: no message"
echo "ok: --help > /dev/full exits 1"
