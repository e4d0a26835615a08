"""The material panel and render settings under the opaline engine: which standard
panels show, where the opaline panel sits and what it says, the render settings reaching the
XML, the Interior IOR only where it acts, the no-UV warning and its fix, the preset chooser's
items, its categories (from the recipes) and filter, the albedo preview nodes the add-on
manages, and the Material tab's Preview panel under opaline."""

import os
import pathlib
import struct
import sys
import unittest
import xml.etree.ElementTree as ET

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_support as S  # noqa: E402

import bpy  # noqa: E402


def fake_opm(path, method, size_cm=None):
    """A container with only a META section (what the add-on reads: method, physical size)."""
    meta = "method=%s\n" % method
    if size_cm is not None:
        meta += "size_x_cm=%g\nsize_y_cm=%g\n" % size_cm
    meta = meta.encode()
    table = 64 + ((len(meta) + 63) // 64) * 64
    head = b"OPALINEM" + struct.pack("<IIQQII", 1, 1, table + 32, table, 0, 0)
    body = head.ljust(64, b"\0") + meta.ljust(table - 64, b"\0")
    body += b"META".ljust(8, b"\0") + struct.pack("<QQII", 64, len(meta), 0, 0)
    with open(path, "wb") as f:
        f.write(body)


def fake_png(path, rgb=(0.2, 0.5, 0.8)):
    im = bpy.data.images.new("albedo_src", 4, 4)
    im.pixels = [c for _ in range(16) for c in (rgb[0], rgb[1], rgb[2], 1.0)]
    im.filepath_raw = path
    im.file_format = 'PNG'
    im.save()
    bpy.data.images.remove(im)


class Rec:
    """A fake UILayout that records the properties drawn and the label texts."""

    def __init__(self, log=None):
        self.log = log if log is not None else {"props": [], "labels": [], "ops": []}

    def prop(self, data, name, **kw):
        self.log["props"].append(name)
        self.log.setdefault("texts", []).append(kw.get("text", data.bl_rna.properties[name].name
                                                        if hasattr(data, "bl_rna") else name))
        return type(self)(self.log)

    def label(self, text="", **kw):
        self.log["labels"].append(text)
        return type(self)(self.log)

    def operator(self, idname, **kw):
        self.log["ops"].append(idname)

        class Props:
            pass
        return Props()

    def __getattr__(self, name):   # sub-layouts (box, column, grid_flow ...) record too
        return lambda *a, **k: type(self)(self.log)

    def __setattr__(self, name, value):
        object.__setattr__(self, name, value)


class Base(unittest.TestCase):
    def setUp(self):
        self.sc = S.empty_scene()
        self.dir = S.tmpdir(self.id().split(".")[-1])
        self.xml = os.path.join(self.dir, "scene.xml")
        self.sc.render.engine = 'OPALINE'

    def presets(self):
        """Two presets of one material with different methods (names sharing a long prefix,
        as the chessboards do), with reports, albedo maps and physical sizes."""
        folder = os.path.join(self.dir, "presets")
        os.makedirs(folder)
        fake_opm(os.path.join(folder, "SVD_S10_Chessboard4x4.opm"), "svd", (12.6, 12.6))
        fake_opm(os.path.join(folder, "SVD_S20_Chessboard4x4.opm"), "svd", (12.6, 12.6))
        fake_opm(os.path.join(folder, "TUCKER_T15_P7_Chessboard4x4.opm"), "tucker", (6.3, 6.3))
        with open(os.path.join(folder, "SVD_S10_Chessboard4x4.json"), "w") as f:
            f.write('{"method": "svd", "terms": 10, "size_bytes": 12071808, '
                    '"relative_rmse": 0.0184553273}')
        fake_png(os.path.join(folder, "SVD_S10_Chessboard4x4.png"))
        fake_png(os.path.join(folder, "TUCKER_T15_P7_Chessboard4x4.png"), (0.9, 0.1, 0.1))
        S.prefs().preset_folders.add().path = folder
        import opaline.chooser
        opaline.chooser.clear()
        return folder

    def plane(self, mat, uv=True):
        ob = S.add_mesh("plane", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [(0, 1, 2, 3)],
                        mat)
        if uv:
            ob.data.uv_layers.new(name="UVMap")
        return ob

    def export(self, **kw):
        self.res = S.export(self.xml, **kw)
        return ET.parse(self.xml).getroot()


def _all_panels():
    out = []

    def walk(c):
        for s in c.__subclasses__():
            out.append(s)
            walk(s)
    walk(bpy.types.Panel)
    return out


class TestPanels(Base):
    def test_only_what_opaline_uses(self):
        """Under opaline, Cycles' settings (denoise, noise threshold, light paths, motion blur,
        light groups ...) must not show: before, adding 'OPALINE' to a Cycles panel added it to
        the set every Cycles panel shares (100 panels)."""
        shown = sorted({p.__name__ for p in _all_panels()
                        if getattr(p, "bl_space_type", "") == 'PROPERTIES'
                        and 'OPALINE' in (getattr(p, "COMPAT_ENGINES", None) or ())})
        self.assertLess(len(shown), 25, shown)
        for key in ("OPALINE_PT_render", "OPALINE_PT_material_engine", "RENDER_PT_format",
                    "RENDER_PT_frame_range", "DATA_PT_lens", "DATA_PT_EEVEE_light",
                    "EEVEE_WORLD_PT_surface", "OPALINE_PT_surface"):
            self.assertIn(key, shown)
        # One Surface panel: EEVEE's would show the preview nodes' EEVEE output.
        self.assertNotIn("EEVEE_MATERIAL_PT_surface", shown)
        self.assertNotIn("CYCLES_MATERIAL_PT_surface", shown)
        for cycles_only in ("CYCLES_RENDER_PT_sampling_render_denoise",
                            "CYCLES_RENDER_PT_sampling_render", "CYCLES_RENDER_PT_motion_blur",
                            "CYCLES_OBJECT_PT_lightgroup", "CYCLES_RENDER_PT_light_paths"):
            self.assertNotIn(cycles_only, shown)
        cy = getattr(bpy.types, "CYCLES_RENDER_PT_sampling", None)
        if cy is not None:   # Cycles' own panels keep showing under Cycles only
            self.assertEqual(set(cy.COMPAT_ENGINES) & {'OPALINE'}, set())
            self.assertIn('CYCLES', cy.COMPAT_ENGINES)
        import opaline.engine as E
        # Unregistering gives the shared sets back untouched.
        E.unregister_engine()
        try:
            self.assertFalse([p.__name__ for p in _all_panels()
                              if 'OPALINE' in (getattr(p, "COMPAT_ENGINES", None) or ())
                              and not p.__name__.startswith("OPALINE_PT_")])
        finally:
            E.register_engine()

    def test_material_panel_first_under_opaline(self):
        from opaline import ui
        eng = ui.OPALINE_PT_material_engine
        self.assertLess(eng.bl_order, 0)       # before the slots' Surface panel (order 0)
        self.assertEqual(eng.bl_context, "material")
        mat = bpy.data.materials.new("m")

        class Ctx:
            material = mat
            object = None
            engine = 'OPALINE'
            scene = self.sc
            space_data = None
        self.assertTrue(eng.poll(Ctx()))
        self.assertFalse(ui.OPALINE_PT_material.poll(Ctx()))   # no second copy below
        Ctx.engine = 'CYCLES'
        self.assertFalse(eng.poll(Ctx()))
        self.assertTrue(ui.OPALINE_PT_material.poll(Ctx()))
        # It says what it replaces, once a material is enabled.
        rec = Rec()
        ui.draw_material_settings(rec, Ctx(), mat)
        self.assertNotIn(ui.REPLACES_NOTE, rec.log["labels"])
        mat.opaline.enabled = True
        rec = Rec()
        ui.draw_material_settings(rec, Ctx(), mat)
        self.assertIn("Replaces the Surface shader for opaline renders", rec.log["labels"])

    def test_ior_only_for_the_dipole(self):
        from opaline import ui
        mat = bpy.data.materials.new("m")
        mat.opaline.enabled = True

        class Ctx:
            material = mat
            scene = self.sc
        for kind, shown in (('PRESET', False), ('FILE', False), ('DIPOLE', True)):
            mat.opaline.kind = kind
            rec = Rec()
            ui.draw_material_settings(rec, Ctx(), mat)
            self.assertEqual("ior" in rec.log["props"], shown, kind)
        # ... and in the XML: intIOR for the dipole only.
        S.add_camera((0, 0, 5))
        mat.opaline.dipole_material = "Ketchup"
        mat.opaline.ior = 1.4
        self.plane(mat)
        sub = self.export().find("shape").find("subsurface")
        self.assertEqual(sub.get("type"), "dipole")
        (ior,) = [c for c in sub if c.get("name") == "intIOR"]
        self.assertAlmostEqual(float(ior.get("value")), 1.4, places=6)


class TestRenderSettings(Base):
    def test_exported(self):
        folder = self.presets()
        S.add_camera((0, 0, 5))
        o = self.sc.opaline
        o.samples, o.max_bounces, o.irr_samples, o.max_sss_points, o.threads = 9, 2, 48, 123456, 3
        mat = bpy.data.materials.new("sss")
        mat.opaline.enabled = True
        mat.opaline.preset = "SVD_S10_Chessboard4x4"
        self.plane(mat)
        root = self.export()
        sampler = root.find("sensor").find("sampler")
        self.assertEqual([c.get("value") for c in sampler if c.get("name") == "sampleCount"],
                         ["9"])
        self.assertEqual([c.get("value") for c in root.find("integrator")
                          if c.get("name") == "maxDepth"], ["4"])
        sub = root.find("shape").find("subsurface")
        vals = {c.get("name"): c.get("value") for c in sub}
        self.assertEqual(vals["irrSamples"], "48")
        self.assertEqual(vals["maxPoints"], "123456")
        self.assertEqual(vals["material"], os.path.join(folder, "SVD_S10_Chessboard4x4.opm"))
        # The panel shows them all.
        from opaline import ui
        rec = Rec()

        class Self:
            layout = rec

        class Ctx:
            scene = self.sc
        ui.OPALINE_PT_render.draw(Self(), Ctx())
        for p in ("samples", "max_bounces", "irr_samples", "max_sss_points", "threads"):
            self.assertIn(p, rec.log["props"])
        # labels that the split layout's default width shows whole (as Cycles' "Max Bounces")
        for text in rec.log["texts"]:
            if text != "Keep exported files":  # a checkbox: its label has the whole width
                self.assertLessEqual(len(text), 13, text)

    def test_point_cap_default(self):
        """The Irradiance Point Cap's default (0) writes no maxPoints: the renderer's own
        default (--limit sss-max-points) applies."""
        self.presets()
        S.add_camera((0, 0, 5))
        self.assertEqual(self.sc.opaline.max_sss_points, 0)
        mat = bpy.data.materials.new("sss")
        mat.opaline.enabled = True
        mat.opaline.preset = "SVD_S10_Chessboard4x4"
        self.plane(mat)
        sub = self.export().find("shape").find("subsurface")
        names = [c.get("name") for c in sub]
        self.assertIn("irrSamples", names)
        self.assertNotIn("maxPoints", names)


class TestNoUV(Base):
    def test_warned_and_fixed(self):
        self.presets()
        S.add_camera((0, 0, 5))
        mat = bpy.data.materials.new("sss")
        mat.opaline.enabled = True
        mat.opaline.preset = "SVD_S10_Chessboard4x4"
        ob = self.plane(mat, uv=False)
        root = self.export()
        warned = [w for w in self.res.warnings if "no UV map" in w]
        self.assertEqual(len(warned), 1, self.res.warnings)
        self.assertIn("plane", warned[0])
        self.assertIn("box projection at the material's physical size", warned[0])
        # The generated projection: no (0, 0) UVs that would collapse the material to one
        # texel; the PLY has no u, v, so the renderer box-projects at the physical size.
        from opaline.export import meshes as M
        fn = [c.get("value") for c in root.find("shape") if c.get("name") == "filename"][0]
        verts, _ = M.read_ply(os.path.join(self.dir, fn))
        self.assertEqual(len(verts[0]), 6)
        with open(os.path.join(self.dir, fn), "rb") as f:
            self.assertNotIn(b"property float u", f.read(400))
        # The panel says so and offers the unwrap.
        from opaline import ui

        class Ctx:
            scene = self.sc
        rec = Rec()
        ui.draw_material_settings(rec, Ctx(), mat)
        self.assertTrue(any("No UV map on plane" in t for t in rec.log["labels"]),
                        rec.log["labels"])
        self.assertIn("opaline.uv_unwrap", rec.log["ops"])
        # The fix: Blender's Smart UV Project, on request.
        self.assertEqual(bpy.ops.opaline.uv_unwrap(material=mat.name), {'FINISHED'})
        self.assertEqual(len(ob.data.uv_layers), 1)
        uvs = [tuple(d.uv) for d in ob.data.uv_layers[0].data]
        self.assertGreater(len(set(uvs)), 1)          # a real unwrap, not one point
        root = self.export()
        self.assertFalse([w for w in self.res.warnings if "no UV map" in w])
        fn = [c.get("value") for c in root.find("shape") if c.get("name") == "filename"][0]
        self.assertEqual(len(M.read_ply(os.path.join(self.dir, fn))[0][0]), 8)
        rec = Rec()
        ui.draw_material_settings(rec, Ctx(), mat)
        self.assertFalse(any("No UV map" in t for t in rec.log["labels"]))


class TestPresetChooser(Base):
    def test_items(self):
        folder = self.presets()
        import opaline.chooser as C
        mat = bpy.data.materials.new("m")
        items = C.enum_items(mat.opaline, bpy.context)
        # Nothing chosen: the chooser shows the "no preset" item, not the first preset.
        self.assertEqual(items[0][0], C.NONE_ID)
        self.assertEqual(mat.opaline.preset_enum, C.NONE_ID)
        presets = [i for i in items[1:] if "Chessboard" in i[0]]   # the built ones aside
        self.assertEqual([i[0] for i in presets], ["SVD_S10_Chessboard4x4",
                                                   "SVD_S20_Chessboard4x4",
                                                   "TUCKER_T15_P7_Chessboard4x4"])
        labels = [i[1] for i in presets]
        self.assertEqual(len(set(labels)), 3, labels)
        # The material's name leads, so cut labels still differ: the first 12 characters
        # tell the methods apart.
        self.assertEqual(labels[0], "Chessboard4x4 (SVD S10)")
        self.assertEqual(labels[2], "Chessboard4x4 (TUCKER T15 P7)")
        desc = presets[0][2]
        for part in ("SVD_S10_Chessboard4x4", "SVD", "11.5 MB", "error 1.85 %",
                     "sample 12.6 x 12.6 cm"):
            self.assertIn(part, desc)
        self.assertIn("sample 6.3 x 6.3 cm", presets[2][2])
        self.assertIn("TUCKER", presets[2][2])
        self.assertIn("error unknown", presets[2][2])
        # Choosing and clearing through the chooser.
        mat.opaline.preset_enum = "TUCKER_T15_P7_Chessboard4x4"
        self.assertEqual(mat.opaline.preset, "TUCKER_T15_P7_Chessboard4x4")
        mat.opaline.preset_enum = C.NONE_ID
        self.assertEqual(mat.opaline.preset, "")
        # The search: every preset, labelled with what one would type.
        found = [i for i in C.search_items(None, bpy.context) if "Chessboard" in i[0]]
        self.assertEqual(len(found), 3)
        self.assertIn("12.6 x 12.6 cm", found[0][1])
        self.assertIn("Chessboard4x4 (SVD S10)", found[0][1])
        with bpy.context.temp_override(material=mat):
            bpy.ops.opaline.preset_search('EXEC_DEFAULT', preset="SVD_S20_Chessboard4x4")
        self.assertEqual(mat.opaline.preset, "SVD_S20_Chessboard4x4")


class TestPreviewNodes(Base):
    def test_created_updated_removed(self):
        folder = self.presets()
        mat = bpy.data.materials.new("m")
        mat.use_nodes = True
        nt = mat.node_tree
        user = nt.nodes.new("ShaderNodeBsdfGlossy")
        user.name = "my glossy"
        nt.links.new(user.outputs[0], nt.nodes["Material Output"].inputs["Surface"])
        before = sorted(n.name for n in nt.nodes)
        links_before = sorted((l.from_node.name, l.to_node.name) for l in nt.links)
        from opaline import preview
        mat.opaline.enabled = True
        self.assertEqual(preview.managed_nodes(mat), {})   # no preset yet
        mat.opaline.preset = "SVD_S10_Chessboard4x4"
        m = preview.managed_nodes(mat)
        self.assertEqual(sorted(m), ["albedo", "bsdf", "output"])
        self.assertEqual(os.path.realpath(bpy.path.abspath(m["albedo"].image.filepath)),
                         os.path.realpath(os.path.join(folder, "SVD_S10_Chessboard4x4.png")))
        self.assertEqual(m["output"].target, 'EEVEE')
        self.assertTrue(m["output"].inputs["Surface"].is_linked)
        # The user's output still feeds Cycles and the exporter.
        self.assertEqual(nt.nodes["Material Output"].inputs["Surface"].links[0].from_node.name,
                         "my glossy")
        mat.opaline.preset = "TUCKER_T15_P7_Chessboard4x4"
        m = preview.managed_nodes(mat)
        self.assertTrue(m["albedo"].image.filepath.endswith("TUCKER_T15_P7_Chessboard4x4.png"))
        self.assertEqual(len(nt.nodes), len(before) + 3)
        mat.opaline.enabled = False
        self.assertEqual(sorted(n.name for n in nt.nodes), before)
        self.assertEqual(sorted((l.from_node.name, l.to_node.name) for l in nt.links),
                         links_before)
        # The Surface panel under opaline shows the user's (Cycles) output, not the preview's.
        mat.opaline.enabled = True
        from opaline import ui
        drawn = []

        class Layout(Rec):
            def template_node_view(self, ntree, node, sock):
                drawn.append(node.name)

        class Self:
            layout = Layout()

        class Ctx:
            material = mat
        ui.OPALINE_PT_surface.draw(Self(), Ctx())
        self.assertEqual(drawn, ["Material Output"])
        self.assertIn("Not used by opaline renders: opaline subsurface replaces it",
                      Self.layout.log["labels"])
        mat.opaline.enabled = False
        # A user's node that merely shares the name prefix is never removed.
        lookalike = nt.nodes.new("ShaderNodeTexImage")
        lookalike.name = preview.PREFIX + "albedo"
        mat.opaline.enabled = True
        mat.opaline.enabled = False
        self.assertIn(lookalike.name, [n.name for n in nt.nodes])


def ctx_for(mat, scene):
    class Ctx:
        material = mat
        object = None
        engine = 'OPALINE'
        space_data = None
        preferences = bpy.context.preferences
        window_manager = bpy.context.window_manager
    Ctx.scene = scene
    return Ctx()


class TestPresetCategories(Base):
    LIBRARY = {"Stone": ["TUCKER_T16_P4_CarraraMarble", "TUCKER_T16_P4_Jade"],
               "Wax & soap": ["SVD_S10_LayeredWax", "SVD_S10_Soap"],
               "Skin & organic": ["SVD_S12_Skin"],
               "Reference (Kurt et al. plugin)": ["SVD_S10_Chess4x4", "SVD_S10_Chess8x8",
                                                  "TUCKER_T10_P4_Chess8x8",
                                                  "TUCKER_T15_P7_Chess4x4"]}

    def test_built_library_grouped(self):
        """The build's presets carry their recipes' categories to the chooser."""
        S.need_preset(self, "SVD_S10_Chess4x4")
        import opaline.presets as P
        import opaline.chooser as C
        C.clear()
        built = [p for p in C.current(bpy.context) if p.folder == S.presets_dir()]
        groups = {c: sorted(p.name for p in members) for c, members in P.group(built)}
        self.assertEqual(groups, self.LIBRARY)
        # The category is the recipe's, copied beside the preset by the build.
        src = os.path.join(S.SOURCE_DIR, "presets", "SVD_S10_Chess4x4.recipe")
        with open(src) as f, open(os.path.join(S.presets_dir(), "SVD_S10_Chess4x4.recipe")) as g:
            self.assertEqual(f.read(), g.read())
        # Searchable by category, in the filter and in the search popup.
        self.assertEqual([c for c, _ in P.group(built, "stone")], ["Stone"])
        self.assertEqual([p.name for c, ms in P.group(built, "kurt svd") for p in ms],
                         ["SVD_S10_Chess4x4", "SVD_S10_Chess8x8"])
        labels = [i[1] for i in C.search_items(None, bpy.context)]
        self.assertTrue(any(t.startswith("Wax & soap / Soap (SVD S10)") for t in labels), labels)

    def test_categories_order_filter_and_chooser(self):
        folder = self.presets()
        with open(os.path.join(folder, "TUCKER_T15_P7_Chessboard4x4.recipe"), "w") as f:
            f.write("# a recipe\ndataset = chess4x4\nmethod = tucker\n"
                    "category = Reference (Kurt et al. plugin)\n")
        with open(os.path.join(folder, "SVD_S20_Chessboard4x4.recipe"), "w") as f:
            f.write("category = A first group\n")
        import opaline.presets as P
        import opaline.chooser as C
        C.clear()
        ps = [p for p in C.current(bpy.context) if p.folder == folder]
        groups = P.group(ps)
        # Alphabetical, presets without a category (no recipe beside them) last.
        self.assertEqual([c for c, _ in groups],
                         ["A first group", "Reference (Kurt et al. plugin)", P.OTHER])
        self.assertEqual([p.name for p in groups[-1][1]], ["SVD_S10_Chessboard4x4"])
        self.assertEqual(P.group(ps, "no such words"), [])
        self.assertEqual([p.name for _, ms in P.group(ps, "TUCKER kurt") for p in ms],
                         ["TUCKER_T15_P7_Chessboard4x4"])
        # The chooser's items follow the groups.
        mat = bpy.data.materials.new("m")
        items = [i for i in C.enum_items(mat.opaline, bpy.context) if "Chessboard" in i[0]]
        self.assertEqual([i[0] for i in items], ["SVD_S20_Chessboard4x4",
                                                 "TUCKER_T15_P7_Chessboard4x4",
                                                 "SVD_S10_Chessboard4x4"])
        self.assertIn("(Reference (Kurt et al. plugin))", items[1][2])
        # The chooser popover: a heading per category, a thumbnail and a button per preset.
        from opaline import ui
        mat.opaline.enabled = True
        wm = bpy.context.window_manager
        wm.opaline_preset_filter = "chessboard"   # only the test's presets
        drawn = {"icons": [], "buttons": []}

        class Layout(Rec):
            def template_icon(self, icon_value=0, **kw):
                drawn["icons"].append(icon_value)

            def prop_enum(self, data, prop, value, text="", **kw):
                drawn["buttons"].append((data.id_data.name, prop, value, text))

        class Self:
            layout = Layout()
        mat.opaline.preset = "SVD_S20_Chessboard4x4"
        ui.OPALINE_PT_preset_chooser.draw(Self(), ctx_for(mat, self.sc))
        log = Self.layout.log
        self.assertIn("opaline_preset_filter", log["props"])
        for c in ("A first group", "Reference (Kurt et al. plugin)", P.OTHER):
            self.assertIn(c, log["labels"])
        # Each button sets this material's preset_enum to its preset (Blender highlights the
        # chosen one): the groups' order, the material's name as the text.
        self.assertEqual(drawn["buttons"],
                         [("m", "preset_enum", "SVD_S20_Chessboard4x4", "Chessboard4x4"),
                          ("m", "preset_enum", "TUCKER_T15_P7_Chessboard4x4", "Chessboard4x4"),
                          ("m", "preset_enum", "SVD_S10_Chessboard4x4", "Chessboard4x4")])
        self.assertIn("TUCKER T15 P7", log["labels"])
        self.assertIn("11.5 MB, 1.85 %", log["labels"])
        # A thumbnail each (icon ids are 0 in the background: the thumbnails are loaded).
        self.assertEqual(len(drawn["icons"]), 3)
        self.assertEqual(sorted(os.path.basename(k) for k in C._PREVIEWS.keys()
                                if k.startswith(folder)),
                         ["SVD_S10_Chessboard4x4.png", "TUCKER_T15_P7_Chessboard4x4.png"])
        mat.opaline.preset_enum = "TUCKER_T15_P7_Chessboard4x4"
        self.assertEqual(mat.opaline.preset, "TUCKER_T15_P7_Chessboard4x4")
        # Nothing matches: it says so.
        wm.opaline_preset_filter = "no such words"
        Self.layout = Layout()
        ui.OPALINE_PT_preset_chooser.draw(Self(), ctx_for(mat, self.sc))
        self.assertIn("No preset matches 'no such words'", Self.layout.log["labels"])
        wm.opaline_preset_filter = ""
        # The material panel opens the chooser and shows the category.
        rec = Rec()
        ui.draw_material_settings(rec, ctx_for(mat, self.sc), mat)
        self.assertIn("Category: Reference (Kurt et al. plugin)", rec.log["labels"])


class TestPreviewPanel(Base):
    def test_registered_and_draws(self):
        from opaline import ui
        import opaline.chooser as C
        panel = ui.OPALINE_PT_material_preview
        self.assertEqual(getattr(bpy.types, panel.bl_idname, None), panel)   # registered
        self.assertEqual(panel.bl_context, "material")
        self.assertEqual(panel.bl_label, "Preview")
        mat = bpy.data.materials.new("m")
        ctx = ctx_for(mat, self.sc)
        self.assertTrue(panel.poll(ctx))
        ctx.engine = 'CYCLES'
        self.assertFalse(panel.poll(ctx))
        ctx.engine = 'OPALINE'
        # One Preview panel under opaline: Blender's renders nothing without an engine preview.
        blender_preview = getattr(bpy.types, "MATERIAL_PT_preview", None)
        self.assertNotIn('OPALINE', getattr(blender_preview, "COMPAT_ENGINES", None) or set())
        drawn = []

        class Layout(Rec):
            def template_icon(self, icon_value=0, **kw):
                drawn.append(icon_value)

        def draw():
            class Self:
                layout = Layout()
            drawn.clear()
            panel.draw(Self(), ctx)
            return Self.layout.log["labels"]
        self.assertIn("opaline subsurface is off for this material", draw())
        self.assertEqual(drawn, [])
        folder = self.presets()
        mat.opaline.enabled = True
        self.assertTrue(draw()[0].startswith("No albedo map to show"))
        mat.opaline.preset = "SVD_S10_Chessboard4x4"
        labels = draw()
        png = os.path.join(folder, "SVD_S10_Chessboard4x4.png")
        self.assertEqual(drawn, [C.image_icon(png)])
        # The thumbnail is the preset's albedo map (icon ids are 0 in the background).
        self.assertEqual(tuple(C._PREVIEWS[png].image_size), (4, 4))
        self.assertIn("Albedo map of SVD_S10_Chessboard4x4", labels)
        # A material file: the NAME.png beside it.
        mat.opaline.kind = 'FILE'
        mat.opaline.filepath = os.path.join(folder, "TUCKER_T15_P7_Chessboard4x4.opm")
        labels = draw()
        self.assertEqual(drawn, [C.image_icon(os.path.join(
            folder, "TUCKER_T15_P7_Chessboard4x4.png"))])
        self.assertIn("Albedo map of TUCKER_T15_P7_Chessboard4x4.png", labels)


class TestGuide(Base):
    def test_preferences_open_the_local_guide(self):
        """The preferences' Open the Guide opens this machine's docs/blender-addon.md (run from
        a checkout: the repository's), not a web address that does not exist."""
        from opaline import locations
        guide = locations.guide_path()
        self.assertIsNotNone(guide)
        self.assertTrue(guide.endswith(os.path.join("docs", "blender-addon.md")))
        self.assertTrue(os.path.isfile(guide))
        rec = Rec()
        urls = []

        class Op:
            def __setattr__(self, name, value):
                urls.append(value)

        rec.operator = lambda idname, **kw: (rec.log["ops"].append(idname), Op())[1]
        prefs = S.prefs()

        class Self:
            layout = rec

            def __getattr__(self, name):
                return getattr(prefs, name)

        type(prefs).draw(Self(), bpy.context)
        self.assertIn("wm.url_open", rec.log["ops"])
        self.assertIn(pathlib.Path(guide).as_uri(), urls)
        from opaline import bl_info
        self.assertNotIn("doc_url", bl_info)


if __name__ == "__main__":
    S.run_tests(TestPanels, TestRenderSettings, TestNoUV, TestPresetChooser, TestPreviewNodes,
                TestPresetCategories, TestPreviewPanel, TestGuide)
