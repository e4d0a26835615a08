#!/usr/bin/env bash
# The subsurface renderer against the Monte Carlo generator's own volumetric transport
# (docs/subsurface-rendering.md, "Against the Monte Carlo generator's transport"): for one channel
# of several media of the table, a slab under a hard-edged spot (radius 2 diffusion lengths L) and
# under uniform light: (a) the exact answer of a Monte Carlo Rd row (op_mc_generate, normal
# incidence, 3 independent rows), (b) the renderer's exitance with those rows as a raw material,
# (c) the renderer's dipole, (d) the dipole's closed form; at 1, 2 and 4 L outside the spot's
# edge, in total and under uniform light. The program is opaline-bench-sss-reference
# (bench/bench_sss_reference.c, built with the tests: OPALINE_BUILD_TESTS=ON).
# Usage: bench/bench_sss_reference.sh [BUILD_DIR] [PHOTONS] [MEDIUM]
#   defaults: build, 200000 photons per row, every medium of the program's table. A Release build.
set -euo pipefail
SRC=$(cd "$(dirname "$0")/.." && pwd)
BUILD=$(cd "${1:-$SRC/build}" && pwd)
PHOTONS=${2:-200000}
PROG=$BUILD/bin/opaline-bench-sss-reference
[ -x "$PROG" ] || { echo "error: $PROG not built (cmake --build $BUILD --target opaline-bench-sss-reference)"; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "# bench_sss_reference: $(git -C "$SRC" rev-parse --short HEAD 2>/dev/null || echo '?'), $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg)"
OPALINE_TEST_TMP=$tmp /usr/bin/time -f "# %e s wall, %U+%S s cpu, %M KB peak" \
    "$PROG" "$PHOTONS" ${3:+"$3"}
