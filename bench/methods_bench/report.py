"""report.py - the report: Kurt et al. 2013's Tables 1 and 2 and K-CTA's Table I shaped tables,
the goals of the issue and their verdicts, the render table, and the CSV files and the summary
of tables.md. Pure functions of the records (tests/bench/test_report.py tests them)."""

import csv
import math
import os

from paper_scene import SCALE
from .common import fmt, mb
from .config import METHODS, NMF_SERIES, OPALINE_SERIES, RANDOM_STATE, SEED, SERIES
from .runs import label, params


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


RUN_FIELDS = ["dataset", "method", "series", "label", "T", "P", "C", "Km", "E", "size_bytes",
              "original_bytes",
              "compression_ratio", "rmse", "relative_rmse", "psnr", "se_ratio_db", "max_error",
              "factor_seconds", "total_seconds", "eval_ns", "eval_random_ns",
              "albedo_map_seconds", "peak_memory_bytes", "channel0_seconds", "repeats",
              "render_seconds", "image_rmse", "image_psnr"]
RENDER_FIELDS = ["dataset", "method", "series", "label", "T", "P", "C", "Km", "E", "size_bytes",
                 "data_rmse",
                 "data_psnr", "res", "spp", "threads", "render_seconds", "cpu_seconds",
                 "prepass_seconds", "camera_seconds", "image_rmse", "image_relative_rmse",
                 "image_psnr", "repeats", "image"]


def write_csvs(out, runs, renders, baselines):
    """runs.csv (one line per configuration), renders.csv (when anything was rendered) and
    baselines.csv in folder out."""
    with open(os.path.join(out, "runs.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=RUN_FIELDS, extrasaction="ignore")
        w.writeheader()
        for r in runs:
            w.writerow(r)
    if renders:
        with open(os.path.join(out, "renders.csv"), "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=RENDER_FIELDS, extrasaction="ignore")
            w.writeheader()
            for r in renders:
                w.writerow(r)
    with open(os.path.join(out, "baselines.csv"), "w", newline="") as f:
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


def summary_lines(quick, repeats, env, gl, notes):
    """The head of tables.md (and of the printed summary): mode, machine, the goals with their
    verdicts, and what was skipped."""
    lines = ["# opaline method benchmark\n",
             f"Mode: {'quick' if quick else 'full'}; {repeats} run(s) per configuration, "
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
    return lines
