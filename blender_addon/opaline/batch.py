"""Batch export without the interface: every frame (or a range) of a .blend to opaline XML.

    blender -b FILE.blend --python blender_addon/opaline/batch.py -- --out DIR [--frames A-B]
        [--scene NAME] [--samples N]

Writes DIR/<blend name>_<frame, 4 digits>.xml per frame, with the meshes in DIR/meshes/
(content-addressed: a mesh that does not change between frames is written once, and converted
once: export/meshes.py). Then render each file with `opaline-render DIR/x_0001.xml`. Exit
status: 0 ok, 2 bad arguments or a scene problem (message on stderr), 1 other failures.
"""

import argparse
import os
import sys


def parse_frames(text, scene):
    """(first, last) from 'A-B' or 'A', defaulting to the scene's frame range."""
    if not text:
        return scene.frame_start, scene.frame_end
    try:
        if "-" in text.strip()[1:]:
            i = text.index("-", 1)
            a, b = int(text[:i]), int(text[i + 1:])
        else:
            a = b = int(text)
    except ValueError:
        raise ValueError("--frames must be A-B or A, got %r" % text)
    if b < a:
        raise ValueError("--frames %s: last frame before first" % text)
    return a, b


def main(argv):
    import bpy
    from opaline.errors import OpalineError
    from opaline.export import scene as scene_export
    from opaline import preferences

    ap = argparse.ArgumentParser(prog="blender -b FILE.blend --python batch.py --",
                                 description="Export frames of a .blend to opaline scene XML")
    ap.add_argument("--out", required=True, help="output folder")
    ap.add_argument("--frames", help="A-B or A (default: the scene's frame range)")
    ap.add_argument("--scene", help="scene name (default: the active scene)")
    ap.add_argument("--samples", type=int, help="samples per pixel (default: render settings)")
    args = ap.parse_args(argv)
    scene = bpy.data.scenes.get(args.scene) if args.scene else bpy.context.scene
    if scene is None:
        print("opaline batch: no scene named %r" % args.scene, file=sys.stderr)
        return 2
    try:
        first, last = parse_frames(args.frames, scene)
    except ValueError as e:
        print("opaline batch: %s" % e, file=sys.stderr)
        return 2
    if bpy.context.window is not None:
        bpy.context.window.scene = scene
    base = os.path.splitext(os.path.basename(bpy.data.filepath))[0] or "scene"
    renderer = preferences.find_renderer(bpy.context, required=False)
    os.makedirs(args.out, exist_ok=True)
    for f in range(first, last + 1):
        scene.frame_set(f)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        path = os.path.join(args.out, "%s_%04d.xml" % (base, f))
        try:
            res = scene_export.export_scene(depsgraph, path, bpy.context, renderer,
                                            samples=args.samples)
        except OpalineError as e:
            print("opaline batch: frame %d: %s" % (f, e), file=sys.stderr)
            return 2
        for w in res.warnings:
            print("opaline batch: frame %d: warning: %s" % (f, w), file=sys.stderr)
        print("opaline batch: frame %d -> %s (%d shapes, %d lights, meshes %d written, %d "
              "unchanged, %d of them not converted again)" % (
                  f, path, res.shapes, res.lights, res.meshes_written, res.meshes_reused,
                  res.meshes_unchanged))
    return 0


def _run_as_script():
    here = os.path.dirname(os.path.abspath(__file__))
    sys.path.insert(0, os.path.dirname(here))
    import opaline
    import bpy
    if not hasattr(bpy.types.Material, "opaline"):
        opaline.register()
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    try:
        code = main(argv)
    except SystemExit as e:  # argparse
        code = e.code if isinstance(e.code, int) else 2
    except OSError as e:
        print("opaline batch: %s" % e, file=sys.stderr)
        code = 1
    sys.stdout.flush()
    # Blender ignores a script's exit status unless the script exits itself.
    sys.exit(code)


if __name__ == "__main__":
    _run_as_script()
