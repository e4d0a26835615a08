"""Add-on preferences (renderer path, extra preset folders, the cluster) and the opaline-render
they choose (locations.py finds it)."""

import pathlib

import bpy
from bpy.props import CollectionProperty, StringProperty

from . import locations
from .errors import OpalineError

ADDON_ID = __package__  # "opaline", or "bl_ext.<repo>.opaline" when installed as an extension


class OPALINE_PG_folder(bpy.types.PropertyGroup):
    path: StringProperty(name="Folder", subtype='DIR_PATH',
                         description="A folder holding NAME.opm, NAME.png and NAME.json presets")


class OPALINE_OT_folder_add(bpy.types.Operator):
    bl_idname = "opaline.preset_folder_add"
    bl_label = "Add Preset Folder"
    bl_options = {'INTERNAL'}

    def execute(self, context):
        p = get(context)
        if p is not None:
            p.preset_folders.add()
        return {'FINISHED'}


class OPALINE_AP_preferences(bpy.types.AddonPreferences):
    bl_idname = ADDON_ID

    renderer_path: StringProperty(
        name="opaline-render", subtype='FILE_PATH',
        description="Path of the opaline-render program. Empty: $OPALINE_BIN_DIR, the one "
                    "built beside the add-on's source (build/bin), the one installed with the "
                    "add-on (PREFIX/bin), PATH, then ~/.local/bin, /usr/local/bin, "
                    "/opt/opaline/bin, /usr/bin")
    preset_folders: CollectionProperty(type=OPALINE_PG_folder)
    cluster_command: StringProperty(
        name="opaline-cluster", subtype='FILE_PATH',
        description="Path of the opaline-cluster program (its submit command is run); set, "
                    "the Render panel shows Render on Cluster (docs/cluster.md)")
    cluster_partition: StringProperty(name="Partition",
                                      description="SLURM partition (empty: the default)")
    cluster_sbatch_args: StringProperty(name="sbatch Arguments",
                                        description="More sbatch arguments, e.g. "
                                                    "--account=lab --time=2:00:00")

    def draw(self, context):
        layout = self.layout
        layout.prop(self, "renderer_path")
        found = find_renderer(context, required=False)
        if found:
            layout.label(text="Using: %s" % found, icon='CHECKMARK')
        else:
            col = layout.column(align=True)
            for i, line in enumerate(renderer_missing_message(context).split("\n")):
                col.label(text=line, icon='ERROR' if i == 0 else 'BLANK1')
        guide = locations.guide_path(found)
        if guide:
            layout.operator("wm.url_open", text="Open the Guide",
                            icon='HELP').url = pathlib.Path(guide).as_uri()
        else:
            layout.label(text="The guide (blender-addon.md) is installed with opaline, in "
                              "share/doc/opaline", icon='HELP')
        box = layout.box()
        box.label(text="Extra preset folders (searched after OPALINE_PRESETS_PATH)")
        for i, f in enumerate(self.preset_folders):
            r = box.row(align=True)
            r.prop(f, "path", text="")
            r.operator("opaline.preset_folder_remove", text="", icon='X').index = i
        r = box.row()
        r.operator(OPALINE_OT_folder_add.bl_idname, icon='ADD')
        r.operator("opaline.presets_refresh", icon='FILE_REFRESH')
        box = layout.box()
        box.label(text="SLURM cluster (Render panel > Render on cluster)")
        box.prop(self, "cluster_command")
        box.prop(self, "cluster_partition")
        box.prop(self, "cluster_sbatch_args")


def get(context=None):
    """The add-on's preferences, or None when the add-on is not registered as an add-on (e.g. its
    module was imported and registered by a script)."""
    context = context or bpy.context
    addons = getattr(getattr(context, "preferences", None), "addons", None)
    if addons is None:
        return None
    entry = addons.get(ADDON_ID)
    if entry is None:
        # this module imported under another name than the registered add-on's (batch.py run
        # as a script while the add-on is installed as the extension bl_ext.<repo>.opaline)
        entry = next((addons[k] for k in addons.keys()
                      if k == "opaline" or k.endswith(".opaline")), None)
    return entry.preferences if entry is not None else None


def renderer_preference(context=None):
    """The renderer path set in the preferences (Blender's // resolved), or ""."""
    prefs = get(context)
    return bpy.path.abspath(prefs.renderer_path) if prefs is not None and prefs.renderer_path \
        else ""


def renderer_missing_message(context=None):
    """Why no renderer is used and what to do, in a few lines (the preferences panel and the
    errors of F12 show it)."""
    return locations.renderer_missing_message(renderer_preference(context))


def find_renderer(context=None, required=True):
    """The opaline-render to run (locations.find_renderer with the preferences' path). Raises
    OpalineError saying where it looked (or returns None when not `required`) when there is
    none."""
    found = locations.find_renderer(renderer_preference(context))
    if found is None and required:
        raise OpalineError(renderer_missing_message(context).replace("\n", ": ", 1))
    return found


classes = (OPALINE_PG_folder, OPALINE_OT_folder_add, OPALINE_AP_preferences)
