"""F12 with the real opaline-render keeps the subsurface pre-pass cache in its session folder
(--sss-cache): a second F12 with only the camera moved reuses it (its log says what was reused
and no irradiance is computed again), and one with a changed light recomputes it. Skipped when
opaline-render is not built."""

import os
import re
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_support as S  # noqa: E402

import bpy  # noqa: E402

from opaline import engine as E  # noqa: E402


class TestSssCache(unittest.TestCase):
    def setUp(self):
        self.sc = S.empty_scene((24, 16))
        self.dir = S.tmpdir("engine_sss_cache")
        self.cam = S.add_camera((0, -4, 1.5), rotation_euler=(1.3, 0, 0))
        S.add_floor(5.0)
        self.sun = S.add_light('SUN', energy=2.0)
        self.sc.render.engine = 'OPALINE'
        self.sc.render.image_settings.file_format = 'OPEN_EXR'
        self.sc.cycles.samples = 1
        self.sc.opaline.threads = 2
        mat = bpy.data.materials.new("skin")
        mat.opaline.enabled = True
        mat.opaline.kind = 'DIPOLE'
        mat.opaline.dipole_material = "Skin1"
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.7, location=(0, 0, 0.7))
        bpy.context.active_object.data.materials.append(mat)
        self.sc.opaline.max_sss_points = 3000

    def render(self, name):
        self.sc.render.filepath = os.path.join(self.dir, name)
        bpy.ops.render.render(write_still=True)
        return [t for lv, t in E.last_log if "pre-pass cache" in t]

    def test_moved_camera_reuses(self):
        S.prefs().renderer_path = S.need_renderer(self)
        first = self.render("one.exr")
        cache = os.path.join(os.path.dirname(E.last_export.xml_path), E.SSS_CACHE_NAME)
        self.assertTrue(os.path.getsize(cache) > 64, first)
        written = [re.search(r"written \((\d+) new sources", t) for t in first]
        computed = [int(m.group(1)) for m in written if m]
        self.assertEqual(len(computed), 1, first)
        self.cam.location.x += 0.4
        second = self.render("two.exr")
        reused = [re.search(r"reused (\d+) sources / (\d+) receivers, computed (\d+) new "
                            r"\((\d+) sources", t) for t in second]
        reused = [m for m in reused if m]
        self.assertEqual(len(reused), 1, second)
        self.assertGreater(int(reused[0].group(1)), 0, second)  # sources of the first view
        self.assertGreater(int(reused[0].group(2)), 0, second)  # receivers of the first view
        # irradiance only at points the first view did not compute (the shape has 3000)
        self.assertLessEqual(int(reused[0].group(4)), 3000 - computed[0], second)
        self.assertFalse(any("key differs" in t for t in second), second)
        self.sun.data.energy = 3.0
        third = self.render("three.exr")
        self.assertTrue(any("key differs" in t for t in third), third)


if __name__ == "__main__":
    S.run_tests(TestSssCache)
