"""Material presets: folders holding NAME.opm (the material), NAME.png (albedo thumbnail) and
NAME.json (the factor report), as the build writes them into <build>/presets/.

The search order matches opaline-render's (docs/interfaces): the colon-separated
OPALINE_PRESETS_PATH, then the add-on preferences' extra folders, then the presets folder of the
renderer the add-on uses (<bin>/../presets), then this source tree's build/presets, then
OPALINE_PRESETS_DIR (set by the test harness). The first folder holding a name wins.
"""

import json
import os

_PREVIEWS = None          # bpy.utils.previews collection (thumbnails)
_ENUM_ITEMS = []          # kept alive: Blender needs the strings of dynamic enums to persist
_CACHE = {"key": None, "presets": []}

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


class Preset:
    """One preset found on disk; `report` is the parsed NAME.json (or {})."""

    __slots__ = ("name", "folder", "opm", "png", "report")

    def __init__(self, name, folder, report):
        self.name = name
        self.folder = folder
        self.opm = os.path.join(folder, name + ".opm")
        png = os.path.join(folder, name + ".png")
        self.png = png if os.path.isfile(png) else None
        self.report = report

    @property
    def method(self):
        """svd | tucker | raw, from the report, else from the name's prefix."""
        m = str(self.report.get("method", "")).lower()
        if m in ("svd", "tucker", "raw"):
            return m
        up = self.name.upper()
        for p in ("SVD", "TUCKER", "RAW"):
            if up.startswith(p):
                return p.lower()
        return "raw"

    def summary(self):
        """One line for the panel and tool tips: method, terms, size, error."""
        r = self.report
        parts = [self.method]
        if "terms" in r:
            parts.append("%s terms" % r["terms"])
        if "size_bytes" in r:
            parts.append(human_size(r["size_bytes"]))
        elif os.path.isfile(self.opm):
            parts.append(human_size(os.path.getsize(self.opm)))
        if "compression_ratio" in r:
            parts.append("%.0fx smaller" % float(r["compression_ratio"]))
        if "relative_rmse" in r:
            parts.append("rel. RMSE %.2f %%" % (100.0 * float(r["relative_rmse"])))
        elif "rmse" in r:
            parts.append("RMSE %.3g" % float(r["rmse"]))
        return ", ".join(parts)


def human_size(n):
    n = float(n)
    for unit in ("B", "KB", "MB", "GB"):
        if n < 1024.0 or unit == "GB":
            return ("%.0f %s" if unit == "B" else "%.1f %s") % (n, unit)
        n /= 1024.0
    return "%.1f GB" % n


def search_folders(extra_folders=(), renderer_path=None):
    """The preset folders in search order (existing folders only, no duplicates)."""
    out = []
    env = os.environ.get("OPALINE_PRESETS_PATH", "")
    cands = [p for p in env.split(":") if p]
    cands += [p for p in extra_folders if p]
    if renderer_path:
        bindir = os.path.dirname(os.path.abspath(renderer_path))
        cands.append(os.path.join(os.path.dirname(bindir), "presets"))
        cands.append(os.path.join(os.path.dirname(bindir), "share", "opaline", "presets"))
    cands.append(os.path.join(REPO_ROOT, "build", "presets"))
    if os.environ.get("OPALINE_PRESETS_DIR"):
        cands.append(os.environ["OPALINE_PRESETS_DIR"])
    for c in cands:
        c = os.path.abspath(os.path.expanduser(c))
        if os.path.isdir(c) and c not in out:
            out.append(c)
    return out


def scan(folders):
    """All presets in `folders` (first folder wins for a name), sorted by name."""
    found = {}
    for folder in folders:
        try:
            names = sorted(os.listdir(folder))
        except OSError:
            continue
        for fn in names:
            if not fn.endswith(".opm"):
                continue
            name = fn[:-4]
            if name in found:
                continue
            report = {}
            jp = os.path.join(folder, name + ".json")
            if os.path.isfile(jp):
                try:
                    with open(jp, "r", encoding="utf-8") as fh:
                        report = json.load(fh)
                    if not isinstance(report, dict):
                        report = {}
                except (OSError, ValueError):
                    report = {}
            found[name] = Preset(name, folder, report)
    return [found[k] for k in sorted(found)]


def renderer_knows(folder, renderer_path):
    """Whether opaline-render finds presets in `folder` by name without help."""
    folder = os.path.abspath(folder)
    env = [os.path.abspath(p) for p in os.environ.get("OPALINE_PRESETS_PATH", "").split(":")
           if p]
    if folder in env:
        return True
    if renderer_path:
        root = os.path.dirname(os.path.dirname(os.path.abspath(renderer_path)))
        if folder in (os.path.join(root, "presets"),
                      os.path.join(root, "share", "opaline", "presets")):
            return True
    return False


# ---------------------------------------------------------------------------------------------
# Blender side: cached scan, thumbnails, enum items.

def current(context=None, refresh=False):
    """The presets visible with the current preferences (cached until folders change)."""
    from . import preferences
    prefs = preferences.get(context)
    extra = [f.path for f in prefs.preset_folders] if prefs else []
    renderer = preferences.find_renderer(context, required=False)
    folders = search_folders(extra, renderer)
    key = tuple(folders)
    if refresh or _CACHE["key"] != key:
        _CACHE["key"] = key
        _CACHE["presets"] = scan(folders)
        _ENUM_ITEMS.clear()
    return _CACHE["presets"]


def find(name, context=None):
    for p in current(context):
        if p.name == name:
            return p
    return None


def _icon(preset):
    global _PREVIEWS
    if preset.png is None:
        return 0
    try:
        if _PREVIEWS is None:
            import bpy.utils.previews
            _PREVIEWS = bpy.utils.previews.new()
        key = preset.png
        if key not in _PREVIEWS:
            _PREVIEWS.load(key, preset.png, 'IMAGE')
        return _PREVIEWS[key].icon_id
    except Exception:  # thumbnails are a nicety; never fail the UI for them
        return 0


def enum_items(self, context):
    """Items for the preset chooser: (name, name, summary, icon, index)."""
    if not _ENUM_ITEMS:
        ps = current(context)
        if not ps:
            _ENUM_ITEMS.append(("NONE", "No presets found",
                                "Build the repository or add a preset folder in the add-on "
                                "preferences", 'ERROR', 0))
        for i, p in enumerate(ps):
            _ENUM_ITEMS.append((p.name, p.name, p.summary(), _icon(p), i))
    return _ENUM_ITEMS


def clear():
    """Frees thumbnails and caches (unregister, refresh)."""
    global _PREVIEWS
    _ENUM_ITEMS.clear()
    _CACHE["key"] = None
    _CACHE["presets"] = []
    if _PREVIEWS is not None:
        try:
            import bpy.utils.previews
            bpy.utils.previews.remove(_PREVIEWS)
        except Exception:
            pass
        _PREVIEWS = None
