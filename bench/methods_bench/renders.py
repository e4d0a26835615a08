"""renders.py - rendering the paper-style scene with every material, and the renderer against
Embree's pathtracer tutorial and Cycles."""

import json
import math
import os
import re
import shutil
import statistics
import subprocess

import pfm
from paper_scene import SCALE
from paper_scene import scene_xml
from paper_scene import compare as image_compare
from paper_scene import render as render_once

from .config import SLOW_SECONDS


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
        image = pfm.read(img).samples
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
