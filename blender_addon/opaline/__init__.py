"""opaline: measured translucent materials in Blender.

Pick a factored measured material preset per material, render with F12 through opaline-render,
export scenes as opaline (Mitsuba 0.5-style) XML for batch rendering. See docs/blender-addon.md
(the preferences' Open the Guide opens this machine's copy; opaline has no web site to link).
Works on Blender 3.4 (legacy add-on, bl_info) and 4.x (also as an extension:
blender_manifest.toml).
"""

bl_info = {
    "name": "opaline",
    "author": "opaline developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Render engine 'opaline'; Properties > Material > opaline subsurface; "
                "Properties > Render > opaline; File > Export > opaline scene",
    "description": "Measured heterogeneous translucent materials: presets, export, F12 render",
    "category": "Render",
}

import bpy  # noqa: E402

from . import chooser, cluster, engine, preferences, properties, ui  # noqa: E402

_classes = (preferences.classes + chooser.classes + properties.classes + ui.classes +
            cluster.classes)


def register():
    for c in _classes:
        bpy.utils.register_class(c)
    properties.register_props()
    ui.register_menus()
    engine.register_engine()


def unregister():
    engine.unregister_engine()
    ui.unregister_menus()
    properties.unregister_props()
    for c in reversed(_classes):
        bpy.utils.unregister_class(c)
    chooser.clear()
