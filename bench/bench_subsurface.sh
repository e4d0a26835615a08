#!/usr/bin/env bash
# Subsurface rendering benchmark, the paper's scene: Spot the cow (../shared/meshes/spot.obj, with
# texture coordinates) on a floor under a spot light, 512 x 512, with the measured chessboards.
# For each material it prints the subsurface pre-pass time, the whole render's wall time, the
# peak memory (/usr/bin/time -v) and the image error (RMSE, and PSNR with the reference's
# largest value as peak) against the `raw` render of the same dataset at equal samples:
#  - raw Chess4x4 (the reference) and SVD with T = 1, 5, 10, 20, 40 (A = 100, B = 1), factored
#    here with opaline-factor from the preset dataset <presets>/datasets/chess4x4.opm;
#  - the presets SVD_S10_Chess4x4, SVD_S10_Chess8x8 (against raw Chess8x8), TUCKER_T15_P7_Chess4x4,
#    TUCKER_T10_P4_Chess8x8 (when built).
# Usage: bench/bench_subsurface.sh [BUILD_DIR] [THREADS] [SPP] [PRESETS_DIR]
#   defaults: build, 2 threads, 16 samples per pixel, BUILD_DIR/presets. Use a Release build.
#   REPEAT=3 renders every material 3 times and reports the median times.
set -euo pipefail
SRC=$(cd "$(dirname "$0")/.." && pwd)
BUILD=$(cd "${1:-$SRC/build}" && pwd)
THREADS=${2:-2}
SPP=${3:-16}
PRESETS=$(cd "${4:-$BUILD/presets}" && pwd)
REPEAT=${REPEAT:-1}
SPOT=${OPALINE_SHARED_DIR:-$SRC/../shared}/meshes/spot.obj
RENDER=$BUILD/bin/opaline-render
FACTOR=$BUILD/bin/opaline-factor
[ -f "$SPOT" ] || { echo "skip: $SPOT is absent (../shared is not beside the checkout)"; exit 0; }
[ -x "$RENDER" ] && [ -x "$FACTOR" ] || { echo "error: $RENDER or $FACTOR not built"; exit 1; }
[ -f "$PRESETS/datasets/chess4x4.opm" ] || { echo "error: $PRESETS/datasets/chess4x4.opm absent (build the presets)"; exit 1; }
[ -x /usr/bin/time ] || { echo "error: /usr/bin/time (GNU time) is needed for the peak memory"; exit 1; }
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT

scene() { # $1 type, $2 material path
cat <<XML
<scene version="0.6.0">
  <integrator type="path"><integer name="maxDepth" value="4"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="35"/>
    <transform name="toWorld"><lookat origin="2.6, 1.2, 2.4" target="0, 0.05, 0.1" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="$SPP"/></sampler>
    <film type="hdrfilm"><integer name="width" value="512"/><integer name="height" value="512"/></film>
  </sensor>
  <emitter type="spot">
    <transform name="toWorld"><lookat origin="1.5, 3.5, 2.0" target="0, 0, 0"/></transform>
    <spectrum name="intensity" value="30"/>
    <float name="cutoffAngle" value="40"/>
  </emitter>
  <emitter type="constant"><spectrum name="radiance" value="0.05"/></emitter>
  <shape type="obj">
    <string name="filename" value="$SPOT"/>
    <subsurface type="$1">
      <string name="material" value="$2"/>
      <float name="scale" value="19"/>
    </subsurface>
  </shape>
  <shape type="rectangle">
    <transform name="toWorld"><rotate x="1" angle="-90"/><scale value="4"/><translate y="-0.737"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>
  </shape>
</scene>
XML
}

# PFM -> RMSE and PSNR of $1 against the reference $2
compare() {
python3 - "$1" "$2" <<'PY'
import math, struct, sys
def pfm(p):
    with open(p, "rb") as f:
        kind = f.readline().strip(); w, h = map(int, f.readline().split()); s = float(f.readline())
        n = w * h * (3 if kind == b"PF" else 1)
        return struct.unpack(("<" if s < 0 else ">") + "%df" % n, f.read(4 * n))
a, b = pfm(sys.argv[1]), pfm(sys.argv[2])
mse = sum((x - y) ** 2 for x, y in zip(a, b)) / len(a)
peak = max(b)
rmse = math.sqrt(mse)
print("%.3g %s" % (rmse, "inf" if rmse == 0 else "%.1f" % (20 * math.log10(peak / rmse))))
PY
}

median() { sort -g | awk '{v[NR]=$1} END{print v[int((NR+1)/2)]}'; }

# render $1 type, $2 material, $3 output pfm: prints "prepass wall peakMiB" (medians over REPEAT)
render() {
    local pre="" wall="" mem=""
    scene "$1" "$2" > "$T/scene.xml"
    for r in $(seq "$REPEAT"); do
        /usr/bin/time -v "$RENDER" -t "$THREADS" -o "$3" "$T/scene.xml" > "$T/out.txt" 2> "$T/err.txt" ||
            { cat "$T/err.txt" >&2; exit 1; }
        pre="$pre $(sed -n 's/.*subsurface pre-pass: \([0-9.]*\) s.*/\1/p' "$T/err.txt" | tail -1)"
        wall="$wall $(awk -F': ' '/Elapsed \(wall clock\)/{n=split($2,t,":"); s=0; for(i=1;i<=n;i++) s=s*60+t[i]; print s}' "$T/err.txt")"
        mem="$mem $(awk -F': ' '/Maximum resident set size/{printf "%.0f", $2/1024}' "$T/err.txt")"
        grep -i "warn" "$T/err.txt" | sort -u | head -3 >&2 || true
    done
    echo "$(echo $pre | tr ' ' '\n' | median) $(echo $wall | tr ' ' '\n' | median) $(echo $mem | tr ' ' '\n' | median)"
}

printf "opaline-render subsurface benchmark: spot.obj 512x512, %s spp, %s threads, %s run(s) each\n" "$SPP" "$THREADS" "$REPEAT"
printf "%-26s %10s %10s %9s %10s %8s\n" material "prepass_s" "total_s" "peak_MiB" "RMSE" "PSNR_dB"

row() { # $1 label, $2 type, $3 material, $4 reference pfm (or "" for the reference itself)
    local out="$T/$1.pfm" f err
    f=$(render "$2" "$3" "$out")
    if [ -n "$4" ]; then err=$(compare "$out" "$4"); else err="- -"; fi
    read -r pre wall mem <<< "$f"
    read -r rmse psnr <<< "$err"
    printf "%-26s %10s %10s %9s %10s %8s\n" "$1" "$pre" "$wall" "$mem" "$rmse" "$psnr"
}

row raw_Chess4x4 raw "$PRESETS/datasets/chess4x4.opm" ""
for t in 1 5 10 20 40; do
    "$FACTOR" factor "$PRESETS/datasets/chess4x4.opm" -o "$T/SVD_S${t}_Chess4x4.opm" --method svd \
        -T "$t" --log-a 100 --log-b 1 -q > /dev/null
    row "SVD_S${t}_Chess4x4" svd "$T/SVD_S${t}_Chess4x4.opm" "$T/raw_Chess4x4.pfm"
done
[ -f "$PRESETS/SVD_S10_Chess4x4.opm" ] && row preset_SVD_S10_Chess4x4 svd "$PRESETS/SVD_S10_Chess4x4.opm" "$T/raw_Chess4x4.pfm"
[ -f "$PRESETS/TUCKER_T15_P7_Chess4x4.opm" ] && row TUCKER_T15_P7_Chess4x4 tucker "$PRESETS/TUCKER_T15_P7_Chess4x4.opm" "$T/raw_Chess4x4.pfm"
if [ -f "$PRESETS/datasets/chess8x8.opm" ]; then
    row raw_Chess8x8 raw "$PRESETS/datasets/chess8x8.opm" ""
    [ -f "$PRESETS/SVD_S10_Chess8x8.opm" ] && row SVD_S10_Chess8x8 svd "$PRESETS/SVD_S10_Chess8x8.opm" "$T/raw_Chess8x8.pfm"
    [ -f "$PRESETS/TUCKER_T10_P4_Chess8x8.opm" ] && row TUCKER_T10_P4_Chess8x8 tucker "$PRESETS/TUCKER_T10_P4_Chess8x8.opm" "$T/raw_Chess8x8.pfm"
fi
exit 0
