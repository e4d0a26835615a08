#!/usr/bin/env bash
# bench_factor.sh - the factorizer at paper size: Chess4x4 (277 x 277 pixels, K = 29, 3
# channels), svd with T = 10. Prints wall time, peak memory against the dataset's size, the time
# of one Rd evaluation and of the whole albedo map, and, when python3-sklearn is installed,
# scikit-learn's randomized_svd on one channel for comparison.
#
# usage: bench/bench_factor.sh [BUILD_DIR] [WORK_DIR]
#   BUILD_DIR defaults to build-factor-rel (use a Release build), WORK_DIR to BUILD_DIR/bench.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build-factor-rel}
work=${2:-$build/bench}
bash "$root/scripts/install-deps.sh" --bench # scikit-learn, the peer
tool=$build/bin/opaline-factor
[ -x "$tool" ] || { echo "bench_factor: $tool not built (cmake --build $build)" >&2; exit 2; }
mkdir -p "$work"
ds=$work/chess4x4.opm
if [ ! -f "$ds" ]; then
  echo "== generating the Chess4x4 dataset (paper size)"
  "$tool" dataset chess4x4 -o "$ds"
fi
echo "== opaline-factor factor --method svd -T 10"
/usr/bin/time -f "%e %M" -o "$work/time.txt" \
  "$tool" factor "$ds" -o "$work/svd.opm" --method svd -T 10 --report "$work/svd.json" -v \
  2> >(grep -E "channel|error" >&2)
read -r wall peak_kb < "$work/time.txt"
# Debian's python3 has the Debian packages (scikit-learn); another python3 may come first on PATH.
py=python3
[ -x /usr/bin/python3 ] && py=/usr/bin/python3
"$py" - "$work/svd.json" "$ds" "$wall" "$peak_kb" <<'PY'
import json, os, sys
r = json.load(open(sys.argv[1]))
ds_bytes = os.path.getsize(sys.argv[2])
wall, peak = float(sys.argv[3]), int(sys.argv[4]) * 1024
def check(ok): return "ok" if ok else "OVER TARGET"
print(f"wall time          {wall:.2f} s (target <= 20 s: {check(wall <= 20)})")
print(f"peak memory        {peak / 2**20:.0f} MiB = {peak / ds_bytes:.2f} x dataset "
      f"({ds_bytes / 2**20:.0f} MiB) (target <= 2: {check(peak <= 2 * ds_bytes)})")
st = r["stage_seconds"]
print("stages             " + ", ".join(f"{k} {v:.2f} s" for k, v in st.items()))
print(f"Rd evaluation      {r['eval_ns']:.1f} ns coherent (target <= 50 ns: "
      f"{check(r['eval_ns'] <= 50)}), {r['eval_random_ns']:.1f} ns at random rows")
print(f"albedo map         {r['albedo_map_seconds'] * 1e3:.3f} ms (target <= 50 ms: "
      f"{check(r['albedo_map_seconds'] <= 0.05)})")
print(f"accuracy           RMSE {r['rmse']:.4g}, relative {r['relative_rmse']:.4g}, "
      f"PSNR {r['psnr']:.2f} dB, size {r['size_bytes']} bytes, ratio {r['compression_ratio']:.1f}")
PY
if "$py" -c "import sklearn" 2>/dev/null; then
  echo "== scikit-learn randomized_svd, one channel (76729 x 841 float32, rank 10)"
  "$py" - "$ds" <<'PY'
import sys, time, numpy as np
from sklearn.utils.extmath import randomized_svd
# Read RD.R straight from the .opm section table (docs/formats.md).
b = open(sys.argv[1], "rb").read()
count = int.from_bytes(b[12:16], "little"); table = int.from_bytes(b[24:32], "little")
for i in range(count):
    e = b[table + 32 * i: table + 32 * i + 32]
    if e[:8].rstrip(b"\0") == b"RD.R":
        off, size = int.from_bytes(e[8:16], "little"), int.from_bytes(e[16:24], "little")
a = np.frombuffer(b, np.float32, size // 4, off).reshape(-1, 841).copy()
t = time.time(); randomized_svd(a, 10, random_state=0); print(f"sklearn {time.time() - t:.3f} s")
PY
else
  echo "(python3-sklearn not installed: no scikit-learn comparison; its figure on this machine"
  echo " was 0.71 s per channel, ../shared/reference/subsurface-facts.md beside the checkout)"
fi
