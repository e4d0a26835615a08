"""Where opaline's files are, as the add-on sees them: the source tree the add-on may run from,
the install prefix it may have come from, and the conventional prefixes. The install layout is
cmake/OpalineInstall.cmake's:

    PREFIX/bin/opaline-render
    PREFIX/share/opaline/presets/                       (the renderer looks there by itself)
    PREFIX/share/opaline/blender_addon/opaline/         (this package, when installed)

Paths are resolved (os.path.realpath) as the renderer resolves its own (/proc/self/exe), so a
symbolic link to the add-on or the renderer leads to the tree it belongs to. No bpy here.
"""

import os

RENDERER_NAME = "opaline-render"
PRESETS_SUBDIR = os.path.join("share", "opaline", "presets")
ADDON_SUBDIR = os.path.join("share", "opaline", "blender_addon")
ADDON_DIR = os.path.dirname(os.path.realpath(__file__))
# Where `cmake --install` is usually pointed (README, Installing), searched after PATH.
COMMON_PREFIXES = ("~/.local", "/usr/local", "/opt/opaline", "/usr")


def source_root():
    """The repository root when the add-on runs from a checkout (ROOT/blender_addon/opaline,
    beside ROOT/CMakeLists.txt), else None."""
    root = os.path.dirname(os.path.dirname(ADDON_DIR))
    if (os.path.basename(os.path.dirname(ADDON_DIR)) == "blender_addon"
            and os.path.isfile(os.path.join(root, "CMakeLists.txt"))
            and os.path.isdir(os.path.join(root, "renderer"))):
        return root
    return None


def install_prefix():
    """PREFIX when the add-on runs from PREFIX/share/opaline/blender_addon/opaline, else None
    (an add-on installed from a zip into Blender's user folder has no prefix)."""
    parent = os.path.dirname(ADDON_DIR)
    prefix = os.path.dirname(os.path.dirname(os.path.dirname(parent)))
    if os.path.join(prefix, ADDON_SUBDIR) == parent:
        return prefix
    return None


def renderer_prefix(renderer_path):
    """The folder above the renderer's bin folder (symbolic links resolved)."""
    return os.path.dirname(os.path.dirname(os.path.realpath(renderer_path)))


def renderer_preset_folders(renderer_path):
    """The folders opaline-render searches by itself, after OPALINE_PRESETS_PATH: its installed
    presets (PREFIX/share/opaline/presets), then, for a build tree's build/bin/opaline-render,
    the build's presets folder (build/presets, compiled in)."""
    prefix = renderer_prefix(renderer_path)
    return [os.path.join(prefix, PRESETS_SUBDIR), os.path.join(prefix, "presets")]


def renderer_dirs():
    """(where, folder) of each place opaline-render is looked for when no path is set, in order:
    $OPALINE_BIN_DIR, the source tree's build/bin (when the add-on runs from a checkout),
    PREFIX/bin (when it runs from PREFIX/share/opaline/blender_addon), each PATH folder, then
    the common prefixes' bin folders (for a Blender started without the user's PATH)."""
    out = []
    if os.environ.get("OPALINE_BIN_DIR"):
        out.append(("$OPALINE_BIN_DIR", os.environ["OPALINE_BIN_DIR"]))
    root = source_root()
    if root:
        out.append(("the source tree", os.path.join(root, "build", "bin")))
    prefix = install_prefix()
    if prefix:
        out.append(("the add-on's prefix", os.path.join(prefix, "bin")))
    for d in os.environ.get("PATH", "").split(os.pathsep):
        if d:
            out.append(("PATH", d))
    for p in COMMON_PREFIXES:
        out.append(("common prefix", os.path.join(os.path.expanduser(p), "bin")))
    return out


def installed_preset_folders():
    """PREFIX/share/opaline/presets of every prefix an opaline-render is looked for in
    (renderer_dirs' bin/..), the add-on's own prefix first: the presets installed with a
    renderer stay listed when that renderer is not the one found (or none is)."""
    out = []
    for _, d in renderer_dirs():
        f = os.path.join(os.path.dirname(os.path.abspath(d)), PRESETS_SUBDIR)
        if f not in out:
            out.append(f)
    return out
