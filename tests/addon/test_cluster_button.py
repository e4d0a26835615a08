"""Render on Cluster (Render panel, cluster.py): exports the frames with the materials collected
beside them, runs the real opaline-cluster submit against a fake sbatch (OPALINE_SBATCH: records
its arguments, prints a job id) and reports the job id; the partition and extra sbatch arguments
reach sbatch; a missing command is an error naming it. Without a cluster in the preferences the
panel still offers rendering here in the background (submit --local with the opaline-cluster
beside the renderer): the frame's image appears and Cluster Status reports it done. The real
cluster is tested by tests/e2e/test_cluster.sh."""

import glob
import os
import subprocess
import sys
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_support as S  # noqa: E402

import bpy  # noqa: E402


class TestClusterButton(unittest.TestCase):
    def setUp(self):
        S.need_renderer(self)
        self.cluster = S.need_built(self, "opaline-cluster")
        S.need_preset(self, "SVD_S10_Chess4x4")
        self.dir = S.tmpdir("cluster")
        sc = S.empty_scene((16, 12))
        sc.render.engine = 'OPALINE'
        S.add_camera((0, -6, 1), rotation_euler=(1.4, 0, 0))
        S.add_light('POINT', (0, -2, 3))
        bpy.ops.mesh.primitive_cube_add()
        ob = bpy.context.object
        mat = bpy.data.materials.new("jade")
        mat.opaline.enabled = True
        mat.opaline.preset = "SVD_S10_Chess4x4"
        ob.data.materials.append(mat)
        bpy.ops.object.mode_set(mode='EDIT')
        bpy.ops.uv.smart_project()
        bpy.ops.object.mode_set(mode='OBJECT')
        sc.frame_start, sc.frame_end = 1, 2
        self.log = os.path.join(self.dir, "sbatch.log")
        fake = os.path.join(self.dir, "fake-sbatch")
        with open(fake, "w") as f:
            f.write('#!/bin/sh\necho "$@" >> "%s"\necho 4242\n' % self.log)
        os.chmod(fake, 0o755)
        os.environ["OPALINE_SBATCH"] = fake

    def tearDown(self):
        os.environ.pop("OPALINE_SBATCH", None)

    def test_submit(self):
        from opaline import cluster
        p = S.prefs()
        p.cluster_command = self.cluster
        p.cluster_partition = "render"
        p.cluster_sbatch_args = "--account=lab --time=1:00:00"
        self.assertTrue(cluster.OPALINE_PT_render_cluster.poll(bpy.context))
        out = os.path.join(self.dir, "shot")
        r = bpy.ops.render.opaline_cluster(animation=True, folder=out, tiles=2, threads=1)
        self.assertEqual(r, {'FINISHED'})
        self.assertEqual(bpy.context.window_manager["opaline_cluster_job"], "4242")
        xmls = sorted(glob.glob(os.path.join(out, "scenes", "*.xml")))
        self.assertEqual([os.path.basename(x) for x in xmls], ["scene_0001.xml", "scene_0002.xml"])
        text = open(xmls[0]).read()
        self.assertIn('value="materials/SVD_S10_Chess4x4.opm"', text)
        self.assertNotIn(S.presets_dir(), text)
        self.assertTrue(os.path.isfile(os.path.join(out, "scenes", "materials",
                                                    "SVD_S10_Chess4x4.opm")))
        calls = open(self.log).read().splitlines()
        render = [c for c in calls if "--job-name opaline-render" in c]
        self.assertEqual(len(render), 1, calls)
        for want in ("--array 0,1,2,3", "--cpus-per-task 1", "--partition render",
                     "--account=lab", "--time=1:00:00"):
            self.assertIn(want, render[0])
        self.assertTrue(any("--job-name opaline-merge" in c and "--dependency afterok:4242" in c
                            for c in calls), calls)
        self.assertTrue(os.path.isfile(os.path.join(out, "opaline-cluster.json")))

    def test_local(self):
        from opaline import cluster
        p = S.prefs()
        p.cluster_command = ""
        if cluster.local_program(bpy.context) != self.cluster:
            self.skipTest("opaline-cluster is not beside the renderer the add-on finds")
        self.assertTrue(cluster.OPALINE_PT_render_cluster.poll(bpy.context))
        out = os.path.join(self.dir, "here")
        open(self.log, "w").close()
        r = bpy.ops.render.opaline_cluster(animation=False, folder=out, threads=1, local=True)
        self.assertEqual(r, {'FINISHED'})
        image = os.path.join(out, "scene_0001.exr")
        deadline = time.time() + 240
        while not os.path.isfile(image) and time.time() < deadline:
            time.sleep(0.5)
        log = os.path.join(out, "opaline-cluster-local.log")
        self.assertTrue(os.path.isfile(image), open(log).read() if os.path.exists(log) else "")
        self.assertEqual(open(self.log).read(), "", "sbatch was called for a local render")
        deadline = time.time() + 60
        while True:
            sp = subprocess.run([self.cluster, "status", out], stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, text=True)
            if "done" in sp.stdout or time.time() > deadline:
                break
            time.sleep(0.5)
        self.assertIn("done", sp.stdout)
        self.assertEqual(bpy.ops.render.opaline_cluster_status(), {'FINISHED'})

    def test_missing_command(self):
        p = S.prefs()
        p.cluster_command = os.path.join(self.dir, "no-such-opaline-cluster")
        with self.assertRaises(RuntimeError) as cm:
            bpy.ops.render.opaline_cluster(folder=os.path.join(self.dir, "x"))
        self.assertIn("no-such-opaline-cluster", str(cm.exception))


if __name__ == "__main__":
    S.run_tests(TestClusterButton)
