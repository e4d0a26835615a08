#!/usr/bin/env bash
# bench_factor_larger_than_ram.sh - a dataset larger than this machine's memory, made by the
# generator and factored by svd T=10 streamed from the file in row blocks.
#
# The dataset is a Chess4x4-like chessboard (Marble, Skin1, eta 1.3, pixel 0.455 mm, K 29) of
# 1.2 x MemTotal bytes (--ram-mib replaces MemTotal: a smaller run of the same kind). Both the
# generation and the factorization run inside a cgroup-v1 memory cgroup of --limit-mib MiB
# (default 2048), page cache of the file included, so neither can hold the dataset. Prints
# for each: wall and CPU time, the process's peak (VmHWM) and the cgroup's peak, and the
# factorization's relative RMSE and PSNR. The dataset and the output are deleted at the end,
# also on failure or Ctrl-C.
#
# Disk needed in --work (default build-rel/bench-ltr): the dataset, 1.2 x the memory size
# (29.0 GB for 24 GiB), plus the factored material (about 1/64 of it) and 1 GiB to spare;
# the script checks `df` first and refuses, naming the space needed.
#
# usage: bench/bench_factor_larger_than_ram.sh [--build DIR] [--work DIR] [--ram-mib N]
#                                              [--limit-mib N] [--threads N]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=$root/build-rel work="" ram_mib="" limit=2048 threads=""
while [ $# -gt 0 ]; do
  case $1 in
    --build) build=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    --ram-mib) ram_mib=$2; shift 2 ;;
    --limit-mib) limit=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    *) echo "bench_factor_larger_than_ram: unknown argument '$1' (see the header)" >&2; exit 2 ;;
  esac
done
work=${work:-$build/bench-ltr}
tool=$build/bin/opaline-factor
[ -x "$tool" ] || { echo "bench_factor_larger_than_ram: $tool not built" >&2; exit 2; }
memtotal_mib=$(( $(awk '/^MemTotal:/ { print $2 }' /proc/meminfo) >> 10 ))
ram_mib=${ram_mib:-$memtotal_mib}
targs=()
[ -z "$threads" ] || targs=(-t "$threads")

# Pixels P x P at K 29 for 1.2 x ram_mib MiB: bytes = P^2 * 841 * 4 * 3.
read -r pixels bytes cm < <(python3 - "$ram_mib" <<'PY'
import math, sys
target = 1.2 * int(sys.argv[1]) * 2**20
p = math.ceil(math.sqrt(target / (841 * 12)))
print(p, p * p * 841 * 12, f"{p * 0.0454874:.4f}")
PY
)
need=$(( bytes + bytes / 64 + (1 << 30) ))
mkdir -p "$work"
avail=$(( $(df -Pk "$work" | awk 'NR == 2 { print $4 }') * 1024 ))
if [ "$avail" -lt "$need" ]; then
  echo "bench_factor_larger_than_ram: needs $(( need / 1000000000 )).$(( need % 1000000000 / 100000000 )) GB" \
       "free in $work (dataset $(( bytes / 1000000 )) MB, 1.2 x $ram_mib MiB, plus its factored" \
       "material and 1 GiB to spare); $(( avail / 1000000 )) MB free there" >&2
  exit 1
fi

ds=$work/ltr-dataset.opm out=$work/ltr-out.opm
cg=""
cleanup() {
  rm -f "$ds" "$out" "$work"/ltr-*.tmp-opaline-* "$work/r.json" "$work/time.txt" "$work/err.txt"
  [ -z "$cg" ] || rmdir "$cg" 2>/dev/null || true
}
trap cleanup EXIT
trap 'exit 130' INT TERM HUP

mine=$(sed -n 's/^[0-9]*:memory:\(.*\)$/\1/p' /proc/self/cgroup | head -1)
base=/sys/fs/cgroup/memory$mine
if [ -n "$mine" ] && [ -w "$base" ] && mkdir "$base/opaline-ltr-$$" 2>/dev/null; then
  cg=$base/opaline-ltr-$$
  echo $((limit << 20)) > "$cg/memory.limit_in_bytes"
  echo $((limit << 20)) > "$cg/memory.memsw.limit_in_bytes" 2>/dev/null || true
else
  echo "(no writable cgroup-v1 memory controller here: runs without a memory limit)"
fi

# Runs "$@" in the cgroup (when there is one) under /usr/bin/time; sets rc, wall, cpu, cg_peak.
in_cgroup() {
  set +e
  ( [ -z "$cg" ] || echo $BASHPID > "$cg/cgroup.procs"
    exec /usr/bin/time -f "%e %U %S" -o "$work/time.txt" "$@" 2> "$work/err.txt" )
  rc=$?
  set -e
  read -r wall user sys < "$work/time.txt" || true
  cpu=$(awk -v u="${user:-0}" -v s="${sys:-0}" 'BEGIN { printf "%.1f", u + s }')
  cg_peak="n/a"
  if [ -n "$cg" ]; then
    cg_peak="$(( $(cat "$cg/memory.max_usage_in_bytes") >> 20 )) MiB"
    echo 0 > "$cg/memory.max_usage_in_bytes" 2>/dev/null || true
  fi
}

echo "Machine: MemTotal $memtotal_mib MiB, $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg)"
echo "Dataset: $pixels x $pixels pixels, K 29, $(( bytes / 1000000 )) MB (1.2 x $ram_mib MiB);" \
     "memory cgroup limit $limit MiB; disk needed $(( need / 1000000 )) MB, free $(( avail / 1000000 )) MB"

in_cgroup "$tool" dataset chess4x4 --pixels "$pixels" --kernel 29 --size-cm "${cm}x${cm}" \
  --eta 1.3 "${targs[@]}" -o "$ds"
if [ "$rc" != 0 ]; then
  echo "- generate: exit $rc; $(tail -c 400 "$work/err.txt" | tr '\n' ' ')"
  exit 1
fi
gen_peak=$(sed -n 's/.*peak memory \([0-9.]*\) MiB.*/\1/p' "$work/err.txt" | tail -1)
echo "- generate: ${wall} s wall, ${cpu} s CPU, process peak (VmHWM) ${gen_peak:-?} MiB," \
     "cgroup peak $cg_peak; file $(stat -c %s "$ds") bytes"

block=$(( (64 << 20) / (841 * 4) ))
in_cgroup "$tool" factor "$ds" -o "$out" --method svd -T 10 --block-rows "$block" \
  --report "$work/r.json" "${targs[@]}" -q > /dev/null
if [ "$rc" != 0 ]; then
  echo "- factor: exit $rc (137: killed by the cgroup's out-of-memory killer); cgroup peak" \
       "$cg_peak; $(tail -c 400 "$work/err.txt" | tr '\n' ' ')"
  exit 1
fi
python3 - "$work/r.json" "$wall" "$cpu" "$cg_peak" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
print(f"- factor (svd T=10, streamed in 64 MiB blocks): {sys.argv[2]} s wall, {sys.argv[3]} s CPU, "
      f"process peak (VmHWM) {r['peak_memory_bytes'] / 2**20:.0f} MiB, cgroup peak {sys.argv[4]}; "
      f"relative RMSE {r['relative_rmse'] * 100:.3f} %, PSNR {r['psnr']:.2f} dB")
PY
