#!/usr/bin/env python3
"""bench_methods.py - every factorization method side by side, run time against error.

Driven by bench/bench_methods.sh (read its header for the command line). For each dataset
(Chess4x4, Chess8x8, the veined marble and one Monte Carlo dataset, made by `opaline-factor
dataset`) and each method (svd, tucker, kcta, nmf; raw as reference) over a sweep of its
parameters, it runs `opaline-factor factor --report` `repeats` times and keeps the medians of
the timings (the errors are deterministic and checked to be). Then, on one channel of the very
same matrices (read from the .opm container with numpy.memmap, docs/formats.md), it times what a
user would otherwise use: scikit-learn's randomized_svd and NMF, and a full LAPACK SVD for the
optimal error at the svd rank.

nmf runs twice over: as the issue's baseline (Peers et al.'s division by the homogeneous
approximation, --homog-exp 1, series "nmf") and as NMF of Rd itself (--homog-exp 0, series
"nmf E=0"), which fits these datasets far better; each goal against NMF is judged against both.

Needs only the Python standard library; numpy (Debian python3-numpy), scikit-learn
(python3-sklearn) and matplotlib (python3-matplotlib) add the baselines and the plots, and each
missing one is named in the output with the part it skips. Nothing is installed here.

Outputs under --out: results.json (everything, with the machine and library versions),
runs.csv (one line per method and parameters), baselines.csv, tables.md (tables shaped like
Kurt et al. 2013's Tables 1 and 2 and K-CTA's Table I, and the goals of the issue), and
plots/*.png."""

import argparse
import csv
import importlib
import json
import math
import os
import platform
import re
import shutil
import statistics
import struct
import subprocess
import sys
import time

from paper_scene import SCALE, find_mesh, pfm, scene_xml
from paper_scene import compare as image_compare
from paper_scene import render as render_once

# --- configuration ----------------------------------------------------------------------------

# name -> (dataset arguments, kind); kind 'chess' marks the chessboards of the NMF goal.
FULL_DATASETS = {
    "chess4x4": (["chess4x4"], "chess"),
    "chess8x8": (["chess8x8"], "chess"),
    "veined-marble": (["veined-marble"], "marble"),
    # Monte Carlo at the paper's pixel pitch (12.6 cm / 277) on a 64 x 64 patch.
    "chess4x4-mc": (["chess4x4", "--generator", "montecarlo", "--pixels", "64x64",
                     "--size-cm", "2.91x2.91", "--photons", "1000"], "mc"),
}
QUICK_DATASETS = {
    "chess4x4": (["chess4x4", "--pixels", "24x24", "--kernel", "9"], "chess"),
    "chess8x8": (["chess8x8", "--pixels", "24x24", "--kernel", "9"], "chess"),
    "veined-marble": (["veined-marble", "--pixels", "24x24", "--kernel", "9"], "marble"),
    "chess4x4-mc": (["chess4x4", "--generator", "montecarlo", "--pixels", "12x12", "--kernel",
                     "9", "--size-cm", "2x2", "--photons", "100"], "mc"),
}
# Parameter sweeps: (method, {option: value}); raw is the reference.
FULL_SWEEP = (
    [("raw", {})]
    + [("svd", {"T": t}) for t in (1, 2, 4, 10, 16, 24, 40)]
    + [("tucker", {"T": t, "P": p}) for t, p in ((5, 4), (10, 7), (15, 7), (40, 7))]
    + [("kcta", {"C": c, "Km": k, "T": t}) for c, k, t in ((8, 1, 4), (8, 2, 4), (16, 2, 4),
                                                          (16, 1, 2), (24, 1, 2), (16, 1, 4),
                                                          (32, 1, 4), (32, 2, 4))]
    + [("nmf", {"T": t}) for t in (5, 10, 20, 40)]
    + [("nmf", {"E": 0, "T": t}) for t in (5, 10, 20)]
)
QUICK_SWEEP = (
    [("raw", {})]
    + [("svd", {"T": t}) for t in (2, 4)]
    + [("tucker", {"T": 3, "P": 2})]
    + [("kcta", {"C": 2, "Km": 1, "T": 2})]
    + [("nmf", {"T": t}) for t in (2, 4)]
    + [("nmf", {"E": 0, "T": 4})]
)
OPTION = {"T": "-T", "P": "-P", "C": "-C", "Km": "--km", "E": "--homog-exp"}
METHODS = ("svd", "tucker", "kcta", "nmf", "raw")
# A series is a method, or nmf with a --homog-exp other than 1: "nmf" is the issue's baseline
# (Peers et al.'s division by the homogeneous approximation), "nmf E=0" is NMF of Rd itself,
# which this benchmark also runs because it is the stronger baseline on these datasets.
SERIES = ("svd", "tucker", "kcta", "nmf", "nmf E=0")
OPALINE_SERIES = ("svd", "tucker", "kcta")
NMF_SERIES = {"nmf": "NMF of the remainder after Peers et al.'s division (E=1; the issue's "
                     "baseline)",
              "nmf E=0": "NMF of Rd itself (E=0, no division; a stronger baseline than the "
                         "issue names)"}
COLOURS = {"svd": "tab:blue", "tucker": "tab:orange", "kcta": "tab:green", "nmf": "tab:red",
           "nmf E=0": "tab:purple", "raw": "black"}
SEED = 1           # dataset generator seed
RANDOM_STATE = 0   # scikit-learn's seed
LOG_A, LOG_B = 100.0, 1.0   # opaline's svd defaults (docs/formats.md)
SLOW_SECONDS = 60.0  # a configuration runs at most this long in all, unless one run is longer

notes = []  # what was skipped and why, printed at the end and kept in results.json


def note(msg):
    notes.append(msg)
    print("NOTE: " + msg, flush=True)


def optional(module, debian):
    """The module, or None with a note naming the Debian package that provides it."""
    try:
        return importlib.import_module(module)
    except ImportError:
        note(f"{module} is not installed (Debian package {debian}): the parts that need it are "
             "SKIPPED")
        return None


# --- the .opm container (docs/formats.md) -----------------------------------------------------

def opm_sections(path):
    """{tag: (offset, size)} and the META dict of a material file; checks magic and version."""
    with open(path, "rb") as f:
        head = f.read(64)
        if len(head) < 64 or head[:8] != b"OPALINEM":
            raise ValueError(f"{path}: not an opaline material file")
        version, count, fsize, table = struct.unpack_from("<IIQQ", head, 8)
        if version != 1 or fsize != os.path.getsize(path):
            raise ValueError(f"{path}: version {version} or size {fsize} unexpected")
        f.seek(table)
        raw = f.read(32 * count)
        secs = {}
        for i in range(count):
            tag = raw[32 * i:32 * i + 8].rstrip(b"\0").decode("ascii")
            off, size = struct.unpack_from("<QQ", raw, 32 * i + 8)
            secs[tag] = (off, size)
        off, size = secs["META"]
        f.seek(off)
        meta = dict(line.split("=", 1) for line in f.read(size).decode("utf-8").splitlines()
                    if "=" in line)
    return secs, meta


def opm_array(np, path, secs, tag, dtype, cols=None):
    """Section tag of path as a read-only numpy memmap (rows x cols when cols is given)."""
    off, size = secs[tag]
    n = size // np.dtype(dtype).itemsize
    a = np.memmap(path, dtype=dtype, mode="r", offset=off, shape=(n,))
    return a.reshape(-1, cols) if cols else a


# --- running opaline-factor ------------------------------------------------------------------

def run(cmd, log):
    """Runs cmd; its stderr goes to the log file; returns (stdout, stderr, seconds)."""
    t = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    dt = time.perf_counter() - t
    with open(log, "a") as f:
        f.write("$ " + " ".join(cmd) + f"\n# exit {p.returncode}, {dt:.3f} s\n" + p.stderr)
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed (exit {p.returncode}):\n{p.stderr[-2000:]}")
    return p.stdout, p.stderr, dt


def make_dataset(tool, name, args, work, log):
    """The dataset file, made once (reused while its arguments are unchanged); its META."""
    path = os.path.join(work, "datasets", name + ".opm")
    stamp = path + ".args"
    want = json.dumps(args + ["--seed", str(SEED)])
    if not (os.path.exists(path) and os.path.exists(stamp) and open(stamp).read() == want):
        os.makedirs(os.path.dirname(path), exist_ok=True)
        print(f"== dataset {name}: opaline-factor dataset {' '.join(args)}", flush=True)
        _, _, dt = run([tool, "dataset"] + args + ["--seed", str(SEED), "-o", path], log)
        with open(stamp, "w") as f:
            f.write(want)
        print(f"   made in {dt:.1f} s", flush=True)
    secs, meta = opm_sections(path)
    return path, secs, meta


def label(method, par):
    return method + "".join(f" {k}={v}" for k, v in par.items())


def series(method, par):
    """The plot and table series of a configuration (SERIES)."""
    return f"nmf E={par['E']}" if method == "nmf" and par.get("E", 1) != 1 else method


def params(rec):
    """A record's parameters as text, without its series name: "T=10 P=7"."""
    return rec["label"][len(rec["series"]):].strip()


def channel_seconds(stderr, method):
    """Per-channel factorization seconds from the -v log, or [] (svd: the SVD alone; nmf: HALS
    alone; kcta: K-CTA alone)."""
    if method == "svd":
        pat = r"channel (\d+): preprocessing [\d.]+ s, SVD of .* ([\d.]+) s"
    elif method in ("nmf", "kcta"):
        pat = method + r" channel (\d+): .*\(([\d.]+) s\)"
    else:
        return []
    return [float(m.group(2)) for m in re.finditer(pat, stderr)]


def factor_runs(tool, ds_name, ds_path, method, par, repeats, work, log):
    """Runs one configuration `repeats` times; returns the record (medians of the timings)."""
    out = os.path.join(work, "materials", f"{ds_name}.{method}" +
                       "".join(f".{k}{v}" for k, v in par.items()) + ".opm")
    rep_path = out[:-4] + ".json"
    os.makedirs(os.path.dirname(out), exist_ok=True)
    cmd = [tool, "factor", ds_path, "-o", out, "--method", method, "--report", rep_path, "-v"]
    for k, v in par.items():
        cmd += [OPTION[k], str(v)]
    reps, chan = [], []
    while len(reps) < repeats:
        _, err, wall = run(cmd, log)
        if not reps and wall * repeats > SLOW_SECONDS:  # slow: fewer runs, at least one
            repeats = max(1, min(repeats, int(SLOW_SECONDS // wall)))
        r = json.load(open(rep_path))
        r["wall_seconds"] = wall
        reps.append(r)
        chan.append(channel_seconds(err, method))
    first = reps[0]
    for r in reps[1:]:
        if r["rmse"] != first["rmse"] or r["size_bytes"] != first["size_bytes"]:
            note(f"{ds_name} {label(method, par)}: repeated runs differ (RMSE {first['rmse']} "
                 f"vs {r['rmse']}): not deterministic")

    def med(key):
        return statistics.median(r[key] if r[key] is not None else math.nan for r in reps)

    def factor_time(r):
        st = r["stage_seconds"]
        return st.get("preprocess", 0.0) + st.get("factor", 0.0)

    rec = {
        "dataset": ds_name, "method": method, "label": label(method, par),
        "series": series(method, par),
        "T": par.get("T", first["terms"] or ""), "P": par.get("P", ""),
        "C": par.get("C", ""), "Km": par.get("Km", ""),
        "E": par.get("E", 1) if method == "nmf" else "",
        "size_bytes": first["size_bytes"], "original_bytes": first["original_bytes"],
        "compression_ratio": first["compression_ratio"], "rmse": first["rmse"],
        "relative_rmse": first["relative_rmse"], "psnr": first["psnr"],
        "se_ratio_db": (-20 * math.log10(first["relative_rmse"])
                        if first["relative_rmse"] > 0 else None),
        "max_error": first["max_error"],
        "factor_seconds": statistics.median(factor_time(r) for r in reps),
        "factor_seconds_runs": [factor_time(r) for r in reps],
        "total_seconds": med("total_seconds"),
        "eval_ns": med("eval_ns"), "eval_random_ns": med("eval_random_ns"),
        "albedo_map_seconds": med("albedo_map_seconds"),
        "peak_memory_bytes": max(r["peak_memory_bytes"] for r in reps),
        "channel0_seconds": (statistics.median(c[0] for c in chan) if all(chan) else None),
        "stage_seconds": {k: statistics.median(r["stage_seconds"].get(k, 0.0) for r in reps)
                          for k in first["stage_seconds"]},
        "repeats": repeats, "tool_version": first.get("tool_version"),
        "material": out,
    }
    return rec


# --- baselines on one channel (numpy, scikit-learn) ------------------------------------------

def timed(fn, repeats):
    """(median seconds, last result) of fn() run `repeats` times."""
    ts, res = [], None
    for _ in range(repeats):
        t = time.perf_counter()
        res = fn()
        ts.append(time.perf_counter() - t)
    return statistics.median(ts), res


def shifted_channel(np, rd):
    """The svd method's preprocessing of one channel (docs/formats.md): (g, mx, s) with g the
    given values circularly shifted so each row's (first) largest cleaned value comes first,
    mx that value, s = clean(g) / mx (0 for rows without a positive value); float32."""
    clean = np.where(np.isfinite(rd) & (rd > 0), rd, 0).astype(np.float32)
    shift = clean.argmax(axis=1)
    mx = clean[np.arange(rd.shape[0]), shift]
    idx = (np.arange(rd.shape[1])[None, :] + shift[:, None]) % rd.shape[1]
    g = np.take_along_axis(np.asarray(rd, dtype=np.float32), idx, axis=1)
    s = np.take_along_axis(clean, idx, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(mx[:, None] > 0, s / mx[:, None], 0).astype(np.float32)
    return g, mx, s


def svd_rd_rmse(np, u, v, g, mx):
    """RMSE against the given values g (shifted like the factors) of the svd reconstruction
    max * max(0, A (exp(U V^T) - 1) + A (1 - B)), by row blocks in double."""
    se = 0.0
    for i in range(0, g.shape[0], 8192):
        x = u[i:i + 8192].astype(np.float64) @ v.astype(np.float64).T
        r = np.maximum(0, LOG_A * np.expm1(x) + LOG_A * (1 - LOG_B)) * mx[i:i + 8192, None]
        se += float(((r - g[i:i + 8192]) ** 2).sum())
    return math.sqrt(se / g.size)


def frob_err(np, m, u, v):
    """||m - u v^T||_F in double, by row blocks."""
    se = 0.0
    for i in range(0, m.shape[0], 8192):
        d = m[i:i + 8192].astype(np.float64) - u[i:i + 8192].astype(np.float64) @ v.T
        se += float((d * d).sum())
    return math.sqrt(se)


def svd_baseline(np, skx, rec, ds_path, repeats, tool, work, log):
    """Opaline's svd (rec, a T-term run) against scikit-learn's randomized_svd and LAPACK on
    channel 0 of the same preprocessed matrix. Opaline's SVD is timed twice: like the peer
    (opaline-bench-rsvd on the very matrix handed to scikit-learn, median of at least 3 runs in
    one process; the goal's figure) and inside opaline-factor (channel 0 of a fresh process,
    so with the BLAS library's start-up)."""
    secs, meta = opm_sections(ds_path)
    cols = int(meta["kernel"]) ** 2
    ch = "RD." + ("Y" if meta["channels"] == "1" else "R")
    rd = opm_array(np, ds_path, secs, ch, np.float32, cols)
    g, mx, s = shifted_channel(np, rd)
    m = np.log1p(s / np.float32(LOG_A) + np.float32(LOG_B - 1)).astype(np.float32)
    T = int(rec["T"])
    msecs, mmeta = opm_sections(rec["material"])
    tag = ch[3:]
    u = np.array(opm_array(np, rec["material"], msecs, "U." + tag, np.float32, T))
    v = np.array(opm_array(np, rec["material"], msecs, "V." + tag, np.float32, T))
    res = {"dataset": rec["dataset"], "channel": tag, "rows": m.shape[0], "cols": m.shape[1],
           "rank": T, "entries": []}
    norm = float(np.linalg.norm(m.astype(np.float64)))

    def entry(who, seconds, uu, vv, extra=None):
        e = {"who": who, "seconds": seconds,
             "log_domain_error": frob_err(np, m, uu, vv) / norm if uu is not None else None,
             "rd_rmse": svd_rd_rmse(np, uu, vv, g, mx) if uu is not None else None}
        e.update(extra or {})
        res["entries"].append(e)
        return e

    runs = max(repeats, 3)  # opaline and scikit-learn alike: the median of at least 3
    bench = os.path.join(os.path.dirname(tool), "opaline-bench-rsvd")
    mat = os.path.join(work, f"{rec['dataset']}.channel0.f32")
    fac = mat[:-4] + ".factors.f32"
    m.tofile(mat)
    try:
        stdout = run([bench, mat, str(m.shape[0]), str(m.shape[1]), str(T), "--repeats",
                      str(runs), "--factors", fac], log)[0]
    finally:
        os.remove(mat)
    timing = json.loads(stdout)
    f = np.fromfile(fac, dtype=np.float32)
    os.remove(fac)
    nu = m.shape[0] * T
    entry("opaline svd (randomized, p=10, q<=4 stopping when converged, float32)",
          timing["median_seconds"], f[:nu].reshape(m.shape[0], T), f[nu:].reshape(m.shape[1], T),
          {"seconds_of": "op_rsvd on this matrix, median of runs in one process "
                         "(opaline-bench-rsvd), as scikit-learn is timed",
           "seconds_runs": timing["seconds"]})
    entry("opaline-factor's svd, channel 0 (a fresh process: with BLAS start-up)",
          rec["channel0_seconds"], u, v,
          {"seconds_of": "the SVD of channel 0 alone inside opaline-factor, median of the runs "
                         "above"})
    if skx is not None:
        rs = skx.randomized_svd
        t, (uu, ss, vt) = timed(lambda: rs(m, T, random_state=RANDOM_STATE), runs)
        entry("sklearn randomized_svd (defaults: n_iter auto=7, p=10)", t, uu * ss, vt.T)
        t, (uu, ss, vt) = timed(lambda: rs(m, T, n_oversamples=10, n_iter=4,
                                           random_state=RANDOM_STATE), runs)
        entry("sklearn randomized_svd (n_iter=4, p=10: opaline's maximum)", t, uu * ss, vt.T)
    m64 = m.astype(np.float64)
    t = time.perf_counter()
    uu, ss, vt = np.linalg.svd(m64, full_matrices=False)
    t = time.perf_counter() - t
    opt = math.sqrt(float((ss[T:].astype(np.float64) ** 2).sum())) / norm
    e = entry("LAPACK full SVD (numpy, float64, gesdd), truncated: the optimum", t,
              uu[:, :T] * ss[:T], vt[:T].T)
    e["log_domain_error"] = opt
    del uu, vt, m64
    res["optimal_log_domain_error"] = opt
    for e in res["entries"]:
        e["error_over_optimal"] = (e["log_domain_error"] / opt if opt > 0 and
                                   e["log_domain_error"] is not None else None)
    return res


def nmf_baseline(np, skd, rec, ds_path):
    """Opaline's nmf (rec) against scikit-learn's NMF on channel 0 of the same remainder
    Q = Rd / (SCALE PROF), with the same rank; errors in Rd after reconstruction."""
    secs, meta = opm_sections(ds_path)
    cols = int(meta["kernel"]) ** 2
    ch = "RD." + ("Y" if meta["channels"] == "1" else "R")
    tag = ch[3:]
    rd = np.asarray(opm_array(np, ds_path, secs, ch, np.float32, cols))
    T = int(rec["T"])
    msecs, _ = opm_sections(rec["material"])
    prof = np.asarray(opm_array(np, rec["material"], msecs, "PROF." + tag, np.float32))
    scale = np.asarray(opm_array(np, rec["material"], msecs, "SCALE." + tag, np.float32))
    w = np.asarray(opm_array(np, rec["material"], msecs, "W." + tag, np.float32, T))
    h = np.asarray(opm_array(np, rec["material"], msecs, "H." + tag, np.float32, T))
    hom = scale[:, None].astype(np.float64) * prof[None, :]
    clean = np.where(np.isfinite(rd) & (rd > 0), rd, 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        q = np.minimum(np.where(hom > 0, clean / hom, 0), 1e30).astype(np.float32)

    def rmse(ww, hh):
        return float(np.sqrt(np.mean((hom * (ww.astype(np.float64) @ hh.T) - rd) ** 2)))

    def qerr(ww, hh):
        return float(np.linalg.norm(q - ww @ hh.T) / np.linalg.norm(q))

    res = {"dataset": rec["dataset"], "channel": tag, "rows": rd.shape[0], "cols": cols,
           "rank": T, "entries": [
               {"who": "opaline nmf (HALS from NNDSVD, tol 1e-4, at most 200 iterations)",
                "seconds": rec["channel0_seconds"], "rd_rmse": rmse(w, h),
                "remainder_relative_error": qerr(w, h)}]}
    if skd is not None:
        import warnings
        model = skd.NMF(n_components=T, init=None, solver="cd", tol=1e-4, max_iter=200,
                        random_state=RANDOM_STATE)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t = time.perf_counter()
            ww = model.fit_transform(q)
            t = time.perf_counter() - t
        hh = model.components_.T
        res["entries"].append({
            "who": "sklearn NMF (defaults: cd solver, init nndsvda, tol 1e-4, max_iter 200)",
            "seconds": t, "rd_rmse": rmse(ww, hh), "remainder_relative_error": qerr(ww, hh),
            "iterations": int(model.n_iter_)})
    return res


# --- rendering: the paper-style scene with every material ------------------------------------

def slug(text):
    return re.sub(r"[^A-Za-z0-9.-]+", "_", text).strip("_")


def render_dataset(renderer, name, ds_path, recs, rs, repeats, work, log):
    """Renders the paper-style scene (bench/paper_scene.py) with the dataset itself (`raw`, the
    reference) and with every factored material of recs (this dataset's sweep), all at rs's size
    and samples and the renderer's default seed; returns one record per material: the process's
    wall and CPU time (median of `repeats` runs, fewer for slow ones, as factor_runs), the
    renderer's own pre-pass and camera-pass seconds, and the image's RMSE, relative RMSE and PSNR
    against the raw image. Its stderr goes to the log."""
    os.makedirs(os.path.join(work, "scenes"), exist_ok=True)
    os.makedirs(os.path.join(work, "images"), exist_ok=True)
    out, ref = [], None
    for rec in sorted(recs, key=lambda r: r["method"] != "raw"):  # raw first: the reference
        mat = ds_path if rec["method"] == "raw" else rec["material"]
        base = slug(f"{name}.{rec['label']}")
        xml = os.path.join(work, "scenes", base + ".xml")
        with open(xml, "w") as f:
            f.write(scene_xml(rec["method"], os.path.abspath(mat), rs["spp"], rs["size"],
                              rs["mesh"], SCALE))
        img = os.path.join(work, "images", base + ".pfm")
        n, runs = repeats, []
        while len(runs) < n:
            try:
                r = render_once(renderer, xml, [img, img[:-4] + ".png"], rs["threads"])
            except RuntimeError as e:
                with open(log, "a") as f:
                    f.write(str(e) + "\n")
                raise
            with open(log, "a") as f:
                f.write(f"$ {renderer} -t {rs['threads']} -o {img} {xml}\n# {r['wall_s']:.3f} s"
                        f"\n{r['stderr']}")
            if not runs and r["wall_s"] * n > SLOW_SECONDS:
                n = max(1, min(n, int(SLOW_SECONDS // r["wall_s"])))
            runs.append(r)
        image = pfm(img)
        if ref is None:
            ref = image
        rmse, rel, psnr = image_compare(image, ref)

        def med(key):
            v = [x[key] for x in runs if x[key] is not None]
            return statistics.median(v) if v else None

        out.append({
            "dataset": name, "method": rec["method"], "label": rec["label"],
            "series": rec["series"], "T": rec["T"], "P": rec["P"], "C": rec["C"],
            "Km": rec["Km"], "E": rec["E"], "size_bytes": rec["size_bytes"],
            "data_rmse": rec["rmse"], "data_psnr": rec["psnr"], "res": rs["size"],
            "spp": rs["spp"], "threads": rs["threads"], "render_seconds": med("wall_s"),
            "render_seconds_runs": [x["wall_s"] for x in runs], "cpu_seconds": med("cpu_s"),
            "prepass_seconds": med("prepass_s"), "camera_seconds": med("render_s"),
            "image_rmse": rmse, "image_relative_rmse": rel,
            "image_psnr": psnr if math.isfinite(psnr) else None, "repeats": n, "image": img})
    return out


def spearman(xs, ys):
    """Spearman's rank correlation (average ranks for ties), or None for fewer than 3 points or
    a constant series."""
    def ranks(v):
        order = sorted(range(len(v)), key=lambda i: v[i])
        r, i = [0.0] * len(v), 0
        while i < len(order):
            j = i
            while j + 1 < len(order) and v[order[j + 1]] == v[order[i]]:
                j += 1
            for k in range(i, j + 1):
                r[order[k]] = (i + j) / 2 + 1
            i = j + 1
        return r
    if len(xs) < 3:
        return None
    a, b = ranks(xs), ranks(ys)
    ma, mb_ = sum(a) / len(a), sum(b) / len(b)
    sab = sum((x - ma) * (y - mb_) for x, y in zip(a, b))
    saa = sum((x - ma) ** 2 for x in a)
    sbb = sum((y - mb_) ** 2 for y in b)
    return sab / math.sqrt(saa * sbb) if saa > 0 and sbb > 0 else None


def rank_agreement(renders, name):
    """How image error ranks against data error over the dataset's factored materials: Spearman's
    rho, the number of pairs, the swapped (discordant) pairs and a one-line statement."""
    rs = [r for r in renders if r["dataset"] == name and r["method"] != "raw"]
    rho = spearman([r["data_rmse"] for r in rs], [r["image_rmse"] for r in rs])
    swapped = [(a["label"], b["label"]) for i, a in enumerate(rs) for b in rs[i + 1:]
               if (a["data_rmse"] - b["data_rmse"]) * (a["image_rmse"] - b["image_rmse"]) < 0]
    pairs = len(rs) * (len(rs) - 1) // 2
    if rho is None:
        say = "not judged (fewer than 3 factored materials)"
    elif rho >= 0.9:
        say = "image error ranks like data error"
    elif rho >= 0.5:
        say = "image error ranks roughly like data error"
    else:
        say = "image error does NOT rank like data error"
    return {"dataset": name, "spearman": rho, "materials": len(rs), "pairs": pairs,
            "swapped": swapped, "statement": say}


def render_table(renders, rs, agreement):
    lines = ["## Render time and image error per method\n"]
    add = lines.append
    if not renders:
        add(f"Not rendered: {rs['why']}.\n")
        return lines
    add(f"The paper-style scene ({rs['scene']}; bench/paper_scene.py) at {rs['size']} x "
        f"{rs['size']} pixels, {rs['spp']} samples per pixel, {rs['threads']} threads, the "
        "renderer's default seed for every material (equal samples, equal random streams), "
        "material scale " + f"{SCALE}. Reference: the `raw` render (the dataset itself). "
        "Render s is the opaline-render process's wall time (scene and material loading, the "
        "subsurface pre-pass, the camera pass, writing the PFM and PNG), the median of the runs; "
        "pre-pass and camera s are the renderer's own `subsurface pre-pass` and `camera pass` "
        "lines; CPU s is the process's user + system time. Image PSNR: peak = the raw image's "
        "largest value. Data RMSE is the material's RMSE of Rd (Table I).\n")
    add("| material | method | parameters | size MB | data RMSE | render s | pre-pass s | "
        "camera s | CPU s | image RMSE | image rel. RMSE | image PSNR dB |")
    add("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in renders:
        add(f"| {r['dataset']} | {r['series']} | {params(r)} | "
            f"{mb(r['size_bytes']):.2f} | {r['data_rmse']:.4g} | {r['render_seconds']:.3f} | "
            f"{r['prepass_seconds']:.3f} | {fmt(r['camera_seconds'], '.3f')} | "
            f"{r['cpu_seconds']:.2f} | {r['image_rmse']:.4g} | "
            f"{r['image_relative_rmse']:.4g} | {fmt(r['image_psnr'], '.2f')} |")
    add("")
    add("Does image error rank like data error? Spearman's rank correlation between data RMSE "
        "and image RMSE over each material's factored configurations:\n")
    for g in agreement:
        sw = g["swapped"]
        add(f"- {g['dataset']}: rho = {fmt(g['spearman'], '.3f')} over {g['materials']} "
            f"materials ({len(sw)} of {g['pairs']} pairs swapped): {g['statement']}" +
            (" (e.g. " + "; ".join(f"{a} vs {b}" for a, b in sw[:3]) + ")" if sw else ""))
    add("")
    return lines


# --- machine and versions --------------------------------------------------------------------

def environment(tool, root):
    env = {"time_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
           "platform": platform.platform(), "machine": platform.machine(),
           "cpus": os.cpu_count(), "python": sys.version.split()[0],
           "python_executable": sys.executable}
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                env["cpu"] = line.split(":", 1)[1].strip()
                break
        for line in open("/proc/meminfo"):
            if line.startswith("MemTotal"):
                env["memory_kib"] = int(line.split()[1])
    except OSError:
        pass
    env["load_average"] = os.getloadavg()
    try:
        env["opaline_factor"] = subprocess.run([tool, "--version"], capture_output=True,
                                               text=True).stdout.strip()
    except OSError:
        pass
    if shutil.which("git"):
        g = subprocess.run(["git", "-C", root, "rev-parse", "HEAD"], capture_output=True,
                           text=True)
        d = subprocess.run(["git", "-C", root, "status", "--porcelain"], capture_output=True,
                           text=True)
        if g.returncode == 0:
            env["source_commit"] = g.stdout.strip() + (" (modified)" if d.stdout.strip() else "")
    env["thread_env"] = {k: os.environ[k] for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")
                         if k in os.environ}
    pkgs = ["libopenblas0-pthread", "libopenblas0-openmp", "libopenblas0-serial", "liblapacke",
            "libembree3-3", "embree-tools", "blender", "python3-numpy", "python3-scipy",
            "python3-sklearn", "python3-matplotlib", "libpng16-16", "zlib1g", "libc6"]
    if shutil.which("dpkg-query"):
        p = subprocess.run(["dpkg-query", "-W", "-f", "${Package} ${Status} ${Version}\n"] + pkgs,
                           capture_output=True, text=True)
        env["debian_packages"] = {ln.split()[0]: ln.split()[-1] for ln in p.stdout.splitlines()
                                  if " installed " in ln}
    for lib in ("libblas.so.3", "liblapack.so.3"):
        p = os.path.join("/usr/lib", platform.machine() + "-linux-gnu", lib)
        if os.path.exists(p):
            env.setdefault("blas_alternatives", {})[lib] = os.path.realpath(p)
    for mod in ("numpy", "scipy", "sklearn", "matplotlib"):
        m = sys.modules.get(mod)
        if m is not None:
            env.setdefault("python_modules", {})[mod] = m.__version__
    return env


# --- tables, goals, plots --------------------------------------------------------------------

def mb(b):
    return b / 1e6


def fmt(v, spec):
    return "n/a" if v is None or v == "" else format(v, spec)


TYPICAL = {"svd": {"T": 10}, "tucker": {"T": 15, "P": 7}, "kcta": {"C": 8, "Km": 2, "T": 4},
           "nmf": {"T": 10}, "raw": {}}
QUICK_TYPICAL = {"svd": {"T": 4}, "tucker": {"T": 3, "P": 2}, "kcta": {"C": 2, "Km": 1, "T": 2},
                 "nmf": {"T": 4}, "raw": {}}


def find(runs, ds, method, par):
    for r in runs:
        if r["dataset"] == ds and r["label"] == label(method, par):
            return r
    return None


def tables(runs, datasets, baselines, typical, ref_nmf):
    lines = []
    add = lines.append
    add("## Table 1 (as Kurt et al. 2013): statistics per material, typical parameters\n")
    add("| material | pixels | K | dataset MB | method | parameters | size MB | CR | RMSE | "
        "PSNR dB | factor s | Rd eval ns | albedo map s |")
    add("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name, meta in datasets.items():
        for method in METHODS:
            r = find(runs, name, method, typical[method])
            if not r:
                continue
            add(f"| {name} | {meta['width']}x{meta['height']} | {meta['kernel']} | "
                f"{mb(r['original_bytes']):.1f} | {r['series']} | {params(r)} |"
                f" {mb(r['size_bytes']):.2f} | {r['compression_ratio']:.1f} | {r['rmse']:.4g} | "
                f"{fmt(r['psnr'], '.2f')} | {r['factor_seconds']:.3f} | {r['eval_ns']:.1f} | "
                f"{r['albedo_map_seconds']:.2e} |")
    add("")
    add("## Table 2 (as Kurt et al. 2013): time and size at equal RMSE\n")
    add(f"For each material, the target is the RMSE of the NMF baseline ({label('nmf', ref_nmf)}"
        "); for each method, its smallest configuration with an RMSE at most the target. "
        "The albedo map time is op_material_albedo_map's: factored materials store their "
        "albedo map (section ALBEDO, computed at factor time), so it is a copy; raw sums "
        "the rows.\n")
    add("| material | target RMSE | method | parameters | RMSE | size MB | factor s | "
        "albedo map s | Rd eval ns |")
    add("|---|---|---|---|---|---|---|---|---|")
    for name in datasets:
        ref = find(runs, name, "nmf", ref_nmf)
        if not ref:
            continue
        for method in SERIES:
            ok = [r for r in runs if r["dataset"] == name and r["series"] == method
                  and r["rmse"] <= ref["rmse"]]
            if not ok:
                add(f"| {name} | {ref['rmse']:.4g} | {method} | none reaches it | | | | | |")
                continue
            r = min(ok, key=lambda r: r["size_bytes"])
            add(f"| {name} | {ref['rmse']:.4g} | {method} | {params(r)} | "
                f"{r['rmse']:.4g} | {mb(r['size_bytes']):.2f} | {r['factor_seconds']:.3f} | "
                f"{r['albedo_map_seconds']:.2e} | {r['eval_ns']:.1f} |")
    add("")
    add("## Table I (as K-CTA, Tsai and Shih 2012): size, error and compression time, "
        "every configuration\n")
    add("| material | method | parameters | size MB | CR | S/E dB | RMSE | compression s "
        "(median) | runs |")
    add("|---|---|---|---|---|---|---|---|---|")
    for r in runs:
        add(f"| {r['dataset']} | {r['series']} | {params(r)} | "
            f"{mb(r['size_bytes']):.2f} | {r['compression_ratio']:.1f} | "
            f"{fmt(r['se_ratio_db'], '.2f')} | {r['rmse']:.4g} | {r['factor_seconds']:.3f} | "
            f"{r['repeats']} |")
    add("")
    if baselines:
        add("## Baselines on one channel of the same matrices\n")
        add("| material | matrix | who | seconds | error (relative, factored domain) | "
            "x optimum | Rd RMSE |")
        add("|---|---|---|---|---|---|---|")
        for b in baselines:
            kind = "svd log-domain" if "optimal_log_domain_error" in b else "nmf remainder"
            for e in b["entries"]:
                err = e.get("log_domain_error", e.get("remainder_relative_error"))
                add(f"| {b['dataset']} | {kind} {b['rows']}x{b['cols']} rank {b['rank']} "
                    f"ch {b['channel']} | {e['who']} | {fmt(e['seconds'], '.3f')} | "
                    f"{fmt(err, '.5g')} | {fmt(e.get('error_over_optimal'), '.5f')} | "
                    f"{fmt(e['rd_rmse'], '.4g')} |")
        add("")
    return lines


def goals(runs, datasets, kinds, baselines, renderer):
    """The issue's goals, each with its figures and a verdict (met / NOT met / not measured)."""
    out = []
    # 1. At equal size, the best opaline method has at most half the RMSE of NMF (chessboards),
    #    judged against each NMF series: the issue's baseline and the stronger NMF of Rd.
    for name in datasets:
        if kinds[name] != "chess":
            continue
        for ser, what in NMF_SERIES.items():
            rows = []
            for n in (r for r in runs if r["dataset"] == name and r["series"] == ser):
                cand = [r for r in runs if r["dataset"] == name and
                        r["series"] in OPALINE_SERIES and r["size_bytes"] <= n["size_bytes"]]
                if not cand:  # smaller than every opaline configuration: not comparable
                    rows.append({"nmf": n["label"], "nmf_size": n["size_bytes"],
                                 "nmf_rmse": n["rmse"], "best": None, "ratio": None})
                    continue
                b = min(cand, key=lambda r: r["rmse"])
                rows.append({"nmf": n["label"], "nmf_size": n["size_bytes"], "nmf_rmse": n["rmse"],
                             "best": b["label"], "best_size": b["size_bytes"],
                             "best_rmse": b["rmse"],
                             "ratio": b["rmse"] / n["rmse"] if n["rmse"] > 0 else None})
            if not rows:
                continue
            judged = [r for r in rows if r["ratio"] is not None]
            met = all(r["ratio"] <= 0.5 for r in judged) if judged else None
            out.append({"goal": f"{name}: at equal (or smaller) size, best opaline RMSE <= 0.5 x "
                        f"{what} (every NMF configuration that some opaline configuration is not "
                        "larger than)",
                        "verdict": "not measured" if met is None else ("met" if met else
                                                                       "NOT met"),
                        "points": rows})
    # 2. svd at least as fast as sklearn's randomized SVD and within 1 % of the optimum.
    for b in baselines:
        if "optimal_log_domain_error" not in b:
            continue
        op = b["entries"][0]
        sk = [e for e in b["entries"] if e["who"].startswith("sklearn")]
        fast = (all(op["seconds"] is not None and op["seconds"] <= e["seconds"] for e in sk)
                if sk else None)
        within = op["error_over_optimal"] is not None and op["error_over_optimal"] <= 1.01
        verdict = ("not measured (scikit-learn missing)" if fast is None else
                   "met" if fast and within else "NOT met")
        tool = [e for e in b["entries"] if e["who"].startswith("opaline-factor")]
        out.append({"goal": f"{b['dataset']}: opaline svd no slower than sklearn randomized_svd "
                    "and within 1 % of the optimal error",
                    "verdict": verdict, "opaline_seconds": op["seconds"],
                    "opaline_factor_seconds": tool[0]["seconds"] if tool else None,
                    "sklearn_seconds": [e["seconds"] for e in sk],
                    "error_over_optimal": op["error_over_optimal"]})
    g = "renderer samples per second >= 0.7 x Embree's tutorial path tracer"
    e = renderer["embree"]
    if e:
        ratio = e["opaline_msamples_per_s"] / e["embree_msamples_per_s"]
        out.append({"goal": g, "verdict": "met" if ratio >= 0.7 else "NOT met",
                    "ratio": ratio, "opaline_msamples_per_s": e["opaline_msamples_per_s"],
                    "embree_msamples_per_s": e["embree_msamples_per_s"]})
    else:
        out.append({"goal": g, "verdict": "not measured", "why": renderer["embree_reason"]})
    g = ("renderer time to equal noise (RMSE 1 % of the mean) on the same exported Lambertian "
         "scene <= Cycles' time")
    c = renderer["cycles"]
    if c:
        out.append({"goal": g, "verdict": c["verdict"], "ratio": c["ratio"],
                    "opaline_seconds": c["opaline"]["seconds_to_target"],
                    "cycles_seconds": c["cycles"]["seconds_to_target"]})
    else:
        out.append({"goal": g, "verdict": "not measured", "why": renderer["cycles_reason"]})
    return out


def plots(plt, runs, datasets, baselines, outdir, renders=()):
    os.makedirs(outdir, exist_ok=True)
    made = []

    def save(fig, filename):
        fig.tight_layout()
        p = os.path.join(outdir, filename)
        fig.savefig(p, dpi=110)
        plt.close(fig)
        made.append(p)
    for name in datasets:
        rs = [r for r in runs if r["dataset"] == name]
        fig, ax = plt.subplots(1, 2, figsize=(12, 4.8))
        raw = [r for r in rs if r["method"] == "raw"]
        for method in SERIES:
            pts = sorted((r for r in rs if r["series"] == method and r["rmse"] > 0),
                         key=lambda r: r["size_bytes"])
            if not pts:
                continue
            c = COLOURS[method]
            # markers for every configuration, a line through the best error at each size
            front = [r for i, r in enumerate(pts) if all(r["rmse"] < q["rmse"] for q in pts[:i])]
            ax[0].plot([mb(r["size_bytes"]) for r in pts], [r["rmse"] for r in pts], "o",
                       color=c, label=method)
            ax[0].plot([mb(r["size_bytes"]) for r in front], [r["rmse"] for r in front], "-",
                       color=c)
            for r in pts:
                ax[0].annotate(params(r).replace(" ", ","),
                               (mb(r["size_bytes"]), r["rmse"]), fontsize=6, color=c,
                               xytext=(3, 3), textcoords="offset points")
            ax[1].plot([r["factor_seconds"] for r in pts], [r["rmse"] for r in pts], "o",
                       color=c, label=method)
        if raw:
            ax[0].axvline(mb(raw[0]["size_bytes"]), color="black", ls="--",
                          label="raw (dataset) size")
        ax[0].set(xscale="log", yscale="log", xlabel="material size (MB)", ylabel="RMSE of Rd",
                  title=f"{name}: error against size (lines: the best up to each size)")
        ax[1].set(xscale="log", yscale="log", xlabel="factor time, median (s)",
                  ylabel="RMSE of Rd", title=f"{name}: error against factor time")
        for a in ax:
            a.grid(True, which="both", alpha=0.3)
            a.legend(fontsize=8)
        save(fig, f"{name}.png")
    svd = [b for b in baselines if "optimal_log_domain_error" in b]
    if svd:
        fig, axs = plt.subplots(1, len(svd), figsize=(6 * len(svd), 4.5), squeeze=False)
        for a, b in zip(axs[0], svd):
            for e in b["entries"]:
                if e["seconds"] is None or e["error_over_optimal"] is None:
                    continue
                a.plot(e["seconds"], (e["error_over_optimal"] - 1) * 1e6, "o",
                       label=e["who"][:45])
            a.ticklabel_format(axis="y", useOffset=False, style="plain")
            a.set(xscale="log", xlabel="seconds (one channel)",
                  ylabel="error above the optimum (parts per million)",
                  title=f"{b['dataset']}: rank-{b['rank']} SVD of {b['rows']}x{b['cols']}")
            a.grid(True, which="both", alpha=0.3)
            a.legend(fontsize=7)
        save(fig, "svd_baselines.png")
    names = [n for n in datasets if any(r["dataset"] == n for r in renders)]
    if names:
        fig, axs = plt.subplots(2, len(names), figsize=(5.5 * len(names), 9), squeeze=False)
        for col, name in enumerate(names):
            rs = [r for r in renders if r["dataset"] == name]
            top, bot = axs[0][col], axs[1][col]
            for r in rs:
                if r["method"] == "raw":
                    top.axvline(r["render_seconds"], color="black", ls="--",
                                label="raw (the reference) render time")
            for method in SERIES:
                pts = [r for r in rs if r["series"] == method and r["image_rmse"] > 0]
                if not pts:
                    continue
                c = COLOURS[method]
                top.plot([r["render_seconds"] for r in pts], [r["image_rmse"] for r in pts], "o",
                         color=c, label=method)
                bot.plot([r["data_rmse"] for r in pts], [r["image_rmse"] for r in pts], "o",
                         color=c, label=method)
                for r in pts:
                    par = params(r).replace(" ", ",")
                    top.annotate(par, (r["render_seconds"], r["image_rmse"]), fontsize=6,
                                 color=c, xytext=(3, 3), textcoords="offset points")
                    bot.annotate(par, (r["data_rmse"], r["image_rmse"]), fontsize=6,
                                 color=c, xytext=(3, 3), textcoords="offset points")
            r0 = rs[0]
            top.set(yscale="log", xlabel="render time, process wall, median (s)",
                    ylabel="image RMSE against raw",
                    title=f"{name}: image RMSE against render time\n"
                          f"({r0['res']}x{r0['res']}, {r0['spp']} spp, {r0['threads']} threads)")
            bot.set(xscale="log", yscale="log", xlabel="data RMSE of Rd",
                    ylabel="image RMSE against raw", title=f"{name}: image against data error")
            for a in (top, bot):
                a.grid(True, which="both", alpha=0.3)
                a.legend(fontsize=8)
        save(fig, "renders.png")
    return made


def renderer_status(tool, root, quick):
    """The renderer against its peers (full mode only; the quick mode skips both with a message):
    samples per second against Embree's pathtracer tutorial (bench/bench_render_peers.sh) and
    time to equal noise against Cycles (bench/bench_cycles_noise.sh). Each absent tool or
    failure becomes the reason its goal is not measured."""
    have = {"embree pathtracer": shutil.which("pathtracer"), "blender": shutil.which("blender")}
    out = {"tools_found": have, "embree": None, "cycles": None}
    if quick:
        out["embree_reason"] = out["cycles_reason"] = "skipped in quick mode"
        return out
    build = os.path.dirname(os.path.dirname(os.path.abspath(tool)))
    threads = str(os.cpu_count() or 1)

    def run(script, *args):
        """(output text, exit status) of bench/SCRIPT ARGS, or (reason, None) on a time-out."""
        try:
            p = subprocess.run(["bash", os.path.join(root, "bench", script)] + list(args),
                               capture_output=True, text=True, timeout=900)
        except subprocess.TimeoutExpired:
            return f"{script} timed out", None
        return p.stdout + p.stderr, p.returncode

    def last(text):
        return (text.strip().splitlines() or ["no output"])[-1]

    text, rc = run("bench_render_peers.sh", build, threads)
    m = re.search(r"opaline-render\s+([\d.]+) M samples/s\s*\nEmbree pathtracer\s+([\d.]+) M",
                  text)
    if rc != 0 or not m:
        out["embree_reason"] = "bench_render_peers.sh: " + last(text)
    else:
        out["embree"] = {"opaline_msamples_per_s": float(m.group(1)),
                         "embree_msamples_per_s": float(m.group(2)), "log": text}
    cdir = os.path.join(build, "bench-cycles-noise")
    js = os.path.join(cdir, "cycles_noise.json")
    if os.path.exists(js):
        os.remove(js)  # never report an earlier run's figures
    text, rc = run("bench_cycles_noise.sh", build, threads, cdir)
    if rc != 0 or not os.path.exists(js):
        out["cycles_reason"] = "bench_cycles_noise.sh: " + last(text)
    else:
        with open(js) as f:
            out["cycles"] = json.load(f)
        out["cycles"]["log"] = text
    return out


# --- main ------------------------------------------------------------------------------------

def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tool", required=True, help="opaline-factor")
    ap.add_argument("--out", required=True)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--repeats", type=int, help="runs per configuration (3; quick 1)")
    ap.add_argument("--datasets", help="comma-separated subset of the datasets")
    ap.add_argument("--skip", default="",
                    help="comma-separated configurations to leave out, e.g. 'nmf T=40,kcta C=16 "
                         "Km=2 T=4' (they are listed as skipped)")
    ap.add_argument("--no-baselines", action="store_true", help="skip numpy/sklearn parts")
    ap.add_argument("--no-plots", action="store_true")
    ap.add_argument("--renderer-only", action="store_true",
                    help="only the renderer against Embree's tutorial and Cycles (no datasets)")
    ap.add_argument("--render-size", type=int,
                    help="side of the rendered images in pixels (256; quick 32)")
    ap.add_argument("--render-spp", type=int, help="samples per pixel of the renders (16; quick 2)")
    ap.add_argument("--no-render", action="store_true",
                    help="skip rendering the scene with every material")
    a = ap.parse_args()
    if a.renderer_only and a.quick:
        sys.exit("bench_methods: --renderer-only measures nothing in quick mode")
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    dsets = dict(QUICK_DATASETS if a.quick else FULL_DATASETS)
    if a.datasets:
        unknown = set(a.datasets.split(",")) - set(dsets)
        if unknown:
            sys.exit(f"bench_methods: unknown dataset(s) {sorted(unknown)}; known: {list(dsets)}")
        dsets = {k: v for k, v in dsets.items() if k in a.datasets.split(",")}
    if a.renderer_only:
        dsets = {}
        note("factorization methods SKIPPED on request (--renderer-only)")
    sweep = QUICK_SWEEP if a.quick else FULL_SWEEP
    typical = QUICK_TYPICAL if a.quick else TYPICAL
    skip = {x.strip() for x in a.skip.split(",") if x.strip()}
    if skip - {label(m, p) for m, p in sweep}:
        sys.exit("bench_methods: --skip names no configuration: "
                 f"{sorted(skip - {label(m, p) for m, p in sweep})}")
    if "raw" in skip:
        sys.exit("bench_methods: --skip 'raw': it is the reference of every comparison")
    if skip:
        note("configurations SKIPPED on request (--skip): " + ", ".join(sorted(skip)))
    sweep = [(m, p) for m, p in sweep if label(m, p) not in skip]
    repeats = a.repeats or (1 if a.quick else 3)
    rs = {"size": a.render_size or (32 if a.quick else 256),
          "spp": a.render_spp or (2 if a.quick else 16), "threads": os.cpu_count() or 1,
          "mesh": find_mesh(root), "why": None}
    if rs["size"] < 8 or rs["spp"] < 1:
        sys.exit("bench_methods: need --render-size >= 8 and --render-spp >= 1")
    renderer = os.path.join(os.path.dirname(os.path.abspath(a.tool)), "opaline-render")
    rs["scene"] = ("Spot the cow, " + rs["mesh"] if rs["mesh"] else
                   "a sphere of radius 0.8 in place of Spot (../shared/meshes/spot.obj absent)")
    if a.no_render:
        rs["why"] = "--no-render given"
    elif not a.renderer_only and not os.access(renderer, os.X_OK):
        rs["why"] = f"{renderer} is not built"
    if rs["why"] and not a.renderer_only:
        note(f"rendering the scene with every material SKIPPED: {rs['why']}")
    elif not rs["mesh"] and not a.renderer_only:
        note("../shared/meshes/spot.obj is absent: the render scene uses a sphere instead of Spot")
    os.makedirs(a.out, exist_ok=True)
    log = os.path.join(a.out, "commands.log")
    open(log, "w").close()
    t_start = time.perf_counter()

    np = skx = skd = plt = None
    if not a.no_baselines:
        np = optional("numpy", "python3-numpy")
        if np is not None:
            skx = optional("sklearn.utils.extmath", "python3-sklearn")
            skd = importlib.import_module("sklearn.decomposition") if skx else None
    if not a.no_plots:
        mpl = optional("matplotlib", "python3-matplotlib")
        if mpl is not None:
            mpl.use("Agg")
            plt = importlib.import_module("matplotlib.pyplot")

    print(f"opaline method benchmark ({'quick' if a.quick else 'full'} mode, {repeats} run(s) "
          f"per configuration) -> {a.out}", flush=True)
    runs, metas, kinds, paths, baselines, renders = [], {}, {}, {}, [], []
    for name, (args, kind) in dsets.items():
        path, _, meta = make_dataset(a.tool, name, args, a.out, log)
        metas[name], kinds[name], paths[name] = meta, kind, path
        for method, par in sweep:
            rec = factor_runs(a.tool, name, path, method, par, repeats, a.out, log)
            runs.append(rec)
            print(f"   {name:14s} {rec['label']:22s} size {mb(rec['size_bytes']):9.3f} MB  "
                  f"CR {rec['compression_ratio']:7.1f}  RMSE {rec['rmse']:.4g}  "
                  f"PSNR {fmt(rec['psnr'], '6.2f')} dB  factor {rec['factor_seconds']:7.3f} s  "
                  f"eval {rec['eval_ns']:6.1f} ns", flush=True)
            if method == "raw":
                os.remove(rec["material"])  # as large as the dataset
        if not rs["why"]:
            print(f"== renders of {name}: the paper-style scene, {rs['size']}x{rs['size']}, "
                  f"{rs['spp']} spp, {rs['threads']} threads ({rs['scene']})", flush=True)
            for r in render_dataset(renderer, name, path,
                                    [r for r in runs if r["dataset"] == name], rs, repeats,
                                    a.out, log):
                renders.append(r)
                print(f"   {name:14s} {r['label']:22s} render {r['render_seconds']:7.3f} s "
                      f"(pre-pass {r['prepass_seconds']:.3f} s, camera "
                      f"{fmt(r['camera_seconds'], '.3f')} s)  image RMSE {r['image_rmse']:.4g}  "
                      f"PSNR {fmt(r['image_psnr'], '6.2f')} dB  data RMSE {r['data_rmse']:.4g}",
                      flush=True)
        if np is not None:
            svd_ref = find(runs, name, "svd", typical["svd"])
            nmf_ref = find(runs, name, "nmf", typical["nmf"])
            print(f"== baselines on {name}, channel 0", flush=True)
            for kind, ref in (("svd", svd_ref), ("nmf", nmf_ref)):
                if not ref:
                    note(f"{name}: the {kind} baselines SKIPPED: their configuration "
                         f"'{label(kind, typical[kind])}' was skipped")
                    continue
                b = (svd_baseline(np, skx, ref, path, repeats, a.tool, a.out, log)
                     if kind == "svd" else
                     nmf_baseline(np, skd, ref, path))
                baselines.append(b)
                for e in b["entries"]:
                    print(f"   {kind}  {e['who'][:62]:62s} {fmt(e['seconds'], '8.3f')} s  "
                          f"error x optimum {fmt(e.get('error_over_optimal'), '.5f')}  "
                          f"Rd RMSE {fmt(e['rd_rmse'], '.4g')}", flush=True)
    if np is None and not a.no_baselines:
        note("baselines (scikit-learn randomized_svd and NMF, LAPACK optimum) SKIPPED: numpy is "
             "missing")
    elif np is not None and skx is None:
        note("scikit-learn baselines SKIPPED (python3-sklearn missing); the LAPACK optimum "
             "was measured")
    print("== renderer against Embree's pathtracer tutorial and Cycles", flush=True)
    renderer = renderer_status(a.tool, root, a.quick)
    if renderer["embree"]:
        e = renderer["embree"]
        print(f"   opaline {e['opaline_msamples_per_s']:.3f} M samples/s, Embree tutorial "
              f"{e['embree_msamples_per_s']:.3f} M samples/s", flush=True)
    else:
        print("   Embree: NOT MEASURED (" + renderer["embree_reason"] + ")", flush=True)
    if renderer["cycles"]:
        c = renderer["cycles"]
        print(f"   time to RMSE 1 % of the mean: opaline "
              f"{c['opaline']['seconds_to_target']:.3f} s, Cycles "
              f"{c['cycles']['seconds_to_target']:.3f} s (Blender {c['blender']})", flush=True)
    else:
        print("   Cycles: NOT MEASURED (" + renderer["cycles_reason"] + ")", flush=True)

    env = environment(a.tool, root)
    gl = goals(runs, metas, kinds, baselines, renderer)
    if a.quick:
        for g in gl:
            if g["verdict"] in ("met", "NOT met"):
                g["verdict"] += " (quick mode: toy sizes, not a verdict)"
    agreement = [rank_agreement(renders, n) for n in metas
                 if any(r["dataset"] == n for r in renders)]
    tab = tables(runs, metas, baselines, typical, typical["nmf"])
    if not a.renderer_only:
        tab += render_table(renders, rs, agreement)
    made = (plots(plt, runs, metas, baselines, os.path.join(a.out, "plots"), renders)
            if plt else [])
    by_label = {(r["dataset"], r["label"]): r for r in renders}
    for r in runs:
        x = by_label.get((r["dataset"], r["label"]), {})
        r["render_seconds"] = x.get("render_seconds")
        r["image_rmse"] = x.get("image_rmse")
        r["image_psnr"] = x.get("image_psnr")
    if plt is None and not a.no_plots:
        note("plots SKIPPED: matplotlib is missing (Debian package python3-matplotlib)")

    fields = ["dataset", "method", "series", "label", "T", "P", "C", "Km", "E", "size_bytes",
              "original_bytes",
              "compression_ratio", "rmse", "relative_rmse", "psnr", "se_ratio_db", "max_error",
              "factor_seconds", "total_seconds", "eval_ns", "eval_random_ns",
              "albedo_map_seconds", "peak_memory_bytes", "channel0_seconds", "repeats",
              "render_seconds", "image_rmse", "image_psnr"]
    with open(os.path.join(a.out, "runs.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields, extrasaction="ignore")
        w.writeheader()
        for r in runs:
            w.writerow(r)
    rfields = ["dataset", "method", "series", "label", "T", "P", "C", "Km", "E", "size_bytes",
               "data_rmse",
               "data_psnr", "res", "spp", "threads", "render_seconds", "cpu_seconds",
               "prepass_seconds", "camera_seconds", "image_rmse", "image_relative_rmse",
               "image_psnr", "repeats", "image"]
    if renders:
        with open(os.path.join(a.out, "renders.csv"), "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=rfields, extrasaction="ignore")
            w.writeheader()
            for r in renders:
                w.writerow(r)
    with open(os.path.join(a.out, "baselines.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["dataset", "problem", "channel", "rows", "cols", "rank", "who", "seconds",
                    "relative_error", "error_over_optimal", "rd_rmse"])
        for b in baselines:
            kind = "svd" if "optimal_log_domain_error" in b else "nmf"
            for e in b["entries"]:
                w.writerow([b["dataset"], kind, b["channel"], b["rows"], b["cols"], b["rank"],
                            e["who"], e["seconds"],
                            e.get("log_domain_error", e.get("remainder_relative_error")),
                            e.get("error_over_optimal"), e["rd_rmse"]])
    lines = ["# opaline method benchmark\n",
             f"Mode: {'quick' if a.quick else 'full'}; {repeats} run(s) per configuration, "
             "timings are medians; dataset seed "
             f"{SEED}, scikit-learn random_state {RANDOM_STATE}. Machine: {env.get('cpu')}, "
             f"{env['cpus']} CPUs, load average at the end {env['load_average'][0]:.2f}.\n",
             "## Goals\n"]
    for g in gl:
        lines.append(f"- **{g['verdict']}** - {g['goal']}" +
                     (f" (opaline {fmt(g.get('opaline_seconds'), '.3f')} s; inside "
                      f"opaline-factor, first channel of a fresh process, "
                      f"{fmt(g.get('opaline_factor_seconds'), '.3f')} s; sklearn "
                      f"{', '.join(fmt(s, '.3f') for s in g['sklearn_seconds'])} s, error "
                      f"{fmt(g['error_over_optimal'], '.5f')} x optimum)"
                      if "sklearn_seconds" in g else "") +
                     ("".join(f"\n  - {p['nmf']} ({mb(p['nmf_size']):.2f} MB, RMSE "
                              f"{p['nmf_rmse']:.4g}): "
                              + (f"best {p['best']} ({mb(p['best_size']):.2f} MB, RMSE "
                                 f"{p['best_rmse']:.4g}, "
                                 f"ratio {p['ratio']:.3f})" if p["best"] else
                                 "(none as small: not judged)")
                              for p in g.get("points", []))) +
                     (f" (opaline {g['opaline_msamples_per_s']:.3f} M samples/s, Embree "
                      f"{g['embree_msamples_per_s']:.3f}, ratio {g['ratio']:.2f})"
                      if "embree_msamples_per_s" in g else "") +
                     (f" (opaline {g['opaline_seconds']:.3f} s, Cycles "
                      f"{g['cycles_seconds']:.3f} s, ratio {g['ratio']:.2f})"
                      if "cycles_seconds" in g else "") +
                     (f" ({g['why']})" if "why" in g else ""))
    lines.append("")
    if notes:
        lines += ["## Skipped\n"] + [f"- {n}" for n in notes] + [""]
    lines += tab
    with open(os.path.join(a.out, "tables.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    result = {"mode": "quick" if a.quick else "full", "repeats": repeats, "seed": SEED,
              "random_state": RANDOM_STATE, "environment": env,
              "datasets": {k: {"args": dsets[k][0], "kind": kinds[k], "meta": metas[k]}
                           for k in metas},
              "runs": runs, "baselines": baselines, "goals": gl, "renderer": renderer,
              "render_settings": {k: v for k, v in rs.items() if k != "why"},
              "render_skipped": rs["why"], "renders": renders,
              "render_rank_agreement": agreement,
              "plots": made, "notes": notes,
              "seconds": time.perf_counter() - t_start}
    with open(os.path.join(a.out, "results.json"), "w") as f:
        json.dump(result, f, indent=1, default=float)
    print("\n".join(lines[:lines.index("## Table 1 (as Kurt et al. 2013): statistics per "
                                       "material, typical parameters\n")]))
    for g in agreement:
        print(f"renders, {g['dataset']}: Spearman rho(data RMSE, image RMSE) = "
              f"{fmt(g['spearman'], '.3f')}: {g['statement']}")
    print(f"results: {a.out}/results.json, runs.csv, baselines.csv, tables.md" +
          (", renders.csv, images/" if renders else "") +
          (", plots/*.png" if made else "") + f" ({result['seconds']:.0f} s)")


if __name__ == "__main__":
    main()
