"""File > Export > opaline scene's options: selected objects only, a frame range (one
XML per frame), samples, and "collect materials" (the material files copied beside the XML and
named relatively, so the exported folder can be moved: checked by opaline-render --check after
moving it and deleting the originals). Run through the operator, as the menu does."""

import os
import shutil
import sys
import unittest
import xml.etree.ElementTree as ET

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_support as S  # noqa: E402

import bpy  # noqa: E402


def shapes(root):
    return [s for s in root.iter("shape") if s.get("type") == "ply"]


def child(el, name):
    for c in el:
        if c.get("name") == name:
            return c
    return None


class Base(unittest.TestCase):
    def setUp(self):
        self.sc = S.empty_scene()
        self.dir = S.tmpdir(self.id().split(".")[-1])
        self.xml = os.path.join(self.dir, "scene.xml")
        S.add_camera((0, 0, 6))
        S.add_light('POINT', (0, 0, 4), energy=100.0)

    def cube(self, name, location):
        bpy.ops.mesh.primitive_cube_add(size=1.0, location=location)
        ob = bpy.context.object
        ob.name = name
        return ob

    def run_export(self, **kw):
        r = bpy.ops.export_scene.opaline(filepath=self.xml, **kw)
        self.assertEqual(r, {'FINISHED'})


class TestOptions(Base):
    def test_has_options(self):
        names = {p.identifier for p in bpy.ops.export_scene.opaline.get_rna_type().properties}
        for n in ("use_selection", "use_frame_range", "frame_start", "frame_end", "samples",
                  "collect_materials"):
            self.assertIn(n, names)

    def test_selection_only(self):
        a = self.cube("keep", (-1, 0, 0))
        b = self.cube("drop", (1, 0, 0))
        for o in bpy.context.view_layer.objects:
            o.select_set(False)
        a.select_set(True)
        self.run_export(use_selection=True)
        root = ET.parse(self.xml).getroot()
        self.assertEqual(len(shapes(root)), 1)
        self.assertIsNotNone(root.find("sensor"))      # the camera always goes
        text = open(self.xml).read()
        self.assertIn("object keep", text)
        self.assertNotIn("object drop", text)
        self.assertIsNone(root.find("emitter"))        # the light is not selected
        self.run_export(use_selection=False)
        self.assertEqual(len(shapes(ET.parse(self.xml).getroot())), 2)
        del b

    def test_samples(self):
        self.cube("c", (0, 0, 0))
        self.sc.opaline.samples = 33
        self.run_export(samples=5)
        sampler = ET.parse(self.xml).getroot().find("sensor").find("sampler")
        self.assertEqual(child(sampler, "sampleCount").get("value"), "5")
        self.run_export(samples=0)      # 0: the scene's setting
        sampler = ET.parse(self.xml).getroot().find("sensor").find("sampler")
        self.assertEqual(child(sampler, "sampleCount").get("value"), "33")

    def test_frame_range(self):
        ob = self.cube("mover", (0, 0, 0))
        for f, x in ((1, 0.0), (3, 2.0)):
            ob.location.x = x
            ob.keyframe_insert("location", frame=f)
        self.sc.frame_set(7)
        self.run_export(use_frame_range=True, frame_start=1, frame_end=3)
        xs = []
        for f in (1, 2, 3):
            path = os.path.join(self.dir, "scene_%04d.xml" % f)
            self.assertTrue(os.path.isfile(path), path)
            (s,) = shapes(ET.parse(path).getroot())
            m = [float(v) for v in child(s, "toWorld").find("matrix").get("value").split()]
            xs.append(m[3])
        self.assertAlmostEqual(xs[0], 0.0, places=5)
        self.assertAlmostEqual(xs[1], 1.0, places=5)
        self.assertAlmostEqual(xs[2], 2.0, places=5)
        self.assertFalse(os.path.exists(self.xml))       # frames only
        self.assertEqual(self.sc.frame_current, 7)       # restored
        self.assertEqual(len(os.listdir(os.path.join(self.dir, "meshes"))), 1)  # shared
        with self.assertRaises(RuntimeError) as cm:
            bpy.ops.export_scene.opaline(filepath=self.xml, use_frame_range=True,
                                         frame_start=3, frame_end=1)
        self.assertIn("frame range 3-1 ends before it starts", str(cm.exception))

    def test_collect_materials_moves(self):
        """The exported folder, moved elsewhere with the material's original deleted, still
        passes opaline-render --check; the file is named relatively, with `$` escaped."""
        S.need_renderer(self)
        src_dir = os.path.dirname(S.need_preset(self, "SVD_S10_Chess4x4"))
        own = os.path.join(self.dir, "own")
        os.makedirs(own)
        opm = os.path.join(own, "my$chess.opm")
        shutil.copyfile(os.path.join(src_dir, "SVD_S10_Chess4x4.opm"), opm)
        mat = bpy.data.materials.new("sss")
        mat.opaline.enabled = True
        mat.opaline.kind = 'FILE'
        mat.opaline.filepath = opm
        ob = self.cube("c", (0, 0, 0))
        ob.data.materials.append(mat)
        bpy.ops.object.mode_set(mode='EDIT')
        bpy.ops.uv.smart_project()
        bpy.ops.object.mode_set(mode='OBJECT')
        # A preset chosen by name is collected too.
        mat2 = bpy.data.materials.new("sss2")
        mat2.opaline.enabled = True
        mat2.opaline.preset = "TUCKER_T15_P7_Chess4x4"
        ob2 = self.cube("c2", (2, 0, 0))
        ob2.data.materials.append(mat2)
        bpy.ops.object.mode_set(mode='EDIT')
        bpy.ops.uv.smart_project()
        bpy.ops.object.mode_set(mode='OBJECT')
        exp = os.path.join(self.dir, "export")
        os.makedirs(exp)
        self.xml = os.path.join(exp, "scene.xml")
        self.run_export(collect_materials=True)
        text = open(self.xml).read()
        self.assertIn('value="materials/my$$chess.opm"', text)
        self.assertIn('value="materials/TUCKER_T15_P7_Chess4x4.opm"', text)
        self.assertNotIn(own, text)
        self.assertNotIn(src_dir, text)
        self.assertTrue(os.path.isfile(os.path.join(exp, "materials", "my$chess.opm")))
        moved = os.path.join(self.dir, "elsewhere")
        shutil.move(exp, moved)
        os.remove(opm)
        env_saved = {k: os.environ.pop(k, None) for k in ("OPALINE_PRESETS_PATH",)}
        try:
            S.check_xml(self, os.path.join(moved, "scene.xml"))
        finally:
            for k, v in env_saved.items():
                if v is not None:
                    os.environ[k] = v
        # Without collecting, the material is named by its (now deleted) absolute path.
        shutil.copyfile(os.path.join(src_dir, "SVD_S10_Chess4x4.opm"), opm)
        self.xml = os.path.join(self.dir, "plain", "scene.xml")
        os.makedirs(os.path.dirname(self.xml))
        self.run_export(collect_materials=False)
        self.assertIn(opm.replace("$", "$$"), open(self.xml).read())


if __name__ == "__main__":
    S.run_tests(TestOptions)
