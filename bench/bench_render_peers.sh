#!/usr/bin/env bash
# Path-tracing throughput of opaline-render against Embree's own `pathtracer` tutorial (Debian's
# embree-tools) on the same OBJ (the Stanford bunny from ../shared/meshes), the same camera,
# resolution, path length and thread count, lit by a uniform ambient light.
#
# Samples per second are measured as pixels * (N - 1) / (t(N spp) - t(1 spp)), so scene loading
# and BVH building cancel out; each figure is the median of REPEAT runs.
# Both see a Lambertian bunny of reflectance 0.8 (the tutorial gets it from a one-line .mtl put
# before a temporary copy of the OBJ; its default OBJ material has Kd = 1) under a uniform white
# environment, and trace paths of at most 8 segments with one shadow ray and one bounce ray per
# vertex, no Russian roulette in the tutorial. Remaining differences: the tutorial adds the ambient
# light both through its light sample and when a bounce ray escapes (no MIS), so its bunny is about
# twice as bright (a bias, not extra work); opaline weighs the two by MIS. The tutorial samples
# with its own sampler and writes 8-bit PPM; opaline writes OpenEXR. Each renderer uses its own
# BVH (opaline-render links whichever Embree the build found, 3 on Debian 12, 4 on Debian 13,
# the same as the tutorial's).
#
# Usage: bench/bench_render_peers.sh [BUILD_DIR] [THREADS] [SPP]   (a Release build)
set -euo pipefail
SRC=$(cd "$(dirname "$0")/.." && pwd)
BUILD=${1:-$SRC/build}
THREADS=${2:-$(nproc)}
SPP=${3:-64}
REPEAT=${REPEAT:-3}
BUNNY=${OPALINE_SHARED_DIR:-$SRC/../shared}/meshes/stanford-bunny.obj
RENDER=$BUILD/bin/opaline-render
[ -f "$BUNNY" ] || { echo "skip: $BUNNY is absent (../shared is not beside the checkout)"; exit 0; }
[ -x "$RENDER" ] || { echo "error: $RENDER not built (cmake --build $BUILD)"; exit 1; }
bash "$SRC/scripts/install-deps.sh" --bench # Embree's tutorials (embree-tools)
# Embree 3's embree-tools name it pathtracer, Embree 4's embree_pathtracer.
PEER=$(command -v pathtracer || command -v embree_pathtracer || true)
[ -n "$PEER" ] || { echo "skip: Embree's pathtracer tutorial is absent (apt-get install embree-tools)"; exit 0; }
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
W=640 H=480
printf 'newmtl matte\nKd 0.8 0.8 0.8\nKs 0 0 0\nd 1\n' > "$T/matte.mtl"
{ printf 'mtllib matte.mtl\nusemtl matte\n'; cat "$BUNNY"; } > "$T/bunny.obj"

cat > "$T/bunny.xml" <<XML
<scene version="0.6.0">
  <integrator type="path"><integer name="maxDepth" value="8"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="30"/><string name="fovAxis" value="y"/>
    <transform name="toWorld"><lookat origin="-0.02, 0.13, 0.42" target="-0.017, 0.105, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="$W"/><integer name="height" value="$H"/></film>
  </sensor>
  <emitter type="constant"><spectrum name="radiance" value="1"/></emitter>
  <shape type="obj">
    <string name="filename" value="$BUNNY"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.8, 0.8"/></bsdf>
  </shape>
</scene>
XML

now() { date +%s.%N; }
seconds() { # command...: wall seconds of one run
  local t0 t1
  t0=$(now)
  "$@" >/dev/null 2>&1
  t1=$(now)
  awk -v a="$t0" -v b="$t1" 'BEGIN { print b - a }'
}
median() { sort -g | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }

opaline() { "$RENDER" -q -t "$THREADS" -s "$1" -o "$T/o.exr" "$T/bunny.xml"; }
embree() {
  "$PEER" -i "$T/bunny.obj" --threads "$THREADS" --size "$W" "$H" --spp "$1" --max-path-length 8 \
    --vp -0.02 0.13 0.42 --vi -0.017 0.105 0 --vu 0 1 0 --fov 30 --ambientlight 1 1 1 \
    -o "$T/e.ppm"
}

rate() { # $1 function: median samples/s over REPEAT runs
  local r
  for ((r = 0; r < REPEAT; r++)); do
    local t1 tn
    t1=$(seconds "$1" 1)
    tn=$(seconds "$1" "$SPP")
    awk -v p=$((W * H)) -v n="$SPP" -v a="$t1" -v b="$tn" 'BEGIN { print p * (n - 1) / (b - a) }'
  done | median
}

echo "bunny $W x $H, $THREADS threads, $SPP spp, paths of at most 8 segments, median of $REPEAT"
ver() { dpkg-query -W -f '${Version}' "$1" 2>/dev/null || echo unknown; }
rev=$(git -C "$SRC" rev-parse --short HEAD 2>/dev/null || echo unknown)
[ -z "$(git -C "$SRC" status --porcelain 2>/dev/null)" ] || rev="$rev (modified)"
lib=$(dpkg-query -W -f='${Package}\n' 'libembree*' 2>/dev/null | grep -v -- -dev | head -n 1)
echo "versions: embree-tools $(ver embree-tools), ${lib:-libembree} $(ver "${lib:-libembree}"), opaline $rev"
echo "machine: $(nproc) CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
ours=$(rate opaline)
peer=$(rate embree)
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
awk -v o="$ours" -v e="$peer" 'BEGIN {
  printf "opaline-render          %.3f M samples/s\n", o / 1e6
  printf "Embree pathtracer       %.3f M samples/s\n", e / 1e6
  printf "ratio opaline / Embree  %.2f (goal >= 0.70: %s)\n", o / e, (o / e >= 0.7) ? "met" : "NOT MET"
}'
