"""Add-on preferences (renderer path, extra preset folders) and finding opaline-render."""

import os
import shutil

import bpy
from bpy.props import CollectionProperty, IntProperty, StringProperty

from .errors import OpalineError

ADDON_ID = __package__  # "opaline", or "bl_ext.<repo>.opaline" when installed as an extension
RENDERER_NAME = "opaline-render"
REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


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
        description="Path of the opaline-render program. Empty: the one built from this "
                    "repository (build/bin), then the one on PATH")
    preset_folders: CollectionProperty(type=OPALINE_PG_folder)

    def draw(self, context):
        layout = self.layout
        layout.prop(self, "renderer_path")
        found = find_renderer(context, required=False)
        row = layout.row()
        row.label(text="Using: %s" % (found or "not found (build the repository or set the "
                                                "path above)"),
                  icon='CHECKMARK' if found else 'ERROR')
        box = layout.box()
        box.label(text="Extra preset folders (searched after OPALINE_PRESETS_PATH)")
        for i, f in enumerate(self.preset_folders):
            r = box.row(align=True)
            r.prop(f, "path", text="")
            r.operator(OPALINE_OT_folder_remove.bl_idname, text="", icon='X').index = i
        r = box.row()
        r.operator(OPALINE_OT_folder_add.bl_idname, icon='ADD')
        r.operator(OPALINE_OT_presets_refresh.bl_idname, icon='FILE_REFRESH')


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


def find_renderer(context=None, required=True):
    """The opaline-render to run: the preference if set, else $OPALINE_BIN_DIR/opaline-render,
    else the repository's build/bin/opaline-render, else PATH. Raises OpalineError (or returns
    None when not `required`) when there is none."""
    prefs = get(context)
    if prefs is not None and prefs.renderer_path:
        p = bpy.path.abspath(prefs.renderer_path)
        if _executable(p):
            return os.path.abspath(p)
        if required:
            raise OpalineError("opaline-render not found at '%s' (set in Preferences > Add-ons "
                               "> opaline)" % p)
        return None
    cands = []
    if os.environ.get("OPALINE_BIN_DIR"):
        cands.append(os.path.join(os.environ["OPALINE_BIN_DIR"], RENDERER_NAME))
    cands.append(os.path.join(REPO_ROOT, "build", "bin", RENDERER_NAME))
    for c in cands:
        if _executable(c):
            return os.path.abspath(c)
    w = shutil.which(RENDERER_NAME)
    if w:
        return w
    if required:
        raise OpalineError("opaline-render not found: build the repository "
                           "(bash scripts/quickstart.sh), put opaline-render on PATH, or set its "
                           "path in Preferences > Add-ons > opaline")
    return None


classes = (OPALINE_PG_folder, OPALINE_OT_folder_add, OPALINE_OT_folder_remove,
           OPALINE_OT_presets_refresh, OPALINE_AP_preferences)
