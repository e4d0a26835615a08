"""bench_addon_export.py - the add-on's mesh export of a scene of about FACES faces (default
2,000,000), run by Blender headless:

    blender -b --factory-startup --python bench/bench_addon_export.py -- [--addon DIR]
        [--faces N] [--repeat R]

DIR is the `blender_addon` folder of the add-on to time (default: this checkout's). The scene
(made by bulk access, in seconds): a flat-shaded wavy grid (45 % of the faces), a smooth one
(45 %), both with a UV seam, and a smooth Suzanne under a Subdivision Surface modifier (the
rest, at most level 4; modifiers applied). Prints the median
over R runs (default 3) of export_scene into an empty folder, and, where the add-on skips
unchanged meshes, of the export of the same frame again into that folder: wall-clock and CPU
seconds (the CPU time of Blender's process, all threads: the figure to compare on a loaded
machine)."""

import argparse
import math
import os
import shutil
import statistics
import sys
import tempfile
import time

import bpy


def grid(name, n, smooth, location):
    """An n x n quad grid 4 m wide whose height is a wave (normals that vary), with a UV map
    split in two islands along its middle (a UV seam), smooth or flat; made by bulk access."""
    import numpy as np
    t = np.linspace(-2.0, 2.0, n + 1)
    x, y = np.meshgrid(t, t)
    co = np.stack([x, y, 0.1 * np.sin(3 * x) * np.cos(2 * y)], -1).astype(np.float32)
    i = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).ravel()
    quads = np.stack([i, i + 1, i + n + 2, i + n + 1], -1).astype(np.int32)
    me = bpy.data.meshes.new(name)
    me.vertices.add((n + 1) * (n + 1))
    me.vertices.foreach_set("co", co.ravel())
    me.loops.add(quads.size)
    me.loops.foreach_set("vertex_index", quads.ravel())
    me.polygons.add(len(quads))
    me.polygons.foreach_set("loop_start", np.arange(0, quads.size, 4, dtype=np.int32))
    if bpy.app.version < (4, 0, 0):
        me.polygons.foreach_set("loop_total", np.full(len(quads), 4, np.int32))
    me.update(calc_edges=True)
    me.polygons.foreach_set("use_smooth", np.full(len(quads), smooth, bool))
    flat = co.reshape(-1, 3)[quads.ravel()]
    uv = (flat[:, :2] + 2.0) / 8.0
    uv[np.repeat(flat.reshape(-1, 4, 3)[:, :, 0].mean(axis=1) > 0.0, 4), 0] += 0.5
    me.uv_layers.new(name="UVMap").data.foreach_set("uv", uv.astype(np.float32).ravel())
    me.update()
    ob = bpy.data.objects.new(name, me)
    ob.location = location
    bpy.context.scene.collection.objects.link(ob)
    return ob


def build(faces):
    """The scene: a flat grid (45 % of the faces), a smooth grid (45 %) and a smooth Suzanne
    under a Subdivision Surface modifier (the rest); returns its face count after modifiers."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    n = max(2, int(math.sqrt(0.45 * faces)))
    grid("flat", n, False, (-2.5, 0, 0))
    grid("smooth", n, True, (2.5, 0, 0))
    bpy.ops.mesh.primitive_monkey_add(location=(0, 0, 1))
    bpy.ops.object.shade_smooth()
    level = max(0, min(4, round(math.log(max(1.0, 0.1 * faces / 500.0), 4))))
    mod = bpy.context.object.modifiers.new("subdivision", 'SUBSURF')
    mod.levels = mod.render_levels = level
    cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    cam.location = (0, -8, 3)
    bpy.context.scene.collection.objects.link(cam)
    bpy.context.scene.camera = cam
    dg = bpy.context.evaluated_depsgraph_get()
    return sum(len(ob.evaluated_get(dg).data.polygons) for ob in bpy.context.scene.objects
               if ob.type == 'MESH')


def main(argv):
    ap = argparse.ArgumentParser(prog="bench_addon_export.py")
    ap.add_argument("--addon", default=os.path.join(os.path.dirname(os.path.dirname(
        os.path.abspath(__file__))), "blender_addon"))
    ap.add_argument("--faces", type=int, default=2000000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    sys.path.insert(0, os.path.abspath(args.addon))
    from opaline.export import scene as se
    faces = build(args.faces)
    base = tempfile.mkdtemp(prefix="bench-addon-export-")
    skips = hasattr(se.ExportResult(), "meshes_unchanged")
    fresh, again = [], []  # (wall s, CPU s) of each run
    try:
        for r in range(args.repeat):
            xml = os.path.join(base, "run%d" % r, "scene.xml")
            os.makedirs(os.path.dirname(xml))
            dg = bpy.context.evaluated_depsgraph_get()
            fresh.append(timed(lambda: se.export_scene(dg, xml, bpy.context)))
            line = "run %d: %.2f s (CPU %.2f s)" % (r + 1, fresh[-1][0], fresh[-1][1])
            if skips:
                again.append(timed(lambda: se.export_scene(dg, xml, bpy.context)))
                line += ", again %.2f s (CPU %.2f s)" % again[-1]
            print("bench_addon_export: " + line, flush=True)
    finally:
        shutil.rmtree(base, ignore_errors=True)
    line = "export %.2f s (CPU %.2f s)" % median(fresh)
    if skips:
        line += ", the unchanged frame again %.2f s (CPU %.2f s)" % median(again)
    print("bench_addon_export: %s, Blender %s, %d faces: %s (medians of %d)" % (
        args.addon, bpy.app.version_string, faces, line, args.repeat), flush=True)


def timed(fn):
    """(wall seconds, CPU seconds of this process) of fn()."""
    w, c = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - w, time.process_time() - c


def median(runs):
    return statistics.median(r[0] for r in runs), statistics.median(r[1] for r in runs)

if __name__ == "__main__":
    code = 0
    try:
        main(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [])
    except SystemExit as e:
        code = e.code if isinstance(e.code, int) else 2
    sys.exit(code)
