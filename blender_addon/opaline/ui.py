"""The material panel "opaline subsurface", the render settings panel, and the File > Export
operator."""

import os

import bpy
from bpy.props import StringProperty
from bpy_extras.io_utils import ExportHelper

from . import presets
from .errors import OpalineError


class OPALINE_PT_material(bpy.types.Panel):
    bl_label = "opaline subsurface"
    bl_idname = "MATERIAL_PT_opaline_subsurface"
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "material"

    @classmethod
    def poll(cls, context):
        return context.material is not None

    def draw_header(self, context):
        self.layout.prop(context.material.opaline, "enabled", text="")

    def draw(self, context):
        layout = self.layout
        s = context.material.opaline
        layout.active = s.enabled
        layout.use_property_split = True
        layout.prop(s, "kind")
        if s.kind == 'PRESET':
            col = layout.column()
            row = col.row()
            row.template_icon_view(s, "preset_enum", show_labels=True, scale=6.0,
                                   scale_popup=5.0)
            row.operator("opaline.presets_refresh", text="", icon='FILE_REFRESH')
            p = presets.find(s.preset, context) if s.preset else None
            if p is not None:
                col.label(text=p.name)
                col.label(text=p.summary(), icon='INFO')
            elif s.preset:
                col.label(text="Unknown preset '%s'" % s.preset, icon='ERROR')
            else:
                col.label(text="Choose a preset", icon='INFO')
        elif s.kind == 'DIPOLE':
            layout.prop(s, "dipole_material")
        else:
            layout.prop(s, "filepath")
            layout.prop(s, "file_method")
        layout.prop(s, "scale")
        layout.prop(s, "ior")


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
        sc = context.scene
        cy = getattr(sc, "cycles", None)
        if cy is not None:
            layout.prop(cy, "samples", text="Samples")
            layout.prop(cy, "max_bounces", text="Max Bounces")
        layout.prop(sc.opaline, "threads")
        layout.prop(sc.opaline, "keep_temp")


class OPALINE_OT_export(bpy.types.Operator, ExportHelper):
    """Export the scene as opaline scene XML (meshes go into a meshes/ folder beside it)"""
    bl_idname = "export_scene.opaline"
    bl_label = "Export opaline scene"
    bl_options = {'PRESET'}
    filename_ext = ".xml"
    filter_glob: StringProperty(default="*.xml", options={'HIDDEN'})

    def execute(self, context):
        from .export import scene as scene_export
        from . import preferences
        try:
            depsgraph = context.evaluated_depsgraph_get()
            res = scene_export.export_scene(depsgraph, self.filepath, context,
                                            preferences.find_renderer(context, required=False))
        except OpalineError as e:
            self.report({'ERROR'}, "opaline export: %s" % e)
            return {'CANCELLED'}
        except OSError as e:
            self.report({'ERROR'}, "opaline export: cannot write: %s" % e)
            return {'CANCELLED'}
        for w in res.warnings:
            self.report({'WARNING'}, w)
        self.report({'INFO'}, "opaline: wrote %s (%d shapes, %d lights; meshes %d written, %d "
                    "unchanged)" % (os.path.basename(res.xml_path), res.shapes, res.lights,
                                    res.meshes_written, res.meshes_reused))
        return {'FINISHED'}


def menu_export(self, context):
    self.layout.operator(OPALINE_OT_export.bl_idname, text="opaline scene (.xml)")


classes = (OPALINE_PT_material, OPALINE_PT_render, OPALINE_OT_export)


def register_menus():
    bpy.types.TOPBAR_MT_file_export.append(menu_export)


def unregister_menus():
    bpy.types.TOPBAR_MT_file_export.remove(menu_export)
