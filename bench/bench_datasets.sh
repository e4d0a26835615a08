#!/usr/bin/env bash
# bench_datasets.sh - paper-size dataset timings (not a test).
#   generator 2 (diffusion): wall time of each paper-size dataset (goal: < 60 s each);
#   generator 1 (Monte Carlo): photon steps per second and the estimated time to reach 5 %
#   relative standard error on the albedo at paper size, from a short run (BENCH_MC_PHOTONS
#   photons per pixel, default 32); BENCH_MC_FULL=1 then also runs that many photons for real.
# Usage: bash bench/bench_datasets.sh [BUILD_DIR]   (a Release build; default: build)
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-${OPALINE_BUILD_DIR:-$here/build}}
tool=$build/bin/opaline-factor
[ -x "$tool" ] || tool=$build/opaline-factor
if [ ! -x "$tool" ]; then
    echo "bench_datasets: no opaline-factor under $build (build it first: cmake --build $build)" >&2
    exit 1
fi
threads=${BENCH_THREADS:-$(nproc)}
photons=${BENCH_MC_PHOTONS:-32}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

now() { date +%s.%N; }
echo "opaline dataset benchmark: $(nproc) cores, $threads threads, tool $tool"
echo
echo "generator 2 (diffusion), paper sizes:"
for name in chess4x4 chess8x8 marble-closeup veined-marble; do
    t0=$(now)
    "$tool" dataset "$name" -t "$threads" -o "$work/$name.opm" 2>"$work/log" ||
        { cat "$work/log" >&2; exit 1; }
    t1=$(now)
    size=$(stat -c %s "$work/$name.opm")
    printf '  %-15s %7.2f s  (%s MB written)\n' "$name" "$(awk -v a="$t0" -v b="$t1" 'BEGIN { print b - a }')" \
        "$((size / 1000000))"
    rm -f "$work/$name.opm"
done
echo
echo "generator 1 (Monte Carlo), chess4x4 at paper size, $photons photons per pixel and channel:"
"$tool" dataset chess4x4 --generator montecarlo --photons "$photons" -t "$threads" \
    -o "$work/mc.opm" 2>"$work/log" || { cat "$work/log" >&2; exit 1; }
grep -E 'montecarlo: [0-9]+ photons|relative standard error|generated and written in' "$work/log" |
    sed 's/^opaline: info: /  /'
need=$(sed -n 's/.*needs about \([0-9]*\) photons.*/\1/p' "$work/log")
if [ "${BENCH_MC_FULL:-0}" = 1 ] && [ -n "$need" ]; then
    echo
    echo "generator 1 at $need photons per pixel (5 % relative standard error on the albedo):"
    "$tool" dataset chess4x4 --generator montecarlo --photons "$need" -t "$threads" \
        -o "$work/mc.opm" 2>"$work/log" || { cat "$work/log" >&2; exit 1; }
    grep -E 'montecarlo: [0-9]+ photons|relative standard error|generated and written in' "$work/log" |
        sed 's/^opaline: info: /  /'
fi
