# Sourced by the end-to-end tests: what several of them share.

# sphere_scene FILE WIDTH HEIGHT SPP SURFACE-XML: writes the tests' small paper-style scene to
# FILE: a sphere of radius 0.5 resting at z = 0.5 that carries SURFACE-XML (a <subsurface> or
# <bsdf> element), on a grey 6 x 6 diffuse floor, under a 40 degree spot light from 6 above,
# seen from (0, -4, 2); path tracing to depth 4, independent sampler with SPP samples.
sphere_scene() {
  cat > "$1" <<XML
<scene version="0.6.0">
  <integrator type="path"><integer name="maxDepth" value="4"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="toWorld"><lookat origin="0, -4, 2" target="0, 0, 0.5" up="0, 0, 1"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="$4"/></sampler>
    <film type="hdrfilm"><integer name="width" value="$2"/><integer name="height" value="$3"/></film>
  </sensor>
  <emitter type="spot">
    <transform name="toWorld"><lookat origin="0, 0, 6" target="0, 0, 0"/></transform>
    <float name="cutoffAngle" value="40"/>
    <spectrum name="intensity" value="60"/>
  </emitter>
  <shape type="sphere">
    <point name="center" x="0" y="0" z="0.5"/>
    <float name="radius" value="0.5"/>
    $5
  </shape>
  <shape type="rectangle">
    <transform name="toWorld"><scale value="3"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>
  </shape>
</scene>
XML
}
