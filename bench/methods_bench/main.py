"""main.py - the command line: runs every part in turn and writes the outputs."""

import argparse
import importlib
import json
import os
import sys
import time

from paper_scene import find_mesh
from .baselines import nmf_baseline, svd_baseline
from .common import fmt, mb, note, notes, optional
from .config import (FULL_DATASETS, FULL_SWEEP, QUICK_DATASETS, QUICK_SWEEP, QUICK_TYPICAL,
                     RANDOM_STATE, SEED, TYPICAL)
from .environment import environment
from .plots import plots
from .renders import render_dataset, renderer_status
from .report import (find, goals, rank_agreement, render_table, summary_lines, tables,
                     write_csvs)
from .runs import factor_runs, label, make_dataset


def main():
    ap = argparse.ArgumentParser(description=sys.modules[__package__].__doc__.split("\n")[0])
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
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
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

    write_csvs(a.out, runs, renders, baselines)
    lines = summary_lines(a.quick, repeats, env, gl, notes) + tab
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
