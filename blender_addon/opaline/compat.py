"""The differences between the Blender versions the add-on supports (3.4 to 5.x), in one place.
Other modules ask these functions instead of testing bpy.app.version themselves."""

import bpy

VERSION = tuple(bpy.app.version)


def uses_nodes(idblock):
    """Whether a material or world renders its node tree: always since Blender 5.0, which
    deprecated `use_nodes`; before, when `use_nodes` is set."""
    if getattr(idblock, "node_tree", None) is None:
        return False
    return VERSION >= (5, 0, 0) or bool(idblock.use_nodes)


def has_use_nodes_toggle():
    """Whether materials have a "Use Nodes" switch worth showing (before 5.0)."""
    return VERSION < (5, 0, 0)
