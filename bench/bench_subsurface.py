"""Subsurface rendering benchmark, the paper's scene (run through bench/bench_subsurface.sh).

Spot the cow (../shared/meshes/spot.obj, with texture coordinates) on a diffuse floor under a spot
light and a dim constant sky, RES x RES, with the measured chessboards Chess4x4 and Chess8x8
(`opaline-factor dataset`, paper size). For each board:
  - `raw` (the dataset itself) is the reference;
  - `svd` (log transform A = 100, B = 1) and `tucker` (the paper's P: 7 for Chess4x4, 4 for
    Chess8x8) for every T in TERMS, factored here with `opaline-factor factor`;
each rendered at SPP samples per pixel, REPEAT times, with the `sobol` sampler (opaline's
Owen-scrambled Sobol numbers, what the Blender add-on writes; --sampler independent for plain
random numbers). Reported per material: the factorization
time (cached), the subsurface pre-pass and the camera pass (the renderer's own `subsurface
pre-pass: X s` and `camera pass: X s` lines), the process wall time, the render process's peak
resident memory (GNU time; the renderer does not report memory), RMSE, relative RMSE (RMSE / mean
of the reference) and PSNR (peak = the reference's largest value) against `raw` at equal samples
(same seeds). Times and memory are medians over REPEAT runs (the images are deterministic).

Convergence, for `raw` and `svd` T = 10 of each board: a reference of the same method at
16 x SPP samples, then renders at doubling sample counts from SPP / 8; the noise is the RMSE
against that reference divided by sqrt(1 - n / N) (the n-sample image reuses the first n samples
of every pixel of the N-sample reference, so the plain RMSE understates the noise by that factor;
see bench_cycles_noise.py). The sample count that reaches noise = 1 % of the reference's mean is
interpolated in log(spp)-log(noise) between the two counts that bracket it (extrapolated from
the last two when none reaches it: below 16 x SPP the target is often not bracketed), and its
time read from a straight-line fit of wall time against spp over the runs (fixed loading and
pre-pass, linear camera pass), its CPU time (user + system of the render process, steadier on
a shared machine) from the same fit of CPU time. With --peer BUILD, BUILD's renderer renders
each svd convergence scene right after ours (REPEAT times, alternating) and its time at the same
sample count is printed beside ours and in the verdict: a before/after under the same load. The subsurface pre-pass is deterministic and does not depend
on the camera's sample count, so this is the camera pass's noise; the pre-pass's own error
(irradiance noise, interpolation) is a bias shared with the reference and shows in the RMSE
against raw instead. The times are whole-process times (loading, pre-pass, camera pass,
writing).

The scene text and the image comparison live in bench/paper_scene.py (shared with
bench/methods_bench). Everything goes to OUT: datasets/ (only those not found in
PRESETS/datasets),
materials/ (factored materials and their reports, reused while newer than the dataset and
opaline-factor), scenes/, images/, results.csv, convergence.csv, results.json. The last line is
the verdict against the goal: svd T = 10 on Chess4x4 converged (1 %) in at most 3 s
with PSNR against raw of at least 47.8 dB (the goal is stated for 512 x 512 on a 2-core machine)."""

import argparse
import csv
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                                "tests"))
import pfm  # noqa: E402
from paper_scene import compare, parse_time_v, scene_xml  # noqa: E402
from paper_scene import render as render_once  # noqa: E402

BOARDS = {"chess4x4": ("Chess4x4", 7), "chess8x8": ("Chess8x8", 4)}
GOAL_SECONDS, GOAL_PSNR, GOAL_T = 3.0, 47.8, 10


def args():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--build", required=True)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--spp", type=int, default=16)
    p.add_argument("--presets", default=None)
    p.add_argument("--out", default=None)
    p.add_argument("--res", type=int, default=512)
    p.add_argument("--repeat", type=int, default=1)
    p.add_argument("--terms", default="1 2 5 10 20 40")
    p.add_argument("--boards", default="chess4x4 chess8x8")
    p.add_argument("--conv-t", type=int, default=GOAL_T)
    p.add_argument("--no-converge", action="store_true")
    p.add_argument("--mesh", required=True)
    p.add_argument("--sampler", default="sobol", choices=["sobol", "independent"])
    p.add_argument("--peer", default=None,
                   help="another build folder: its opaline-render renders the svd convergence "
                        "runs too, interleaved with ours (the machine's load shows in both)")
    a = p.parse_args()
    a.presets = a.presets or os.path.join(a.build, "presets")
    a.out = a.out or os.path.join(a.build, "bench-subsurface")
    a.terms = [int(t) for t in a.terms.split()]
    a.boards = a.boards.split()
    for b in a.boards:
        if b not in BOARDS:
            sys.exit("bench_subsurface: unknown board %r (known: %s)" % (b, ", ".join(BOARDS)))
    if a.res < 8 or a.spp < 1 or a.repeat < 1 or a.threads < 1 or not a.terms:
        sys.exit("bench_subsurface: need --res >= 8, --spp, --repeat, --threads >= 1, terms")
    return a


A = None
RENDER = FACTOR = PEER = None


def log(msg):
    print(msg, flush=True)


def fresh(path, *deps):
    """True when path exists and is newer than every existing dependency."""
    if not os.path.exists(path):
        return False
    t = os.path.getmtime(path)
    return all(not os.path.exists(d) or os.path.getmtime(d) <= t for d in deps)


def dataset(board):
    pre = os.path.join(A.presets, "datasets", board + ".opm")
    if os.path.exists(pre):
        return pre
    path = os.path.join(A.out, "datasets", board + ".opm")
    if not fresh(path, FACTOR):
        log("generating dataset %s (paper size) into %s" % (board, path))
        subprocess.run([FACTOR, "dataset", board, "-o", path, "-t", str(A.threads), "-q"],
                       check=True)
    return path


def factor(board, method, terms):
    """Factors the board's dataset (cached); returns (path, factor seconds)."""
    name, degree = BOARDS[board]
    ds = dataset(board)
    if method == "svd":
        label, extra = "SVD_S%d_%s" % (terms, name), ["--log-a", "100", "--log-b", "1"]
    else:
        label, extra = "TUCKER_T%d_P%d_%s" % (terms, degree, name), ["-P", str(degree)]
    path = os.path.join(A.out, "materials", label + ".opm")
    tfile = path[:-4] + ".seconds"
    if not (fresh(path, ds, FACTOR) and os.path.exists(tfile)):
        t0 = time.perf_counter()
        subprocess.run([FACTOR, "factor", ds, "-o", path, "--method", method, "-T", str(terms),
                        "--report", path[:-4] + ".json", "-q"] + extra, check=True,
                       stdout=subprocess.DEVNULL)
        with open(tfile, "w") as f:
            f.write("%.3f\n" % (time.perf_counter() - t0))
    with open(tfile) as f:
        return label, path, float(f.read())


def render(label, method, material, spp, repeat, peer=False):
    """Renders `repeat` times; returns the image path and the median figures. With peer (and
    --peer given), each run is followed by one of the peer build's renderer on the same scene,
    and the peer's median figures are returned too: (image, figures, peer figures)."""
    xml = os.path.join(A.out, "scenes", "%s_s%d.xml" % (label, spp))
    with open(xml, "w") as f:
        f.write(scene_xml(method, material, spp, A.res, A.mesh, sampler=A.sampler))
    img = os.path.join(A.out, "images", "%s_s%d.pfm" % (label, spp))
    peer_img = os.path.join(A.out, "images", "%s_s%d_peer.pfm" % (label, spp))
    renderers = [(RENDER, img)] + ([(PEER, peer_img)] if peer and PEER else [])
    runs = [[] for _ in renderers]
    for _ in range(repeat):
        for (binary, out), got in zip(renderers, runs):
            try:
                r = render_once(binary, xml, [out], A.threads, prefix=["/usr/bin/time", "-v"])
            except RuntimeError as e:
                sys.exit("bench_subsurface: %s" % e)
            for line in sorted({l for l in r["stderr"].splitlines() if "warn" in l.lower()})[:3]:
                sys.stderr.write(line + "\n")
            wall, rss = parse_time_v(r["stderr"])
            got.append({"prepass_s": r["prepass_s"], "render_s": r["render_s"],
                        "total_s": wall, "cpu_s": r["cpu_s"], "peak_MiB": rss})
    meds = []
    for got in runs:
        med = {k: statistics.median(r[k] for r in got) for k in got[0]}
        med["runs"] = got
        meds.append(med)
    return (img, meds[0], meds[1]) if len(meds) > 1 else (img, meds[0])


def crossing(runs, target, key="total_s"):
    """(samples, seconds) at which the noise reaches target. The sample count is interpolated in
    log(spp)-log(noise) between the runs that bracket it (sorted by spp, noise falling), else
    extrapolated from the last two; the time is the least-squares line through (spp, wall time)
    of all runs at that count (the pre-pass is a fixed cost, the camera pass grows linearly, and
    a fit is steadier than two timings on a shared machine)."""
    pts = [(math.log(r["spp"]), math.log(r["noise"])) for r in runs]
    lt = math.log(target)
    i = next((k for k in range(1, len(pts)) if pts[k][1] <= lt), len(pts) - 1)
    (x0, y0), (x1, y1) = pts[i - 1], pts[i]
    n = runs[i]["spp"] if y1 == y0 else math.exp(x0 + (lt - y0) * (x1 - x0) / (y1 - y0))
    xs, ys = [r["spp"] for r in runs], [r[key] for r in runs]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    sxx = sum((x - mx) ** 2 for x in xs)
    slope = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sxx if sxx > 0 else 0.0
    return n, my + slope * (n - mx), slope


def converge(board, label, method, material):
    ref_spp = 16 * A.spp
    log("  %s: reference at %d spp ..." % (label, ref_spp))
    ref_img, ref_f = render(label + "_ref", method, material, ref_spp, 1)
    ref = pfm.read(ref_img).samples
    mean = sum(ref) / len(ref)
    target = 0.01 * mean
    runs, peer_runs, spp = [], [], max(1, A.spp // 8)
    with_peer = PEER is not None and method == "svd"
    while spp < ref_spp:
        got = render(label, method, material, spp, A.repeat, peer=with_peer)
        img, f = got[0], got[1]
        e = compare(pfm.read(img).samples, ref)[0]
        f.update(board=board, label=label, spp=spp, rmse_vs_reference=e,
                 noise=e / math.sqrt(1.0 - spp / ref_spp))
        runs.append(f)
        peer_note = ""
        if with_peer:
            p = got[2]
            p.update(spp=spp, noise=f["noise"])
            peer_runs.append(p)
            peer_note = "   peer %.2f s (%.2f CPU s)" % (p["total_s"], p["cpu_s"])
        log("  %-22s %5d spp %8.2f s (%.2f CPU s)  noise %.3g%% of the mean%s" %
            (label, spp, f["total_s"], f["cpu_s"], 100 * f["noise"] / mean, peer_note))
        if f["noise"] <= target and len(runs) >= 2:
            break
        spp *= 2
    n, secs, per_spp = crossing(runs, target)
    _, cpu, cpu_per_spp = crossing(runs, target, "cpu_s")
    peer = None
    if with_peer:  # the peer renders the same method: its noise at each count is ours
        _, psecs, _ = crossing(peer_runs, target)
        _, pcpu, _ = crossing(peer_runs, target, "cpu_s")
        peer = {"build": A.peer, "seconds_to_1pct": psecs, "cpu_seconds_to_1pct": pcpu,
                "runs": [{k: v for k, v in r.items() if k != "runs"} for r in peer_runs]}
    return {"board": board, "label": label, "method": method, "reference_spp": ref_spp,
            "reference_total_s": ref_f["total_s"], "mean": mean, "target_rmse": target,
            "target_reached": runs[-1]["noise"] <= target, "spp_to_1pct": n,
            "seconds_per_spp": per_spp, "seconds_to_1pct": secs,
            "cpu_seconds_per_spp": cpu_per_spp, "cpu_seconds_to_1pct": cpu, "peer": peer,
            "runs": [{k: v for k, v in r.items() if k != "runs"} for r in runs]}


def main():
    global A, RENDER, FACTOR, PEER
    A = args()
    RENDER = os.path.join(A.build, "bin", "opaline-render")
    if A.peer:
        PEER = os.path.join(A.peer, "bin", "opaline-render")
        if not os.access(PEER, os.X_OK):
            sys.exit("bench_subsurface: --peer %s: no bin/opaline-render there" % A.peer)
    FACTOR = os.path.join(A.build, "bin", "opaline-factor")
    for d in ("datasets", "materials", "scenes", "images"):
        os.makedirs(os.path.join(A.out, d), exist_ok=True)
    log("opaline-render subsurface benchmark: %s %dx%d, %d spp (%s), %d threads, median of %d "
        "run(s)" % (os.path.basename(A.mesh), A.res, A.res, A.spp, A.sampler, A.threads, A.repeat))
    log("output: %s" % A.out)
    head = "%-24s %8s %9s %9s %9s %9s %10s %8s %8s" % (
        "material", "factor_s", "prepass_s", "render_s", "total_s", "peak_MiB", "RMSE",
        "relRMSE", "PSNR_dB")
    rows, conv = [], []
    for board in A.boards:
        name, degree = BOARDS[board]
        log("\n== %s (tucker P = %d)" % (name, degree))
        log(head)
        ds = dataset(board)
        raw_img, f = render("RAW_" + name, "raw", ds, A.spp, A.repeat)
        raw = pfm.read(raw_img).samples
        rows.append({"board": name, "method": "raw", "T": "", "P": "", "spp": A.spp,
                     "res": A.res, "label": "RAW_" + name, "factor_s": 0.0,
                     "prepass_s": f["prepass_s"], "render_s": f["render_s"],
                     "total_s": f["total_s"], "peak_MiB": f["peak_MiB"],
                     "material_MiB": os.path.getsize(ds) / 2**20, "rmse": 0.0, "rel_rmse": 0.0,
                     "psnr_db": None})
        log("%-24s %8s %9.2f %9.2f %9.2f %9.0f %10s %8s %8s   (the reference)" % (
            "RAW_" + name, "-", f["prepass_s"], f["render_s"], f["total_s"], f["peak_MiB"],
            "-", "-", "-"))
        for method in ("svd", "tucker"):
            for t in A.terms:
                label, mat, fs = factor(board, method, t)
                img, f = render(label, method, mat, A.spp, A.repeat)
                r = compare(pfm.read(img).samples, raw)
                rows.append({"board": name, "method": method, "T": t,
                             "P": degree if method == "tucker" else "", "spp": A.spp,
                             "res": A.res, "label": label, "factor_s": fs,
                             "prepass_s": f["prepass_s"], "render_s": f["render_s"],
                             "total_s": f["total_s"], "peak_MiB": f["peak_MiB"],
                             "material_MiB": os.path.getsize(mat) / 2**20, "rmse": r[0],
                             "rel_rmse": r[1], "psnr_db": r[2]})
                log("%-24s %8.2f %9.2f %9.2f %9.2f %9.0f %10.4g %8.4f %8.2f" % (
                    label, fs, f["prepass_s"], f["render_s"], f["total_s"], f["peak_MiB"],
                    r[0], r[1], r[2]))
        if not A.no_converge:
            log("-- time to 1 %% relative RMSE against 16 x %d spp of the same method" % A.spp)
            label, mat, _ = factor(board, "svd", A.conv_t)
            for lab, method, m in (("RAW_" + name, "raw", ds), (label, "svd", mat)):
                c = converge(name, lab, method, m)
                conv.append(c)
                log("  %-22s 1 %% at %.0f spp, %.2f s, %.2f CPU s (%s; %.3f s, %.3f CPU s "
                    "per spp)" % (lab, c["spp_to_1pct"], c["seconds_to_1pct"],
                                  c["cpu_seconds_to_1pct"],
                                  "bracketed" if c["target_reached"] else "extrapolated",
                                  c["seconds_per_spp"], c["cpu_seconds_per_spp"]))
                if c["peer"]:
                    log("  %-22s peer %s, same runs interleaved: %.2f s, %.2f CPU s at that "
                        "count" % (lab, A.peer, c["peer"]["seconds_to_1pct"],
                                   c["peer"]["cpu_seconds_to_1pct"]))

    keys = ["board", "method", "T", "P", "spp", "res", "label", "factor_s", "prepass_s",
            "render_s", "total_s", "peak_MiB", "material_MiB", "rmse", "rel_rmse", "psnr_db"]
    with open(os.path.join(A.out, "results.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, keys)
        w.writeheader()
        w.writerows(rows)
    ckeys = ["board", "label", "spp", "prepass_s", "render_s", "total_s", "cpu_s", "peak_MiB",
             "rmse_vs_reference", "noise"]
    with open(os.path.join(A.out, "convergence.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, ckeys, extrasaction="ignore")
        w.writeheader()
        for c in conv:
            w.writerows(c["runs"])

    verdict = None
    main_name = BOARDS[A.boards[0]][0]
    psnr = next((r["psnr_db"] for r in rows if r["board"] == main_name and
                 r["method"] == "svd" and r["T"] == GOAL_T), None)
    cv = next((c for c in conv if c["board"] == main_name and
               c["label"].startswith("SVD_S%d_" % GOAL_T)), None)
    secs = cv["seconds_to_1pct"] if cv else None
    if psnr is not None and secs is not None:
        ok_t, ok_p = secs <= GOAL_SECONDS, psnr >= GOAL_PSNR
        verdict = ("verdict: %s svd T=%d at %dx%d: converged (1 %%) in %.1f s, %.1f CPU s (goal "
                   "<= %g s: %s), PSNR against raw %.2f dB (goal >= %g dB: %s)%s" % (
                       main_name, GOAL_T, A.res, A.res, secs, cv["cpu_seconds_to_1pct"],
                       GOAL_SECONDS,
                       "ok" if ok_t else "MISSED", psnr, GOAL_PSNR, "ok" if ok_p else "MISSED",
                       "" if A.res == 512 else " [the goal is stated for 512x512]"))
        if cv["peer"]:
            verdict += "; the peer build in the same run: %.1f s, %.1f CPU s" % (
                cv["peer"]["seconds_to_1pct"], cv["peer"]["cpu_seconds_to_1pct"])
    else:
        verdict = "verdict: not measured (needs svd T=%d in the terms and the convergence runs)" \
            % GOAL_T
    with open(os.path.join(A.out, "results.json"), "w") as f:
        json.dump({"settings": {"mesh": A.mesh, "res": A.res, "spp": A.spp,
                                "threads": A.threads, "repeat": A.repeat, "terms": A.terms,
                                "sampler": A.sampler,
                                "boards": A.boards, "machine": platform.machine(),
                                "cpus": os.cpu_count()},
                   "results": rows, "convergence": conv, "verdict": verdict}, f, indent=1,
                  default=lambda x: None)
    log("\nresults: %s/results.csv, convergence.csv, results.json" % A.out)
    log(verdict)


if __name__ == "__main__":
    main()
