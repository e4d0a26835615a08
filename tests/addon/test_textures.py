"""Image textures: a Diffuse or Principled BSDF whose colour is linked to an Image Texture node
exports a bitmap texture, its image copied (an 8-bit PNG, from disk or packed) or saved from
Blender's pixels (a generated image) into textures/ beside the XML, with the node's
extension, interpolation, colour space and a Mapping node's scale and offset mapped; opaline-
render --check accepts the result; and a textured plane lit by a sun, rendered by Cycles and by
opaline, agrees quadrant by quadrant (an asymmetric 2 x 2 image: catches a flipped axis)."""

import math
import os
import sys
import unittest
import xml.etree.ElementTree as ET

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_support as S  # noqa: E402

import bpy  # noqa: E402

from opaline.export import textures as T  # noqa: E402

RES = 48
# Texel bytes, rows from the image's TOP: top-left, top-right / bottom-left, bottom-right.
TEXELS = [[(200, 40, 40), (40, 200, 40)], [(40, 40, 200), (128, 128, 128)]]


def srgb_to_linear(b):
    v = b / 255.0
    return v / 12.92 if v <= 0.04045 else ((v + 0.055) / 1.055) ** 2.4


def gradient(n):
    """An n x n image of gentle ramps: red across, green down, blue constant (neighbours differ
    little, so where a filter interpolates, before or after sRGB decoding, hardly matters)."""
    return [[(40 + 180 * i // (n - 1), 40 + 180 * j // (n - 1), 100) for i in range(n)]
            for j in range(n)]


def make_image(name, path=None, pack=False, colorspace=None, texels=TEXELS):
    """The image of texels (rows from the top; default the 2 x 2 TEXELS): generated in memory,
    or saved as PNG at path and loaded (then packed when pack is set). The colour space is set
    first: changing it regenerates a generated image."""
    n = len(texels)
    img = bpy.data.images.new(name, n, n, alpha=False)
    if colorspace:
        img.colorspace_settings.name = colorspace
    px = []
    for row in range(n - 1, -1, -1):  # Blender stores the bottom row first
        for col in range(n):
            px.extend([c / 255.0 for c in texels[row][col]] + [1.0])
    img.pixels = px
    if path is None:
        return img
    img.filepath_raw = path
    img.file_format = 'PNG'
    img.save()
    bpy.data.images.remove(img)
    img = bpy.data.images.load(path)
    if pack:
        img.pack()
    return img


def textured_plane(img, principled=False, extension='REPEAT', interpolation='Closest',
                   colorspace=None, mapping=None):
    """A 2 x 2 plane at z = 0 with UVs [0, 1]^2 and a material whose colour is img."""
    mat = bpy.data.materials.new("tex")
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    if principled:
        b = nt.nodes.new("ShaderNodeBsdfPrincipled")
        S.set_specular(b, 0.0)
        sock = b.inputs["Base Color"]
    else:
        b = nt.nodes.new("ShaderNodeBsdfDiffuse")
        sock = b.inputs["Color"]
    o = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(b.outputs[0], o.inputs["Surface"])
    t = nt.nodes.new("ShaderNodeTexImage")
    t.image = img
    t.extension = extension
    t.interpolation = interpolation
    if colorspace:
        img.colorspace_settings.name = colorspace
    nt.links.new(t.outputs["Color"], sock)
    if mapping is not None:
        m = nt.nodes.new("ShaderNodeMapping")
        m.inputs["Location"].default_value = mapping[0]
        m.inputs["Scale"].default_value = mapping[1]
        tc = nt.nodes.new("ShaderNodeTexCoord")
        nt.links.new(tc.outputs["UV"], m.inputs["Vector"])
        nt.links.new(m.outputs["Vector"], t.inputs["Vector"])
    ob = S.add_mesh("plane", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [(0, 1, 2, 3)],
                    mat)
    me = ob.data
    uv = me.uv_layers.new(name="UVMap")
    for loop in me.loops:
        x, y = me.vertices[loop.vertex_index].co[:2]
        uv.data[loop.index].uv = ((x + 1) / 2, (y + 1) / 2)
    return ob


def texture_el(root):
    texs = list(root.iter("texture"))
    assert len(texs) == 1, "expected one texture, got %d" % len(texs)
    return texs[0]


def props(el):
    return {c.get("name"): c.get("value") for c in el if c.get("name")}


class TestTextureExport(unittest.TestCase):
    def setUp(self):
        self.sc = S.empty_scene((RES, RES))
        S.add_camera((0.0, 0.0, 4.0))
        S.add_light('SUN', (0, 0, 5), energy=3.0, angle=0.0)
        self.dir = S.tmpdir(self.id().split(".")[-1])
        self.xml = os.path.join(self.dir, "scene.xml")

    def export(self):
        self.res = S.export(self.xml, samples=4)
        return ET.parse(self.xml).getroot()

    def test_png_file_copied(self):
        src = os.path.join(self.dir, "src dir", "my image.png")
        os.makedirs(os.path.dirname(src))
        textured_plane(make_image("quad", src))
        root = self.export()
        tex = texture_el(root)
        p = props(tex)
        self.assertEqual(tex.get("type"), "bitmap")
        self.assertEqual(tex.get("name"), "reflectance")
        self.assertTrue(p["filename"].startswith("textures/my_image-"), p["filename"])
        with open(src, "rb") as a, open(os.path.join(self.dir, p["filename"]), "rb") as b:
            self.assertEqual(a.read(), b.read())
        self.assertEqual(p["wrapMode"], "repeat")
        self.assertEqual(p["filterType"], "nearest")
        self.assertEqual(float(p["gamma"]), -1.0)
        self.assertEqual(self.res.textures_written, 1)
        self.assertEqual(self.res.warnings, [])
        S.check_xml(self, self.xml)
        # a second export reuses the file
        self.export()
        self.assertEqual((self.res.textures_written, self.res.textures_reused), (0, 1))

    def test_packed_and_generated(self):
        src = os.path.join(self.dir, "packed.png")
        img = make_image("packed", src, pack=True)
        os.unlink(src)  # only the packed copy remains
        self.assertIsNotNone(img.packed_file)
        textured_plane(img, principled=True)
        tex = texture_el(self.export())
        self.assertEqual(tex.get("name"), "reflectance")  # Specular 0: a diffuse
        p = props(tex)
        with open(os.path.join(self.dir, p["filename"]), "rb") as f:
            self.assertEqual(f.read()[:8], T.PNG_MAGIC)
        S.check_xml(self, self.xml)
        # a generated image (never saved) is written from its pixels as an 8-bit PNG
        self.sc = S.empty_scene((RES, RES))
        S.add_camera((0.0, 0.0, 4.0))
        textured_plane(make_image("gen", colorspace="Non-Color"), extension='EXTEND',
                       interpolation='Linear')
        tex = texture_el(self.export())
        p = props(tex)
        self.assertEqual(p["wrapMode"], "clamp")
        self.assertNotIn("filterType", p)
        self.assertEqual(float(p["gamma"]), 1.0)
        out = os.path.join(self.dir, p["filename"])
        back = bpy.data.images.load(out)
        got = list(back.pixels)
        want = []
        for row in (1, 0):
            for col in (0, 1):
                want.extend([c / 255.0 for c in TEXELS[row][col]] + [1.0])
        for a, b in zip(got, want):
            self.assertAlmostEqual(a, b, places=5)
        S.check_xml(self, self.xml)

    def test_modes_and_mapping(self):
        textured_plane(make_image("m"), extension='CLIP', interpolation='Cubic',
                       mapping=((0.25, 0.5, 0.0), (2.0, 3.0, 1.0)))
        root = self.export()
        p = props(texture_el(root))
        self.assertEqual(p["wrapMode"], "zero")
        self.assertAlmostEqual(float(p["uscale"]), 2.0)
        self.assertAlmostEqual(float(p["vscale"]), 3.0)
        self.assertAlmostEqual(float(p["uoffset"]), 0.25)
        self.assertAlmostEqual(float(p["voffset"]), 1.0 - 3.0 - 0.5)
        self.assertTrue(any("cubic" in w for w in self.res.warnings), self.res.warnings)
        # the principled of a Principled BSDF takes it as baseColor
        self.sc = S.empty_scene((RES, RES))
        S.add_camera((0.0, 0.0, 4.0))
        ob = textured_plane(make_image("r"), principled=True)
        S.set_specular(ob.data.materials[0].node_tree.nodes["Principled BSDF"], 0.5)
        root = self.export()
        self.assertEqual(texture_el(root).get("name"), "baseColor")
        S.check_xml(self, self.xml)

    def test_not_an_image_texture(self):
        mat = S.diffuse_material("n", (0.3, 0.3, 0.3))
        nt = mat.node_tree
        noise = nt.nodes.new("ShaderNodeTexNoise")
        nt.links.new(noise.outputs["Color"], nt.nodes["Diffuse BSDF"].inputs["Color"])
        S.add_mesh("p", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [(0, 1, 2, 3)], mat)
        root = self.export()
        self.assertEqual(list(root.iter("texture")), [])
        self.assertTrue(any("ShaderNodeTexNoise" in w for w in self.res.warnings),
                        self.res.warnings)

    def quadrants(self, rows_top_first, w, h):
        """Mean RGB of four windows, one inside each quadrant of the plane (world x, y in
        +-[0.2, 0.8]); keys (row from the top, column)."""
        t = math.tan(math.atan(18.0 / 50.0))  # lens 50, sensor 36: half-width / distance
        out = {}
        for qr, ys in ((0, (0.2, 0.8)), (1, (-0.8, -0.2))):
            for qc, xs in ((0, (-0.8, -0.2)), (1, (0.2, 0.8))):
                acc, n = [0.0, 0.0, 0.0], 0
                for j in range(h):
                    y = (1 - 2 * (j + 0.5) / h) * 4.0 * t
                    if not ys[0] < y < ys[1]:
                        continue
                    for i in range(w):
                        x = (2 * (i + 0.5) / w - 1) * 4.0 * t
                        if xs[0] < x < xs[1]:
                            for c in range(3):
                                acc[c] += rows_top_first[j][3 * i + c]
                            n += 1
                out[(qr, qc)] = [a / n for a in acc]
        return out

    def test_cycles_match(self):
        self.cycles_match('Closest')

    def test_cycles_match_linear(self):
        self.cycles_match('Linear')

    def cycles_match(self, interpolation):
        """Closest: the 2 x 2 image, each window its texel, as computed. Linear: a 16 x 16
        gradient, clamped, compared with Cycles' bilinear lookups (Cycles interpolates 8-bit
        sRGB texels before decoding them, Mitsuba and opaline after: the same on gentle
        gradients, darker in Cycles between strongly different texels)."""
        S.need_renderer(self)
        self.sc.cycles.max_bounces = 0
        self.sc.opaline.max_bounces = 0
        src = os.path.join(self.dir, "quad.png")
        linear = interpolation == 'Linear'
        textured_plane(make_image("quad", src, texels=gradient(16) if linear else TEXELS),
                       interpolation=interpolation, extension='EXTEND' if linear else 'REPEAT')
        self.export()
        w, h, a = S.load_image_rgba(S.render_cycles(os.path.join(self.dir, "cycles.exr"),
                                                    samples=16))
        cyc_rows = [[a[4 * ((h - 1 - j) * w + i) + c] for i in range(w) for c in range(3)]
                    for j in range(h)]
        out = S.render_cli(self, self.xml, os.path.join(self.dir, "opaline.pfm"), samples=16)
        ow, oh, ren_rows = S.read_pfm(out)
        cq = self.quadrants(cyc_rows, w, h)
        oq = self.quadrants(ren_rows, ow, oh)
        for k in sorted(cq):
            texel = [srgb_to_linear(b) for b in TEXELS[k[0]][k[1]]]
            # sun of irradiance 3 straight down: radiance = albedo * 3 / pi
            expect = [3.0 / math.pi * v for v in texel]
            print("%s quadrant %s: Cycles %s  opaline %s%s" % (
                interpolation, k, ["%.4f" % v for v in cq[k]], ["%.4f" % v for v in oq[k]],
                "" if linear else "  expected %s" % ["%.4f" % v for v in expect]))
            for c in range(3):
                if interpolation == 'Closest':
                    self.assertLess(S.approx_rel(cq[k][c], expect[c]), 0.02)
                self.assertLess(S.approx_rel(oq[k][c], cq[k][c]), 0.02,
                                "quadrant %s channel %d: opaline %.5f vs Cycles %.5f"
                                % (k, c, oq[k][c], cq[k][c]))


if __name__ == "__main__":
    S.run_tests(TestTextureExport)
