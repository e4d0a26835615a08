"""The world: Film > Transparent in F12 (alpha 1 everywhere when off, as Cycles; alpha 0 and
black over the background when on, the world still lighting the scene), Environment Texture
worlds exported as opaline envmaps (XML: the image copied, Strength as scale, the rotation of
Blender's equirectangular convention and of a Mapping node), rendered against Cycles (the
image's mean and its quadrants within a few %, plain and rotated), Sky Textures warned by
name, and DWAB-compressed EXR maps (what Blender's studio lights are) read by the renderer."""

import array
import math
import os
import subprocess
import sys
import unittest
import xml.etree.ElementTree as ET

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_support as S  # noqa: E402

import bpy  # noqa: E402

from opaline.export import world as W  # noqa: E402

RES = 40
SPP = 32


def hdr_image(path, width=128, height=64, codec='ZIP'):
    """Writes a smooth HDR lat-long map to path (OpenEXR, half float, `codec`): a sky
    brighter towards the top, tinted by u, and a broad bright blob at (u, v) = (0.3, 0.3)
    (Blender's u = 0.3 faces between +Y and -X, v = 0.3 from the top is 36 degrees up)."""
    im = bpy.data.images.new("hdr", width, height, float_buffer=True)
    px = array.array('f', bytes(16 * width * height))
    for by in range(height):
        v = 1.0 - (by + 0.5) / height  # from the top
        for x in range(width):
            u = (x + 0.5) / width
            du = min(abs(u - 0.3), 1.0 - abs(u - 0.3))
            blob = 12.0 * math.exp(-(du * du + (v - 0.3) ** 2) / (2 * 0.06 ** 2))
            sky = 0.15 + 0.35 * (1.0 - v)
            i = 4 * (by * width + x)
            px[i:i + 4] = array.array('f', [sky * (0.6 + 0.8 * u) + blob, sky + 0.7 * blob,
                                             sky * (1.4 - 0.8 * u) + 0.4 * blob, 1.0])
    im.pixels.foreach_set(px)
    sc = bpy.context.scene
    st = sc.render.image_settings
    st.file_format, st.color_depth, st.exr_codec = 'OPEN_EXR', '16', codec
    im.save_render(path, scene=sc)
    bpy.data.images.remove(im)
    return path


def env_world(sc, path, strength=1.0, rotation=None):
    """Makes sc's world a Background fed by an Environment Texture of the image at path,
    through Texture Coordinate > Mapping when rotation (XYZ Euler, degrees) is given."""
    nt = sc.world.node_tree
    bg = nt.nodes["Background"]
    bg.inputs["Strength"].default_value = strength
    env = nt.nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.load(path)
    nt.links.new(env.outputs["Color"], bg.inputs["Color"])
    if rotation is not None:
        tc = nt.nodes.new("ShaderNodeTexCoord")
        mp = nt.nodes.new("ShaderNodeMapping")
        mp.inputs["Rotation"].default_value = [math.radians(a) for a in rotation]
        nt.links.new(tc.outputs["Generated"], mp.inputs["Vector"])
        nt.links.new(mp.outputs["Vector"], env.inputs["Vector"])
    return env


def quadrant_means(w, h, rgba):
    """Mean RGB of the four quadrants and of the whole image (RGBA floats, any row order:
    the same for both images compared)."""
    sums = [0.0] * 4
    for y in range(h):
        for x in range(w):
            i = 4 * (y * w + x)
            sums[(2 if y >= h // 2 else 0) + (1 if x >= w // 2 else 0)] += (
                rgba[i] + rgba[i + 1] + rgba[i + 2])
    q = [s / (3 * (w // 2) * (h // 2)) for s in sums]
    return q, sum(q) / 4


class TestFilm(unittest.TestCase):
    """F12 with the real renderer: a diffuse sphere in a blue world."""

    def f12(self, transparent):
        sc = S.empty_scene((24, 16))
        S.prefs().renderer_path = S.need_renderer(self)
        sc.world.node_tree.nodes["Background"].inputs[0].default_value = (0.2, 0.3, 0.5, 1.0)
        S.add_camera((0, -6, 0), (math.pi / 2, 0, 0))
        S.add_mesh("box", [(-0.5, -0.5, -0.5), (0.5, -0.5, -0.5), (0.5, 0.5, -0.5),
                           (-0.5, 0.5, -0.5), (-0.5, -0.5, 0.5), (0.5, -0.5, 0.5),
                           (0.5, 0.5, 0.5), (-0.5, 0.5, 0.5)],
                   [(0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7), (4, 5, 6, 7),
                    (3, 2, 1, 0)], S.diffuse_material("grey", (0.8, 0.8, 0.8)))
        sc.render.engine = 'OPALINE'
        sc.render.film_transparent = transparent
        sc.opaline.samples = 4
        sc.opaline.threads = 1
        st = sc.render.image_settings
        st.file_format, st.color_depth, st.color_mode = 'OPEN_EXR', '32', 'RGBA'
        sc.view_settings.view_transform = 'Standard'
        sc.render.filepath = os.path.join(S.tmpdir("film"), "f12.exr")
        bpy.ops.render.render(write_still=True)
        return S.load_image_rgba(sc.render.filepath)

    def test_film_transparent(self):
        w, h, opaque = self.f12(False)
        _, _, clear = self.f12(True)
        corner = 0  # bottom-left pixel: the world
        centre = 4 * ((h // 2) * w + w // 2)  # the box's front face
        alphas = set(opaque[3::4])
        self.assertEqual(alphas, {1.0}, "Film > Transparent off: alpha %s, not 1 everywhere"
                         % sorted(alphas)[:4])
        # off: the world shows in colour
        self.assertAlmostEqual(opaque[corner + 2], 0.5, places=3)
        # on: the background is transparent and black; the box is opaque and lit the same
        self.assertEqual(tuple(clear[corner:corner + 4]), (0.0, 0.0, 0.0, 0.0))
        self.assertEqual(clear[centre + 3], 1.0)
        self.assertGreater(clear[centre], 0.05)
        for k in range(3):
            self.assertAlmostEqual(clear[centre + k], opaque[centre + k], places=4)


    def test_film_panel_shown(self):
        """Film > Transparent can be set under opaline: Workbench's Film panel (only that
        setting, in every supported Blender) shows."""
        S.empty_scene()
        self.assertIn('OPALINE', bpy.types.RENDER_PT_opengl_film.COMPAT_ENGINES)


class TestEnvExport(unittest.TestCase):
    def setUp(self):
        self.sc = S.empty_scene((16, 16))
        S.add_camera((0, -5, 0), (math.pi / 2, 0, 0))
        self.dir = S.tmpdir("envxml")
        self.hdr = hdr_image(os.path.join(self.dir, "sky ✓.exr"), 16, 8)

    def envmap(self, xml):
        root = ET.parse(xml).getroot()
        ems = [e for e in root.iter("emitter") if e.get("type") == "envmap"]
        self.assertEqual(len(ems), 1)
        props = {c.get("name"): c for c in ems[0]}
        m = [float(v) for v in props["toWorld"].find("matrix").get("value").split()]
        return props, [m[0:3], m[4:7], m[8:11]]

    def test_rotation_strength_file(self):
        env_world(self.sc, self.hdr, strength=2.5, rotation=(0, 0, 90))
        xml = os.path.join(self.dir, "scene.xml")
        res = S.export(xml)
        self.assertEqual(res.warnings, [])
        props, m = self.envmap(xml)
        self.assertAlmostEqual(float(props["scale"].get("value")), 2.5, places=6)
        rel = props["filename"].get("value")
        self.assertTrue(rel.startswith("textures/") and rel.endswith(".exr"), rel)
        with open(os.path.join(self.dir, rel), "rb") as f, open(self.hdr, "rb") as g:
            self.assertEqual(f.read(), g.read())
        # lookup at Rz(90) d; toWorld = Rz(90)^T BLENDER_AXES: map +Z (u = 0) -> world -Y ...
        want = [[0, 0, 1], [1, 0, 0], [0, 1, 0]]
        rz_t = [[0, 1, 0], [-1, 0, 0], [0, 0, 1]]
        want = [[sum(rz_t[r][k] * want[k][c] for k in range(3)) for c in range(3)]
                for r in range(3)]
        for r in range(3):
            for c in range(3):
                self.assertAlmostEqual(m[r][c], want[r][c], places=6)
        self.assertNotIn("visibleToCamera", open(xml).read())
        S.check_xml(self, xml)

    def test_plain_orientation(self):
        """Without a Mapping node, the map's u = 0.5 (opaline: map -Z) faces Blender's +X and
        its top (+Y) Blender's +Z."""
        env_world(self.sc, self.hdr)
        self.sc.render.film_transparent = True
        xml = os.path.join(self.dir, "scene.xml")
        S.export(xml)
        _, m = self.envmap(xml)
        col = lambda k: [m[r][k] for r in range(3)]  # noqa: E731
        self.assertEqual([round(v, 6) for v in col(2)], [1.0, 0.0, 0.0])
        self.assertEqual([round(v, 6) for v in col(1)], [0.0, 0.0, 1.0])
        self.assertEqual([list(r) for r in W.envmap_to_world()], [list(r) for r in m])
        self.assertIn('name="visibleToCamera" value="false"', open(xml).read())

    def test_packed_image(self):
        """A packed map is written from the .blend's copy: the source file may be gone."""
        env = env_world(self.sc, self.hdr)
        env.image.pack()
        with open(self.hdr, "rb") as f:
            original = f.read()
        os.remove(self.hdr)
        xml = os.path.join(self.dir, "packed", "scene.xml")
        self.assertEqual(S.export(xml).warnings, [])
        props, _ = self.envmap(xml)
        with open(os.path.join(self.dir, "packed", props["filename"].get("value")), "rb") as f:
            self.assertEqual(f.read(), original)

    def test_mapping_without_vector_warned(self):
        env_world(self.sc, self.hdr, rotation=(0, 0, 30))
        nt = self.sc.world.node_tree
        mp = [n for n in nt.nodes if n.bl_idname == "ShaderNodeMapping"][0]
        nt.links.remove(mp.inputs["Vector"].links[0])
        res = S.export(os.path.join(self.dir, "scene.xml"))
        self.assertTrue(any("no Vector input" in w for w in res.warnings), res.warnings)

    def test_sky_texture_warned(self):
        nt = self.sc.world.node_tree
        sky = nt.nodes.new("ShaderNodeTexSky")
        sky.name = "My Sky"
        nt.links.new(sky.outputs["Color"], nt.nodes["Background"].inputs["Color"])
        res = S.export(os.path.join(self.dir, "scene.xml"))
        self.assertTrue(any("My Sky" in w and "ShaderNodeTexSky" in w for w in res.warnings),
                        res.warnings)


class TestEnvCycles(unittest.TestCase):
    """A diffuse box under an HDRI (partly seen behind it) by Cycles and by opaline."""

    def compare(self, name, strength=1.0, rotation=None, tol=0.04):
        sc = S.empty_scene((RES, RES))
        d = S.tmpdir("env-" + name)
        hdr = hdr_image(os.path.join(d, "sky.exr"))
        env_world(sc, hdr, strength, rotation)
        S.add_camera((0.0, -7.0, 1.0), (math.radians(85), 0, 0), lens=35)
        S.add_mesh("box", [(-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1), (-1, -1, 1),
                           (1, -1, 1), (1, 1, 1), (-1, 1, 1)],
                   [(0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7), (4, 5, 6, 7),
                    (3, 2, 1, 0)], S.diffuse_material("grey", (0.8, 0.8, 0.8)),
                   location=(0.3, 0, 0.3))
        sc.cycles.max_bounces = 0
        sc.opaline.max_bounces = 0
        xml = os.path.join(d, "scene.xml")
        S.export(xml, samples=SPP)
        S.need_renderer(self)
        cw, ch, cyc = S.load_image_rgba(S.render_cycles(os.path.join(d, "cycles.exr"), SPP))
        out = S.render_cli(self, xml, os.path.join(d, "opaline.exr"), samples=SPP)
        ow, oh, ren = S.load_image_rgba(out)
        self.assertEqual((cw, ch), (ow, oh))
        cq, cm = quadrant_means(cw, ch, cyc)
        oq, om = quadrant_means(ow, oh, ren)
        print("%-8s mean Cycles %.4f opaline %.4f ratio %.4f; quadrants %s" % (
            name, cm, om, om / cm, " ".join("%.3f" % (o / c) for o, c in zip(oq, cq))))
        self.assertLess(S.approx_rel(om, cm), tol)
        for o, c in zip(oq, cq):
            self.assertLess(S.approx_rel(o, c), 2 * tol, "quadrants: opaline %s, Cycles %s"
                            % (oq, cq))
        return om

    def test_plain(self):
        self.compare("plain")

    def test_rotated_strength(self):
        self.compare("rotated", strength=1.7, rotation=(20, -10, 120))


class TestDwab(unittest.TestCase):
    """A DWAB-compressed map renders as its ZIP twin (DWAB is lossy: within 2 %); Blender's own
    studio lights (DWAB) render."""

    def render_env(self, path, d, name):
        sc = S.empty_scene((16, 8))
        env_world(sc, path)
        S.add_camera((0, 0, 0), (math.pi / 2, 0, 0), lens=12)
        xml = os.path.join(d, name + ".xml")
        S.export(xml, samples=1)
        r = S.need_renderer(self)
        out = os.path.join(d, name + ".pfm")
        p = subprocess.run([r, "-q", "-t", "1", "-o", out, xml], stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, timeout=300)
        err = p.stderr.decode(errors="replace")
        if p.returncode != 0 and "image module is missing" in err:
            raise unittest.SkipTest("this build has no OpenImageIO module: %s" % err.strip())
        self.assertEqual(p.returncode, 0, err)
        return S.read_pfm(out)[2]

    def test_dwab_like_zip(self):
        d = S.tmpdir("dwab")
        zipped = self.render_env(hdr_image(os.path.join(d, "zip.exr")), d, "zip")
        dwab_path = hdr_image(os.path.join(d, "dwab.exr"), codec='DWAB')
        with open(dwab_path, "rb") as f:
            self.assertIn(b"compression", f.read(4096))
        dwab = self.render_env(dwab_path, d, "dwab")
        a, b = S.mean_rgb_rows(dwab), S.mean_rgb_rows(zipped)
        print("DWAB mean %.5f, ZIP mean %.5f" % (a, b))
        self.assertGreater(b, 0.1)
        self.assertLess(S.approx_rel(a, b), 0.02)

    def test_studio_light(self):
        folder = bpy.utils.system_resource('DATAFILES', path="studiolights/world")
        exrs = sorted(f for f in os.listdir(folder) if f.endswith(".exr")) if folder else []
        if not exrs:
            raise unittest.SkipTest("this Blender has no studio-light EXRs")
        rows = self.render_env(os.path.join(folder, exrs[0]), S.tmpdir("studio"), "studio")
        self.assertGreater(S.mean_rgb_rows(rows), 0.01)


if __name__ == "__main__":
    S.run_tests(TestFilm, TestEnvExport, TestEnvCycles, TestDwab)
