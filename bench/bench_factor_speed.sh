#!/usr/bin/env bash
# bench_factor_speed.sh - the whole `opaline-factor factor` command on Chess4x4 (277 x 277
# pixels, K 29, 3 channels, 774 MB), against its time goals: svd T=10 <= 2.5 s, tucker T=15 P=7
# <= 5 s, kcta C=32 K_m=1 T=4 <= 6 s (wall time of the whole command, report included), error
# figures unchanged or better. Each configuration runs REPEATS times, interleaved with
# scikit-learn's randomized_svd of the same three channels (rank 10, n_iter 4 and 7) in the same
# run (once per repeat, with --only too); the table gives medians. With --before DIR, the same
# runs with another build (the baseline) interleaved too, for before/after figures on the same
# machine state. The error figures are the report's, over every value of the dataset on every
# run (the stored albedo map needs every row evaluated anyway, so a sampled quick estimate would
# save little): there is no sampled estimate to compare with.
#
# usage: bench/bench_factor_speed.sh [--build DIR] [--before DIR] [--repeats N] [--work DIR]
#                                    [--only svd,tucker,kcta]
#   --build defaults to build-rel, --work to BUILD/bench-speed (the dataset is made there once,
#   about a minute). Times: wall clock and CPU (user + system) of the process; the machine may
#   be shared, so read the medians beside scikit-learn's figure of the same run.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=$root/build-rel before="" repeats=3 work="" only="svd,tucker,kcta"
while [ $# -gt 0 ]; do
  case $1 in
    --build) build=$2; shift 2 ;;
    --before) before=$2; shift 2 ;;
    --repeats) repeats=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    --only) only=$2; shift 2 ;;
    *) echo "bench_factor_speed: unknown argument '$1' (see the header)" >&2; exit 2 ;;
  esac
done
work=${work:-$build/bench-speed}
tool=$build/bin/opaline-factor
[ -x "$tool" ] || { echo "bench_factor_speed: $tool not built" >&2; exit 2; }
if [ -n "$before" ] && [ ! -x "$before/bin/opaline-factor" ]; then
  echo "bench_factor_speed: $before/bin/opaline-factor not built" >&2; exit 2
fi
bash "$root/scripts/install-deps.sh" --bench >/dev/null # scikit-learn, the peer
mkdir -p "$work"
ds=$work/chess4x4.opm
[ -f "$ds" ] || "$tool" dataset chess4x4 -o "$ds" --eta 1.3 2>/dev/null
py=python3
[ -x /usr/bin/python3 ] && py=/usr/bin/python3 # Debian's, with python3-sklearn
"$py" - "$tool" "${before:+$before/bin/opaline-factor}" "$repeats" "$work" "$ds" "$only" <<'PY'
import json, os, statistics, subprocess, sys, time
tool, before, repeats, work, ds, only = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4], sys.argv[5], sys.argv[6].split(",")
configs = [("svd", ["--method", "svd", "-T", "10"], "svd T=10", 2.5),
           ("tucker", ["--method", "tucker", "-T", "15", "-P", "7"], "tucker T=15 P=7", 5.0),
           ("kcta", ["--method", "kcta", "-C", "32", "--km", "1", "-T", "4"], "kcta C=32 K_m=1 T=4", 6.0)]
configs = [c for c in configs if c[0] in only]

def run(binary, args, tag):
    rep = os.path.join(work, f"{tag}.json")
    t = time.time()
    p = subprocess.Popen([binary, "factor", ds, "-o", os.path.join(work, f"{tag}.opm"), "--report", rep, "-q"] + args,
                         stdout=subprocess.DEVNULL)
    _, status, ru = os.wait4(p.pid, 0)
    wall = time.time() - t
    if status != 0:
        sys.exit(f"bench_factor_speed: {binary} {' '.join(args)} failed ({status})")
    r = json.load(open(rep))
    return {"wall": wall, "cpu": ru.ru_utime + ru.ru_stime, "total": r["total_seconds"],
            "stages": r["stage_seconds"], "rel": r["relative_rmse"], "max": r["max_error"],
            "peak": r["peak_memory_bytes"] / 2**20}

import numpy as np
from sklearn.utils.extmath import randomized_svd
b = open(ds, "rb").read()
count = int.from_bytes(b[12:16], "little"); table = int.from_bytes(b[24:32], "little")
chan = []
for i in range(count):
    e = b[table + 32 * i: table + 32 * i + 32]
    if e[:3] == b"RD.":
        off, size = int.from_bytes(e[8:16], "little"), int.from_bytes(e[16:24], "little")
        chan.append(np.frombuffer(b, np.float32, size // 4, off).reshape(-1, 841))
def sklearn(n_iter):
    t = time.time()
    for a in chan:  # its input as opaline's svd sees it: float32, one channel at a time
        randomized_svd(a, 10, n_iter=n_iter, random_state=0)
    return time.time() - t

res = {}
load_start = os.getloadavg()[0]
for k in range(repeats):
    for name, args, _, _ in configs:
        res.setdefault(("after", name), []).append(run(tool, args, f"{name}-after"))
        if before:
            res.setdefault(("before", name), []).append(run(before, args, f"{name}-before"))
        if name == configs[0][0]:  # the peer once per repeat, whichever configs run
            res.setdefault("sk4", []).append(sklearn(4))
            res.setdefault("sk7", []).append(sklearn(7))
med = statistics.median
print(f"Chess4x4 ({os.path.getsize(ds) / 1e6:.0f} MB), medians of {repeats} runs, interleaved; "
      f"load average {load_start:.1f} at the start, {os.getloadavg()[0]:.1f} at the end "
      f"({os.cpu_count()} cores here)")
# "wall met?" is the goal as measured, at this machine's load; "CPU/2 met?" only says that two
# idle cores could meet it if the work were spread perfectly (a bound, not a measurement).
print("| method | build | load | preprocess | factor | evaluate | total (report) | wall | CPU | goal | wall met? | CPU/2 met? | relative RMSE | max error | peak MiB |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
for name, _, label, goal in configs:
    for which in (["before"] if before else []) + ["after"]:
        rs = res[(which, name)]
        st = lambda key: med([r["stages"].get(key, 0.0) for r in rs])
        wall, cpu = med([r["wall"] for r in rs]), med([r["cpu"] for r in rs])
        met = "yes" if wall <= goal else "no"
        half = "yes" if cpu / 2 <= goal else "no"
        print(f"| {label} | {which} | {st('load'):.2f} | {st('preprocess'):.2f} | {st('factor'):.2f} | "
              f"{st('evaluate'):.2f} | {med([r['total'] for r in rs]):.2f} | {wall:.2f} | "
              f"{cpu:.2f} | <= {goal:g} s | {met} | {half} | "
              f"{rs[-1]['rel'] * 100:.5f} % | {rs[-1]['max']:.6g} | {med([r['peak'] for r in rs]):.0f} |")
if "sk4" in res:
    print(f"| scikit-learn randomized_svd, 3 channels, rank 10, n_iter 4 | | | | | | | "
          f"{med(res['sk4']):.2f} | | | | | | | |")
    print(f"| scikit-learn randomized_svd, 3 channels, rank 10, n_iter 7 (its default) | | | | | | | "
          f"{med(res['sk7']):.2f} | | | | | | | |")
PY
