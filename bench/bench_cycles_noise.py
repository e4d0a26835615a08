"""Time to equal error: opaline-render against Cycles on the same exported scenes.

Run inside Blender (see bench/bench_cycles_noise.sh):
    blender --background --factory-startup --python bench/bench_cycles_noise.py -- \
        --renderer BUILD/bin/opaline-render [--out DIR] [--res 128] [--threads 2] [--repeats 3]
        [--scene lambert|mixed|cbox|manylights|all]

Each scene is built in code, exported with the add-on, and rendered by both renderers at
doubling sample counts:
  lambert     a diffuse floor and box, a point light, a grey world (both renderers' models agree);
  mixed       an artist's mixed scene: a glass sphere, a translucent object (opaline: a measured
              preset; Cycles: its Principled subsurface), an opaque floor, a point and an area
              light, a grey world;
  cbox        a Cornell box lit by an emissive ceiling patch, with a glass sphere and a
              translucent box (as in mixed);
  manylights  an interior lit by 64 small emissive quads on the ceiling (many-light sampling).
Each renderer's noise is the RMSE against its own high-sample reference (so a small difference in
mean or model does not count as noise); the two references are also compared with each other
(where their models are the same, as in lambert, they must agree). Both renderers reuse the same
random numbers for the first n samples of a pixel whatever the sample count, so an n-sample image
is a prefix of the N-sample reference and the plain RMSE understates the noise by sqrt(1 - n/N)
(exact for plain Monte Carlo); the reported noise divides that out. Fireflies: the 99.9th
percentile of the pixels' absolute errors (the largest 0.1 %), reported at each count. The time
to reach a target (RMSE = 1 % of the reference mean; 99.9th percentile error = 10 % of it) is
interpolated, in log time against log error, between the two sample counts that bracket it
(extrapolated from the last two when none reaches it). The renderers alternate, one render each
at a sample count, `repeats` times, and the median wall time is used (the images are
deterministic); CPU time (all threads) is reported beside it. Cycles is timed around
bpy.ops.render.render (scene sync and the EXR write included, Blender start-up excluded);
opaline-render as a process (start-up, scene loading, the subsurface pre-pass and the PFM write
included)."""

import json
import math
import os
import platform
import resource
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
    out = {"renderer": None, "out": "bench-cycles-noise", "res": 128, "threads": 2, "repeats": 3,
           "scene": "lambert"}
    i = 0
    while i < len(argv):
        key = argv[i].lstrip("-")
        if key not in out or i + 1 >= len(argv):
            sys.exit("bench_cycles_noise: unknown or incomplete option %r" % argv[i])
        try:
            out[key] = argv[i + 1] if key in ("renderer", "out", "scene") else int(argv[i + 1])
        except ValueError:
            sys.exit("bench_cycles_noise: %s needs a whole number, not %r" % (argv[i], argv[i + 1]))
        i += 2
    if not out["renderer"] or not os.access(out["renderer"], os.X_OK):
        sys.exit("bench_cycles_noise: --renderer must name a built opaline-render")
    if out["scene"] != "all" and out["scene"] not in SCENES:
        sys.exit("bench_cycles_noise: --scene must be one of %s or all" % ", ".join(SCENES))
    if out["res"] < 8 or out["threads"] < 1 or out["repeats"] < 1:
        sys.exit("bench_cycles_noise: --res must be >= 8, --threads and --repeats >= 1")
    return out


def _box(name, centre, half, mat):
    """An axis-aligned box mesh of half-extents `half` at `centre`, faces outward."""
    (cx, cy, cz), (hx, hy, hz) = centre, half
    verts = [(cx + x * hx, cy + y * hy, cz + z * hz) for z in (-1, 1) for y in (-1, 1)
             for x in (-1, 1)]
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    return S.add_mesh(name, verts, faces, mat)


def _glass(name):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    g = nt.nodes.new("ShaderNodeBsdfGlass")
    g.inputs["IOR"].default_value = 1.5
    g.inputs["Roughness"].default_value = 0.0
    o = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(g.outputs[0], o.inputs["Surface"])
    return mat


def _emissive(name, strength):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    e = nt.nodes.new("ShaderNodeEmission")
    e.inputs["Strength"].default_value = strength
    o = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(e.outputs[0], o.inputs["Surface"])
    return mat


PRESET = "TUCKER_T16_P4_Jade"


def _translucent(name):
    """A material that opaline renders with the measured preset PRESET and Cycles with its
    Principled BSDF's random-walk subsurface of a similar colour and radius (not the same model:
    each renderer's error is against its own reference)."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    p = mat.node_tree.nodes.get("Principled BSDF")
    p.inputs["Base Color"].default_value = (0.55, 0.75, 0.55, 1.0)
    sub = p.inputs.get("Subsurface Weight") or p.inputs.get("Subsurface")
    sub.default_value = 1.0
    p.inputs["Subsurface Radius"].default_value = (0.01, 0.02, 0.01)
    mat.opaline.enabled = True
    mat.opaline.preset = PRESET
    return mat


def scene_lambert(res):
    sc = S.empty_scene((res, res))
    sc.world.node_tree.nodes["Background"].inputs[0].default_value = (0.2, 0.2, 0.2, 1.0)
    S.add_floor(size=20.0)
    s = 0.5
    verts = [(x, y, z) for z in (0, 2 * s) for y in (-s, s) for x in (-s, s)]
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    S.add_mesh("box", verts, faces, S.diffuse_material("box", (0.6, 0.5, 0.4)))
    S.add_light('POINT', (1.5, -1.0, 3.0), energy=300.0, shadow_soft_size=0.0)
    S.add_camera((0.0, -5.0, 4.0), (math.radians(50), 0.0, 0.0), lens=35.0)
    return sc


def scene_mixed(res):
    sc = S.empty_scene((res, res * 3 // 4))
    sc.world.node_tree.nodes["Background"].inputs[0].default_value = (0.15, 0.15, 0.15, 1.0)
    S.add_floor(size=20.0, rgb=(0.7, 0.7, 0.7))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.5, location=(-0.7, 0.0, 0.5), segments=64,
                                         ring_count=32)
    bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(_glass("glass"))
    ob = _box("translucent", (0.7, 0.2, 0.4), (0.4, 0.4, 0.4), _translucent("jade"))
    ob.data.uv_layers.new(name="UVMap")
    S.add_light('POINT', (2.0, -2.0, 3.0), energy=400.0, shadow_soft_size=0.0)
    S.add_light('AREA', (-2.0, -1.0, 3.0), (math.radians(30), math.radians(-30), 0.0),
                energy=200.0, size=1.0)
    S.add_camera((0.0, -5.0, 2.5), (math.radians(68), 0.0, 0.0), lens=40.0)
    return sc


def scene_cbox(res):
    sc = S.empty_scene((res, res))
    white, red, green = ((0.73, 0.73, 0.73), (0.63, 0.065, 0.05), (0.14, 0.45, 0.091))
    walls = [("floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], white),
             ("ceiling", [(-1, -1, 2), (-1, 1, 2), (1, 1, 2), (1, -1, 2)], white),
             ("back", [(-1, 1, 0), (1, 1, 0), (1, 1, 2), (-1, 1, 2)], white),
             ("left", [(-1, -1, 0), (-1, 1, 0), (-1, 1, 2), (-1, -1, 2)], red),
             ("right", [(1, -1, 0), (1, -1, 2), (1, 1, 2), (1, 1, 0)], green)]
    for name, verts, rgb in walls:
        S.add_mesh(name, verts, [(0, 1, 2, 3)], S.diffuse_material(name, rgb))
    S.add_mesh("lamp", [(-0.25, -0.25, 1.999), (-0.25, 0.25, 1.999), (0.25, 0.25, 1.999),
                        (0.25, -0.25, 1.999)], [(0, 1, 2, 3)], _emissive("lamp", 15.0))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.35, location=(-0.4, 0.1, 0.35), segments=64,
                                         ring_count=32)
    bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(_glass("glass"))
    ob = _box("translucent", (0.4, 0.3, 0.4), (0.3, 0.3, 0.4), _translucent("jade"))
    ob.data.uv_layers.new(name="UVMap")
    S.add_camera((0.0, -3.9, 1.0), (math.radians(90), 0.0, 0.0), lens=35.0)
    return sc


def scene_manylights(res):
    sc = S.empty_scene((res, res * 3 // 4))
    grey = (0.6, 0.6, 0.6)
    S.add_mesh("floor", [(-4, -4, 0), (4, -4, 0), (4, 4, 0), (-4, 4, 0)], [(0, 1, 2, 3)],
               S.diffuse_material("floor", grey))
    S.add_mesh("ceiling", [(-4, -4, 2.5), (-4, 4, 2.5), (4, 4, 2.5), (4, -4, 2.5)],
               [(0, 1, 2, 3)], S.diffuse_material("ceiling", grey))
    S.add_mesh("back", [(-4, 4, 0), (4, 4, 0), (4, 4, 2.5), (-4, 4, 2.5)], [(0, 1, 2, 3)],
               S.diffuse_material("back", (0.5, 0.4, 0.3)))
    for k in range(4):  # pillars
        _box("pillar%d" % k, (-3 + 2 * k, 1.0, 1.25), (0.2, 0.2, 1.25),
             S.diffuse_material("pillar%d" % k, (0.4, 0.5, 0.6)))
    lamp = _emissive("lamp", 40.0)
    for i in range(8):
        for j in range(8):
            x, y, h = -3.5 + i, -3.5 + j, 0.05
            S.add_mesh("lamp%d_%d" % (i, j), [(x - h, y - h, 2.49), (x - h, y + h, 2.49),
                                              (x + h, y + h, 2.49), (x + h, y - h, 2.49)],
                       [(0, 1, 2, 3)], lamp)
    S.add_camera((0.0, -3.8, 1.2), (math.radians(88), 0.0, 0.0), lens=24.0)
    return sc


SCENES = {"lambert": scene_lambert, "mixed": scene_mixed, "cbox": scene_cbox,
          "manylights": scene_manylights}


def build_scene(name, res):
    sc = SCENES[name](res)
    sc.cycles.max_bounces = 8
    sc.cycles.diffuse_bounces = 8
    sc.cycles.glossy_bounces = 8
    sc.cycles.transmission_bounces = 8
    sc.cycles.caustics_reflective = True
    sc.cycles.caustics_refractive = True
    sc.cycles.sample_clamp_direct = 0.0
    sc.cycles.sample_clamp_indirect = 0.0
    sc.opaline.max_bounces = 8
    if name == "lambert":  # the scene of the first measurements
        sc.cycles.max_bounces = sc.cycles.diffuse_bounces = 4
        sc.opaline.max_bounces = 4
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
    c0, t0 = time.process_time(), time.perf_counter()
    bpy.ops.render.render(write_still=True)
    t, cpu = time.perf_counter() - t0, time.process_time() - c0
    w, h, a = S.load_image_rgba(path)
    return t, cpu, [a[4 * i + c] for i in range(w * h) for c in range(3)]


def opaline(renderer, xml, path, spp, threads):
    """One opaline-render run to a PFM file: (process seconds, CPU seconds, flat RGB list bottom
    row first)."""
    r0, t0 = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
    subprocess.run([renderer, "-q", "-t", str(threads), "-s", str(spp), "-o", path, xml],
                   check=True, timeout=3600)
    t, r1 = time.perf_counter() - t0, resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return t, cpu, list(pfm.read(path).samples)  # bottom row first, like Blender's pixels


def rmse(a, b):
    return math.sqrt(sum((x - y) ** 2 for x, y in zip(a, b)) / len(a))


def p999(a, b):
    """The 99.9th percentile of the pixels' absolute errors (mean over the channels)."""
    errs = sorted(sum(abs(a[3 * i + c] - b[3 * i + c]) for c in range(3)) / 3.0
                  for i in range(len(a) // 3))
    return errs[min(len(errs) - 1, int(0.999 * len(errs)))]


def crossing(runs, key, target):
    """Seconds at which runs' `key` error reaches target: log-log interpolation between the runs
    that bracket it (runs sorted by spp, error falling), else extrapolation from the last two."""
    pts = [(math.log(r["seconds"]), math.log(max(r[key], 1e-30))) for r in runs]
    lt = math.log(target)
    i = next((k for k in range(1, len(pts)) if pts[k][1] <= lt), len(pts) - 1)
    (x0, y0), (x1, y1) = pts[i - 1], pts[i]
    if y1 == y0:
        return runs[i]["seconds"]
    return math.exp(x0 + (lt - y0) * (x1 - x0) / (y1 - y0))


def measure(renderers, ref_spp, levels, repeats):
    """Each renderer's reference, then at each level every renderer in turn, `repeats` times
    (median time); noise, fireflies and the times to their targets, per renderer."""
    out = {}
    for name, render in renderers.items():
        t, cpu, ref = render("ref", ref_spp)
        mean = sum(ref) / len(ref)
        out[name] = {"reference_spp": ref_spp, "reference_seconds": t, "mean": mean,
                     "target_rmse": 0.01 * mean, "target_p999": 0.1 * mean, "runs": [],
                     "ref": ref}
    for spp in levels:
        for name, render in renderers.items():
            o = out[name]
            if o["runs"] and o["runs"][-1]["noise"] <= o["target_rmse"] and len(o["runs"]) >= 2:
                continue
            times, cpus = [], []
            for _ in range(repeats):
                t, cpu, img = render("s%d" % spp, spp)
                times.append(t)
                cpus.append(cpu)
            e = rmse(img, o["ref"])
            noise = e / math.sqrt(1.0 - spp / ref_spp)
            fire = p999(img, o["ref"])
            o["runs"].append({"spp": spp, "seconds": statistics.median(times), "times": times,
                              "cpu_seconds": statistics.median(cpus), "rmse_vs_reference": e,
                              "noise": noise, "p999": fire})
            print("%-8s %5d spp  %7.3f s (median of %d; CPU %.3f s)  noise RMSE %.5f  (target "
                  "%.5f)  p99.9 error %.4f" % (name, spp, o["runs"][-1]["seconds"], repeats,
                                               o["runs"][-1]["cpu_seconds"], noise,
                                               o["target_rmse"], fire), flush=True)
    for o in out.values():
        o["target_reached"] = o["runs"][-1]["noise"] <= o["target_rmse"]
        o["seconds_to_target"] = crossing(o["runs"], "noise", o["target_rmse"])
        o["seconds_to_p999_target"] = crossing(o["runs"], "p999", o["target_p999"])
    return out


def run_scene(a, name):
    out = os.path.join(os.path.abspath(a["out"]), name)
    os.makedirs(out, exist_ok=True)
    build_scene(name, a["res"])
    xml = os.path.join(out, "scene.xml")
    S.export(xml, samples=16)
    levels = [4, 8, 16, 32, 64, 128, 256, 512]
    load_before = os.getloadavg()
    res_x, res_y = bpy.context.scene.render.resolution_x, bpy.context.scene.render.resolution_y
    print("scene %s, %d x %d, %d threads; load average %.2f %.2f %.2f" %
          ((name, res_x, res_y, a["threads"]) + load_before), flush=True)
    m = measure({
        "Cycles": lambda tag, spp: cycles(os.path.join(out, "cycles-%s.exr" % tag), spp,
                                          a["threads"]),
        "opaline": lambda tag, spp: opaline(a["renderer"], xml,
                                            os.path.join(out, "opaline-%s.pfm" % tag), spp,
                                            a["threads"])}, 1024, levels, a["repeats"])
    ref_c, ref_o = m["Cycles"].pop("ref"), m["opaline"].pop("ref")
    cross = rmse(ref_o, ref_c) / m["Cycles"]["mean"]
    res = {"scene": name, "cycles": m["Cycles"], "opaline": m["opaline"],
           "references_relative_rmse": cross,
           "blender": bpy.app.version_string, "resolution": [res_x, res_y],
           "threads": a["threads"], "repeats": a["repeats"], "cpu_count": os.cpu_count(),
           "platform": platform.platform(), "load_average_before": load_before,
           "load_average_after": os.getloadavg()}
    tc, to = res["cycles"]["seconds_to_target"], res["opaline"]["seconds_to_target"]
    res["ratio"] = to / tc
    res["verdict"] = "met" if to <= tc else "NOT met"
    with open(os.path.join(out, "cycles_noise.json"), "w") as f:
        json.dump(res, f, indent=1)
    print("%s: means opaline %.5f, Cycles %.5f; the references differ by a relative RMSE of "
          "%.3f (the same models agree; translucent shapes use different ones)"
          % (name, res["opaline"]["mean"], res["cycles"]["mean"], cross), flush=True)
    print("%s: load average after: %.2f %.2f %.2f" % ((name,) + res["load_average_after"]),
          flush=True)
    print("%s: time to RMSE = 1 %% of the mean: opaline %.3f s, Cycles %.3f s, ratio %.2f "
          "(goal: opaline no slower: %s); to p99.9 error = 10 %%: opaline %.3f s, Cycles %.3f s"
          % (name, to, tc, to / tc, res["verdict"], res["opaline"]["seconds_to_p999_target"],
             res["cycles"]["seconds_to_p999_target"]), flush=True)
    return res


def main():
    a = args()
    os.makedirs(a["out"], exist_ok=True)
    names = list(SCENES) if a["scene"] == "all" else [a["scene"]]
    results = [run_scene(a, n) for n in names]
    print("\n| scene | opaline s to 1 % | Cycles s to 1 % | ratio | opaline s to p99.9 10 % | "
          "Cycles s to p99.9 10 % | references' relative RMSE |")
    print("|---|---|---|---|---|---|---|")
    for r in results:
        print("| %s | %.3f | %.3f | %.2f | %.3f | %.3f | %.3f |" % (
            r["scene"], r["opaline"]["seconds_to_target"], r["cycles"]["seconds_to_target"],
            r["ratio"], r["opaline"]["seconds_to_p999_target"],
            r["cycles"]["seconds_to_p999_target"], r["references_relative_rmse"]), flush=True)


main()
