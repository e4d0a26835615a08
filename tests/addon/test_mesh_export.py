"""The mesh exporter (export/meshes.py): every PLY holds what a straightforward per-corner
conversion of Blender's data holds (flat and smooth faces, sharp edges, UV seams, custom normals,
n-gons, modifiers, material slots, meshes without UVs); the export reports its progress; a mesh
that did not change is not converted again from frame to frame, in an exported frame range, in
batch.py and in an animation rendered by the engine."""

import os
import re
import struct
import subprocess
import sys
import unittest
import xml.etree.ElementTree as ET

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_support as S  # noqa: E402

import bpy  # noqa: E402

from opaline import engine as E  # noqa: E402
from opaline.export import meshes as M  # noqa: E402
from opaline.export import scene as se  # noqa: E402

BATCH = os.path.join(S.SOURCE_DIR, "blender_addon", "opaline", "batch.py")


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


def corner_normals(me):
    """Blender's normal of each corner (loop), one Python list of 3-tuples."""
    if hasattr(me, "corner_normals"):  # 4.1 and later
        return [tuple(c.vector) for c in me.corner_normals]
    me.calc_normals_split()
    return [tuple(lp.normal) for lp in me.loops]


def reference(me):
    """{material index: (vertices, faces)} of a mesh as the PLY files must hold it, computed
    corner by corner: a vertex per distinct (vertex, normal, uv) of a material's corners, in
    the order of their first corner; vertices x y z nx ny nz [u 1-v] as float32 values."""
    me.calc_loop_triangles()
    normals = corner_normals(me)
    layer = None
    for lay in me.uv_layers:
        if lay.active_render:
            layer = lay
    if layer is None and len(me.uv_layers):
        layer = me.uv_layers.active
    parts = {}
    for tri in me.loop_triangles:
        index, verts, faces = parts.setdefault(tri.material_index, ({}, [], []))
        face = []
        for lp in tri.loops:
            v = me.loops[lp].vertex_index
            n = normals[lp]
            uv = tuple(layer.data[lp].uv) if layer is not None else ()
            key = (v, n, uv)
            if key not in index:
                index[key] = len(verts)
                co = me.vertices[v].co
                rec = tuple(co) + n + ((uv[0], 1.0 - uv[1]) if uv else ())
                verts.append(tuple(f32(x) for x in rec))
            face.append(index[key])
        faces.append(tuple(face))
    return {m: (p[1], p[2]) for m, p in parts.items()}


def shapes_of(xml):
    """(object name, material index, file path) of each PLY shape of an exported scene."""
    out = []
    for s in ET.parse(xml).getroot().iter("shape"):
        if s.get("type") != "ply":
            continue
        fn = [c.get("value") for c in s if c.get("name") == "filename"][0]
        mi = int(re.search(r"_m(\d+)-[0-9a-f]+\.ply$", fn).group(1))
        out.append((mi, os.path.join(os.path.dirname(xml), fn)))
    return out


class TestMeshExport(unittest.TestCase):
    def setUp(self):
        self.sc = S.empty_scene()
        self.dir = S.tmpdir("mesh-" + self.id().split(".")[-1])
        self.xml = os.path.join(self.dir, "scene.xml")
        S.add_camera((0, -10, 2), (1.4, 0, 0))

    def check_object(self, ob):
        """Exports the scene with ob alone in it and compares each of its PLY files with the
        reference conversion of its evaluated mesh."""
        for o in list(self.sc.objects):
            if o.type == 'MESH' and o is not ob:
                bpy.data.objects.remove(o)
        res = S.export(self.xml)
        dg = bpy.context.evaluated_depsgraph_get()
        ev = ob.evaluated_get(dg)
        me = ev.to_mesh()
        try:
            ref = reference(me)
            has_uv = len(me.uv_layers) > 0
        finally:
            ev.to_mesh_clear()
        got = {mi: M.read_ply(path) for mi, path in shapes_of(self.xml)}
        self.assertEqual(sorted(got), sorted(ref), ob.name)
        for mi, (verts, faces) in ref.items():
            gv, gf = got[mi]
            self.assertEqual(gf, faces, "%s slot %d: faces" % (ob.name, mi))
            self.assertEqual(len(gv), len(verts), "%s slot %d: vertex count" % (ob.name, mi))
            for a, b in zip(gv, verts):
                self.assertEqual(len(a), 8 if has_uv else 6)
                self.assertEqual(a[:3] + a[6:], b[:3] + b[6:], "%s: position or UV" % ob.name)
                # Blender 3.x sums vertex normals in parallel: last-bit differences between
                # two evaluations of one mesh.
                for x, y in zip(a[3:6], b[3:6]):
                    self.assertAlmostEqual(x, y, places=5)
        return res

    def test_flat_faces(self):
        bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=2)
        self.check_object(bpy.context.object)

    def test_smooth_faces_and_uv_seams(self):
        bpy.ops.mesh.primitive_uv_sphere_add(segments=24, ring_count=12)
        bpy.ops.object.shade_smooth()
        self.check_object(bpy.context.object)

    def test_sharp_edges(self):
        bpy.ops.mesh.primitive_cylinder_add(vertices=16)
        ob = bpy.context.object
        bpy.ops.object.shade_smooth()
        me = ob.data
        if hasattr(me, "use_auto_smooth"):  # before 4.1 sharp edges need Auto Smooth
            me.use_auto_smooth = True
            me.auto_smooth_angle = 3.14
        for e in me.edges:
            e.use_edge_sharp = e.index % 3 == 0
        self.check_object(ob)

    def test_custom_normals(self):
        bpy.ops.mesh.primitive_cube_add()
        ob = bpy.context.object
        me = ob.data
        if hasattr(me, "use_auto_smooth"):  # before 4.1 custom normals need Auto Smooth
            me.use_auto_smooth = True
        me.normals_split_custom_set_from_vertices(
            [(0.0, 0.0, 1.0) if v.co.z > 0 else (0.6, 0.0, -0.8) for v in me.vertices])
        self.assertTrue(me.has_custom_normals)
        self.check_object(ob)

    def test_ngons_and_no_uvs(self):
        ob = S.add_mesh("ngons", [(0, 0, 0), (2, 0, 0), (3, 1, 0), (2, 2, 0), (0, 2, 0),
                                  (-1, 1, 0.5), (1, 3, 0.2)],
                        [(0, 1, 2, 3, 4, 5), (3, 6, 4)])
        self.assertEqual(len(ob.data.uv_layers), 0)
        self.check_object(ob)
        bpy.ops.mesh.primitive_cylinder_add(vertices=9, end_fill_type='NGON')
        self.check_object(bpy.context.object)

    def test_modifiers_and_material_slots(self):
        bpy.ops.mesh.primitive_monkey_add()
        ob = bpy.context.object
        bpy.ops.object.shade_smooth()
        ob.data.materials.append(S.diffuse_material("a", (1, 0, 0)))
        ob.data.materials.append(S.diffuse_material("b", (0, 1, 0)))
        for p in ob.data.polygons:
            p.material_index = p.index % 2
        mod = ob.modifiers.new("sub", 'SUBSURF')
        mod.levels = mod.render_levels = 1
        ob.modifiers.new("split", 'EDGE_SPLIT')
        self.check_object(ob)

    def test_hash_collisions(self):
        """Corners whose keys share a hash are told apart (the welding hashes again)."""
        real = M._hash_rows
        M._hash_rows = lambda np, keys, seed: (real(np, keys, seed) if seed else
                                               np.zeros(len(keys), np.uint64))
        try:
            bpy.ops.mesh.primitive_uv_sphere_add(segments=12, ring_count=6)
            self.check_object(bpy.context.object)
        finally:
            M._hash_rows = real

    def test_progress(self):
        for i in range(3):
            bpy.ops.mesh.primitive_uv_sphere_add(location=(3 * i, 0, 0))
        heard = []
        dg = bpy.context.evaluated_depsgraph_get()
        se.export_scene(dg, self.xml, bpy.context, progress=lambda f, name: heard.append(
            (f, name)))
        self.assertGreaterEqual(len(heard), 2, heard)
        fractions = [f for f, _ in heard]
        self.assertEqual(fractions, sorted(fractions))
        self.assertEqual(fractions[-1], 1.0)
        self.assertIn("Sphere", [n for _, n in heard])


def build_animation(sc):
    """A still smooth sphere (many faces around its poles), a cube that moves and a grid that a
    Wave modifier deforms, over frames 1-3."""
    sc.frame_start, sc.frame_end = 1, 3
    bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32)
    bpy.ops.object.shade_smooth()
    bpy.ops.mesh.primitive_cube_add(location=(3, 0, 0))
    cube = bpy.context.object
    for f, x in ((1, 3.0), (3, 5.0)):
        cube.location.x = x
        cube.keyframe_insert("location", frame=f)
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=8, y_subdivisions=8, location=(0, 3, 0))
    bpy.context.object.modifiers.new("wave", 'WAVE')


class TestUnchangedAcrossFrames(unittest.TestCase):
    """Still meshes are converted once over frames 1-3; the deformed grid each frame."""

    def setUp(self):
        self.sc = S.empty_scene((16, 8))
        self.dir = S.tmpdir("mesh-frames")
        S.add_camera((0, -10, 2), (1.4, 0, 0))
        build_animation(self.sc)

    def test_frame_range_export(self):
        results = se.export_frames(bpy.context, os.path.join(self.dir, "f.xml"), (1, 3))
        self.assertEqual([(r.meshes_written, r.meshes_unchanged) for r in results],
                         [(3, 0), (1, 2), (1, 2)])

    def test_batch(self):
        blend = os.path.join(self.dir, "anim.blend")
        bpy.ops.wm.save_as_mainfile(filepath=blend)
        p = subprocess.run([bpy.app.binary_path, "-b", "--factory-startup", blend, "--python",
                            BATCH, "--", "--out", os.path.join(self.dir, "batch")],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=300)
        out = p.stdout.decode(errors="replace")
        self.assertEqual(p.returncode, 0, p.stderr.decode(errors="replace"))
        counts = [tuple(int(x) for x in m) for m in re.findall(
            r"meshes (\d+) written, (\d+) unchanged, (\d+) of them not converted again", out)]
        self.assertEqual(counts, [(3, 0, 0), (1, 2, 2), (1, 2, 2)], out)

    def test_animation_render(self):
        sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
        from test_engine import FAKE
        fake = os.path.join(self.dir, "fake-opaline-render")
        with open(fake, "w") as f:
            f.write(FAKE)
        os.chmod(fake, 0o755)
        S.prefs().renderer_path = fake
        sc = self.sc
        sc.render.engine = 'OPALINE'
        sc.render.image_settings.file_format = 'PNG'
        sc.render.filepath = os.path.join(self.dir, "anim_")
        results, statuses = [], []
        export_scene, status = se.export_scene, E.OpalineRenderEngine._status

        def record_export(*a, **kw):
            results.append(export_scene(*a, **kw))
            return results[-1]
        se.export_scene = record_export
        E.OpalineRenderEngine._status = lambda eng, text: (statuses.append(text),
                                                           status(eng, text))
        try:
            bpy.ops.render.render(animation=True)
        finally:
            se.export_scene, E.OpalineRenderEngine._status = export_scene, status
        self.assertEqual(len(results), 3, E.last_reports)
        # Frame 1 may find files of an earlier render of this session: written or reused.
        self.assertEqual([(r.meshes_written + r.meshes_reused, r.meshes_unchanged)
                          for r in results], [(3, 0), (3, 2), (3, 2)])
        self.assertTrue(any(t.startswith("opaline: exporting meshes 100 %") for t in statuses),
                        statuses)


if __name__ == "__main__":
    S.run_tests(TestMeshExport, TestUnchangedAcrossFrames)
