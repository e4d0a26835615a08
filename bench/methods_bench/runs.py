"""runs.py - making the datasets and timing `opaline-factor factor` over the sweep."""

import json
import math
import os
import re
import statistics
import time

from .common import note, run
from .config import OPTION, SEED, SLOW_SECONDS
from .files import opm_sections


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


def timed(fn, repeats):
    """(median seconds, last result) of fn() run `repeats` times."""
    ts, res = [], None
    for _ in range(repeats):
        t = time.perf_counter()
        res = fn()
        ts.append(time.perf_counter() - t)
    return statistics.median(ts), res
