#!/usr/bin/env python3
"""The factorizer's numerical stress suite: every method (svd, tucker, kcta, nmf) on data that
breaks naive numerics (constant, rank-deficient, one-hot, a single kernel column, random, a
dynamic range of 1e-12..1e-1, and physically impossible values up to 1e3) at extreme settings
(T from 1 to above the rank, P from 0 to 20). Each case must give finite output with an error
no worse than its documented bound, or a clear refusal (exit 2 with a message).

    stress_factor.py --bin BUILD/bin --out DIR

Writes DIR/stress.csv and DIR/stress.md (method, case, settings, outcome, relative RMSE, bound,
verdict) and prints the table; exits 1 when any verdict is FAIL. Needs only python3.
"""

import argparse
import csv
import json
import math
import os
import random
import struct
import subprocess
import sys

W = H = 10   # incident pixels
K = 5        # kernel side: 25 columns


def write_npy(path, values, k=K):
    """(3, H, W, k, k) float32 little-endian .npy plus its JSON sidecar."""
    shape = "(3, %d, %d, %d, %d)" % (H, W, k, k)
    hdr = "{'descr': '<f4', 'fortran_order': False, 'shape': %s, }" % shape
    hdr += " " * (63 - (10 + len(hdr)) % 64) + "\n"
    with open(path, "wb") as f:
        f.write(b"\x93NUMPY\x01\x00" + struct.pack("<H", len(hdr)) + hdr.encode())
        f.write(struct.pack("<%df" % len(values), *values))
    with open(path[:-4] + ".json", "w") as f:
        f.write('{"size_cm": [1, 1], "name": "%s"}' % os.path.basename(path)[:-4])


def datasets(rng):
    """name -> (values generator, kernel side, whether success is required)."""
    n = 3 * H * W * K * K

    def rank2():
        out = []
        for c in range(3):
            for r in range(H * W):
                a, b = 0.5 + (r % 7) / 7.0, 0.3 + (r % 3) / 3.0
                for j in range(K * K):
                    p = math.exp(-((j // K - K // 2) ** 2 + (j % K - K // 2) ** 2) / 2.0)
                    q = math.exp(-((j // K - K // 2) ** 2 + (j % K - K // 2) ** 2) / 8.0)
                    out.append(0.01 * (a * p + b * q))
        return out

    def onehot():
        v = [0.0] * n
        v[H * W * K * K // 2 + K * K // 2] = 0.5
        return v

    return {
        "random": ([0.02 * rng.random() for _ in range(n)], K, True),
        "constant": ([0.01] * n, K, True),
        "rank-2": (rank2(), K, True),
        "one-hot": (onehot(), K, False),
        "kernel-1": ([0.3 * rng.random() for _ in range(3 * H * W)], 1, False),
        "range-1e-12..1e-1": ([10 ** rng.uniform(-12, -1) for _ in range(n)], K, True),
        "range-1e-12..1e3": ([10 ** rng.uniform(-12, 3) for _ in range(n)], K, False),
    }


# (method, label, arguments); T above the rank: 30 > 25 columns.
SETTINGS = [
    ("svd", "T=1", ["-T", "1"]),
    ("svd", "T=4", ["-T", "4"]),
    ("svd", "T=30", ["-T", "30"]),
    ("svd", "T=4 A=1e30", ["-T", "4", "--log-a", "1e30"]),
    ("svd", "T=4 B=1e-30", ["-T", "4", "--log-b", "1e-30"]),
    ("tucker", "T=2 P=0", ["-T", "2", "-P", "0"]),
    ("tucker", "T=2 P=7", ["-T", "2", "-P", "7"]),
    ("tucker", "T=2 P=20", ["-T", "2", "-P", "20"]),
    ("tucker", "T=30 P=4", ["-T", "30", "-P", "4"]),
    ("kcta", "C=4 Km=1 T=2", ["-C", "4", "--km", "1", "-T", "2"]),
    ("kcta", "C=4 Km=2 T=30", ["-C", "4", "--km", "2", "-T", "30"]),
    ("nmf", "T=2", ["-T", "2"]),
    ("nmf", "T=30", ["-T", "30"]),
]


# Relative RMSE of single-precision storage and its log/exp round trip (float32 epsilon 6e-8,
# times a few): errors below it are rounding, equal for the "never hurt" comparison.
ROUNDING_FLOOR = 1e-6


def bound(case, method, label):
    """The documented bound on the relative RMSE of a case that succeeds."""
    if case == "constant":
        return 1e-3          # every method represents a constant exactly (rank 1)
    if case == "rank-2" and (method == "kcta" and "T=2" in label or label in ("T=2 P=7",
                                                                              "T=2 P=20")):
        return 1e-3          # the data is in the model: rank 2, all channels alike
    if case == "rank-2" and method == "svd" and label in ("T=4", "T=30"):
        return 1e-2          # ln(R/A + 1) of rank-2 data is nearly rank 2
    return 1.0               # never worse than the zero material


def run(binary, args):
    p = subprocess.run([binary] + args, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       universal_newlines=True)
    errs = [l for l in p.stderr.splitlines() if l.startswith("opaline: error:")]
    return p.returncode, errs[0][len("opaline: error: "):] if errs else ""


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bin", required=True)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    factor = os.path.join(a.bin, "opaline-factor")
    os.makedirs(a.out, exist_ok=True)
    rng = random.Random(12345)
    rows = []
    chess = os.path.join(a.out, "chessboard.opm")
    code, msg = run(factor, ["dataset", "chess4x4", "--pixels", "%dx%d" % (W, H), "--kernel",
                             str(K), "-o", chess])
    if code:
        sys.exit("stress: cannot make the chessboard dataset: %s" % msg)
    cases = {"chessboard": (None, K, True)}
    cases.update(datasets(rng))
    for case, (values, k, must_succeed) in cases.items():
        path = chess
        if values is not None:
            npy = os.path.join(a.out, case + ".npy")
            write_npy(npy, values, k)
            path = os.path.join(a.out, case + ".opm")
            code, msg = run(factor, ["import", npy, "-o", path])
            if code:
                verdict = "ok" if code == 2 and msg and not must_succeed else "FAIL"
                rows.append(dict(method="(import)", case=case, settings="", outcome="refused: " +
                                 msg, error="", bound="", verdict=verdict))
                continue
        previous = {}
        for method, label, extra in SETTINGS:
            if method != "svd" and ("A=" in label or "B=" in label):
                continue
            out = os.path.join(a.out, "m.opm")
            rep = os.path.join(a.out, "r.json")
            code, msg = run(factor, ["factor", path, "--method", method, "-o", out, "--report",
                                     rep, "-t", "1"] + extra)
            b = bound(case, method, label)
            row = dict(method=method, case=case, settings=label, bound="%.0e" % b)
            if code == 2 and msg:
                row.update(outcome="refused: " + msg, error="",
                           verdict="FAIL" if must_succeed and "=1e" not in label else "ok")
            elif code != 0:
                row.update(outcome="exit %d: %s" % (code, msg), error="", verdict="FAIL")
            else:
                r = json.load(open(rep))
                e = r["relative_rmse"]
                ok = e is not None and math.isfinite(e) and e <= b
                # more terms or a higher degree never hurt (within 1 %, or both at the float
                # rounding floor, where the order of two errors is noise: constant data at T=1
                # and T=4 gave 1.26e-07 and 1.45e-07 with Debian 13's OpenBLAS)
                key = (method, label.split()[0] if method == "tucker" else "")
                if method in ("svd", "tucker") and key in previous \
                        and e > max(previous[key] * 1.01, ROUNDING_FLOOR) and "=1e" not in label:
                    ok = False
                if method in ("svd", "tucker") and "=1e" not in label:
                    previous[key] = min(previous.get(key, e), e)
                row.update(outcome="ok", error="%.3g" % e, verdict="ok" if ok else "FAIL")
            rows.append(row)
    fields = ["method", "case", "settings", "outcome", "error", "bound", "verdict"]
    with open(os.path.join(a.out, "stress.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)
    lines = ["| " + " | ".join(fields) + " |", "|" + "---|" * len(fields)]
    for r in rows:
        lines.append("| " + " | ".join(str(r[k]).replace("|", "/")[:110] for k in fields) + " |")
    with open(os.path.join(a.out, "stress.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))
    bad = sum(r["verdict"] == "FAIL" for r in rows)
    print("%d passed, %d failed" % (len(rows) - bad, bad))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
