"""Per-material opaline settings (Material.opaline) and per-scene render settings
(Scene.opaline)."""

import bpy
from bpy.props import (BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty,
                       StringProperty)

from . import chooser, presets

# Jensen et al. 2001 media, as named by Mitsuba's dipole `material` parameter.
DIPOLE_MATERIALS = ("Apple", "Chicken1", "Chicken2", "Cream", "Ketchup", "Marble", "Potato",
                    "Skimmilk", "Skin1", "Skin2", "Spectralon", "Wholemilk")


def _preset_get(self):
    """The chooser's value: the NONE item when no preset is chosen (nothing looks selected)."""
    items = chooser.enum_items(self, bpy.context)
    for it in items:
        if it[0] == (self.preset or chooser.NONE_ID):
            return it[4]
    return 0


def _preset_set(self, value):
    items = chooser.enum_items(self, bpy.context)
    for it in items:
        if it[4] == value:
            self.preset = "" if it[0] == chooser.NONE_ID else it[0]
            return


def _update_preview(self, context):
    from . import preview
    preview.sync(self.id_data)


class OPALINE_PG_material(bpy.types.PropertyGroup):
    enabled: BoolProperty(name="opaline subsurface", default=False,
                          description="Render this material as a measured translucent material "
                                      "(replaces the Surface shader in opaline renders)",
                          update=_update_preview)
    kind: EnumProperty(
        name="Kind",
        items=[('PRESET', "Factored preset", "A factored measured material from the preset "
                "folders (%s or %s: the type is read from the preset)"
                % (", ".join(presets.METHODS[:-1]), presets.METHODS[-1]), 'MATERIAL', 0),
               ('DIPOLE', "Dipole material type", "A homogeneous medium from the Jensen et al. "
                "2001 table, rendered with the dipole model", 'SHADING_RENDERED', 1),
               ('FILE', "Material file", "An .opm material file", 'FILE', 2)],
        default='PRESET', update=_update_preview)
    preset: StringProperty(name="Preset", description="Preset name (NAME.opm in a preset folder)",
                           update=_update_preview)
    preset_enum: EnumProperty(name="Preset", items=chooser.enum_items, get=_preset_get,
                              set=_preset_set, description="The measured material preset")
    dipole_material: EnumProperty(
        name="Material type",
        items=[(n, n, "Jensen et al. 2001 measured medium '%s'" % n) for n in DIPOLE_MATERIALS],
        default="Skin1")
    filepath: StringProperty(name="Material file", subtype='FILE_PATH',
                             description="An .opm file written by opaline-factor",
                             update=_update_preview)
    file_method: EnumProperty(
        name="Method",
        items=[('AUTO', "Auto", "From the file's report (NAME.json beside it), the file's "
                "own header, or its name"),
               ('svd', "SVD", "Truncated SVD of the log-shifted Rd (Onel, Kurt, Ozturk)"),
               ('tucker', "Tucker", "Tucker factorization with a polynomial fit"),
               ('kcta', "K-CTA", "Clustered tensor approximation"),
               ('nmf', "NMF", "Non-negative matrix factorization"),
               ('raw', "Raw", "The measured Rd, not factored")],
        default='AUTO')
    scale: FloatProperty(name="Physical scale", default=1.0, min=1e-6, soft_min=0.01,
                         soft_max=100.0,
                         description="Multiplies the material sample's physical size when it "
                                     "is laid over the surface (10: a 12.6 cm sample covers "
                                     "1.26 m)", update=_update_preview)
    ior: FloatProperty(name="Interior IOR", default=1.3, min=1.0, max=3.0,
                       description="Index of refraction inside the medium (dipole only: it "
                                   "sets the dipole's boundary; measured materials contain "
                                   "their boundary, so they have no IOR)")
    sheen: EnumProperty(
        name="Surface sheen",
        items=[('PRINCIPLED', "From Principled BSDF", "The surface reflection of the Surface's "
                "Principled BSDF: IOR from its Specular (Specular IOR Level), roughness from its "
                "Roughness; none when the Surface is not a Principled BSDF or has no specular"),
               ('ON', "On", "A dielectric surface reflection of the roughness and IOR below"),
               ('OFF', "Off", "No surface reflection: the measured subsurface look alone")],
        default='PRINCIPLED',
        description="The specular reflection of the translucent object's surface (exported as "
                    "a dielectric or roughdielectric beside the subsurface; what it does not "
                    "reflect enters the material)")
    sheen_roughness: FloatProperty(name="Sheen roughness", default=0.2, min=0.0, max=1.0,
                                   description="Roughness of the surface reflection (as "
                                               "Blender's: the GGX alpha is its square)")
    sheen_ior: FloatProperty(name="Sheen IOR", default=1.5, min=1.0, max=3.0,
                             description="Index of refraction of the surface (1.5: 4 % "
                                         "reflected at normal incidence)")


class OPALINE_PG_scene(bpy.types.PropertyGroup):
    """opaline's render settings (Render properties > opaline), exported into the scene XML
    (samples: the camera's sampleCount; max_bounces: the integrator's maxDepth; irr_samples and
    max_sss_points: each <subsurface>'s irrSamples and maxPoints) and used by F12 (threads)."""
    samples: IntProperty(name="Samples", default=64, min=1, soft_max=4096,
                         description="Paths per pixel")
    max_bounces: IntProperty(name="Max Bounces", default=8, min=0, soft_max=64,
                             description="Bounces of a path (as Cycles' Max Bounces; 0: "
                                         "direct light only; the exported maxDepth is "
                                         "bounces + 2)")
    irr_samples: IntProperty(name="Irradiance Samples", default=16, min=1, max=65536,
                             soft_max=256,
                             description="Subsurface pre-pass: paths per irradiance point "
                                         "(more: less noise in translucent objects, longer "
                                         "pre-pass)")
    max_sss_points: IntProperty(name="Irradiance Point Cap", default=0, min=0,
                                max=50000000, soft_max=5000000,
                                description="Subsurface pre-pass: most irradiance points laid "
                                            "per translucent object (0: the renderer's own "
                                            "default; else written as each <subsurface>'s "
                                            "maxPoints). Only the points near the view are "
                                            "laid; where the view needs more, they are laid "
                                            "coarser (the light is kept, the material's "
                                            "detail blurs) and, where the image can show it, "
                                            "the render warns: raise it (more memory and "
                                            "pre-pass time)")
    threads: IntProperty(name="Threads", default=0, min=0,
                         description="Worker threads for opaline-render (0: all cores)")
    keep_temp: BoolProperty(name="Keep exported files", default=False,
                            description="Keep the temporary export of each F12 render (its "
                                        "folder is printed in the report)")


classes = (OPALINE_PG_material, OPALINE_PG_scene)


def register_props():
    bpy.types.Material.opaline = PointerProperty(type=OPALINE_PG_material)
    bpy.types.Scene.opaline = PointerProperty(type=OPALINE_PG_scene)
    bpy.types.WindowManager.opaline_preset_filter = StringProperty(
        name="Filter", options={'TEXTEDIT_UPDATE'},
        description="Show the presets whose category, name, method, size or error contain "
                    "these words")


def unregister_props():
    del bpy.types.Material.opaline
    del bpy.types.Scene.opaline
    del bpy.types.WindowManager.opaline_preset_filter
