#!/usr/bin/env bash
# Subsurface rendering benchmark, the paper's scene: Spot the cow (../shared/meshes/spot.obj) on a
# floor under a spot light, with the measured chessboards Chess4x4 and Chess8x8. For each board,
# raw (the reference) and svd / tucker (P = 7 for Chess4x4, 4 for Chess8x8) at T = 1 2 5 10 20 40:
# factorization, subsurface pre-pass and camera-pass times, wall time, peak resident memory, RMSE
# and PSNR against raw at equal samples; for raw and svd T = 10 the time to reach 1 % relative
# RMSE against a 16x-sample reference of the same method; the verdict against the goal (svd
# T = 10 converged in <= 3 s with PSNR >= 47.8 dB at 512 x 512). Details: bench_subsurface.py,
# docs/subsurface-rendering.md.
# Usage: bench/bench_subsurface.sh [BUILD_DIR] [THREADS] [SPP] [PRESETS_DIR]
#   defaults: build, 2 threads, 16 samples per pixel, BUILD_DIR/presets. Use a Release build.
#   Environment: OUT (output folder, default BUILD_DIR/bench-subsurface; materials factored
#   there are reused by later runs), RES (image side, default 512), REPEAT (runs per render,
#   median; default 1), TERMS (default "1 2 5 10 20 40"), BOARDS (default "chess4x4 chess8x8"),
#   CONVERGE=0 (skip the time-to-1 % runs), OPALINE_SHARED_DIR (where meshes/spot.obj is),
#   SAMPLER (sobol, the default, or independent), PEER (another build folder, e.g. of an earlier
#   commit: its renderer runs the svd convergence renders too, each right after ours, and its
#   time to 1 % is printed beside ours: the same machine load for both).
set -euo pipefail
SRC=$(cd "$(dirname "$0")/.." && pwd)
BUILD=$(cd "${1:-$SRC/build}" && pwd)
THREADS=${2:-2}
SPP=${3:-16}
PRESETS=${4:-$BUILD/presets}
SHARED=${OPALINE_SHARED_DIR:-$SRC/../shared}
# a worktree under wt/ has shared/ two levels up
[ -d "$SHARED" ] || [ -n "${OPALINE_SHARED_DIR:-}" ] || SHARED=$SRC/../../shared
SPOT=$SHARED/meshes/spot.obj
[ -f "$SPOT" ] || { echo "skip: $SPOT is absent (../shared is not beside the checkout)"; exit 0; }
for tool in opaline-render opaline-factor; do
    [ -x "$BUILD/bin/$tool" ] || { echo "error: $BUILD/bin/$tool not built"; exit 1; }
done
[ -x /usr/bin/time ] || { echo "error: /usr/bin/time (GNU time) is needed for the peak memory"; exit 1; }
conv=()
[ "${CONVERGE:-1}" = 0 ] && conv=(--no-converge)
[ -n "${PEER:-}" ] && conv+=(--peer "$(cd "$PEER" && pwd)")
exec python3 "$SRC/bench/bench_subsurface.py" --build "$BUILD" --threads "$THREADS" --spp "$SPP" \
    --presets "$PRESETS" --out "${OUT:-$BUILD/bench-subsurface}" --res "${RES:-512}" \
    --repeat "${REPEAT:-1}" --terms "${TERMS:-1 2 5 10 20 40}" \
    --boards "${BOARDS:-chess4x4 chess8x8}" --sampler "${SAMPLER:-sobol}" --mesh "$(cd "$(dirname "$SPOT")" && pwd)/spot.obj" \
    "${conv[@]}"
