"""The surface reflection ("Surface sheen") of translucent materials: exported beside the
<subsurface> from the Principled BSDF's Specular / Roughness (a GGX roughdielectric), from the
material settings (On: dielectric when smooth), or not at all (Off, no specular, no Principled);
the export passes opaline-render --check, and the render shows the light's highlight that the
plain one lacks (skipped without opaline-render)."""

import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_support as S  # noqa: E402
from addon_support import prop  # noqa: E402

import bpy  # noqa: E402



class TestSheen(unittest.TestCase):
    def setUp(self):
        self.sc = S.empty_scene((64, 64))
        self.dir = S.tmpdir("sheen")
        S.add_camera((0, -4, 0.7), rotation_euler=(1.5708, 0, 0))
        # a small bright area light behind the camera (out of view), facing the sphere: its
        # mirror image lies on the sphere
        S.add_light('AREA', location=(0, -5.5, 1.5), rotation_euler=(1.43, 0, 0), energy=30.0,
                    size=1.2)
        self.sc.opaline.max_sss_points = 5000
        self.sc.opaline.irr_samples = 4
        mat = bpy.data.materials.new("marble")
        mat.use_nodes = True
        o = mat.opaline
        o.enabled = True
        o.kind = 'DIPOLE'
        o.dipole_material = "Marble"
        o.ior = 1.5
        o.scale = 20.0  # a 4 cm kernel pixel: about 4000 points on the sphere
        self.mat = mat
        self.principled = mat.node_tree.nodes["Principled BSDF"]
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.7, location=(0, 0, 0.7), segments=64,
                                             ring_count=32)
        bpy.ops.object.shade_smooth()  # facets would each mirror their own direction
        bpy.context.active_object.data.materials.append(mat)

    def export(self, name):
        from xml.etree import ElementTree as ET
        path = os.path.join(self.dir, name, "scene.xml")
        S.export(path, samples=4)
        root = ET.parse(path).getroot()
        (shape,) = [s for s in root.iter("shape") if s.find("subsurface") is not None]
        return path, shape.find("bsdf")

    def test_export(self):
        self.principled.inputs["Roughness"].default_value = 0.5
        self.principled.inputs["IOR"].default_value = 1.5  # Blender 4.x: F0 from IOR x level
        S.set_specular(self.principled, 0.5)  # F0 = 0.04: IOR 1.5
        _, b = self.export("principled")
        self.assertIsNotNone(b)
        self.assertEqual(b.get("type"), "roughdielectric")
        self.assertAlmostEqual(float(prop(b, "float", "alpha").get("value")), 0.25, places=5)
        self.assertAlmostEqual(float(prop(b, "float", "intIOR").get("value")), 1.5, places=3)
        S.set_specular(self.principled, 0.0)
        _, b = self.export("nospecular")
        self.assertIsNone(b)
        self.mat.opaline.sheen = 'ON'
        self.mat.opaline.sheen_roughness = 0.0
        self.mat.opaline.sheen_ior = 1.6
        _, b = self.export("on")
        self.assertEqual(b.get("type"), "dielectric")
        self.assertAlmostEqual(float(prop(b, "float", "intIOR").get("value")), 1.6, places=5)
        self.mat.opaline.sheen = 'OFF'
        S.set_specular(self.principled, 0.5)
        _, b = self.export("off")
        self.assertIsNone(b)

    def render(self, name):
        path, b = self.export(name)
        S.check_xml(self, path)
        out = S.render_cli(self, path, os.path.join(self.dir, name + ".pfm"))
        w, h, rows = S.read_pfm(out)
        lum = [row[i] + row[i + 1] + row[i + 2] for row in rows for i in range(0, len(row), 3)]
        for v in lum:
            self.assertTrue(v == v and abs(v) < 1e30)
        return b, lum

    def test_render_highlight(self):
        S.need_renderer(self)
        self.mat.opaline.sheen = 'ON'
        self.mat.opaline.sheen_roughness = 0.1
        b, lit = self.render("sheen")
        self.assertEqual(b.get("type"), "roughdielectric")
        self.mat.opaline.sheen = 'OFF'
        b, plain = self.render("plain")
        self.assertIsNone(b)
        # the light's reflection: pixels of the sphere (plain) much brighter with the sheen
        top = max(plain)
        self.assertGreater(top, 0.0)
        ratio = max(a / p for a, p in zip(lit, plain) if p > 0.2 * top)
        print("brightest pixel: with the sheen %.3f, without %.3f; largest ratio %.2f" % (
            max(lit), top, ratio))
        self.assertGreater(ratio, 1.5)


if __name__ == "__main__":
    S.run_tests(TestSheen)
