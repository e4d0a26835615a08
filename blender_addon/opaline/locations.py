"""Where opaline's files are, as the add-on sees them: the source tree the add-on may run from,
the install prefix it may have come from, and the conventional prefixes. The install layout is
cmake/OpalineInstall.cmake's:

    PREFIX/bin/opaline-render
    PREFIX/share/opaline/presets/                       (the renderer looks there by itself)
    PREFIX/share/opaline/blender_addon/opaline/         (this package, when installed)

Paths are resolved (os.path.realpath) as the renderer resolves its own (/proc/self/exe), so a
symbolic link to the add-on or the renderer leads to the tree it belongs to. Where material
presets are found is the renderer's to say (opaline-render --preset-folders, --find-material):
the add-on asks it instead of knowing the search order. No bpy here: Blender's preferences are
passed in.
"""

import os
import subprocess

RENDERER_NAME = "opaline-render"
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


GUIDE = "blender-addon.md"


def guide_path(renderer=None):
    """The add-on's guide (docs/blender-addon.md) on this machine: the checkout's when the add-on
    runs from one, else the installed one (PREFIX/share/doc/opaline) beside the add-on's prefix or
    the renderer's (PREFIX/bin/opaline-render); None when there is none."""
    candidates = []
    root = source_root()
    if root:
        candidates.append(os.path.join(root, "docs", GUIDE))
    prefixes = [install_prefix()]
    if renderer:
        prefixes.append(os.path.dirname(os.path.dirname(os.path.realpath(renderer))))
    candidates += [os.path.join(p, "share", "doc", "opaline", GUIDE) for p in prefixes if p]
    return next((c for c in candidates if os.path.isfile(c)), None)


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


def _executable(path):
    return bool(path) and os.path.isfile(path) and os.access(path, os.X_OK)


def renderer_candidates():
    """(where, path) of each opaline-render looked for when no path is set, in order
    (renderer_dirs)."""
    return [(w, os.path.join(d, RENDERER_NAME)) for w, d in renderer_dirs()]


def find_renderer(preference=""):
    """The opaline-render to run: `preference` (the add-on preferences' path, absolute) when
    set, else the first executable of renderer_candidates(); None when there is none."""
    if preference:
        return os.path.abspath(preference) if _executable(preference) else None
    for _, c in renderer_candidates():
        if _executable(c):
            return os.path.abspath(c)
    return None


def renderer_missing_message(preference=""):
    """Why no renderer is used and what to do, in a few lines."""
    if preference:
        return ("opaline-render not found at '%s'\nfix or clear its path above (Preferences > "
                "Add-ons > opaline)" % preference)
    dirs = []
    for _, c in renderer_candidates():
        d = os.path.dirname(c)
        if d not in dirs:
            dirs.append(d)
    return ("opaline-render not found (searched %s)\ninstall it (cmake --install build --prefix "
            "~/.local), put it on PATH, or set its path in Preferences > Add-ons > opaline"
            % ", ".join(dirs))


def any_renderer(preference=""):
    """find_renderer(preference), else the first executable candidate: a renderer to ask where
    presets are installed while the preferred one is missing, or None."""
    return find_renderer(preference) or find_renderer("")


def renderer_env(extra_folders=()):
    """The environment to run opaline-render in: this process's, with extra_folders appended
    to OPALINE_PRESETS_PATH (the renderer's way of being told more preset folders)."""
    env = dict(os.environ)
    path = [p for p in env.get("OPALINE_PRESETS_PATH", "").split(":") if p]
    path += [os.path.abspath(os.path.expanduser(p)) for p in extra_folders if p]
    if path:
        env["OPALINE_PRESETS_PATH"] = ":".join(path)
    return env


_FOLDERS = {}  # (renderer, extra folders, OPALINE_PRESETS_PATH) -> its --preset-folders


def preset_folders(renderer, extra_folders=()):
    """The folders opaline-render looks preset names up in after a scene's own folder, in its
    order (--preset-folders), extra_folders among them (renderer_env); only extra_folders and
    OPALINE_PRESETS_PATH's without a renderer (None) or when it cannot say. Cached per
    renderer, folders and environment."""
    extra = tuple(extra_folders)
    key = (renderer, extra, os.environ.get("OPALINE_PRESETS_PATH", ""))
    if key not in _FOLDERS:
        env = renderer_env(extra)
        folders = [p for p in env.get("OPALINE_PRESETS_PATH", "").split(":") if p]
        if renderer:
            try:
                r = subprocess.run([renderer, "--preset-folders", "-q", "-q"], env=env,
                                   stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                                   timeout=30)
                if r.returncode == 0:
                    folders = r.stdout.decode("utf-8", "surrogateescape").splitlines()
            except (OSError, subprocess.SubprocessError):
                pass
        _FOLDERS[key] = folders
    return list(_FOLDERS[key])


def forget_preset_folders():
    """Forgets what renderers said about their preset folders (after a rescan request)."""
    _FOLDERS.clear()


def find_material(renderer, name, scene_dir=None, extra_folders=()):
    """(file or None, folders searched): where opaline-render finds the material `name` for a
    scene in scene_dir (--find-material); (None, []) when the renderer cannot be run."""
    cmd = [renderer, "--find-material", name, "-q", "-q"]
    if scene_dir is not None:
        cmd += ["--scene-dir", scene_dir]
    try:
        r = subprocess.run(cmd, env=renderer_env(extra_folders), stdout=subprocess.PIPE,
                           stderr=subprocess.DEVNULL, timeout=30)
    except (OSError, subprocess.SubprocessError):
        return None, []
    found, searched = None, []
    for line in r.stdout.decode("utf-8", "surrogateescape").splitlines():
        key, _, value = line.partition(" ")
        if key == "searched":
            searched.append(value)
        elif key == "found" and r.returncode == 0:
            found = value
    return found, searched
