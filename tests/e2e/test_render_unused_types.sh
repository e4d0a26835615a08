#!/usr/bin/env bash
# The unused-object warning names an object's type as unknown when opaline does not render
# that type for its element (bsdf, texture, medium, phase: the builders' own op_*_type_known),
# and only then: unused objects of known types are "unused object" alone. The scene still loads
# (exit 0); the warnings go to standard error.
set -uo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup render_unused_types opaline-render

fail() { echo "FAIL: $*"; cat "$T/err"; exit 1; }

cat > "$T/scene.xml" <<XML
<scene version="0.6.0">
  <sensor type="perspective"><transform name="toWorld"><lookat origin="0, -6, 3" target="0, 0, 0" up="0, 0, 1"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="1"/></sampler>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film></sensor>
  <emitter type="constant"/>
  <bsdf type="disneybsdf" id="disney"/>
  <bsdf type="roughplastic" id="plastic"/>
  <bsdf type="thindielectric" id="thin"/>
  <texture type="foo" id="foo"/>
  <texture type="checkerboard" id="checks"/>
  <medium type="weird" id="weird"/>
  <medium type="homogeneous" id="fog"/>
  <phase type="kkay"/>
  <phase type="hg"/>
  <phase type="rayleigh"/>
  <shape type="sphere"><float name="radius" value="0.5"/></shape>
</scene>
XML

"$R" --check "$T/scene.xml" >/dev/null 2>"$T/err" || fail "--check exited $?"
# line TYPE-TAG SUFFIX: the warning about the object <TAG type="TYPE"> ends with SUFFIX.
line() {
  grep -F "<$1 type=\"$2\"" "$T/err" | grep -q -- "unused object$3\$" ||
    fail "no warning '<$1 type=\"$2\"...: unused object$3'"
}
u=", of a type opaline does not render"
line bsdf disneybsdf "$u (unknown bsdf type)"
line texture foo "$u (unknown texture type)"
line medium weird "$u (unknown medium type)"
line phase kkay "$u (unknown phase type)"
line bsdf roughplastic ""
line bsdf thindielectric ""
line texture checkerboard ""
line medium homogeneous ""
line phase hg ""
line phase rayleigh ""
[ "$(grep -c 'unused object' "$T/err")" -eq 10 ] || fail "not 10 unused objects"
echo "ok"
