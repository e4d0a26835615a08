#!/usr/bin/env bash
# The ground truth for subsurface: each subsurface model (the dipole; the measured raw and, in
# the full mode, svd of a homogeneous Monte Carlo dataset) against the same medium rendered as
# a volume by volpath, behind the same smooth dielectric, per image region (flat, curved, thin,
# near shadow edges), for Skin1, Marble, Ketchup and Vein (low albedo) on a slab, a sphere, a
# 1 mm fin, the bunny and the cow. Details: bench_sss_truth.py, docs/subsurface-rendering.md
# (*Against a volume*).
# Usage: bench/bench_sss_truth.sh [BUILD_DIR] [THREADS] [MODE]
#   defaults: build, 2 threads, quick (Skin1 and Vein on the sphere and the fin; 48 x 48,
#   volume 256 spp: a few minutes on 2 cores); full (every medium and shape, 128 x 128, volume
#   4096 spp, models 256 spp: hours). Use a Release build.
#   Environment: OUT (output folder, default BUILD_DIR/bench-sss-truth; renders whose scene and
#   renderer did not change are reused), MEDIA, SHAPES (subsets), RES, VOL_SPP, MODEL_SPP,
#   PHOTONS (Monte Carlo photons per dataset pixel and channel), OPALINE_SHARED_DIR (where
#   meshes/ is; the bunny and the cow are skipped when absent).
set -euo pipefail
SRC=$(cd "$(dirname "$0")/.." && pwd)
BUILD=$(cd "${1:-$SRC/build}" && pwd)
THREADS=${2:-2}
MODE=${3:-quick}
SHARED=${OPALINE_SHARED_DIR:-$SRC/../shared}
extra=()
[ -d "$SHARED/meshes" ] && extra+=(--meshes "$(cd "$SHARED/meshes" && pwd)")
[ -n "${MEDIA:-}" ] && extra+=(--media "$MEDIA")
[ -n "${SHAPES:-}" ] && extra+=(--shapes "$SHAPES")
[ -n "${RES:-}" ] && extra+=(--res "$RES")
[ -n "${VOL_SPP:-}" ] && extra+=(--vol-spp "$VOL_SPP")
[ -n "${MODEL_SPP:-}" ] && extra+=(--model-spp "$MODEL_SPP")
[ -n "${PHOTONS:-}" ] && extra+=(--photons "$PHOTONS")
exec python3 "$SRC/bench/bench_sss_truth.py" --build "$BUILD" --threads "$THREADS" --mode "$MODE" \
    --out "${OUT:-$BUILD/bench-sss-truth}" "${extra[@]}"
