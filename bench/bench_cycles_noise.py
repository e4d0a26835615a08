"""Time to equal noise: opaline-render against Cycles on the same exported Lambertian scene.

Run inside Blender (see bench/bench_cycles_noise.sh):
    blender --background --factory-startup --python bench/bench_cycles_noise.py -- \
        --renderer BUILD/bin/opaline-render [--out DIR] [--res 128] [--threads 2] [--repeats 3]

The scene (a diffuse floor, a diffuse box casting a shadow, a point light and a grey world) is
built in code, exported with the add-on and rendered by both renderers at doubling sample counts.
Each renderer's noise is the RMSE against its own high-sample reference (so a small difference in
mean or filtering does not count as noise). Both renderers reuse the same random numbers for the
first n samples of a pixel whatever the sample count, so an n-sample image is a prefix of the
N-sample reference and the plain RMSE understates the noise by sqrt(1 - n/N) (exact for plain
Monte Carlo); the reported noise divides that out. The time to reach the target (RMSE = 1 % of
the reference mean) is interpolated, in log time against log RMSE, between the two sample counts
that bracket it (extrapolated from the last two when none reaches it). Every render runs
`repeats` times and its median time is used (the images are deterministic). Cycles is timed
around bpy.ops.render.render (scene sync and the EXR write included, Blender start-up
excluded); opaline-render is timed as a process (start-up, scene loading and the PFM write
included)."""

import json
import math
import os
import platform
import statistics
import subprocess
import sys
import time

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [os.path.join(os.path.dirname(HERE), "tests", "addon"),
                os.path.join(os.path.dirname(HERE), "tests")]
import addon_support as S  # noqa: E402
import pfm  # noqa: E402


def args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    out = {"renderer": None, "out": "bench-cycles-noise", "res": 128, "threads": 2, "repeats": 3}
    i = 0
    while i < len(argv):
        key = argv[i].lstrip("-")
        if key not in out or i + 1 >= len(argv):
            sys.exit("bench_cycles_noise: unknown or incomplete option %r" % argv[i])
        try:
            out[key] = argv[i + 1] if key in ("renderer", "out") else int(argv[i + 1])
        except ValueError:
            sys.exit("bench_cycles_noise: %s needs a whole number, not %r" % (argv[i], argv[i + 1]))
        i += 2
    if not out["renderer"] or not os.access(out["renderer"], os.X_OK):
        sys.exit("bench_cycles_noise: --renderer must name a built opaline-render")
    if out["res"] < 8 or out["threads"] < 1 or out["repeats"] < 1:
        sys.exit("bench_cycles_noise: --res must be >= 8, --threads and --repeats >= 1")
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
    """One Cycles CPU render to an OpenEXR file: (seconds inside bpy.ops.render.render, flat RGB
    list bottom row first). Settings as the add-on tests' render_cycles, with our thread count."""
    sc = bpy.context.scene
    sc.render.engine = 'CYCLES'
    sc.cycles.device = 'CPU'
    sc.cycles.samples = spp
    sc.cycles.use_adaptive_sampling = False
    sc.cycles.use_denoising = False
    sc.cycles.seed = 1
    sc.render.threads_mode = 'FIXED'
    sc.render.threads = threads
    sc.render.image_settings.file_format = 'OPEN_EXR'
    sc.render.image_settings.color_depth = '32'
    sc.view_settings.view_transform = 'Standard'
    sc.render.filepath = path
    t0 = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    t = time.perf_counter() - t0
    w, h, a = S.load_image_rgba(path)
    return t, [a[4 * i + c] for i in range(w * h) for c in range(3)]


def opaline(renderer, xml, path, spp, threads):
    """One opaline-render run to a PFM file: (process seconds, flat RGB list bottom row first)."""
    t0 = time.perf_counter()
    subprocess.run([renderer, "-q", "-t", str(threads), "-s", str(spp), "-o", path, xml],
                   check=True, timeout=3600)
    t = time.perf_counter() - t0
    return t, list(pfm.read(path).samples)  # bottom row first, like Blender's pixels


def rmse(a, b):
    return math.sqrt(sum((x - y) ** 2 for x, y in zip(a, b)) / len(a))


def crossing(runs, target):
    """Seconds at which the noise reaches target: log-log interpolation between the runs that
    bracket it (runs sorted by spp, noise falling), else extrapolation from the last two."""
    pts = [(math.log(r["seconds"]), math.log(r["noise"])) for r in runs]
    lt = math.log(target)
    i = next((k for k in range(1, len(pts)) if pts[k][1] <= lt), len(pts) - 1)
    (x0, y0), (x1, y1) = pts[i - 1], pts[i]
    if y1 == y0:
        return runs[i]["seconds"]
    return math.exp(x0 + (lt - y0) * (x1 - x0) / (y1 - y0))


def measure(name, render, ref_spp, levels, repeats):
    """Reference, then each level `repeats` times (median time); noise and time to target."""
    t_ref, ref = render("ref", ref_spp)
    mean = sum(ref) / len(ref)
    target = 0.01 * mean
    runs = []
    for spp in levels:
        times = []
        for _ in range(repeats):
            t, img = render("s%d" % spp, spp)
            times.append(t)
        e = rmse(img, ref)
        noise = e / math.sqrt(1.0 - spp / ref_spp)
        runs.append({"spp": spp, "seconds": statistics.median(times), "times": times,
                     "rmse_vs_reference": e, "noise": noise})
        print("%-8s %5d spp  %7.3f s (median of %d)  noise RMSE %.5f  (target %.5f)"
              % (name, spp, runs[-1]["seconds"], repeats, noise, target), flush=True)
        if noise <= target and len(runs) >= 2:
            break
    reached = runs[-1]["noise"] <= target
    return {"reference_spp": ref_spp, "reference_seconds": t_ref, "mean": mean,
            "target_rmse": target, "runs": runs, "target_reached": reached,
            "seconds_to_target": crossing(runs, target)}


def main():
    a = args()
    os.makedirs(a["out"], exist_ok=True)
    build_scene(a["res"])
    xml = os.path.join(os.path.abspath(a["out"]), "scene.xml")
    S.export(xml, samples=16)
    levels = [4, 8, 16, 32, 64, 128, 256, 512]
    load_before = os.getloadavg()
    print("scene %d x %d, %d threads; load average %.2f %.2f %.2f" %
          ((a["res"], a["res"], a["threads"]) + load_before), flush=True)
    res = {
        "cycles": measure("Cycles", lambda tag, spp: cycles(
            os.path.join(a["out"], "cycles-%s.exr" % tag), spp, a["threads"]), 1024, levels,
            a["repeats"]),
        "opaline": measure("opaline", lambda tag, spp: opaline(
            a["renderer"], xml, os.path.join(a["out"], "opaline-%s.pfm" % tag), spp,
            a["threads"]), 1024, levels, a["repeats"]),
        "blender": bpy.app.version_string, "resolution": a["res"], "threads": a["threads"],
        "repeats": a["repeats"], "cpu_count": os.cpu_count(), "platform": platform.platform(),
        "load_average_before": load_before, "load_average_after": os.getloadavg(),
    }
    tc, to = res["cycles"]["seconds_to_target"], res["opaline"]["seconds_to_target"]
    res["ratio"] = to / tc
    res["verdict"] = "met" if to <= tc else "NOT met"
    with open(os.path.join(a["out"], "cycles_noise.json"), "w") as f:
        json.dump(res, f, indent=1)
    print("means: opaline %.5f, Cycles %.5f (same scene: they should agree)"
          % (res["opaline"]["mean"], res["cycles"]["mean"]), flush=True)
    print("load average after: %.2f %.2f %.2f" % res["load_average_after"], flush=True)
    print("time to RMSE = 1 %% of the mean: opaline %.3f s, Cycles %.3f s, ratio %.2f "
          "(goal: opaline no slower: %s)" % (to, tc, to / tc, res["verdict"]), flush=True)


main()
