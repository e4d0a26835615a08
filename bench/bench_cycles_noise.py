"""Time to equal noise: opaline-render against Cycles on the same exported Lambertian scene.

Run inside Blender (see bench/bench_cycles_noise.sh):
    blender --background --factory-startup --python bench/bench_cycles_noise.py -- \
        --renderer BUILD/bin/opaline-render [--out DIR] [--res 128] [--threads 2]

The scene (a diffuse floor, a diffuse box casting a shadow, a point light and a grey world) is
built in code, exported with the add-on and rendered by both renderers at several sample counts.
Each renderer's noise is the RMSE against its own high-sample reference (so a small difference in
mean or filtering does not count as noise); since noise falls like 1/sqrt(time), each run predicts
the time to reach the target RMSE (1 % of the reference mean), and the median prediction is
reported. Cycles is timed around bpy.ops.render.render (scene sync included, Blender start-up
excluded); opaline-render is timed as a process (scene loading included)."""

import json
import math
import os
import statistics
import subprocess
import sys
import time

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tests", "addon"))
import addon_support as S  # noqa: E402


def args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    out = {"renderer": None, "out": "bench-cycles-noise", "res": 128, "threads": 2}
    i = 0
    while i < len(argv):
        key = argv[i].lstrip("-")
        if key not in out or i + 1 >= len(argv):
            sys.exit("bench_cycles_noise: unknown or incomplete option %r" % argv[i])
        out[key] = argv[i + 1] if key in ("renderer", "out") else int(argv[i + 1])
        i += 2
    if not out["renderer"] or not os.access(out["renderer"], os.X_OK):
        sys.exit("bench_cycles_noise: --renderer must name a built opaline-render")
    return out


def build_scene(res):
    sc = S.empty_scene((res, res))
    sc.world.node_tree.nodes["Background"].inputs[0].default_value = (0.2, 0.2, 0.2, 1.0)
    S.add_floor(size=20.0)
    s = 0.5
    verts = [(x, y, z) for z in (0, 2 * s) for y in (-s, s) for x in (-s, s)]
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    S.add_mesh("box", verts, faces, S.diffuse_material("box", (0.6, 0.5, 0.4)))
    S.add_light('POINT', (1.5, -1.0, 3.0), energy=300.0, shadow_soft_size=0.0)
    S.add_camera((0.0, -5.0, 4.0), (math.radians(50), 0.0, 0.0), lens=35.0)
    sc.cycles.max_bounces = 4
    sc.cycles.diffuse_bounces = 4
    return sc


def cycles(path, spp, threads):
    sc = bpy.context.scene
    sc.render.threads = threads
    t0 = time.perf_counter()
    S.render_cycles(path, samples=spp)
    t = time.perf_counter() - t0
    w, h, a = S.load_image_rgba(path)
    return t, [a[4 * i + c] for i in range(w * h) for c in range(3)]


def opaline(renderer, xml, path, spp, threads):
    t0 = time.perf_counter()
    subprocess.run([renderer, "-q", "-t", str(threads), "-s", str(spp), "-o", path, xml],
                   check=True, timeout=3600)
    t = time.perf_counter() - t0
    w, h, rows = S.read_pfm(path)
    rows.reverse()  # bottom row first, like Blender's pixels
    return t, [v for row in rows for v in row]


def rmse(a, b):
    return math.sqrt(sum((x - y) ** 2 for x, y in zip(a, b)) / len(a))


def measure(name, render, ref_spp, levels):
    t_ref, ref = render("ref", ref_spp)
    mean = sum(ref) / len(ref)
    target = 0.01 * mean
    runs = []
    for spp in levels:
        t, img = render("s%d" % spp, spp)
        e = rmse(img, ref)
        runs.append({"spp": spp, "seconds": t, "rmse": e,
                     "seconds_to_target": t * (e / target) ** 2})
        print("%-8s %5d spp  %7.3f s  RMSE %.5f" % (name, spp, t, e), flush=True)
    return {"reference_spp": ref_spp, "reference_seconds": t_ref, "mean": mean,
            "target_rmse": target, "runs": runs,
            "seconds_to_target": statistics.median(r["seconds_to_target"] for r in runs)}


def main():
    a = args()
    os.makedirs(a["out"], exist_ok=True)
    build_scene(a["res"])
    xml = os.path.join(os.path.abspath(a["out"]), "scene.xml")
    S.export(xml, samples=16)
    levels = [4, 16, 64]
    res = {
        "cycles": measure("Cycles", lambda tag, spp: cycles(
            os.path.join(a["out"], "cycles-%s.exr" % tag), spp, a["threads"]), 1024, levels),
        "opaline": measure("opaline", lambda tag, spp: opaline(
            a["renderer"], xml, os.path.join(a["out"], "opaline-%s.pfm" % tag), spp,
            a["threads"]), 1024, levels),
        "blender": bpy.app.version_string, "resolution": a["res"], "threads": a["threads"],
        "load_average": os.getloadavg(),
    }
    tc, to = res["cycles"]["seconds_to_target"], res["opaline"]["seconds_to_target"]
    res["verdict"] = "met" if to <= tc else "NOT met"
    with open(os.path.join(a["out"], "cycles_noise.json"), "w") as f:
        json.dump(res, f, indent=1)
    print("time to RMSE = 1 %% of the mean: opaline %.3f s, Cycles %.3f s, ratio %.2f "
          "(goal: opaline no slower: %s)" % (to, tc, to / tc, res["verdict"]), flush=True)


main()
