"""Export tests: registration, the panel and preferences, and the exported numbers (camera,
transforms, every light conversion, meshes, materials, world, render settings, visibility),
plus the error reports for bad states. Only test_check_* needs opaline-render."""

import math
import os
import sys
import unittest
import xml.etree.ElementTree as ET

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_support as S  # noqa: E402
from addon_support import floats, prop, value  # noqa: E402

import bpy  # noqa: E402
from mathutils import Matrix, Vector  # noqa: E402

from opaline import compat  # noqa: E402
from opaline.errors import OpalineError  # noqa: E402
from opaline.export import camera as cam_mod  # noqa: E402
from opaline.export import lights as L  # noqa: E402
from opaline.export import meshes as M  # noqa: E402





def matrix_of(el):
    t = prop(el, "transform", "toWorld")
    m = floats(t.find("matrix").get("value"))
    return Matrix([m[0:4], m[4:8], m[8:12], m[12:16]])


def _seq(x):
    try:
        return [float(v) for v in x]
    except TypeError:
        return [float(x)]


class Base(unittest.TestCase):
    def setUp(self):
        self.sc = S.empty_scene()
        self.dir = S.tmpdir(self.id().split(".")[-1])
        self.xml = os.path.join(self.dir, "scene.xml")

    def export(self, **kw):
        self.res = S.export(self.xml, **kw)
        self.root = ET.parse(self.xml).getroot()
        return self.root

    def assertClose(self, a, b, tol=1e-5, msg=None):
        a, b = _seq(a), _seq(b)
        self.assertEqual(len(a), len(b), msg)
        for x, y in zip(a, b):
            self.assertLessEqual(abs(x - y), tol * max(1.0, abs(y)), "%s vs %s %s" %
                                 (a, b, msg or ""))


class TestRegistration(Base):
    def test_registered(self):
        self.assertIn("OPALINE", [getattr(e, "bl_idname", None)
                                  for e in bpy.types.RenderEngine.__subclasses__()])
        self.assertTrue(hasattr(bpy.types, "MATERIAL_PT_opaline_subsurface"))
        self.assertTrue(hasattr(bpy.ops.export_scene, "opaline"))
        p = S.prefs()
        self.assertEqual(p.renderer_path, "")
        p.preset_folders.add().path = self.dir
        self.assertEqual(len(p.preset_folders), 1)
        mat = bpy.data.materials.new("m")
        for k in ("enabled", "kind", "preset", "preset_enum", "dipole_material", "filepath",
                  "scale", "ior"):
            self.assertTrue(hasattr(mat.opaline, k), k)

    def test_panel_draws(self):
        # The panel's draw() must run without errors for each kind (a fake layout records).
        class Layout:
            def __getattr__(self, name):
                return lambda *a, **k: Layout()
        mat = bpy.data.materials.new("m")

        class Ctx:
            material = mat
            engine = 'OPALINE'

        class Self:
            layout = Layout()
        from opaline.ui import OPALINE_PT_material
        for kind in ('PRESET', 'DIPOLE', 'FILE'):
            mat.opaline.kind = kind
            OPALINE_PT_material.draw(Self(), Ctx())
            OPALINE_PT_material.draw_header(Self(), Ctx())


class TestConversions(unittest.TestCase):
    def test_point(self):
        self.assertAlmostEqual(L.point_intensity(100.0)[0], 100.0 / (4 * math.pi), places=12)
        self.assertAlmostEqual(L.point_intensity(4 * math.pi, (0.5, 1, 2))[2], 2.0, places=12)

    def test_spot(self):
        self.assertEqual(L.spot_intensity(10.0), L.point_intensity(10.0))
        c, b = L.spot_angles(math.radians(90.0), 0.0)
        self.assertAlmostEqual(c, 45.0)
        self.assertAlmostEqual(b, 45.0)
        c, b = L.spot_angles(math.radians(90.0), 1.0)
        self.assertAlmostEqual(b, 0.0)
        c, b = L.spot_angles(math.radians(60.0), 0.5)
        self.assertAlmostEqual(math.cos(math.radians(b)),
                               math.cos(math.radians(30)) + 0.5 * (1 - math.cos(math.radians(30))))

    def test_sun(self):
        self.assertEqual(L.sun_irradiance(3.0, (1, 0.5, 0)), (3.0, 1.5, 0.0))

    def test_area(self):
        d34, d42 = compat.area_light_divisor((3, 4, 1)), compat.area_light_divisor((4, 2, 0))
        self.assertAlmostEqual(L.area_radiance(100.0, 2.0, divisor=d34)[0], 12.5)
        self.assertAlmostEqual(L.area_radiance(100.0, 2.0, divisor=d42)[0],
                               100.0 / (2 * math.pi))
        self.assertAlmostEqual(L.area_shape_area('SQUARE', 2, 9), 4.0)
        self.assertAlmostEqual(L.area_shape_area('RECTANGLE', 2, 3), 6.0)
        self.assertAlmostEqual(L.area_shape_area('DISK', 2, 9), math.pi)
        self.assertAlmostEqual(L.area_shape_area('ELLIPSE', 2, 4), 2 * math.pi)
        with self.assertRaises(ValueError):
            L.area_radiance(1.0, 0.0)

    def test_world(self):
        self.assertEqual(L.world_radiance((0.5, 0.25, 1.0), 2.0), (1.0, 0.5, 2.0))

    def test_camera_pure(self):
        self.assertEqual(cam_mod.render_size(1920, 1080, 50), (960, 540))
        fov, axis = cam_mod.perspective_fov(50, 36, 24, 'AUTO', 100, 50)
        self.assertEqual(axis, 'x')
        self.assertAlmostEqual(fov, math.degrees(2 * math.atan(18 / 50)))
        fov, axis = cam_mod.perspective_fov(50, 36, 24, 'AUTO', 50, 100)
        self.assertEqual(axis, 'y')
        self.assertAlmostEqual(fov, math.degrees(2 * math.atan(18 / 50)))
        fov, axis = cam_mod.perspective_fov(50, 36, 24, 'VERTICAL', 100, 50)
        self.assertEqual(axis, 'y')
        self.assertAlmostEqual(fov, math.degrees(2 * math.atan(12 / 50)))
        self.assertEqual(cam_mod.max_depth_from_bounces(0), 2)


class TestCamera(Base):
    def frame_fov(self, cam):
        """Blender's own framing: full angles along x and y from Camera.view_frame()."""
        pts = cam.data.view_frame(scene=self.sc)
        x = max(abs(p.x) for p in pts)
        y = max(abs(p.y) for p in pts)
        z = abs(pts[0].z)
        return 2 * math.degrees(math.atan(x / z)), 2 * math.degrees(math.atan(y / z))

    def test_fov_every_fit(self):
        cam = S.add_camera((0, 0, 5), lens=35.0)
        cam.data.sensor_height = 20.0
        for fit in ('AUTO', 'HORIZONTAL', 'VERTICAL'):
            for res in ((64, 48), (48, 64), (100, 100)):
                cam.data.sensor_fit = fit
                self.sc.render.resolution_x, self.sc.render.resolution_y = res
                sensor = self.export().find("sensor")
                fov = value(sensor, "float", "fov")[0]
                axis = value(sensor, "string", "fovAxis")
                fx, fy = self.frame_fov(cam)
                other = cam_mod.fov_other_axis(fov, axis, res[0], res[1])
                got_x, got_y = (fov, other) if axis == 'x' else (other, fov)
                self.assertClose([got_x, got_y], [fx, fy], 1e-4, "%s %s" % (fit, res))

    def test_transform_and_resolution(self):
        cam = S.add_camera((1.0, -2.0, 3.0), (math.radians(60), math.radians(10),
                                               math.radians(30)))
        self.sc.render.resolution_x, self.sc.render.resolution_y = 300, 200
        self.sc.render.resolution_percentage = 50
        sensor = self.export().find("sensor")
        la = sensor.find("transform").find("lookat")
        o, t, u = floats(la.get("origin")), floats(la.get("target")), floats(la.get("up"))
        mw = cam.matrix_world
        self.assertClose(o, mw.translation)
        fwd = -(mw.to_3x3() @ Vector((0, 0, 1))).normalized()
        self.assertClose([t[i] - o[i] for i in range(3)], fwd)
        self.assertClose(u, (mw.to_3x3() @ Vector((0, 1, 0))).normalized())
        film = sensor.find("film")
        self.assertEqual(int(prop(film, "integer", "width").get("value")), 150)
        self.assertEqual(int(prop(film, "integer", "height").get("value")), 100)
        self.assertClose(value(sensor, "float", "nearClip"), [cam.data.clip_start])
        self.assertClose(value(sensor, "float", "farClip"), [cam.data.clip_end])

    def test_samples_and_bounces(self):
        S.add_camera((0, 0, 5))
        self.sc.opaline.samples = 7
        self.sc.opaline.max_bounces = 3
        root = self.export()
        s = root.find("sensor").find("sampler")
        self.assertEqual(s.get("type"), "sobol")  # low-discrepancy, as Cycles
        self.assertEqual(prop(s, "integer", "sampleCount").get("value"), "7")
        self.assertEqual(prop(root.find("integrator"), "integer", "maxDepth").get("value"), "5")


class TestLights(Base):
    def setUp(self):
        super().setUp()
        S.add_camera((0, 0, 10))

    def emitters(self, typ):
        return [e for e in self.export().iter("emitter") if e.get("type") == typ]

    def test_point(self):
        S.add_light('POINT', (1, 2, 3), energy=250.0, color=(1.0, 0.5, 0.25))
        (e,) = self.emitters("point")
        self.assertClose(floats(" ".join(prop(e, "point", "position").get(k)
                                         for k in "xyz")), [1, 2, 3])
        k = 250.0 / (4 * math.pi)
        self.assertClose(value(e, "rgb", "intensity"), [k, 0.5 * k, 0.25 * k])

    def test_spot(self):
        ob = S.add_light('SPOT', (0, 0, 4), (math.radians(30), 0, math.radians(45)),
                         energy=80.0, spot_size=math.radians(50), spot_blend=0.3)
        (e,) = self.emitters("spot")
        la = e.find("transform").find("lookat")
        o, t = floats(la.get("origin")), floats(la.get("target"))
        d = (ob.matrix_world.to_3x3() @ Vector((0, 0, -1))).normalized()
        self.assertClose([t[i] - o[i] for i in range(3)], d)
        self.assertClose(value(e, "rgb", "intensity"), [80 / (4 * math.pi)] * 3)
        cut, beam = L.spot_angles(math.radians(50), 0.3)
        self.assertClose(value(e, "float", "cutoffAngle"), [25.0], 1e-6)
        self.assertClose(value(e, "float", "beamWidth"), [beam], 1e-6)

    def test_sun(self):
        ob = S.add_light('SUN', (5, 5, 5), (math.radians(40), 0, 0), energy=4.0)
        (e,) = self.emitters("directional")
        d = floats(" ".join(prop(e, "vector", "direction").get(k) for k in "xyz"))
        self.assertClose(d, (ob.matrix_world.to_3x3() @ Vector((0, 0, -1))).normalized())
        self.assertClose(value(e, "rgb", "irradiance"), [4.0] * 3)

    def test_area_shapes(self):
        cases = [('SQUARE', 0.5, 0.7, 0.25), ('RECTANGLE', 0.5, 2.0, 1.0),
                 ('DISK', 2.0, 0.3, math.pi), ('ELLIPSE', 2.0, 1.0, math.pi * 0.5)]
        for shape, sx, sy, area in cases:
            self.sc = S.empty_scene()
            S.add_camera((0, 0, 10))
            ob = S.add_light('AREA', (1, 1, 2), (0.3, 0.2, 0.1), energy=100.0, shape=shape,
                             size=sx, size_y=sy)
            ob.scale = (2.0, 1.0, 1.0)
            root = self.export()
            (s,) = [s for s in root.iter("shape") if s.find("emitter") is not None]
            self.assertEqual(s.get("type"), "rectangle" if shape in ('SQUARE', 'RECTANGLE')
                             else "disk")
            m = matrix_of(s)
            mw = ob.matrix_world
            # Columns: x half-size, y half-size (flipped), normal = Blender's -Z.
            ey = sy if shape in ('RECTANGLE', 'ELLIPSE') else sx
            self.assertClose(m.col[0].xyz, mw.col[0].xyz * (sx / 2), 1e-5, shape)
            self.assertClose(m.col[1].xyz, -mw.col[1].xyz * (ey / 2), 1e-5, shape)
            self.assertClose(m.col[2].xyz, -mw.col[2].xyz, 1e-5, shape)
            self.assertClose(m.col[3].xyz, mw.translation, 1e-5, shape)
            world_area = area * 2.0  # object scale 2 in x
            exp = L.area_radiance(100.0, world_area,
                                  divisor=compat.area_light_divisor(bpy.app.version))
            self.assertClose(value(s.find("emitter"), "rgb", "radiance"), exp, 1e-5, shape)
            if bpy.app.version < (4, 0, 0):
                self.assertClose([exp[0]], [100.0 / (4 * world_area)], 1e-9)

    def test_world(self):
        bg = self.sc.world.node_tree.nodes["Background"]
        bg.inputs[0].default_value = (0.2, 0.4, 0.6, 1.0)
        bg.inputs[1].default_value = 2.5
        (e,) = self.emitters("constant")
        self.assertClose(value(e, "rgb", "radiance"), [0.5, 1.0, 1.5])
        if bpy.app.version >= (5, 0, 0):
            # 5.0 deprecated world.use_nodes: the Background node is what renders
            bg.inputs[0].default_value = (0.1, 0.2, 0.3, 1.0)
            bg.inputs[1].default_value = 1.0
            (e,) = self.emitters("constant")
            self.assertClose(value(e, "rgb", "radiance"), [0.1, 0.2, 0.3])
            bg.inputs[1].default_value = 0.0
            self.assertEqual(self.emitters("constant"), [])
            return
        self.sc.world.use_nodes = False
        self.sc.world.color = (0.1, 0.2, 0.3)
        (e,) = self.emitters("constant")
        self.assertClose(value(e, "rgb", "radiance"), [0.1, 0.2, 0.3])
        self.sc.world.color = (0, 0, 0)
        self.assertEqual(self.emitters("constant"), [])


class TestMeshes(Base):
    def setUp(self):
        super().setUp()
        S.add_camera((0, 0, 10))

    def shapes(self):
        return [s for s in self.export().iter("shape") if s.get("type") == "ply"]

    def ply(self, shape):
        fn = prop(shape, "string", "filename").get("value")
        return M.read_ply(os.path.join(self.dir, fn)), fn

    def test_flat_cube_transform_uvs(self):
        bpy.ops.mesh.primitive_cube_add(size=2.0, location=(1, 2, 3), rotation=(0.1, 0.2, 0.3))
        ob = bpy.context.object
        ob.scale = (1, 2, 3)
        (s,) = self.shapes()
        self.assertClose([x for r in matrix_of(s) for x in r],
                         [x for r in ob.matrix_world for x in r])
        (verts, faces), _ = self.ply(s)
        self.assertEqual(len(faces), 12)
        self.assertEqual(len(verts), 24)  # flat: 4 corners per face, each with its normal
        for v in verts:
            n = v[3:6]
            self.assertAlmostEqual(sorted(abs(c) for c in n)[2], 1.0, places=5)
            # The normal points out of the face the vertex belongs to.
            big = max(range(3), key=lambda i: abs(n[i]))
            self.assertAlmostEqual(v[big] * n[big], 1.0, places=5)
        uvl = ob.data.uv_layers.active.data
        us = sorted({(round(u.uv[0], 5), round(1 - u.uv[1], 5)) for u in uvl})
        self.assertEqual(sorted({(round(v[6], 5), round(v[7], 5)) for v in verts}), us)

    def test_smooth_normals_and_modifiers(self):
        bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, segments=16, ring_count=8)
        ob = bpy.context.object
        bpy.ops.object.shade_smooth()
        (s,) = self.shapes()
        (verts, faces), _ = self.ply(s)
        self.assertEqual(len(faces), 16 * 6 * 2 + 2 * 16)
        for v in verts:  # smooth: vertex normals, close to radial on a sphere
            r = math.sqrt(sum(c * c for c in v[:3]))
            self.assertGreater(sum(v[3 + i] * v[i] / r for i in range(3)), 0.99)
        self.assertEqual(len(verts), len({v[:3] + v[6:] for v in verts}))
        mod = ob.modifiers.new("sub", 'SUBSURF')
        mod.levels = 1
        mod.render_levels = 1
        (s,) = self.shapes()
        (verts, faces), _ = self.ply(s)
        # Subdivided once: each quad -> 4 quads, each triangle -> 3 quads; 2 triangles a quad.
        self.assertEqual(len(faces), 2 * (16 * 6 * 4 + 2 * 16 * 3))

    def test_instances_share_and_unchanged_not_rewritten(self):
        bpy.ops.mesh.primitive_cube_add()
        a = bpy.context.object
        b = bpy.data.objects.new("b", a.data)
        b.location = (3, 0, 0)
        self.sc.collection.objects.link(b)
        s1, s2 = self.shapes()
        f1 = prop(s1, "string", "filename").get("value")
        self.assertEqual(f1, prop(s2, "string", "filename").get("value"))
        self.assertEqual(self.res.meshes_written, 1)
        path = os.path.join(self.dir, f1)
        st = os.stat(path)
        os.utime(path, (st.st_atime - 100, st.st_mtime - 100))
        mtime = os.stat(path).st_mtime
        self.shapes()
        self.assertEqual(self.res.meshes_written, 0)
        self.assertEqual(self.res.meshes_reused, 1)
        self.assertEqual(os.stat(path).st_mtime, mtime)
        a.data.vertices[0].co.x += 0.5
        s1, s2 = self.shapes()
        self.assertEqual(self.res.meshes_written, 1)
        self.assertNotEqual(prop(s1, "string", "filename").get("value"), f1)

    def test_material_slots_split(self):
        bpy.ops.mesh.primitive_cube_add()
        ob = bpy.context.object
        ob.data.materials.append(S.diffuse_material("red", (1, 0, 0)))
        ob.data.materials.append(S.diffuse_material("blue", (0, 0, 1)))
        for p in ob.data.polygons:
            p.material_index = 1 if p.index < 2 else 0
        shapes = self.shapes()
        self.assertEqual(len(shapes), 2)
        bsdfs = {b.get("id"): b for b in self.root.findall("bsdf")}
        cols = sorted(tuple(value(bsdfs[s.find("ref").get("id")].find("bsdf"), "rgb",
                                  "reflectance")) for s in shapes)
        self.assertEqual(cols, [(0.0, 0.0, 1.0), (1.0, 0.0, 0.0)])
        nfaces = sorted(len(self.ply(s)[0][1]) for s in shapes)
        self.assertEqual(nfaces, [4, 8])

    def test_visibility(self):
        bpy.ops.mesh.primitive_cube_add()
        hidden = bpy.context.object
        hidden.hide_render = True
        col = bpy.data.collections.new("hidden")
        self.sc.collection.children.link(col)
        col.hide_render = True
        me = bpy.data.meshes.new("x")
        me.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)])
        col.objects.link(bpy.data.objects.new("in_hidden", me))
        bpy.ops.mesh.primitive_cube_add(location=(4, 0, 0))
        shown = bpy.context.object
        bpy.ops.mesh.primitive_cube_add(location=(8, 0, 0))
        eye = bpy.context.object
        eye.hide_set(True)  # hidden in the viewport: File > Export leaves it out
        shapes = self.shapes()
        self.assertEqual([s.get("type") for s in shapes], ["ply"])
        fn = prop(shapes[0], "string", "filename").get("value")
        self.assertTrue(fn.startswith("meshes/%s_m0-" % shown.data.name), fn)


class TestMaterials(Base):
    def setUp(self):
        super().setUp()
        S.add_camera((0, 0, 10))
        bpy.ops.mesh.primitive_cube_add()
        self.ob = bpy.context.object

    def shape(self):
        return S.mesh_shape_bsdf(self.export())

    def set_mat(self, mat):
        self.ob.data.materials.clear()
        self.ob.data.materials.append(mat)

    def test_bsdfs(self):
        s, b = self.shape()
        self.assertEqual(b.get("type"), "diffuse")  # no material: Cycles' grey
        self.assertClose(value(b, "rgb", "reflectance"), [0.8] * 3)
        mat = bpy.data.materials.new("p")
        mat.use_nodes = True
        self.set_mat(mat)
        pr = mat.node_tree.nodes["Principled BSDF"]
        pr.inputs["Base Color"].default_value = (0.1, 0.2, 0.3, 1)
        pr.inputs["Roughness"].default_value = 0.4
        s, b = self.shape()
        self.assertEqual(b.get("type"), "principled")
        self.assertClose(value(b, "float", "roughness"), [0.4])
        self.assertClose(value(b, "rgb", "baseColor"), [0.1, 0.2, 0.3])
        self.assertClose(value(b, "float", "eta"), [1.5], 1e-4)
        self.assertClose(value(b, "float", "metallic"), [0.0])
        pr.inputs["Metallic"].default_value = 1.0
        s, b = self.shape()
        self.assertEqual(b.get("type"), "principled")
        self.assertClose(value(b, "float", "metallic"), [1.0])
        pr.inputs["Metallic"].default_value = 0.0
        tr = pr.inputs.get("Transmission") or pr.inputs.get("Transmission Weight")
        tr.default_value = 1.0
        pr.inputs["Roughness"].default_value = 0.0
        pr.inputs["IOR"].default_value = 1.33
        s, b = self.shape()
        self.assertEqual(b.get("type"), "dielectric")
        self.assertClose(value(b, "float", "intIOR"), [1.33])
        nt = mat.node_tree
        em = nt.nodes.new("ShaderNodeEmission")
        em.inputs["Color"].default_value = (1, 0.5, 0.25, 1)
        em.inputs["Strength"].default_value = 4.0
        nt.links.new(em.outputs[0], nt.nodes["Material Output"].inputs["Surface"])
        s, b = self.shape()
        self.assertClose(value(s.find("emitter"), "rgb", "radiance"), [4, 2, 1])

    def fake_presets(self):
        folder = os.path.join(self.dir, "presets")
        os.makedirs(folder)
        with open(os.path.join(folder, "SVD_S10_Test.opm"), "wb") as f:
            f.write(b"placeholder: the export only names the file")
        with open(os.path.join(folder, "SVD_S10_Test.json"), "w") as f:
            f.write('{"method": "svd", "terms": 10, "size_bytes": 1234567, '
                    '"relative_rmse": 0.0123}')
        S.prefs().preset_folders.add().path = folder
        import opaline.chooser
        opaline.chooser.clear()
        return folder

    def test_subsurface_kinds(self):
        folder = self.fake_presets()
        import opaline.chooser as C
        p = C.find("SVD_S10_Test")
        self.assertIsNotNone(p)
        self.assertEqual(p.summary(), "SVD, 10 terms, 1.2 MB, error 1.23 % (rel. RMSE), "
                                      "sample size unknown")
        mat = bpy.data.materials.new("sss")
        self.set_mat(mat)
        o = mat.opaline
        o.enabled = True
        o.preset = "SVD_S10_Test"
        self.assertIn("SVD_S10_Test", [i[0] for i in C.enum_items(o, bpy.context)])
        o.scale = 10.0
        o.ior = 1.4
        s, _ = self.shape()
        sub = s.find("subsurface")
        self.assertEqual(sub.get("type"), "svd")
        # The renderer does not know this folder: the file is named by path.
        self.assertEqual(value(sub, "string", "material"),
                         os.path.join(folder, "SVD_S10_Test.opm"))
        self.assertClose(value(sub, "float", "sceneUnitsPerMetre"), [10.0])
        # Measured Rd contains its boundary: no IOR is written for it (dipole only).
        self.assertIsNone(prop(sub, "float", "intIOR"))
        os.environ["OPALINE_PRESETS_PATH"] = folder
        try:
            s, _ = self.shape()
            self.assertEqual(value(s.find("subsurface"), "string", "material"), "SVD_S10_Test")
        finally:
            del os.environ["OPALINE_PRESETS_PATH"]
        o.kind = 'DIPOLE'
        o.dipole_material = "Ketchup"
        s, _ = self.shape()
        self.assertEqual(s.find("subsurface").get("type"), "dipole")
        self.assertEqual(value(s.find("subsurface"), "string", "material"), "Ketchup")
        o.kind = 'FILE'
        o.filepath = os.path.join(folder, "SVD_S10_Test.opm")
        s, _ = self.shape()
        self.assertEqual(s.find("subsurface").get("type"), "svd")

    def test_every_subsurface_type(self):
        """kcta and nmf presets (by report, by the .opm's own META, by name), every method in
        the file Method menu, and every dipole medium reach the scene as their type."""
        folder = self.fake_presets()
        import struct
        import opaline.chooser as C

        def opm(name, method):
            # a container with only a META section: header, META at 64, table after it
            meta = ("method=%s\nname=%s\n" % (method, name)).encode()
            table = 64 + ((len(meta) + 63) // 64) * 64
            head = b"OPALINEM" + struct.pack("<IIQQII", 1, 1, table + 32, table, 0, 0)
            body = head.ljust(64, b"\0") + meta.ljust(table - 64, b"\0")
            body += b"META".ljust(8, b"\0") + struct.pack("<QQII", 64, len(meta), 0, 0)
            with open(os.path.join(folder, name + ".opm"), "wb") as f:
                f.write(body)

        opm("KCTA_C8_T4_Test", "kcta")
        with open(os.path.join(folder, "KCTA_C8_T4_Test.json"), "w") as f:
            f.write('{"method": "kcta", "terms": 4}')
        opm("NmfFromMeta", "nmf")        # no report, no prefix: the file's META says nmf
        opm("NMF_T8_Test", "nmf")
        opm("TUCKER_T4_P2_Test", "tucker")
        opm("RAW_Test", "raw")
        C.clear()
        expect = {"KCTA_C8_T4_Test": "kcta", "NmfFromMeta": "nmf", "NMF_T8_Test": "nmf",
                  "TUCKER_T4_P2_Test": "tucker", "RAW_Test": "raw", "SVD_S10_Test": "svd"}
        mat = bpy.data.materials.new("sss")
        self.set_mat(mat)
        o = mat.opaline
        o.enabled = True
        for name, typ in expect.items():
            self.assertEqual(C.find(name).method, typ, name)
            o.kind = 'PRESET'
            o.preset = name
            s, _ = self.shape()
            self.assertEqual(s.find("subsurface").get("type"), typ, name)
            o.kind = 'FILE'
            o.filepath = os.path.join(folder, name + ".opm")
            o.file_method = 'AUTO'
            s, _ = self.shape()
            self.assertEqual(s.find("subsurface").get("type"), typ, name)
        items = [i.identifier for i in o.bl_rna.properties["file_method"].enum_items]
        self.assertEqual(set(items), {"AUTO", "svd", "tucker", "kcta", "nmf", "raw"})
        for m in ("svd", "tucker", "kcta", "nmf", "raw"):
            o.file_method = m
            s, _ = self.shape()
            self.assertEqual(s.find("subsurface").get("type"), m)
        o.kind = 'DIPOLE'
        media = [i.identifier for i in o.bl_rna.properties["dipole_material"].enum_items]
        self.assertEqual(media, ["Apple", "Chicken1", "Chicken2", "Cream", "Ketchup", "Marble",
                                 "Potato", "Skimmilk", "Skin1", "Skin2", "Spectralon",
                                 "Wholemilk"])
        for m in media:
            o.dipole_material = m
            s, _ = self.shape()
            sub = s.find("subsurface")
            self.assertEqual((sub.get("type"), value(sub, "string", "material")), ("dipole", m))

    def test_unknown_preset_reports(self):
        mat = bpy.data.materials.new("sss")
        self.set_mat(mat)
        mat.opaline.enabled = True
        mat.opaline.preset = "NO_SUCH_PRESET"
        with self.assertRaises(OpalineError) as cm:
            self.export()
        self.assertIn("unknown opaline preset 'NO_SUCH_PRESET'", str(cm.exception))
        with self.assertRaises(RuntimeError) as cm:
            bpy.ops.export_scene.opaline(filepath=self.xml)
        self.assertIn("NO_SUCH_PRESET", str(cm.exception))
        self.assertNotIn("Traceback", str(cm.exception))


class TestBadStates(Base):
    def test_no_camera(self):
        with self.assertRaises(OpalineError) as cm:
            self.export()
        self.assertIn("no camera", str(cm.exception))
        with self.assertRaises(RuntimeError) as cm:
            bpy.ops.export_scene.opaline(filepath=self.xml)
        self.assertIn("no camera", str(cm.exception))
        self.assertFalse(os.path.exists(self.xml))

    def test_missing_renderer(self):
        from opaline import preferences
        S.prefs().renderer_path = os.path.join(self.dir, "no-such-opaline-render")
        with self.assertRaises(OpalineError) as cm:
            preferences.find_renderer(bpy.context)
        self.assertIn("opaline-render not found", str(cm.exception))
        S.add_camera((0, 0, 5))
        self.sc.render.engine = 'OPALINE'
        self.sc.render.filepath = os.path.join(self.dir, "x.png")
        with self.assertRaises(RuntimeError) as cm:
            bpy.ops.render.render(write_still=True)
        self.assertIn("opaline-render not found", str(cm.exception))

    def test_operator_writes(self):
        S.add_camera((0, 0, 5))
        bpy.ops.mesh.primitive_cube_add()
        self.assertEqual(bpy.ops.export_scene.opaline(filepath=self.xml), {'FINISHED'})
        self.assertTrue(os.path.isfile(self.xml))


class TestCheck(Base):
    def test_check_full_scene(self):
        S.need_renderer(self)
        S.add_camera((0, -6, 2), (math.radians(75), 0, 0))
        S.add_floor(5.0)
        for kind, loc in (('POINT', (1, 0, 2)), ('SPOT', (0, 0, 3)), ('SUN', (0, 0, 5))):
            S.add_light(kind, loc)
        for shape in ('SQUARE', 'RECTANGLE', 'DISK', 'ELLIPSE'):
            S.add_light('AREA', (0, 0, 3), shape=shape, size=0.5, size_y=0.3)
        bpy.ops.mesh.primitive_uv_sphere_add(location=(0, 0, 1))
        bpy.ops.object.shade_smooth()
        bpy.context.object.modifiers.new("s", 'SUBSURF')
        mat = bpy.data.materials.new("p")
        mat.use_nodes = True
        bpy.context.object.data.materials.append(mat)
        self.sc.world.node_tree.nodes["Background"].inputs[0].default_value = (0.1, 0.1, 0.1, 1)
        self.export()
        S.check_xml(self, self.xml)

    def test_check_dollar_in_paths(self):
        """A `$` in a path the exporter writes (here a material file in a folder named
        'ma$terials', itself named 'm$a.opm') is written `$$`, so opaline-render reads it back as
        the path instead of as a $parameter."""
        S.need_renderer(self)
        presets = os.path.dirname(S.need_preset(self, "SVD_S10_Chess4x4"))
        folder = os.path.join(self.dir, "ma$terials")
        os.makedirs(folder)
        opm = os.path.join(folder, "m$a.opm")
        os.symlink(os.path.join(presets, "SVD_S10_Chess4x4.opm"), opm)
        S.add_camera((0, 0, 5))
        S.add_light('SUN', (0, 0, 5))
        mat = bpy.data.materials.new("m$a")
        mat.opaline.enabled = True
        mat.opaline.kind = 'FILE'
        mat.opaline.filepath = opm
        S.add_mesh("m$a", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [(0, 1, 2, 3)], mat)
        root = self.export()
        subs = list(root.iter("subsurface"))
        self.assertEqual(len(subs), 1)
        self.assertEqual(value(subs[0], "string", "material"), opm.replace("$", "$$"))
        for el in root.iter():
            for k, v in el.attrib.items():
                self.assertNotIn("$", v.replace("$$", ""), "<%s %s=%r>" % (el.tag, k, v))
        S.check_xml(self, self.xml)


if __name__ == "__main__":
    S.run_tests(TestRegistration, TestConversions, TestCamera, TestLights, TestMeshes,
                TestMaterials, TestBadStates, TestCheck)
