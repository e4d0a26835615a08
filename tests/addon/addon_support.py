"""Shared helpers of the add-on tests (run inside `blender --background --factory-startup`).

Makes the add-on importable from the source tree (OPALINE_SOURCE_DIR/blender_addon, else this
checkout), registers it, finds opaline-render (OPALINE_BIN_DIR) and the presets
(OPALINE_PRESETS_DIR), builds small scenes in code, and reads images without NumPy.
"""

import array
import os
import subprocess
import sys
import tempfile
import unittest

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE_DIR = os.environ.get("OPALINE_SOURCE_DIR") or os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(SOURCE_DIR, "blender_addon"))
sys.path.insert(0, os.path.dirname(HERE))

import opaline  # noqa: E402
import pfm  # noqa: E402


def register():
    """Enables the add-on from the source tree the way Blender enables add-ons (so that its
    preferences exist)."""
    import addon_utils
    if bpy.context.preferences.addons.get("opaline") is None:
        addon_utils.enable("opaline", default_set=True, handle_error=None)
    assert hasattr(bpy.types.Material, "opaline"), "add-on failed to register"


def prefs():
    return bpy.context.preferences.addons["opaline"].preferences


def built(name):
    """Path of the built program `name` (OPALINE_BIN_DIR, else this checkout's build/bin), or None
    when it is not there."""
    d = os.environ.get("OPALINE_BIN_DIR") or os.path.join(SOURCE_DIR, "build", "bin")
    path = os.path.join(d, name)
    return path if os.path.isfile(path) and os.access(path, os.X_OK) else None


def renderer():
    """Path of opaline-render, or None when it is not built."""
    return built("opaline-render")


def presets_dir():
    """The build's presets folder, or None when the build makes none (OPALINE_PRESETS_DIR empty:
    OPALINE_BUILD_PRESETS=OFF)."""
    return os.environ.get("OPALINE_PRESETS_DIR") or None


def tmpdir(name):
    base = os.environ.get("OPALINE_TEST_TMP") or tempfile.gettempdir()
    d = tempfile.mkdtemp(prefix="addon-%s-" % name, dir=base)
    return d


def need_built(test, name):
    """Path of the built program `name`; fails the test when it is missing (the build under test
    is broken)."""
    path = built(name)
    if path is None:
        test.fail("%s is not built (OPALINE_BIN_DIR=%s)" % (name,
                                                            os.environ.get("OPALINE_BIN_DIR")))
    return path


def need_renderer(test):
    return need_built(test, "opaline-render")


def need_preset(test, name):
    """Path of the built preset name.opm; skips the test when the build makes no presets, fails
    it when the build made them but not this one."""
    d = presets_dir()
    if d is None:
        raise unittest.SkipTest("the build makes no presets (OPALINE_BUILD_PRESETS=OFF)")
    path = os.path.join(d, name + ".opm")
    if not os.path.isfile(path):
        test.fail("the preset %s is not built in %s" % (name, d))
    return path


def run_tests(*cases):
    """Runs the cases and exits Blender: 1 when a test failed, else 77 (ctest's SKIP_RETURN_CODE)
    when a test was skipped, after printing why, else 0."""
    suite = unittest.TestSuite()
    for c in cases:
        suite.addTests(unittest.defaultTestLoader.loadTestsFromTestCase(c))
    result = unittest.TextTestRunner(verbosity=2, stream=sys.stdout).run(suite)
    if result.wasSuccessful() and result.skipped:
        for test, reason in result.skipped:
            print("skipped: %s: %s" % (test.id(), reason))
    sys.stdout.flush()
    sys.exit(1 if not result.wasSuccessful() else 77 if result.skipped else 0)


# ---------------------------------------------------------------------------------------------
# Scene building.

def empty_scene(res=(64, 64)):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    register()
    sc = bpy.context.scene
    sc.render.resolution_x, sc.render.resolution_y = res
    sc.render.resolution_percentage = 100
    w = bpy.data.worlds.new("World")
    sc.world = w
    w.use_nodes = True
    bg = w.node_tree.nodes["Background"]
    bg.inputs[0].default_value = (0.0, 0.0, 0.0, 1.0)
    return sc


def diffuse_material(name, rgb):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    d = nt.nodes.new("ShaderNodeBsdfDiffuse")
    d.inputs["Color"].default_value = (rgb[0], rgb[1], rgb[2], 1.0)
    o = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(d.outputs[0], o.inputs["Surface"])
    return mat


def set_specular(principled, value):
    """Sets a Principled BSDF's specular amount: 'Specular' before Blender 4.0, 'Specular IOR
    Level' since (both 0.5 by default, 0 for no specular layer)."""
    sock = principled.inputs.get("Specular IOR Level") or principled.inputs["Specular"]
    sock.default_value = value


def add_mesh(name, verts, faces, mat=None, location=(0, 0, 0)):
    me = bpy.data.meshes.new(name)
    me.from_pydata(verts, [], faces)
    me.update()
    ob = bpy.data.objects.new(name, me)
    ob.location = location
    bpy.context.scene.collection.objects.link(ob)
    if mat is not None:
        me.materials.append(mat)
    return ob


def add_floor(size=50.0, rgb=(0.8, 0.8, 0.8)):
    s = size
    return add_mesh("floor", [(-s, -s, 0), (s, -s, 0), (s, s, 0), (-s, s, 0)], [(0, 1, 2, 3)],
                    diffuse_material("floor", rgb))


def add_camera(location, rotation_euler=(0, 0, 0), lens=50.0, sensor_fit='AUTO'):
    cd = bpy.data.cameras.new("cam")
    cd.lens = lens
    cd.sensor_fit = sensor_fit
    ob = bpy.data.objects.new("cam", cd)
    ob.location = location
    ob.rotation_euler = rotation_euler
    bpy.context.scene.collection.objects.link(ob)
    bpy.context.scene.camera = ob
    return ob


def add_light(kind, location=(0, 0, 0), rotation_euler=(0, 0, 0), **props):
    ld = bpy.data.lights.new("L_" + kind.lower(), kind)
    for k, v in props.items():
        setattr(ld, k, v)
    ob = bpy.data.objects.new(ld.name, ld)
    ob.location = location
    ob.rotation_euler = rotation_euler
    bpy.context.scene.collection.objects.link(ob)
    return ob


def export(path, samples=None):
    from opaline.export import scene as se
    bpy.context.view_layer.update()
    dg = bpy.context.evaluated_depsgraph_get()
    return se.export_scene(dg, path, bpy.context, renderer(), samples=samples)


def check_xml(test, path):
    """Runs opaline-render --check on path; fails the test with its messages when invalid."""
    r = need_renderer(test)
    p = subprocess.run([r, "--check", path], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       timeout=120)
    test.assertEqual(p.returncode, 0, "opaline-render --check %s failed:\n%s%s" % (
        path, p.stdout.decode(errors="replace"), p.stderr.decode(errors="replace")))


def render_cli(test, xml, out, samples=None, threads=2, extra=()):
    r = need_renderer(test)
    cmd = [r, "-t", str(threads), "-q", "-o", out] + list(extra)
    if samples is not None:
        cmd += ["-s", str(samples)]
    cmd.append(xml)
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=600)
    test.assertEqual(p.returncode, 0, "opaline-render failed:\n%s" %
                     p.stderr.decode(errors="replace"))
    return out


# ---------------------------------------------------------------------------------------------
# Images without NumPy.

def read_pfm(path):
    """(width, height, list of rows top to bottom, each a flat list of RGB floats) of a PFM file
    (tests/pfm.py reads it)."""
    im = pfm.read(path)
    rows = [list(row) if im.channels == 3 else [v for v in row for _ in range(3)]
            for row in reversed(im.rows())]
    return im.width, im.height, rows


def load_image_rgba(path):
    """(width, height, array('f') RGBA bottom row first) through Blender's image loader."""
    im = bpy.data.images.load(path, check_existing=False)
    try:
        w, h = im.size
        a = array.array('f', bytes(4 * len(im.pixels)))
        im.pixels.foreach_get(a)
        return w, h, a
    finally:
        bpy.data.images.remove(im)


def mean_rgb_rgba(a):
    n = len(a) // 4
    s = 0.0
    for i in range(n):
        s += a[4 * i] + a[4 * i + 1] + a[4 * i + 2]
    return s / (3 * n)


def mean_rgb_rows(rows):
    s = 0.0
    n = 0
    for row in rows:
        s += sum(row)
        n += len(row)
    return s / n


def render_cycles(path, samples=16):
    """Renders the current scene with Cycles on the CPU into an OpenEXR file at path."""
    sc = bpy.context.scene
    sc.render.engine = 'CYCLES'
    sc.cycles.device = 'CPU'
    sc.cycles.samples = samples
    sc.cycles.use_adaptive_sampling = False
    sc.cycles.use_denoising = False
    sc.cycles.seed = 1
    sc.render.threads_mode = 'FIXED'
    sc.render.threads = 2
    sc.render.image_settings.file_format = 'OPEN_EXR'
    sc.render.image_settings.color_depth = '32'
    sc.view_settings.view_transform = 'Standard'
    sc.render.filepath = path
    bpy.ops.render.render(write_still=True)
    return path


def look_down(height):
    """A camera rotation and location looking straight down -Z from `height`."""
    return (0.0, 0.0, height), (0.0, 0.0, 0.0)


def approx_rel(a, b):
    return abs(a - b) / max(abs(b), 1e-12)


# ---------------------------------------------------------------------------------------------
# Reading exported XML.

def floats(s):
    """The numbers of an XML value ("1, 2 3")."""
    return [float(x) for x in s.replace(",", " ").split()]


def prop(el, tag, name):
    """el's child <tag name=name>, or None."""
    for c in el:
        if c.tag == tag and c.get("name") == name:
            return c
    return None


def value(el, tag, name):
    """The value of el's child <tag name=name> (numbers for rgb and float), asserting it exists."""
    p = prop(el, tag, name)
    assert p is not None, "no <%s name=%s> in <%s %s>" % (tag, name, el.tag, el.attrib)
    return floats(p.get("value")) if tag in ("rgb", "float") else p.get("value")


def mesh_shape_bsdf(root):
    """(shape, bsdf) of the one mesh (ply) shape of exported scene root: its bsdf, nested or
    referenced, inside any twosided; bsdf None when it has none."""
    (s,) = [s for s in root.iter("shape") if s.get("type") == "ply"]
    ref = s.find("ref")
    if ref is not None:
        (b,) = [b for b in root.findall("bsdf") if b.get("id") == ref.get("id")]
    else:
        b = s.find("bsdf")
    if b is not None and b.get("type") == "twosided":
        b = b.find("bsdf")
    return s, b
