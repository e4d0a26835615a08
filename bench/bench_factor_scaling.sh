#!/usr/bin/env bash
# bench_factor_scaling.sh - how the factorizer's cost grows with the dataset: time and
# peak memory of the whole `opaline-factor factor` command against the dataset's size, for each
# method, with the exponent of a least-squares fit time ~ bytes^e (and memory ~ bytes^e), on
# chessboards made by the generator (Chess4x4's media and pixel size, 0.455 mm):
#   --series pixels: 139^2, 196^2, 277^2 (the paper's), 392^2 pixels at K 29 (0.25x to 2x bytes)
#   --series kernel: K 15, 21, 29, 41 at 196^2 pixels (0.27x to 1x the paper's bytes)
# Methods: svd T=10, svd T=10 streamed (--block-rows, 64 MiB blocks), tucker T=15 P=7, kcta C=32
# K_m=1 T=4, nmf T=10 --iters 50 (one run each: the exponent is the figure, not the times).
# Then the out-of-core check: the paper-size dataset factored by svd inside a memory cgroup
# whose limit (--limit-mib, default 256) is a third of the dataset, in memory (expected: killed)
# and streamed (expected: done, peak under the limit). Datasets are deleted at the end; disk
# needed: the largest dataset (1.55 GB) plus one other at a time.
#
# usage: bench/bench_factor_scaling.sh [--build DIR] [--work DIR] [--series pixels|kernel|both]
#                                      [--methods svd,svd-stream,tucker,kcta,nmf]
#                                      [--limit-mib N] [--no-ooc]
#   --series none runs the out-of-core check alone.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=$root/build-rel work="" series=pixels methods="svd,svd-stream,tucker,kcta,nmf" limit=256 ooc=1
while [ $# -gt 0 ]; do
  case $1 in
    --build) build=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    --series) series=$2; shift 2 ;;
    --methods) methods=$2; shift 2 ;;
    --limit-mib) limit=$2; shift 2 ;;
    --no-ooc) ooc=0; shift ;;
    *) echo "bench_factor_scaling: unknown argument '$1' (see the header)" >&2; exit 2 ;;
  esac
done
work=${work:-$build/bench-scaling}
tool=$build/bin/opaline-factor
[ -x "$tool" ] || { echo "bench_factor_scaling: $tool not built" >&2; exit 2; }
mkdir -p "$work"
trap 'rm -f "$work"/ds-*.opm "$work"/out-*.opm' EXIT
results=$work/results.tsv
: > "$results"

# One dataset: pixels side P, kernel K (pixel size 0.455 mm, Chess4x4's).
make_ds() {
  local p=$1 k=$2 out=$work/ds-$1-$2.opm
  local cm
  cm=$(awk -v p="$p" 'BEGIN { printf "%.4f", p * 0.0454874 }')
  [ -f "$out" ] || "$tool" dataset chess4x4 --pixels "$p" --kernel "$k" --size-cm "${cm}x${cm}" \
    --eta 1.3 -o "$out" 2>/dev/null
  echo "$out"
}

# Runs one method on a dataset; appends series, pixels, K, bytes, method, wall, cpu, peak MiB,
# relative RMSE to the results.
run_method() {
  local s=$1 p=$2 k=$3 ds=$4 m=$5 args
  case $m in
    svd) args=(--method svd -T 10) ;;
    svd-stream) args=(--method svd -T 10 --block-rows $(( (64 << 20) / (k * k * 4) ))) ;;
    tucker) args=(--method tucker -T 15 -P 7) ;;
    kcta) args=(--method kcta -C 32 --km 1 -T 4) ;;
    nmf) args=(--method nmf -T 10 --iters 50) ;;
    *) echo "bench_factor_scaling: unknown method $m" >&2; exit 2 ;;
  esac
  /usr/bin/time -f "%e %U %S" -o "$work/time.txt" "$tool" factor "$ds" -o "$work/out-$m.opm" \
    --report "$work/r.json" -q "${args[@]}" > /dev/null
  read -r wall user sys < "$work/time.txt"
  python3 - "$work/r.json" "$s" "$p" "$k" "$(stat -L -c %s "$ds")" "$m" "$wall" "$user" "$sys" \
    >> "$results" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
s, p, k, b, m, wall, user, sys_ = sys.argv[2:]
print(f"{s}\t{p}\t{k}\t{b}\t{m}\t{float(wall):.2f}\t{float(user) + float(sys_):.2f}\t"
      f"{r['peak_memory_bytes'] / 2**20:.0f}\t{r['relative_rmse']}")
PY
}

points=()
case $series in
  pixels) points=("pixels 139 29" "pixels 196 29" "pixels 277 29" "pixels 392 29") ;;
  kernel) points=("kernel 196 15" "kernel 196 21" "kernel 196 29" "kernel 196 41") ;;
  both) points=("pixels 139 29" "pixels 196 29" "pixels 277 29" "pixels 392 29"
                "kernel 196 15" "kernel 196 21" "kernel 196 41") ;;
  none) ;;
  *) echo "bench_factor_scaling: --series pixels, kernel, both or none" >&2; exit 2 ;;
esac
for pt in ${points[@]+"${points[@]}"}; do
  read -r s p k <<< "$pt"
  ds=$(make_ds "$p" "$k")
  for m in ${methods//,/ }; do
    echo "== $s: $p x $p pixels, K $k, $m" >&2
    run_method "$s" "$p" "$k" "$ds" "$m"
  done
  [ "$p $k" = "277 29" ] || rm -f "$ds" # the paper's size stays for the out-of-core check
done

[ -s "$results" ] && python3 - "$results" <<'PY'
import math, sys
rows = [l.rstrip("\n").split("\t") for l in open(sys.argv[1])]
print("| series | pixels | K | dataset MB | method | wall s | CPU s | peak MiB | relative RMSE |")
print("|---|---|---|---|---|---|---|---|---|")
for s, p, k, b, m, wall, cpu, peak, rel in rows:
    print(f"| {s} | {p} x {p} | {k} | {int(b) / 1e6:.0f} | {m} | {wall} | {cpu} | {peak} | "
          f"{float(rel) * 100:.3f} % |")
def slope(xs, ys):
    lx = [math.log(x) for x in xs]; ly = [math.log(y) for y in ys]
    mx, my = sum(lx) / len(lx), sum(ly) / len(ly)
    return sum((a - mx) * (b - my) for a, b in zip(lx, ly)) / sum((a - mx) ** 2 for a in lx)
print()
print("| series | method | exponent of wall time | of CPU time | of peak memory (vs dataset bytes) |")
print("|---|---|---|---|---|")
for s in sorted({r[0] for r in rows}):
    for m in dict.fromkeys(r[4] for r in rows):
        pts = [r for r in rows if r[0] == s and r[4] == m]
        if len(pts) < 2:
            continue
        b = [float(r[3]) for r in pts]
        print(f"| {s} | {m} | {slope(b, [float(r[5]) for r in pts]):.2f} | "
              f"{slope(b, [max(float(r[6]), 1e-3) for r in pts]):.2f} | "
              f"{slope(b, [float(r[7]) for r in pts]):.2f} |")
PY

if [ "$ooc" = 1 ]; then
  ds=$(make_ds 277 29)
  echo
  echo "Out of core: $(basename "$ds") ($(( $(stat -L -c %s "$ds") >> 20 )) MiB) factored by svd T=10 in a"
  echo "memory cgroup limited to $limit MiB (page cache of the mapped file included)"
  cg=""
  mine=$(sed -n 's/^[0-9]*:memory:\(.*\)$/\1/p' /proc/self/cgroup | head -1)
  base=/sys/fs/cgroup/memory$mine
  if [ -n "$mine" ] && [ -w "$base" ]; then
    cg=$base/opaline-ooc-$$
  fi
  if [ -z "$cg" ] || ! mkdir "$cg" 2>/dev/null; then
    echo "(no writable cgroup-v1 memory controller here: out-of-core check skipped)"
  else
    echo $((limit << 20)) > "$cg/memory.limit_in_bytes"
    echo $((limit << 20)) > "$cg/memory.memsw.limit_in_bytes" 2>/dev/null || true
    for mode in "in memory:--block-rows 0" "streamed:--block-rows 19950"; do
      label=${mode%%:*} opt=${mode#*:}
      set +e
      ( echo $BASHPID > "$cg/cgroup.procs"
        exec /usr/bin/time -f "%e %U %S" -o "$work/time.txt" "$tool" factor "$ds" \
          -o "$work/out-ooc.opm" --method svd -T 10 $opt --report "$work/r.json" -q > /dev/null \
          2> "$work/ooc.err" )
      rc=$?
      set -e
      maxu=$(( $(cat "$cg/memory.max_usage_in_bytes") >> 20 ))
      if [ $rc = 0 ]; then
        read -r wall user sys < "$work/time.txt"
        python3 - "$work/r.json" "$label" "$wall" "$maxu" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
print(f"- {sys.argv[2]}: done in {sys.argv[3]} s, relative RMSE {r['relative_rmse'] * 100:.3f} %, "
      f"process peak (VmHWM) {r['peak_memory_bytes'] / 2**20:.0f} MiB, cgroup peak {sys.argv[4]} MiB")
PY
      else
        echo "- $label: exit $rc (137: killed by the cgroup's out-of-memory killer); cgroup peak" \
             "$maxu MiB; $(tail -c 300 "$work/ooc.err" | tr '\n' ' ')"
      fi
      echo 0 > "$cg/memory.max_usage_in_bytes" 2>/dev/null || true
    done
    rmdir "$cg"
  fi
fi
