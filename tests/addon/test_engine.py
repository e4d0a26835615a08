"""The "opaline" render engine: the tile stream parser, F12 through a scripted stand-in that
speaks the tile stream protocol (tiles placed right, progress, errors reported readably), and
F12 with the real opaline-render compared pixel by pixel with its command-line render of the
same export (skipped when opaline-render is not built)."""

import io
import os
import stat
import struct
import sys
import textwrap
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_support as S  # noqa: E402

import bpy  # noqa: E402

from opaline import engine as E  # noqa: E402


def rec(typ, payload):
    return struct.pack("<4sIQ", b"OPTS", typ, len(payload)) + payload


def tile(x, y, w, h, fn):
    vals = []
    for r in range(h):
        for c in range(w):
            vals += fn(x + c, y + r)
    return rec(2, struct.pack("<4I", x, y, w, h) + struct.pack("<%df" % len(vals), *vals))


class TestStream(unittest.TestCase):
    def test_parse(self):
        data = (rec(1, struct.pack("<3I", 4, 2, 4)) + rec(3, struct.pack("<d", 0.5)) +
                tile(2, 0, 2, 2, lambda x, y: (x, y, 0, 1)) + rec(4, struct.pack("<I", 0)))
        r = E.StreamReader(io.BytesIO(data))
        self.assertEqual(r.next(), (1, (4, 2, 4)))
        self.assertEqual(r.next(), (3, 0.5))
        typ, (x, y, w, h, a) = r.next()
        self.assertEqual((typ, x, y, w, h), (2, 2, 0, 2, 2))
        self.assertEqual(list(a[:8]), [2, 0, 0, 1, 3, 0, 0, 1])
        self.assertEqual(list(E.flip_rows(a, 2, 2)[:4]), [2, 1, 0, 1])
        self.assertEqual(r.next(), (4, 0))
        self.assertIsNone(r.next())

    def test_malformed(self):
        bad = [b"XXXX" + bytes(12),
               rec(1, struct.pack("<3I", 4, 2, 4))[:-3],
               rec(9, b""),
               rec(1, struct.pack("<3I", 4, 2, 3)),
               rec(1, struct.pack("<3I", 2, 2, 4)) + tile(1, 1, 2, 2, lambda x, y: (0, 0, 0, 0)),
               rec(2, struct.pack("<4I", 0, 0, 2, 2) + bytes(8))]
        for data in bad:
            r = E.StreamReader(io.BytesIO(data))
            with self.assertRaises(E.StreamError):
                while r.next() is not None:
                    pass


FAKE = textwrap.dedent('''\
    #!/usr/bin/env python3
    # A stand-in for opaline-render that speaks the tile stream (for the engine test only):
    # it reads the film size from the exported XML and streams a known gradient in 4 tiles.
    import re, struct, sys
    args = sys.argv[1:]
    xml = open(args[-1]).read()
    if "FAIL" in open(args[-1]).read() or "--fail" in args:
        sys.stderr.write("scene.xml:12: <shape>: something is wrong\\n")
        sys.exit(2)
    w = int(re.search(r'name="width" value="(\\d+)"', xml).group(1))
    h = int(re.search(r'name="height" value="(\\d+)"', xml).group(1))
    out = sys.stdout.buffer
    def rec(t, p):
        out.write(struct.pack("<4sIQ", b"OPTS", t, len(p)) + p)
    rec(1, struct.pack("<3I", w, h, 4))
    tiles = [(0, 0, w // 2, h // 2), (w // 2, 0, w - w // 2, h // 2),
             (0, h // 2, w // 2, h - h // 2), (w // 2, h // 2, w - w // 2, h - h // 2)]
    for i, (x, y, tw, th) in enumerate(tiles):
        v = []
        for r in range(th):
            for c in range(tw):
                v += [(x + c) / w, (y + r) / h, 0.25, 1.0]
        rec(2, struct.pack("<4I", x, y, tw, th) + struct.pack("<%df" % len(v), *v))
        rec(3, struct.pack("<d", (i + 1) / 4.0))
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

    def test_failure_is_readable(self):
        self.fake()
        bpy.data.objects["floor"].name = "FAIL"
        with self.assertRaises(RuntimeError) as cm:
            self.render("fail.exr")
        msg = str(cm.exception)
        self.assertIn("opaline-render failed (exit 2)", msg)
        self.assertIn("something is wrong", msg)
        self.assertNotIn("Traceback", msg)

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


if __name__ == "__main__":
    S.run_tests(TestStream, TestEngine)
