"""The add-on's tile stream reader (blender_addon/opaline/stream.py) in plain Python, without
Blender: records made here parse into their named fields, malformed streams are refused, and
the real opaline-render's stream (OPALINE_BIN_DIR; skipped when it is not built) reads back
with the tile size it rendered in, the counts of its STATS record and the image it wrote."""

import importlib.util
import io
import os
import struct
import subprocess
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE_DIR = os.environ.get("OPALINE_SOURCE_DIR") or os.path.dirname(os.path.dirname(HERE))
_spec = importlib.util.spec_from_file_location(
    "opaline_stream", os.path.join(SOURCE_DIR, "blender_addon", "opaline", "stream.py"))
S = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(S)  # the module alone: the package's __init__ needs bpy


def rec(typ, payload):
    return struct.pack("<4sIQ", b"OPTS", typ, len(payload)) + payload


def begin(w, h, tile=32, channels=4):
    return rec(S.BEGIN, struct.pack("<4I", w, h, channels, tile))


def tile(x, y, w, h, fn):
    vals = []
    for r in range(h):
        for c in range(w):
            vals += fn(x + c, y + r)
    return rec(S.TILE, struct.pack("<4I", x, y, w, h) + struct.pack("<%df" % len(vals), *vals))


def read_all(data):
    return list(S.StreamReader(io.BytesIO(data)))


class TestRecords(unittest.TestCase):
    def test_named_records(self):
        stats = struct.pack("<5q4I2d", 10, 9, 8, 7, 6, 2, 1, 4, 4, 0.5, 1.5)
        data = (begin(4, 2, 16) + rec(S.PROGRESS, struct.pack("<dI", 0.25, 10) + b"irradiance") +
                tile(2, 0, 2, 2, lambda x, y: (x, y, 0, 1)) + rec(99, b"a newer record") +
                rec(S.LOG, struct.pack("<I", 1) + "capped at 5 \u00e9".encode()) +
                rec(S.STATS, stats) + rec(S.END, struct.pack("<I", 0)))
        recs = read_all(data)
        self.assertEqual(recs[0], S.Begin(4, 2, 4, 16))
        self.assertEqual(recs[1], S.Progress(0.25, "irradiance"))
        t = recs[2]
        self.assertIsInstance(t, S.Tile)
        self.assertEqual((t.x, t.y, t.width, t.height), (2, 0, 2, 2))
        self.assertEqual(list(t.rgba[:8]), [2, 0, 0, 1, 3, 0, 0, 1])
        self.assertEqual(recs[3], S.Log("warning", "capped at 5 \u00e9"))  # 99 skipped
        self.assertEqual(recs[4], S.Stats(10, 9, 8, 7, 6, 2, 1, 4, 4, 0.5, 1.5))
        self.assertEqual(recs[4].sss_shapes_capped, 1)
        self.assertEqual(recs[5], S.End(0))
        self.assertEqual(len(recs), 6)

    def test_tile_count(self):
        self.assertEqual(S.tile_count(40, 24, 16), 3 * 2)
        self.assertEqual(S.tile_count(32, 32, 32), 1)
        self.assertEqual(S.tile_count(33, 1, 32), 2)

    def test_malformed(self):
        bad = {"bad magic": b"XXXX" + bytes(12),
               "short payload": begin(4, 2)[:-3],
               "old BEGIN without its tile size": rec(S.BEGIN, struct.pack("<3I", 4, 2, 4)),
               "label past the payload": rec(S.PROGRESS, struct.pack("<dI", 0.5, 9) + b"abc"),
               "short LOG": rec(S.LOG, b"ab"),
               "three channels": begin(4, 2, channels=3),
               "tile side 0": begin(4, 2, tile=0),
               "tile outside": begin(2, 2) + tile(1, 1, 2, 2, lambda x, y: (0, 0, 0, 0)),
               "tile size and bytes": rec(S.TILE, struct.pack("<4I", 0, 0, 2, 2) + bytes(8)),
               "short STATS": rec(S.STATS, bytes(40))}
        for what, data in bad.items():
            with self.assertRaises(S.StreamError, msg=what):
                read_all(data)


SCENE = """<scene version="0.6.0"><integrator type="path"><integer name="maxDepth" value="3"/></integrator>
 <sensor type="perspective"><float name="fov" value="40"/>
  <transform name="toWorld"><lookat origin="0,1,4" target="0,0,0" up="0,1,0"/></transform>
  <sampler type="independent"><integer name="sampleCount" value="2"/></sampler>
  <film type="hdrfilm"><integer name="width" value="40"/><integer name="height" value="24"/></film></sensor>
 <emitter type="constant"><rgb name="radiance" value="0.8"/></emitter>
 <shape type="sphere"><float name="radius" value="0.7"/>%s</shape>
 <shape type="rectangle"><transform name="toWorld"><scale value="5"/><rotate x="1" angle="-90"/><translate y="-0.7"/></transform><bsdf type="diffuse"><rgb name="reflectance" value="0.5,0.4,0.3"/></bsdf></shape>
</scene>
"""
TRANSLUCENT = ('<subsurface type="dipole"><string name="material" value="Skin1"/>'
               '<float name="sceneUnitsPerMetre" value="1000"/><integer name="irrSamples" value="2"/>'
               '<integer name="maxPoints" value="%d"/></subsurface>')


def renderer():
    d = os.environ.get("OPALINE_BIN_DIR")
    r = os.path.join(d, "opaline-render") if d else ""
    return r if os.path.isfile(r) and os.access(r, os.X_OK) else None


def read_pfm(path):
    """(w, h, RGB floats with the top row first) of a little-endian colour PFM."""
    with open(path, "rb") as f:
        data = f.read()
    kind, size, scale, body = data.split(b"\n", 3)
    assert kind == b"PF" and float(scale) < 0, (kind, scale)
    w, h = map(int, size.split())
    vals = struct.unpack("<%df" % (3 * w * h), body[:12 * w * h])
    rows = [vals[3 * w * r:3 * w * (r + 1)] for r in range(h)]
    return w, h, [v for row in reversed(rows) for v in row]


@unittest.skipIf(renderer() is None, "opaline-render is not built (OPALINE_BIN_DIR has none)")
class TestRenderer(unittest.TestCase):
    def setUp(self):
        base = os.environ.get("OPALINE_TEST_TMP") or tempfile.gettempdir()
        self.dir = tempfile.mkdtemp(prefix="unit-stream-", dir=base)

    def stream(self, inner, *args):
        xml = os.path.join(self.dir, "scene.xml")
        with open(xml, "w") as f:
            f.write(SCENE % inner)
        pfm = os.path.join(self.dir, "out.pfm")
        p = subprocess.run([renderer(), "--stream", "--stream-log", "-t", "2", "-o", pfm] +
                           list(args) + [xml], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        self.assertEqual(p.returncode, 0, p.stderr.decode(errors="replace"))
        return read_all(p.stdout), pfm

    def test_tile_size_travels(self):
        """--tile-size 16: BEGIN says 16, every tile is a cell of the 16-pixel grid, STATS
        counts them, and the tiles put together are the image written with -o."""
        recs, pfm = self.stream('<bsdf type="diffuse"/>', "--tile-size", "16")
        b = recs[0]
        self.assertEqual(b, S.Begin(40, 24, 4, 16))
        tiles = [r for r in recs if isinstance(r, S.Tile)]
        self.assertEqual(len(tiles), S.tile_count(40, 24, 16))
        self.assertEqual(sorted((t.x, t.y) for t in tiles),
                         sorted((x, y) for x in range(0, 40, 16) for y in range(0, 24, 16)))
        for t in tiles:
            self.assertEqual((t.width, t.height), (min(16, 40 - t.x), min(16, 24 - t.y)))
        stats = [r for r in recs if isinstance(r, S.Stats)]
        self.assertEqual(len(stats), 1)
        self.assertEqual((stats[0].tiles, stats[0].tiles_done), (6, 6))
        self.assertEqual(recs[-1], S.End(0))
        img = [0.0] * (40 * 24 * 3)
        for t in tiles:
            for r in range(t.height):
                for c in range(t.width):
                    i = 4 * (r * t.width + c)
                    j = 3 * ((t.y + r) * 40 + t.x + c)
                    img[j:j + 3] = t.rgba[i:i + 3]
        w, h, ref = read_pfm(pfm)
        self.assertEqual((w, h), (40, 24))
        self.assertEqual(img, list(ref))
        self.assertGreater(sum(ref), 0.0)
        default, _ = self.stream('<bsdf type="diffuse"/>')
        self.assertEqual(default[0].tile_size, 32)
        self.assertEqual(sum(isinstance(r, S.Tile) for r in default), S.tile_count(40, 24, 32))

    def test_capped_shapes_counted(self):
        """A translucent shape held under its maxPoints: STATS counts it (the add-on reports
        that, not the warning's words); with room enough, none."""
        recs, _ = self.stream(TRANSLUCENT % 50)
        stats = [r for r in recs if isinstance(r, S.Stats)][0]
        self.assertEqual((stats.sss_shapes_reached, stats.sss_shapes_capped), (1, 1))
        self.assertGreater(stats.sss_points, 0)
        self.assertTrue(any(isinstance(r, S.Log) and r.level == "warning" for r in recs))
        recs, _ = self.stream(TRANSLUCENT % 100000)
        stats = [r for r in recs if isinstance(r, S.Stats)][0]
        self.assertEqual((stats.sss_shapes_reached, stats.sss_shapes_capped), (1, 0))


if __name__ == "__main__":
    unittest.main(verbosity=2)
