#!/usr/bin/env bash
# The factor report's peak memory is opaline-factor's own (VmHWM), not the peak of the process
# that started it: run from a parent that holds 600 MiB, a small factorization must still report
# far less (getrusage's ru_maxrss carries the parent's peak across execve).
set -euo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup peak_memory opaline-factor

"$F" dataset chess4x4 --pixels 16x16 --kernel 7 -o "$T/d.opm" 2>/dev/null
python3 - "$F" "$T" <<'PY'
import json, os, subprocess, sys
f, t = sys.argv[1], sys.argv[2]
held = bytearray(600 << 20)
for i in range(0, len(held), 4096):  # touch every page: resident, not just reserved
    held[i] = 1
with open("/proc/self/status") as st:
    parent = next(int(l.split()[1]) for l in st if l.startswith("VmHWM")) * 1024
subprocess.run([f, "factor", os.path.join(t, "d.opm"), "--method", "svd", "-T", "2",
                "-o", os.path.join(t, "m.opm"), "--report", os.path.join(t, "r.json")],
               check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
peak = json.load(open(os.path.join(t, "r.json")))["peak_memory_bytes"]
print("parent peak %.0f MiB, reported factor peak %.0f MiB" % (parent / 2**20, peak / 2**20))
assert parent > 600 << 20, parent
assert 0 < peak < 400 << 20, "the report's peak memory includes the parent's: %d bytes" % peak
PY
echo "peak memory OK"
