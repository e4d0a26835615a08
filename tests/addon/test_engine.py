"""The "opaline" render engine (the tile stream's reader has its plain-Python test,
unit_stream.py): progress texts, F12 through a scripted stand-in that
speaks the tile stream protocol (tiles placed right, progress, errors reported readably), and
F12 with the real opaline-render compared pixel by pixel with its command-line render of the
same export (skipped when opaline-render is not built)."""

import os
import stat
import sys
import textwrap
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_support as S  # noqa: E402

import bpy  # noqa: E402

from opaline import engine as E  # noqa: E402
from opaline.stream import Progress, StreamReader  # noqa: E402


class TestProgress(unittest.TestCase):
    def test_progress_text(self):
        p = E.Progress(True, 64, 12)
        total, text = p.stage("irradiance", 0.4)
        self.assertEqual(text, "Subsurface pre-pass: irradiance 40 %")
        self.assertAlmostEqual(total, 0.20)
        t2, text = p.stage("subsurface", 0.5)
        self.assertEqual(text, "Subsurface pre-pass: scattering 50 %")
        p.tiles_done = 3
        t3, text = p.stage("render", 0.25)
        self.assertEqual(text, "Path tracing 25 %, 3/12 tiles, 64 samples")
        self.assertTrue(total < t2 < t3 < 1.0)

    def test_flip_rows(self):
        a = [float(v) for v in range(16)]  # 2x2 RGBA, top row first
        self.assertEqual(list(E.flip_rows(a, 2, 2)), a[8:] + a[:8])


FAKE = textwrap.dedent('''\
    #!/usr/bin/env python3
    # A stand-in for opaline-render that speaks the tile stream (for the engine test only):
    # it reads the film size from the exported XML and streams a known gradient in 4 tiles.
    import re, struct, sys
    args = sys.argv[1:]
    open(sys.argv[0] + ".args", "w").write("\\n".join(args))
    xml = open(args[-1]).read()
    if "FAIL" in open(args[-1]).read() or "--fail" in args:
        sys.stderr.write("scene.xml:12: <shape>: something is wrong\\n")
        sys.exit(2)
    w = int(re.search(r'name="width" value="(\\d+)"', xml).group(1))
    h = int(re.search(r'name="height" value="(\\d+)"', xml).group(1))
    out = sys.stdout.buffer
    def rec(t, p):
        out.write(struct.pack("<4sIQ", b"OPTS", t, len(p)) + p)
    if "BADSCENE" in xml:
        rec(5, struct.pack("<I", 0) + b"scene.xml:7: <bsdf>: a long message that says all")
        sys.exit(2)
    if "WARN" in xml:
        rec(5, struct.pack("<I", 1) + b"scene.xml:3: unused parameter 'intIOR'")
    if "--crop" in args:
        w, h = [int(v) for v in args[args.index("--crop") + 1].split(",")][2:]
    rec(1, struct.pack("<4I", w, h, 4, 8))
    tiles = [(0, 0, w // 2, h // 2), (w // 2, 0, w - w // 2, h // 2),
             (0, h // 2, w // 2, h - h // 2), (w // 2, h // 2, w - w // 2, h - h // 2)]
    for i, (x, y, tw, th) in enumerate(tiles):
        v = []
        for r in range(th):
            for c in range(tw):
                v += [(x + c) / w, (y + r) / h, 0.25, 1.0]
        rec(2, struct.pack("<4I", x, y, tw, th) + struct.pack("<%df" % len(v), *v))
        rec(3, struct.pack("<dI", (i + 1) / 4.0, 6) + b"render")
    rec(4, struct.pack("<I", 0))
''')


class TestEngine(unittest.TestCase):
    def setUp(self):
        self.sc = S.empty_scene((16, 8))
        self.dir = S.tmpdir("engine")
        S.add_camera((0, 0, 5))
        S.add_floor(5.0)
        S.add_light('SUN', energy=2.0)
        self.sc.render.engine = 'OPALINE'
        self.sc.render.image_settings.file_format = 'OPEN_EXR'
        self.sc.render.image_settings.color_depth = '32'
        self.sc.view_settings.view_transform = 'Standard'

    def fake(self):
        path = os.path.join(self.dir, "fake-opaline-render")
        with open(path, "w") as f:
            f.write(FAKE)
        os.chmod(path, os.stat(path).st_mode | stat.S_IXUSR)
        S.prefs().renderer_path = path
        return path

    def render(self, name):
        self.sc.render.filepath = os.path.join(self.dir, name)
        bpy.ops.render.render(write_still=True)
        return S.load_image_rgba(self.sc.render.filepath)

    def test_tiles_placed(self):
        self.fake()
        w, h, a = self.render("fake.exr")
        self.assertEqual((w, h), (16, 8))
        for by in range(h):
            for x in range(w):
                y = h - 1 - by  # Blender's rows go up; the stream's go down
                px = a[4 * (by * w + x):4 * (by * w + x) + 4]
                self.assertAlmostEqual(px[0], x / w, places=5)
                self.assertAlmostEqual(px[1], y / h, places=5)
                self.assertAlmostEqual(px[2], 0.25, places=5)
        # the tiles counted in the stream's tile size (BEGIN: 8, so 2 x 1 tiles), not 32
        self.assertTrue(E.last_status[0].startswith("opaline: Path tracing 100 %, 2/2 tiles"),
                        E.last_status)

    def test_point_cap_one_way(self):
        """The Irradiance Point Cap reaches the renderer one way, as each <subsurface>'s
        maxPoints: none at its default (0: the renderer's own default), 777 when set; F12
        passes no --limit."""
        fake = self.fake()
        self.translucent_sphere(0)
        for cap, name in ((0, "default.exr"), (777, "set.exr")):
            self.sc.opaline.max_sss_points = cap
            self.render(name)
            with open(fake + ".args") as f:
                args = f.read().split("\n")
            self.assertNotIn("--limit", args)
            with open(args[-1]) as f:
                xml = f.read()
            self.assertIn("<subsurface", xml)
            self.assertEqual('name="maxPoints" value="777"' in xml, cap == 777, xml)
            self.assertEqual("maxPoints" in xml, cap > 0, xml)

    def test_failure_is_readable(self):
        self.fake()
        bpy.data.objects["floor"].name = "FAIL"
        with self.assertRaises(RuntimeError) as cm:
            self.render("fail.exr")
        msg = str(cm.exception)
        self.assertIn("opaline-render failed (exit 2)", msg)
        self.assertIn("something is wrong", msg)
        self.assertNotIn("Traceback", msg)

    def test_error_and_warning_reports(self):
        self.fake()
        bpy.data.objects["floor"].name = "WARN"
        self.render("warn.exr")
        self.assertIn(('WARNING', "opaline-render: scene.xml:3: unused parameter 'intIOR'"),
                      E.last_reports)
        self.assertTrue(E.last_status[0].startswith("opaline: "), E.last_status)
        bpy.data.objects["WARN"].name = "BADSCENE"
        with self.assertRaises(RuntimeError) as cm:
            self.render("bad.exr")
        self.assertIn("a long message that says all", str(cm.exception))
        # One report each: the render's own (which F12 moves to the Info editor once;
        # scripts/addon-screenshots.sh checks that under a display), no second path.
        self.assertFalse(hasattr(E, "_wm_reports"))
        self.assertFalse(hasattr(bpy.types, "OPALINE_OT_render_report"))
        errs = [m for k, m in E.last_reports if k == 'ERROR']
        self.assertEqual(len(errs), 1, E.last_reports)
        self.assertIn("opaline-render failed (exit 2):\nscene.xml:7: <bsdf>: a long message "
                      "that says all", errs[0])

    def test_session_folder_reused(self):
        self.fake()
        d = os.urandom(4)[0] / 255.0  # a mesh no earlier render of this session wrote
        S.add_mesh("unique", [(0, 0, d), (1, 0, d), (0, 1, d)], [(0, 1, 2)])
        self.render("one.exr")
        first = E.last_export
        folder = os.path.dirname(first.xml_path)
        self.assertTrue(os.path.basename(folder).startswith("opaline-blender-%d-" % os.getpid()))
        self.assertGreater(first.meshes_written, 0)
        self.render("two.exr")
        self.assertEqual(os.path.dirname(E.last_export.xml_path), folder)
        self.assertEqual(E.last_export.meshes_written, 0)
        self.assertEqual(E.last_export.meshes_reused,
                         first.meshes_written + first.meshes_reused)

    def test_stale_folders_removed(self):
        import subprocess
        base = S.tmpdir("stale")
        dead = subprocess.Popen([sys.executable, "-c", "pass"])
        dead.wait()
        alive = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
        try:
            names = ["opaline-blender-%d-abc" % dead.pid, "opaline-blender-%d-def" % alive.pid,
                     "opaline-blender-%d-own" % os.getpid(), "other-%d-x" % dead.pid,
                     "opaline-blender-%d-kept" % dead.pid]
            for n in names:
                os.makedirs(os.path.join(base, n, "meshes"))
            open(os.path.join(base, names[4], E.KEEP_MARKER), "w").close()
            removed = E.remove_stale_folders(base)
        finally:
            alive.kill()
            alive.wait()
        self.assertEqual(removed, [os.path.join(base, names[0])])
        self.assertEqual(sorted(os.listdir(base)), sorted(names[1:]))

    def test_region_fake(self):
        # Blender's border of a 16x8 image: x 4..12, y (up) 2..6; the renderer's crop counts
        # y from the top.
        self.fake()
        r = self.sc.render
        r.use_border = True
        r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y = 0.25, 0.75, 0.25, 0.75
        self.assertEqual(E.render_region(r), (16, 8, 4, 2, 8, 4))
        for crop in (True, False):
            r.use_crop_to_border = crop
            w, h, a = self.render("region%d.exr" % crop)
            self.assertEqual((w, h), (8, 4) if crop else (16, 8))

    def test_no_camera(self):
        self.fake()
        self.sc.camera = None
        with self.assertRaises(RuntimeError) as cm:
            self.render("nocam.exr")
        self.assertIn("no camera", str(cm.exception))

    def test_matches_command_line(self):
        r = S.need_renderer(self)
        S.prefs().renderer_path = r
        self.sc.render.resolution_x, self.sc.render.resolution_y = 24, 16
        self.sc.opaline.samples = 4
        self.sc.opaline.threads = 1
        self.sc.opaline.keep_temp = False
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.7, location=(0, 0, 0.7))
        w, h, a = self.render("engine.exr")
        xml = os.path.join(self.dir, "cli", "scene.xml")
        S.export(xml)
        pfm = S.render_cli(self, xml, os.path.join(self.dir, "cli.pfm"), threads=1)
        cw, ch, rows = S.read_pfm(pfm)
        self.assertEqual((cw, ch), (w, h))
        worst = 0.0
        for y in range(h):
            for x in range(w):
                px = a[4 * ((h - 1 - y) * w + x):4 * ((h - 1 - y) * w + x) + 3]
                ref = rows[y][3 * x:3 * x + 3]
                for p, q in zip(px, ref):
                    worst = max(worst, abs(p - q) / max(1.0, abs(q)))
        # Same scene, same renderer, same seed: equal up to half-float storage.
        self.assertLess(worst, 2e-3, "engine and command line differ by %g" % worst)


    def translucent_sphere(self, max_points):
        mat = bpy.data.materials.new("skin")
        mat.opaline.enabled = True
        mat.opaline.kind = 'DIPOLE'
        mat.opaline.dipole_material = "Skin1"
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.7, location=(0, 0, 0.7))
        bpy.context.active_object.data.materials.append(mat)
        self.sc.opaline.max_sss_points = max_points

    def test_region_real(self):
        """Render Region: with crop, the region's pixels; without, the full image with only the
        region filled; both equal to the same pixels of a full render."""
        S.prefs().renderer_path = S.need_renderer(self)
        r = self.sc.render
        r.resolution_x, r.resolution_y = 40, 24
        self.sc.cycles.samples = 2
        self.sc.opaline.threads = 2
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.7, location=(0, 0, 0.7))
        fw, fh, full = self.render("full.exr")
        r.use_border = True
        r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y = 0.3, 0.8, 0.2, 0.6
        _, _, x0, top, rw, rh = E.render_region(r)
        bx0, by0 = x0, fh - top - rh  # Blender's rows go up
        r.use_crop_to_border = True
        w, h, crop = self.render("crop.exr")
        self.assertEqual((w, h), (rw, rh))
        for y in range(rh):
            for x in range(rw):
                i, j = 4 * (y * rw + x), 4 * ((by0 + y) * fw + bx0 + x)
                self.assertEqual(list(crop[i:i + 4]), list(full[j:j + 4]), (x, y))
        r.use_crop_to_border = False
        w, h, uncrop = self.render("uncrop.exr")
        self.assertEqual((w, h), (fw, fh))
        inside = 0
        for y in range(fh):
            for x in range(fw):
                j = 4 * (y * fw + x)
                if bx0 <= x < bx0 + rw and by0 <= y < by0 + rh:
                    self.assertEqual(list(uncrop[j:j + 4]), list(full[j:j + 4]), (x, y))
                    inside += 1
                else:
                    self.assertEqual(list(uncrop[j:j + 3]), [0.0, 0.0, 0.0], (x, y))
        self.assertEqual(inside, rw * rh)
        self.assertGreater(sum(full), 0.0)

    def test_stage_progress_real(self):
        """The pre-pass stages of a translucent scene reach a StreamReader over the real
        renderer, each stage's fractions rising to 1; then the render's."""
        import subprocess
        rend = S.need_renderer(self)
        self.sc.render.resolution_x, self.sc.render.resolution_y = 24, 16
        self.translucent_sphere(20000)
        xml = os.path.join(self.dir, "sss", "scene.xml")
        S.export(xml, samples=2)
        proc = subprocess.Popen([rend, "--stream", "-t", "2", xml], stdout=subprocess.PIPE,
                                stderr=subprocess.DEVNULL)
        stages = {}
        order = []
        for rec in StreamReader(proc.stdout):
            if isinstance(rec, Progress):
                frac, label = rec
                if label not in stages:
                    order.append(label)
                stages.setdefault(label, []).append(frac)
        self.assertEqual(proc.wait(), 0)
        self.assertEqual(order, ["irradiance", "subsurface", "render"])
        for label, fr in stages.items():
            self.assertEqual(fr, sorted(fr), label)
            self.assertEqual(fr[-1], 1.0, label)

    def test_warning_real(self):
        """A quality warning (irradiance points capped) reaches the render's reports, and the
        artist's cap (scene.opaline.max_sss_points) is the one applied; the STATS record's
        count of capped shapes, not the warning's words, adds the setting to raise."""
        S.prefs().renderer_path = S.need_renderer(self)
        self.sc.render.resolution_x, self.sc.render.resolution_y = 16, 8
        self.sc.cycles.samples = 1
        self.translucent_sphere(50)
        self.render("capped.exr")
        warns = [m for k, m in E.last_reports if k == 'WARNING']
        self.assertTrue(any("capped at 50 " in m for m in warns), E.last_reports)
        self.assertEqual(E.last_stats[0].sss_shapes_capped, 1, E.last_stats)
        self.assertTrue(any("1 translucent object got fewer irradiance points" in m and
                            "Irradiance Point Cap" in m for m in warns), E.last_reports)


if __name__ == "__main__":
    S.run_tests(TestProgress, TestEngine)
