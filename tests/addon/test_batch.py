"""The batch command line: blender -b FILE.blend --python blender_addon/opaline/batch.py --
--out DIR [--frames A-B] exports each frame without the interface; an unchanged mesh is
written once; bad arguments exit with status 2 and a message."""

import glob
import os
import subprocess
import sys
import unittest
import xml.etree.ElementTree as ET

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_support as S  # noqa: E402

import bpy  # noqa: E402

BATCH = os.path.join(S.SOURCE_DIR, "blender_addon", "opaline", "batch.py")


class TestBatch(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = S.tmpdir("batch")
        sc = S.empty_scene((32, 24))
        S.add_camera((0, -6, 2))
        S.add_light('POINT', (0, 0, 3))
        bpy.ops.mesh.primitive_cube_add()
        ob = bpy.context.object
        sc.frame_start, sc.frame_end = 1, 4
        for f, x in ((1, 0.0), (4, 3.0)):
            ob.location.x = x
            ob.keyframe_insert("location", frame=f)
        cls.blend = os.path.join(cls.dir, "anim.blend")
        bpy.ops.wm.save_as_mainfile(filepath=cls.blend)

    def run_batch(self, *args):
        cmd = [bpy.app.binary_path, "-b", "--factory-startup", self.blend, "--python", BATCH,
               "--"] + list(args)
        env = dict(os.environ)
        return subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env,
                              timeout=300)

    def test_range(self):
        out = os.path.join(self.dir, "range")
        p = self.run_batch("--out", out, "--frames", "2-3")
        self.assertEqual(p.returncode, 0, p.stderr.decode(errors="replace"))
        xmls = sorted(os.path.basename(x) for x in glob.glob(os.path.join(out, "*.xml")))
        self.assertEqual(xmls, ["anim_0002.xml", "anim_0003.xml"])
        self.assertEqual(len(glob.glob(os.path.join(out, "meshes", "*.ply"))), 1)
        xs = []
        for x in xmls:
            root = ET.parse(os.path.join(out, x)).getroot()
            (s,) = [s for s in root.findall("shape") if s.get("type") == "ply"]
            m = [float(v) for v in s.find("transform").find("matrix").get("value").split()]
            xs.append(m[3])
        self.assertLess(xs[0], xs[1])
        S.check_xml(self, os.path.join(out, xmls[0]))

    def test_all_frames(self):
        out = os.path.join(self.dir, "all")
        p = self.run_batch("--out", out)
        self.assertEqual(p.returncode, 0, p.stderr.decode(errors="replace"))
        self.assertEqual(len(glob.glob(os.path.join(out, "*.xml"))), 4)
        self.assertIn(b"meshes 0 written, 1 unchanged", p.stdout)

    def test_bad_arguments(self):
        p = self.run_batch("--out", os.path.join(self.dir, "bad"), "--frames", "5-2")
        self.assertEqual(p.returncode, 2)
        self.assertIn(b"last frame before first", p.stderr)
        p = self.run_batch("--frames", "1")
        self.assertEqual(p.returncode, 2)
        self.assertIn(b"--out", p.stderr)


if __name__ == "__main__":
    S.run_tests(TestBatch)
