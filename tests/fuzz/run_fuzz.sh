#!/usr/bin/env bash
# run_fuzz.sh TARGET EXE [SECONDS] - one fuzz target on a fresh corpus: the committed seeds of
# tests/fuzz/seeds/TARGET, inputs made by the built commands (materials of every method;
# images of every format, opaline-render's outputs and image_seeds') and the saved regressions
# of tests/fuzz/regressions/TARGET.
# SECONDS 0 (default) replays that corpus once (any compiler); otherwise EXE is a libFuzzer
# binary fuzzed for SECONDS from it. A crash prints the input (base64) and keeps it under
# $OPALINE_TEST_TMP/fuzz-artifacts; add it to tests/fuzz/regressions/TARGET with the fix.
set -euo pipefail
target=${1:?target} exe=${2:?executable} seconds=${3:-0}
src=$(cd "$(dirname "$0")" && pwd)
BIN=${OPALINE_BIN_DIR:?OPALINE_BIN_DIR is not set}
tmp=${OPALINE_TEST_TMP:-/tmp}
work=$(mktemp -d "$tmp/fuzz_$target.XXXXXX")
trap 'rm -rf "$work"' EXIT
corpus=$work/corpus
mkdir -p "$corpus"
[ -d "$src/seeds/$target" ] && cp "$src/seeds/$target"/* "$corpus/"

case $target in
  material)
    factor() { "$BIN/opaline-factor" "$@" >/dev/null; }
    factor dataset chess4x4 --pixels 5x4 --kernel 3 -o "$corpus/raw.opm" 2>/dev/null
    factor factor "$corpus/raw.opm" --method svd -T 2 -o "$corpus/svd.opm"
    factor factor "$corpus/raw.opm" --method svd -T 1 --no-shift -o "$corpus/svd1.opm"
    factor factor "$corpus/raw.opm" --method tucker -T 2 -P 2 -o "$corpus/tucker.opm"
    factor factor "$corpus/raw.opm" --method kcta -T 1 -C 2 --km 1 --iters 2 -o "$corpus/kcta.opm"
    factor factor "$corpus/raw.opm" --method nmf -T 2 --iters 5 -o "$corpus/nmf.opm"
    ;;
  image)
    cat > "$work/scene.xml" <<'XML'
<scene version="0.6.0">
  <sensor type="perspective"><sampler type="independent"><integer name="sampleCount" value="1"/></sampler>
    <film type="hdrfilm"><integer name="width" value="3"/><integer name="height" value="2"/></film></sensor>
  <emitter type="constant"><rgb name="radiance" value="0.25, 0.5, 2"/></emitter>
</scene>
XML
    for ext in png exr pfm hdr; do
      "$BIN/opaline-render" -q -o "$corpus/image.$ext" "$work/scene.xml"
    done
    "$BIN/image_seeds" "$corpus" # JPEG, TGA, TIFF, HDR, BMP, PNM, 16-bit PNG, OpenEXR layers
    ;;
  sss_cache)
    cat > "$work/scene.xml" <<'XML'
<scene version="0.6.0">
  <sensor type="perspective"><transform name="toWorld"><lookat origin="0, -4, 1" target="0, 0, 0.5" up="0, 0, 1"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="1"/></sampler>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film></sensor>
  <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
  <shape type="sphere"><point name="center" x="0" y="0" z="0.5"/><float name="radius" value="0.5"/>
    <subsurface type="dipole"><integer name="maxPoints" value="40"/><integer name="irrSamples" value="1"/></subsurface></shape>
</scene>
XML
    "$BIN/opaline-render" -q -t 1 --sss-cache "$corpus/cache.sssc" --sss-cache-only "$work/scene.xml" 2>/dev/null
    { printf '\001'; tail -c +65 "$corpus/cache.sssc"; } > "$corpus/body"
    ;;
esac

inputs=("$corpus")
[ -d "$src/regressions/$target" ] && inputs+=("$src/regressions/$target")
if [ "$seconds" = 0 ]; then
  exec "$exe" "${inputs[@]}"
fi
dict=()
[ -f "$src/$target.dict" ] && dict=(-dict="$src/$target.dict")
artifacts=$tmp/fuzz-artifacts/$target
mkdir -p "$artifacts"
status=0
"$exe" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=65536 \
  -artifact_prefix="$artifacts/" -print_final_stats=1 "${dict[@]}" "${inputs[@]}" || status=$?
if [ "$status" -ne 0 ]; then
  for f in "$artifacts"/*; do
    [ -f "$f" ] || continue
    echo "== $f (base64):"
    base64 "$f" | head -c 20000
    echo
  done
fi
exit "$status"
