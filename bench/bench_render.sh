#!/usr/bin/env bash
# Renderer throughput on the Stanford bunny (../shared/meshes/stanford-bunny.obj):
#  - Mrays/s: the `normals` debug view, exactly one primary ray per sample (ray casting speed);
#  - samples/s: the path tracer (diffuse bunny and floor, spot light + sky), full paths.
# Usage: bench/bench_render.sh [BUILD_DIR] [THREADS]   (build in Release for real figures)
set -euo pipefail
SRC=$(cd "$(dirname "$0")/.." && pwd)
BUILD=${1:-$SRC/build}
THREADS=${2:-$(nproc)}
BUNNY=${OPALINE_SHARED_DIR:-$SRC/../shared}/meshes/stanford-bunny.obj
RENDER=$BUILD/bin/opaline-render
[ -f "$BUNNY" ] || { echo "skip: $BUNNY is absent (../shared is not beside the checkout)"; exit 0; }
[ -x "$RENDER" ] || { echo "error: $RENDER not built"; exit 1; }
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT

scene() { # $1 integrator xml, $2 spp
cat <<XML
<scene version="0.6.0">
  $1
  <sensor type="perspective">
    <float name="fov" value="30"/>
    <transform name="toWorld"><lookat origin="-0.02, 0.13, 0.42" target="-0.017, 0.105, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="$2"/></sampler>
    <film type="hdrfilm"><integer name="width" value="640"/><integer name="height" value="480"/></film>
  </sensor>
  <emitter type="spot">
    <transform name="toWorld"><lookat origin="0.3, 0.6, 0.4" target="0, 0.1, 0"/></transform>
    <spectrum name="intensity" value="3"/>
  </emitter>
  <emitter type="constant"><spectrum name="radiance" value="0.2"/></emitter>
  <shape type="obj">
    <string name="filename" value="$BUNNY"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.6, 0.5"/></bsdf>
  </shape>
  <shape type="rectangle">
    <transform name="toWorld"><rotate x="1" angle="-90"/><scale value="2"/><translate y="0.033"/></transform>
    <bsdf type="diffuse"/>
  </shape>
</scene>
XML
}

now() { date +%s.%N; }
calc() { awk "BEGIN { print $1 }"; } # floating-point arithmetic without bc
run() { # $1 name, $2 integrator, $3 spp; prints seconds
  scene "$2" "$3" > "$T/$1.xml"
  local t0 t1
  t0=$(now)
  "$RENDER" -q -t "$THREADS" -o "$T/$1.exr" "$T/$1.xml"
  t1=$(now)
  calc "$t1 - $t0"
}

PIX=$((640 * 480))
# scene load (OBJ parse + BVH build) is measured alone with --check and subtracted
scene '<integrator type="normals"/>' 1 > "$T/load.xml"
t0=$(now); "$RENDER" -q --check "$T/load.xml"; t1=$(now)
LOAD=$(calc "$t1 - $t0")
SPP_RAY=32
SPP_PATH=8
TR=$(run rays '<integrator type="normals"/>' $SPP_RAY)
TP=$(run path '<integrator type="path"><integer name="maxDepth" value="8"/></integrator>' $SPP_PATH)
printf 'bunny 640x480, %s threads, scene load %.2f s\n' "$THREADS" "$LOAD"
printf 'primary rays: %.2f Mrays/s (%d spp in %.2f s)\n' \
  "$(calc "$PIX * $SPP_RAY / ($TR - $LOAD) / 1000000")" $SPP_RAY "$TR"
printf 'path tracing: %.3f M samples/s (%d spp in %.2f s)\n' \
  "$(calc "$PIX * $SPP_PATH / ($TP - $LOAD) / 1000000")" $SPP_PATH "$TP"
