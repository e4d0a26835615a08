"""The preset chooser's Blender side: the presets the current preferences see (scanned once
per set of folders), their thumbnails, the enum items of the chooser and its search, the message
for a preset that is not found, and the preferences' operators that change or rescan the preset
folders."""

import bpy
from bpy.props import IntProperty

from . import locations, preferences, presets

_PREVIEWS = None          # bpy.utils.previews collection (thumbnails)
_ENUM_ITEMS = []          # kept alive: Blender needs the strings of dynamic enums to persist
_CACHE = {"key": None, "presets": []}


def _folders(context):
    """The preset folders with the current preferences: the renderer in use (else any
    installed one) says them."""
    prefs = preferences.get(context)
    extra = [bpy.path.abspath(f.path) for f in prefs.preset_folders if f.path] if prefs else []
    return presets.search_folders(locations.any_renderer(preferences.renderer_preference(context)),
                                  extra)



def current(context=None, refresh=False):
    """The presets visible with the current preferences (cached until folders change)."""
    folders = _folders(context)
    key = tuple(folders)
    if refresh or _CACHE["key"] != key:
        _CACHE["key"] = key
        _CACHE["presets"] = presets.scan(folders)
        _ENUM_ITEMS.clear()
    return _CACHE["presets"]


def find(name, context=None):
    for p in current(context):
        if p.name == name:
            return p
    return None


def missing_message(name, context=None):
    """Why the preset `name` is not found, blaming what is really missing: the renderer (whose
    installed presets cannot be searched without it), else the preset, with the folders
    searched."""
    renderer = preferences.find_renderer(context, required=False)
    folders = _folders(context)
    where = ("preset folders searched: " + ", ".join(folders)) if folders else \
        "no preset folder exists"
    if renderer is None:
        return ("opaline preset '%s' not found because %s; %s" % (
            name, preferences.renderer_missing_message(context).replace("\n", ": ", 1), where))
    return "unknown opaline preset '%s' (%s; see Preferences > Add-ons > opaline)" % (
        name, where)


def image_icon(path):
    """The icon id of the image file at path (a thumbnail loaded once into the add-on's
    previews), or 0 when path is None or it cannot be loaded."""
    global _PREVIEWS
    if path is None:
        return 0
    try:
        if _PREVIEWS is None:
            import bpy.utils.previews
            _PREVIEWS = bpy.utils.previews.new()
        if path not in _PREVIEWS:
            _PREVIEWS.load(path, path, 'IMAGE')
        return _PREVIEWS[path].icon_id
    except Exception:  # thumbnails are a nicety; never fail the UI for them
        return 0


def icon(preset):
    """The icon id of the preset's thumbnail (its albedo map), or 0."""
    return image_icon(preset.png)


NONE_ID = "NONE"


def enum_items(self, context):
    """Items for the preset chooser: (name, label, summary, icon, index). The first item,
    NONE_ID, stands for "no preset chosen" (so that no preset looks selected when none is)."""
    if not _ENUM_ITEMS:
        ps = current(context)
        if ps:
            _ENUM_ITEMS.append((NONE_ID, "No preset", "No preset chosen", 'BLANK1', 0))
        else:
            _ENUM_ITEMS.append((NONE_ID, "No presets found",
                                "Build the repository or add a preset folder in the add-on "
                                "preferences", 'ERROR', 0))
        labels = [p.label for p in ps]
        i = 0
        for category, members in presets.group(ps):
            for p in members:
                i += 1
                label = p.label if labels.count(p.label) == 1 else p.name
                _ENUM_ITEMS.append((p.name, label, "%s (%s): %s" % (p.name, category,
                                                                    p.summary()), icon(p), i))
    return _ENUM_ITEMS


_SEARCH_ITEMS = []


def search_items(self, context):
    """Items for the preset search popup: the label says category, name, method, MB, error
    and sample size, so typing any of them ("stone", "svd", "marble", "12.6 cm") finds a
    preset."""
    _SEARCH_ITEMS[:] = [(p.name, "%s / %s  -  %s" % (c, p.label, p.summary()), p.name)
                        for c, members in presets.group(current(context)) for p in members]
    return _SEARCH_ITEMS


def clear():
    """Frees thumbnails and caches (unregister, refresh)."""
    global _PREVIEWS
    locations.forget_preset_folders()
    _ENUM_ITEMS.clear()
    _SEARCH_ITEMS.clear()
    _CACHE["key"] = None
    _CACHE["presets"] = []
    if _PREVIEWS is not None:
        try:
            import bpy.utils.previews
            bpy.utils.previews.remove(_PREVIEWS)
        except Exception:
            pass
        _PREVIEWS = None


class OPALINE_OT_folder_remove(bpy.types.Operator):
    bl_idname = "opaline.preset_folder_remove"
    bl_label = "Remove Preset Folder"
    bl_options = {'INTERNAL'}
    index: IntProperty()

    def execute(self, context):
        p = preferences.get(context)
        if p is not None and 0 <= self.index < len(p.preset_folders):
            p.preset_folders.remove(self.index)
        clear()
        return {'FINISHED'}


class OPALINE_OT_presets_refresh(bpy.types.Operator):
    bl_idname = "opaline.presets_refresh"
    bl_label = "Rescan Presets"
    bl_description = "Scan the preset folders again"

    def execute(self, context):
        clear()
        n = len(current(context, refresh=True))
        self.report({'INFO'}, "opaline: %d presets found" % n)
        return {'FINISHED'}


classes = (OPALINE_OT_folder_remove, OPALINE_OT_presets_refresh)
