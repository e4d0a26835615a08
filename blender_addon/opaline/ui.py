"""The material panel "opaline subsurface", the render settings panel, and the File > Export
operator."""

import os

import bpy
from bpy.props import BoolProperty, EnumProperty, IntProperty, StringProperty
from bpy_extras.io_utils import ExportHelper

from . import chooser, compat, presets
from .errors import OpalineError


REPLACES_NOTE = "Replaces the Surface shader for opaline renders"
CHOOSER_COLUMNS = 4   # presets per row in the chooser (the four chessboards fill one)


def objects_without_uvs(mat, objects):
    """The mesh objects among `objects` that use material `mat` and have no UV map: a measured
    material is laid over the surface by its UVs; on them the renderer falls back to a box
    projection (seams where the projection axis changes)."""
    out = []
    for ob in objects:
        if ob.type != 'MESH' or ob.data is None or len(ob.data.uv_layers):
            continue
        if any(slot.material == mat for slot in ob.material_slots):
            out.append(ob)
    return out


def draw_material_settings(layout, context, mat):
    """The opaline settings of `mat` (shared by the panel under opaline and under other
    engines)."""
    s = mat.opaline
    col = layout.column()
    col.active = s.enabled
    col.use_property_split = True
    if s.enabled:
        col.label(text=REPLACES_NOTE, icon='SHADING_RENDERED')
    col.prop(s, "kind")
    if s.kind == 'PRESET':
        p = chooser.find(s.preset, context) if s.preset else None
        row = col.row()
        if p is not None and chooser.icon(p):
            row.template_icon(icon_value=chooser.icon(p), scale=5.0)
        sub = row.column(align=True)
        sub.context_pointer_set("material", mat)
        sub.popover(OPALINE_PT_preset_chooser.bl_idname,
                    text=p.label if p is not None else "Choose a preset", icon='MATERIAL')
        r = sub.row(align=True)
        r.operator(OPALINE_OT_preset_search.bl_idname, text="Search", icon='VIEWZOOM')
        r.operator("opaline.presets_refresh", text="", icon='FILE_REFRESH')
        if p is not None:
            box = col.box()
            box.label(text="%s  (%s)" % (p.label, p.name))
            box.label(text="Category: %s" % p.category, icon='ASSET_MANAGER')
            first, second = p.summary_lines()
            box.label(text=first, icon='INFO')
            box.label(text=second, icon='BLANK1')
            size = p.size_cm
            if size is not None:
                box.label(text="Covers %.3g x %.3g cm of the surface at Physical scale %g" % (
                    size[0] * s.scale, size[1] * s.scale, s.scale))
        elif s.preset:
            col.label(text="Unknown preset '%s'" % s.preset, icon='ERROR')
        else:
            col.label(text="No preset chosen: pick one, or search", icon='INFO')
    elif s.kind == 'DIPOLE':
        col.prop(s, "dipole_material")
        col.prop(s, "ior")
    else:
        col.prop(s, "filepath")
        col.prop(s, "file_method")
    col.prop(s, "scale")
    col.prop(s, "sheen")
    if s.sheen == 'ON':
        col.prop(s, "sheen_roughness")
        col.prop(s, "sheen_ior")
    if s.enabled and s.kind != 'DIPOLE':
        bad = objects_without_uvs(mat, context.scene.objects) if context.scene else []
        if bad:
            box = layout.box()
            box.alert = True
            names = ", ".join(ob.name for ob in bad[:3]) + (" ..." if len(bad) > 3 else "")
            box.label(text="No UV map on %s: box-projected (seams), not laid by UVs" % names,
                      icon='ERROR')
            op = box.operator(OPALINE_OT_uv_unwrap.bl_idname, icon='UV')
            op.material = mat.name


class OPALINE_PT_material(bpy.types.Panel):
    """The opaline settings under other render engines (at the bottom of the Material tab)."""
    bl_label = "opaline subsurface"
    bl_idname = "MATERIAL_PT_opaline_subsurface"
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "material"

    @classmethod
    def poll(cls, context):
        return context.material is not None and context.engine != 'OPALINE'

    def draw_header(self, context):
        self.layout.prop(context.material.opaline, "enabled", text="")

    def draw(self, context):
        draw_material_settings(self.layout, context, context.material)


class OPALINE_PT_material_engine(bpy.types.Panel):
    """The Material tab's first panel when opaline is the render engine: the material slots,
    then the opaline settings of the active material (before the Surface panel)."""
    bl_label = "opaline material"
    bl_idname = "MATERIAL_PT_opaline_engine"
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "material"
    bl_options = {'HIDE_HEADER'}
    bl_order = -1
    COMPAT_ENGINES = {'OPALINE'}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES and (context.material is not None or
                                                         context.object is not None)

    def draw(self, context):
        layout = self.layout
        ob = context.object
        mat = context.material
        if ob is not None:
            row = layout.row()
            row.template_list("MATERIAL_UL_matslots", "", ob, "material_slots", ob,
                              "active_material_index", rows=3)
            col = row.column(align=True)
            col.operator("object.material_slot_add", icon='ADD', text="")
            col.operator("object.material_slot_remove", icon='REMOVE', text="")
            layout.template_ID(ob, "active_material", new="material.new")
        elif mat is not None and context.space_data is not None:
            layout.template_ID(context.space_data, "pin_id")
        if mat is None:
            return
        box = layout.box()
        box.prop(mat.opaline, "enabled", text="opaline subsurface")
        draw_material_settings(box, context, mat)


class MaterialPanel:
    """Where the add-on's own Material tab panels under the opaline engine show: with a
    material."""
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "material"
    COMPAT_ENGINES = {'OPALINE'}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES and context.material is not None


class OPALINE_PT_surface(MaterialPanel, bpy.types.Panel):
    """The material's Surface under opaline: the nodes of its Cycles output (the one opaline's
    exporter reads), not the EEVEE output the preview nodes add; says when opaline subsurface
    replaces it."""
    bl_label = "Surface"
    bl_idname = "MATERIAL_PT_opaline_surface"

    def draw(self, context):
        layout = self.layout
        mat = context.material
        if mat.opaline.enabled:
            layout.label(text="Not used by opaline renders: opaline subsurface replaces it",
                         icon='INFO')
        if compat.has_use_nodes_toggle():
            layout.prop(mat, "use_nodes", icon='NODETREE')
        layout.use_property_split = True
        if compat.uses_nodes(mat):
            node = mat.node_tree.get_output_node('CYCLES')
            sock = node.inputs.get("Surface") if node is not None else None
            if sock is not None:
                layout.template_node_view(mat.node_tree, node, sock)
            else:
                layout.label(text="No output node")
        else:
            layout.prop(mat, "diffuse_color", text="Base Color")


class OPALINE_PT_preset_chooser(bpy.types.Panel):
    """The preset chooser, a popover of the material panel: a filter, then the presets grouped
    under their categories (the recipes' `category`), each with its thumbnail, name, method,
    size and error, and a button setting the material's preset_enum (highlighted when chosen;
    its tool tip is the enum item's summary). context.material is the material it sets (the
    caller's context_pointer_set)."""
    bl_label = "opaline presets"
    bl_idname = "OPALINE_PT_preset_chooser"
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'HEADER'   # a popover only: never drawn in the editor itself
    bl_ui_units_x = 34

    def draw(self, context):
        layout = self.layout
        mat = getattr(context, "material", None)
        wm = context.window_manager
        layout.prop(wm, "opaline_preset_filter", text="", icon='VIEWZOOM')
        every = chooser.current(context)
        groups = presets.group(every, wm.opaline_preset_filter)
        if not groups:
            layout.label(text="No preset matches '%s'" % wm.opaline_preset_filter if every else
                         "No presets found: build the repository or add a preset folder "
                         "in the add-on preferences", icon='INFO')
        for category, members in groups:
            box = layout.box()
            box.label(text=category, icon='ASSET_MANAGER')
            grid = box.grid_flow(row_major=True, columns=CHOOSER_COLUMNS, even_columns=True,
                                 even_rows=True, align=False)
            for p in members:
                cell = grid.column(align=True)
                cell.template_icon(icon_value=chooser.icon(p), scale=3.5)
                name = presets.display_parts(p.name)[0]
                if mat is not None:
                    cell.prop_enum(mat.opaline, "preset_enum", p.name, text=name)
                else:
                    cell.label(text=name)
                for line in p.brief():
                    cell.label(text=line)


class OPALINE_PT_material_preview(MaterialPanel, bpy.types.Panel):
    """The Material tab's Preview under opaline: the preset's (or material file's) albedo map,
    which Material Preview lays on the object by its UVs. Blender's own Preview panel renders
    with the scene's engine, which opaline does not do for previews."""
    bl_label = "Preview"
    bl_idname = "MATERIAL_PT_opaline_preview"

    def draw(self, context):
        from . import preview
        layout = self.layout
        mat = context.material
        path = preview.albedo_path(mat, context)
        if path is None:
            layout.label(text="opaline subsurface is off for this material" if not
                         mat.opaline.enabled else "No albedo map to show (no preset chosen, "
                         "or no NAME.png beside the material file)", icon='INFO')
            return
        layout.template_icon(icon_value=chooser.image_icon(path), scale=7.0)
        s = mat.opaline
        what = s.preset if s.kind == 'PRESET' else os.path.basename(path)
        layout.label(text="Albedo map of %s" % what, icon='IMAGE_DATA')
        layout.label(text="Material Preview lays it on the object by its UVs")


class OPALINE_OT_preset_search(bpy.types.Operator):
    """Search the presets by name, method, size, error or sample size"""
    bl_idname = "opaline.preset_search"
    bl_label = "Search Presets"
    bl_property = "preset"
    bl_options = {'REGISTER', 'UNDO', 'INTERNAL'}
    preset: EnumProperty(name="Preset", items=chooser.search_items)

    @classmethod
    def poll(cls, context):
        return context.material is not None

    def invoke(self, context, event):
        context.window_manager.invoke_search_popup(self)
        return {'RUNNING_MODAL'}

    def execute(self, context):
        context.material.opaline.preset = self.preset
        return {'FINISHED'}


class OPALINE_OT_uv_unwrap(bpy.types.Operator):
    """Unwrap the objects that use this material and have no UV map, with Blender's Smart UV
    Project"""
    bl_idname = "opaline.uv_unwrap"
    bl_label = "Unwrap UVs (Smart UV Project)"
    bl_options = {'REGISTER', 'UNDO'}
    material: StringProperty(name="Material", description="The material whose objects to unwrap")

    def execute(self, context):
        mat = bpy.data.materials.get(self.material)
        if mat is None:
            self.report({'ERROR'}, "opaline: no material named '%s'" % self.material)
            return {'CANCELLED'}
        bad = objects_without_uvs(mat, context.scene.objects)
        done, skipped = smart_uv_project(context, bad)
        for ob in skipped:
            self.report({'WARNING'}, "opaline: %s is not in the view layer; not unwrapped"
                        % ob.name)
        self.report({'INFO'}, "opaline: unwrapped %d objects" % len(done))
        return {'FINISHED'}


def smart_uv_project(context, objects):
    """Runs Smart UV Project on each mesh of `objects` (in edit mode, all faces); returns
    (unwrapped, skipped: not in the view layer). Restores the selection and mode."""
    vl = context.view_layer
    prev_active = vl.objects.active
    prev_sel = [ob for ob in vl.objects if ob.select_get()]
    prev_mode = context.mode
    if prev_mode != 'OBJECT' and prev_active is not None:
        bpy.ops.object.mode_set(mode='OBJECT')
    done, skipped, meshes = [], [], set()
    try:
        for ob in objects:
            if ob.data in meshes:
                done.append(ob)
                continue
            if vl.objects.get(ob.name) is None:
                skipped.append(ob)
                continue
            for o in vl.objects:
                o.select_set(False)
            ob.select_set(True)
            vl.objects.active = ob
            bpy.ops.object.mode_set(mode='EDIT')
            bpy.ops.mesh.select_all(action='SELECT')
            bpy.ops.uv.smart_project()
            bpy.ops.object.mode_set(mode='OBJECT')
            meshes.add(ob.data)
            done.append(ob)
    finally:
        for o in vl.objects:
            o.select_set(o in prev_sel)
        vl.objects.active = prev_active
    return done, skipped


class OPALINE_PT_render(bpy.types.Panel):
    bl_label = "opaline"
    bl_idname = "RENDER_PT_opaline"
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "render"
    COMPAT_ENGINES = {'OPALINE'}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        o = context.scene.opaline
        col = layout.column()
        col.prop(o, "samples")
        col.prop(o, "max_bounces")
        col = layout.column(heading="Subsurface Pre-pass")
        # short labels: the split layout's default width cuts longer ones ("Irradiance ...")
        col.prop(o, "irr_samples", text="Point Samples")
        col.prop(o, "max_sss_points", text="Point Cap")
        col = layout.column()
        col.prop(o, "threads")
        col.prop(o, "keep_temp")


class OPALINE_OT_export(bpy.types.Operator, ExportHelper):
    """Export the scene as opaline scene XML (meshes go into a meshes/ folder beside it)"""
    bl_idname = "export_scene.opaline"
    bl_label = "Export opaline scene"
    bl_options = {'PRESET'}
    filename_ext = ".xml"
    filter_glob: StringProperty(default="*.xml", options={'HIDDEN'})
    use_selection: BoolProperty(name="Selected Only", default=False,
                                description="Export only the selected objects (and the "
                                            "scene camera)")
    use_frame_range: BoolProperty(name="Frame Range", default=False,
                                  description="Export one XML per frame, NAME_<frame>.xml, "
                                              "sharing meshes/ (as batch.py)")
    frame_start: IntProperty(name="Start", default=1, description="First frame exported")
    frame_end: IntProperty(name="End", default=250, description="Last frame exported")
    samples: IntProperty(name="Samples", default=0, min=0,
                         description="Samples per pixel written into the XML (0: the scene's "
                                     "opaline render settings)")
    collect_materials: BoolProperty(name="Collect Materials", default=False,
                                    description="Copy every material file the scene uses "
                                                "(.opm) into materials/ beside the XML and "
                                                "name it relatively, so the export can be "
                                                "moved to another machine")

    def invoke(self, context, event):
        if not self.properties.is_property_set("frame_start"):
            self.frame_start = context.scene.frame_start
        if not self.properties.is_property_set("frame_end"):
            self.frame_end = context.scene.frame_end
        return ExportHelper.invoke(self, context, event)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.prop(self, "use_selection")
        layout.prop(self, "samples")
        layout.prop(self, "collect_materials")
        layout.prop(self, "use_frame_range")
        col = layout.column(align=True)
        col.active = self.use_frame_range
        col.prop(self, "frame_start")
        col.prop(self, "frame_end")

    def execute(self, context):
        from .export import scene as scene_export
        from . import preferences
        if self.use_frame_range and self.frame_end < self.frame_start:
            self.report({'ERROR'}, "opaline export: frame range %d-%d ends before it starts"
                        % (self.frame_start, self.frame_end))
            return {'CANCELLED'}
        frames = (self.frame_start, self.frame_end) if self.use_frame_range else None
        try:
            results = scene_export.export_frames(
                context, self.filepath, frames,
                renderer_path=preferences.find_renderer(context, required=False),
                samples=self.samples or None, selected_only=self.use_selection,
                collect_materials=self.collect_materials)
        except OpalineError as e:
            self.report({'ERROR'}, "opaline export: %s" % e)
            return {'CANCELLED'}
        except OSError as e:
            self.report({'ERROR'}, "opaline export: cannot write: %s" % e)
            return {'CANCELLED'}
        for res in results:
            for w in res.warnings:
                self.report({'WARNING'}, w)
        res = results[-1]
        self.report({'INFO'}, "opaline: wrote %s%s (%d shapes, %d lights; meshes %d written, "
                    "%d unchanged)" % (os.path.basename(res.xml_path),
                                       " and %d more frames" % (len(results) - 1)
                                       if len(results) > 1 else "", res.shapes, res.lights,
                                       res.meshes_written, res.meshes_reused))
        return {'FINISHED'}


def menu_export(self, context):
    self.layout.operator(OPALINE_OT_export.bl_idname, text="opaline scene (.xml)")


classes = (OPALINE_OT_preset_search, OPALINE_OT_uv_unwrap,
           OPALINE_PT_preset_chooser, OPALINE_PT_material, OPALINE_PT_material_engine,
           OPALINE_PT_material_preview, OPALINE_PT_surface, OPALINE_PT_render,
           OPALINE_OT_export)


def register_menus():
    bpy.types.TOPBAR_MT_file_export.append(menu_export)


def unregister_menus():
    bpy.types.TOPBAR_MT_file_export.remove(menu_export)
