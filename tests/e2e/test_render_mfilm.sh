#!/usr/bin/env bash
# Mitsuba's measuring sensors from the command line, with mfilm's text output:
#  - an irradiancemeter on a unit disk under a facing emitting disk of radiance 1 at distance 2
#    (Mitsuba 0.6's test_bidir_0 geometry, no reflection) reads pi times the view factor of two
#    coaxial disks, F = (X - sqrt(X^2 - 4)) / 2 with X = 2 + (h / a)^2, in the MATLAB file the
#    film's default output name gets (SCENE.m), parsed back;
#  - -o with .m writes the text matrix, with .exr an image of the same measurement;
#  - outputs refused as every output is (docs/limits.md): the scene itself, a folder, a file in a
#    missing folder, each with an old output of the same run left as it was.
set -uo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup render_mfilm opaline-render
FAILS=0
fail() { echo "FAIL: $*"; FAILS=$((FAILS + 1)); }
cat >"$T/meter.xml" <<'XML'
<scene version="0.5.0">
  <integrator type="path"><integer name="maxDepth" value="1"/></integrator>
  <shape type="disk">
    <transform name="toWorld"><translate z="-1"/></transform>
    <sensor type="irradiancemeter">
      <sampler type="independent"><integer name="sampleCount" value="200000"/></sampler>
      <film type="mfilm"><integer name="digits" value="6"/></film>
    </sensor>
  </shape>
  <shape type="disk">
    <boolean name="flipNormals" value="true"/>
    <transform name="toWorld"><translate z="1"/></transform>
    <emitter type="area"><spectrum name="radiance" value="1"/></emitter>
  </shape>
</scene>
XML
(cd "$T" && "$R" -q -t 2 meter.xml) || fail "meter.xml: exit $?"
[ -f "$T/meter.m" ] || fail "no meter.m (the mfilm's default output) was written"
# check FILE: the one value of FILE's MATLAB matrix against pi F (200000 samples: sigma 0.0026)
check() {
  python3 - "$1" <<'PY' || fail "$1: $(cat "$1" 2>/dev/null)"
import math, re, sys
text = open(sys.argv[1]).read()
m = re.fullmatch(r"data = \[([-+0-9.e]+)\];\n", text)
if not m:
    sys.exit("not a 1 x 1 MATLAB matrix: %r" % text)
x = 2.0 + 2.0 ** 2
expect = math.pi * (x - math.sqrt(x * x - 4.0)) / 2.0
value = float(m.group(1))
print("irradiance %.6f, pi F = %.6f" % (value, expect))
sys.exit(0 if abs(value - expect) < 0.011 else "irradiance %g, expected %g" % (value, expect))
PY
}
check "$T/meter.m"
"$R" -q -t 2 -s 20000 -o "$T/again.m" -o "$T/again.exr" "$T/meter.xml" || fail "-o .m -o .exr: exit $?"
[ -s "$T/again.exr" ] || fail "no again.exr"
grep -q '^data = \[' "$T/again.m" || fail "again.m is not a MATLAB matrix: $(cat "$T/again.m")"

# refused outputs: nothing replaced
cp "$T/meter.m" "$T/old.m"
cp "$T/meter.xml" "$T/scene.copy"
mkdir "$T/folder.m"
for bad in "$T/meter.xml" "$T/folder.m" "$T/missing/out.m"; do
  "$R" -q -s 16 -o "$T/old.m" -o "$bad" "$T/meter.xml" 2>"$T/err" && fail "-o $bad was accepted"
  grep -q . "$T/err" || fail "-o $bad: refused without a message"
  cmp -s "$T/old.m" "$T/meter.m" || fail "-o $bad: the other output old.m was replaced"
  cmp -s "$T/meter.xml" "$T/scene.copy" || fail "-o $bad: the scene was replaced"
done
[ -d "$T/folder.m" ] || fail "the folder folder.m was replaced"
[ -z "$(find "$T" -name '*.tmp-*')" ] || fail "temporary files left: $(find "$T" -name '*.tmp-*')"
[ $FAILS = 0 ] && echo "ok   mfilm: the irradiance parsed back, outputs refused as every output"
exit $((FAILS > 0))
