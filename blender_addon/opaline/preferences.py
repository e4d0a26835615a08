"""Add-on preferences (renderer path, extra preset folders) and finding opaline-render."""

import os

import bpy
from bpy.props import CollectionProperty, IntProperty, StringProperty

from . import locations
from .errors import OpalineError

ADDON_ID = __package__  # "opaline", or "bl_ext.<repo>.opaline" when installed as an extension
RENDERER_NAME = locations.RENDERER_NAME


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


class OPALINE_OT_folder_remove(bpy.types.Operator):
    bl_idname = "opaline.preset_folder_remove"
    bl_label = "Remove Preset Folder"
    bl_options = {'INTERNAL'}
    index: IntProperty()

    def execute(self, context):
        p = get(context)
        if p is not None and 0 <= self.index < len(p.preset_folders):
            p.preset_folders.remove(self.index)
        from . import presets
        presets.clear()
        return {'FINISHED'}


class OPALINE_OT_presets_refresh(bpy.types.Operator):
    bl_idname = "opaline.presets_refresh"
    bl_label = "Rescan Presets"
    bl_description = "Scan the preset folders again"

    def execute(self, context):
        from . import presets
        presets.clear()
        n = len(presets.current(context, refresh=True))
        self.report({'INFO'}, "opaline: %d presets found" % n)
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
        box = layout.box()
        box.label(text="Extra preset folders (searched after OPALINE_PRESETS_PATH)")
        for i, f in enumerate(self.preset_folders):
            r = box.row(align=True)
            r.prop(f, "path", text="")
            r.operator(OPALINE_OT_folder_remove.bl_idname, text="", icon='X').index = i
        r = box.row()
        r.operator(OPALINE_OT_folder_add.bl_idname, icon='ADD')
        r.operator(OPALINE_OT_presets_refresh.bl_idname, icon='FILE_REFRESH')
        from . import cluster
        cluster.draw_preferences(self, layout)


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


def _executable(path):
    return bool(path) and os.path.isfile(path) and os.access(path, os.X_OK)


def renderer_candidates():
    """(where, path) of each opaline-render looked for when the preference is empty, in order
    (locations.renderer_dirs)."""
    return [(w, os.path.join(d, RENDERER_NAME)) for w, d in locations.renderer_dirs()]


def renderer_missing_message(context=None):
    """Why no renderer is used and what to do, in a few lines (the preferences panel and the
    errors of F12 show it)."""
    prefs = get(context)
    if prefs is not None and prefs.renderer_path:
        return ("opaline-render not found at '%s'\nfix or clear its path above (Preferences > "
                "Add-ons > opaline)" % bpy.path.abspath(prefs.renderer_path))
    dirs = []
    for _, c in renderer_candidates():
        d = os.path.dirname(c)
        if d not in dirs:
            dirs.append(d)
    return ("opaline-render not found (searched %s)\ninstall it (cmake --install build --prefix "
            "~/.local), put it on PATH, or set its path in Preferences > Add-ons > opaline"
            % ", ".join(dirs))


def find_renderer(context=None, required=True):
    """The opaline-render to run: the preference if set, else the first executable of
    renderer_candidates(). Raises OpalineError saying where it looked (or returns None when
    not `required`) when there is none."""
    prefs = get(context)
    if prefs is not None and prefs.renderer_path:
        p = bpy.path.abspath(prefs.renderer_path)
        if _executable(p):
            return os.path.abspath(p)
    else:
        for _, c in renderer_candidates():
            if _executable(c):
                return os.path.abspath(c)
    if required:
        raise OpalineError(renderer_missing_message(context).replace("\n", ": ", 1))
    return None


classes = (OPALINE_PG_folder, OPALINE_OT_folder_add, OPALINE_OT_folder_remove,
           OPALINE_OT_presets_refresh, OPALINE_AP_preferences)
