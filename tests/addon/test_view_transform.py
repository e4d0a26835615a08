"""One colour pipeline: the PNG that opaline-render writes from an export matches the PNG Blender
saves from its own render of the scene, through the scene's colour management (display device,
view transform, look, exposure, gamma) and Blender's own OpenColorIO config, which the export
records on the film (export/colour.py).

A world of one colour seen by every pixel, rendered by Cycles (1 sample, no dither) and saved as
an 8-bit PNG, then exported and rendered by opaline-render as PNG: every pixel's channels within
1 of 255. Cases: Filmic (Blender 3.x) or AgX (4.x and later) with a look and exposure +1.2,
and Standard with a negative exposure and a gamma; each also differs from the plain sRGB value by
more than 5 of 255, so that the comparison could fail."""

import os
import sys
import unittest
import xml.etree.ElementTree as ET

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_support as S  # noqa: E402

import bpy  # noqa: E402

RES = (8, 6)
LOOKS = ("AgX - Punchy", "Punchy", "Filmic - Medium High Contrast", "Medium High Contrast")


def srgb_byte(v):
    v = min(max(v, 0.0), 1.0)
    e = 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055
    return round(255 * e)


def bytes_of(path):
    """The RGB values (0..255) of every pixel of an 8-bit image file."""
    w, h, a = S.load_image_rgba(path)
    return [round(255 * a[4 * i + c]) for i in range(w * h) for c in range(3)]


class TestViewTransform(unittest.TestCase):
    def setUp(self):
        self.dir = S.tmpdir("view_transform")

    def compare(self, name, rgb, view, exposure, gamma, look):
        sc = S.empty_scene(res=RES)
        S.add_camera((0.0, 0.0, 5.0))
        bg = sc.world.node_tree.nodes["Background"]
        bg.inputs[0].default_value = (rgb[0], rgb[1], rgb[2], 1.0)
        bg.inputs[1].default_value = 1.0
        vs = sc.view_settings
        vs.view_transform = view
        vs.exposure = exposure
        vs.gamma = gamma
        chosen = "None"
        for candidate in LOOKS if look else ():
            try:
                vs.look = candidate
                chosen = candidate
                break
            except TypeError:
                pass
        sc.render.dither_intensity = 0.0
        sc.render.film_transparent = False

        xml = os.path.join(self.dir, name + ".xml")
        S.export(xml, samples=1)
        film = ET.parse(xml).getroot().find("sensor/film")
        params = {p.get("name"): p.get("value") for p in film}
        self.assertEqual(params.get("viewTransform"), view)
        self.assertEqual(params.get("viewDisplay"), sc.display_settings.display_device)
        self.assertTrue(os.path.isfile(params.get("viewConfig", "")), params)
        self.assertEqual(params.get("viewLook", "None"), chosen)

        sc.render.engine = 'CYCLES'
        sc.cycles.device = 'CPU'
        sc.cycles.samples = 1
        sc.cycles.use_denoising = False
        sc.render.threads_mode = 'FIXED'
        sc.render.threads = 2
        sc.render.image_settings.file_format = 'PNG'
        sc.render.image_settings.color_mode = 'RGB'
        sc.render.image_settings.color_depth = '8'
        sc.render.filepath = os.path.join(self.dir, name + "_blender.png")
        bpy.ops.render.render(write_still=True)
        blender = bytes_of(sc.render.filepath)

        S.need_renderer(self)
        ours = bytes_of(S.render_cli(self, xml, os.path.join(self.dir, name + "_opaline.png"),
                                     samples=1))
        diff = [max(abs(ours[i] - blender[i]) for i in range(c, len(ours), 3)) for c in range(3)]
        plain = [srgb_byte(v) for v in rgb]
        print("%s (%s, look %s, exposure %g, gamma %g): Blender %s, opaline %s, plain sRGB %s; "
              "largest difference per channel %s" % (name, view, chosen, exposure, gamma,
                                                     blender[:3], ours[:3], plain, diff))
        self.assertEqual(len(ours), len(blender))
        self.assertLessEqual(max(diff), 1, "opaline %s vs Blender %s" % (ours[:3], blender[:3]))
        self.assertGreater(max(abs(blender[c] - plain[c]) for c in range(3)), 5,
                           "the case does not tell the view transform from plain sRGB")

    def test_filmic_or_agx_look_exposure(self):
        try:
            bpy.context.scene.view_settings.view_transform = "AgX"
            view = "AgX"
        except TypeError:  # before Blender 4.0
            view = "Filmic"
        self.compare("tonemapped", (0.5, 0.1, 0.02), view, 1.2, 1.0, look=True)

    def test_standard_exposure_gamma(self):
        self.compare("standard", (0.5, 0.12, 0.3), "Standard", -0.6, 1.4, look=False)


if __name__ == "__main__":
    S.run_tests(TestViewTransform)
