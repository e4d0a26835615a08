"""Material presets: folders holding NAME.opm (the material), NAME.png (albedo thumbnail) and
NAME.json (the factor report), as the build writes them into <build>/presets/.

The search order follows opaline-render's (docs/subsurface-rendering.md, "Finding the
material"): the colon-separated OPALINE_PRESETS_PATH, the add-on preferences' extra folders, the
folders the renderer in use searches by itself (PREFIX/share/opaline/presets beside its bin
folder, then a build tree's build/presets), the presets installed in each prefix a renderer is
looked for in (PREFIX/share/opaline/presets: the add-on's own prefix when it runs from
PREFIX/share/opaline/blender_addon, then $OPALINE_BIN_DIR/.., PATH's folders' .., ~/.local,
/usr/local, /opt/opaline, /usr), this source tree's build/presets, then OPALINE_PRESETS_DIR (set
by the test harness). The first folder holding a name wins. So the presets installed with a
renderer stay listed when no renderer is found (or another one is).
"""

import json
import os
import struct

from . import locations

# The measured subsurface types opaline-render accepts (<subsurface type="...">), i.e. the
# methods of the .opm container (docs/formats.md); `dipole` is not a file method.
METHODS = ("svd", "tucker", "kcta", "nmf", "raw")

_PREVIEWS = None          # bpy.utils.previews collection (thumbnails)
_ENUM_ITEMS = []          # kept alive: Blender needs the strings of dynamic enums to persist
_CACHE = {"key": None, "presets": []}


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
        """One of METHODS: from the report, else the .opm's META, else the name's prefix."""
        return method_of(self.opm, self.report)

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


def opm_meta_method(path):
    """The `method` of the META section of the .opm container at path (docs/formats.md), or
    None when the file cannot be read or has none. Reads the header and the section table only,
    not the (possibly large) data."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(40)
            if len(head) < 40 or head[:8] != b"OPALINEM":
                return None
            nsec, = struct.unpack_from("<I", head, 12)
            table, = struct.unpack_from("<Q", head, 24)
            if not 1 <= nsec <= 4096:
                return None
            fh.seek(table)
            ents = fh.read(32 * nsec)
            for i in range(len(ents) // 32):
                tag = ents[32 * i:32 * i + 8].rstrip(b"\0")
                if tag != b"META":
                    continue
                off, size = struct.unpack_from("<QQ", ents, 32 * i + 8)
                if size > 1 << 20:
                    return None
                fh.seek(off)
                for line in fh.read(size).decode("utf-8", "replace").splitlines():
                    k, _, v = line.partition("=")
                    if k.strip() == "method":
                        return v.strip().lower()
    except (OSError, ValueError, struct.error):
        return None
    return None


def method_of(opm_path, report=None):
    """The subsurface type (one of METHODS) of the material file opm_path: the factor report's
    `method` (report, or NAME.json beside the file), else the file's own META, else the name's
    prefix (SVD_..., TUCKER_..., KCTA_..., NMF_...), else raw."""
    if report is None:
        report = {}
        jp = os.path.splitext(opm_path)[0] + ".json"
        if os.path.isfile(jp):
            try:
                with open(jp, "r", encoding="utf-8") as fh:
                    report = json.load(fh)
            except (OSError, ValueError):
                report = {}
    m = str(report.get("method", "") if isinstance(report, dict) else "").lower()
    if m in METHODS:
        return m
    m = opm_meta_method(opm_path)
    if m in METHODS:
        return m
    up = os.path.basename(opm_path).upper()
    for p in METHODS:
        if up.startswith(p.upper()):
            return p
    return "raw"


def human_size(n):
    n = float(n)
    for unit in ("B", "KB", "MB", "GB"):
        if n < 1024.0 or unit == "GB":
            return ("%.0f %s" if unit == "B" else "%.1f %s") % (n, unit)
        n /= 1024.0
    return "%.1f GB" % n


def search_folders(extra_folders=(), renderer_path=None):
    """The preset folders in search order (existing folders only, no duplicates)."""
    cands = [p for p in os.environ.get("OPALINE_PRESETS_PATH", "").split(":") if p]
    cands += [p for p in extra_folders if p]
    if renderer_path:
        cands += locations.renderer_preset_folders(renderer_path)
    cands += locations.installed_preset_folders()
    root = locations.source_root()
    if root:
        cands.append(os.path.join(root, "build", "presets"))
    if os.environ.get("OPALINE_PRESETS_DIR"):
        cands.append(os.environ["OPALINE_PRESETS_DIR"])
    out = []
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
        own = [os.path.abspath(f) for f in locations.renderer_preset_folders(renderer_path)]
        return folder in own or os.path.realpath(folder) in own
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


def missing_message(name, context=None):
    """Why the preset `name` is not found, blaming what is really missing: the renderer (whose
    installed presets cannot be searched without it), else the preset, with the folders
    searched."""
    from . import preferences
    prefs = preferences.get(context)
    extra = [f.path for f in prefs.preset_folders] if prefs else []
    renderer = preferences.find_renderer(context, required=False)
    folders = search_folders(extra, renderer)
    where = ("preset folders searched: " + ", ".join(folders)) if folders else \
        "no preset folder exists"
    if renderer is None:
        return ("opaline preset '%s' not found because %s; %s" % (
            name, preferences.renderer_missing_message(context).replace("\n", ": ", 1), where))
    return "unknown opaline preset '%s' (%s; see Preferences > Add-ons > opaline)" % (
        name, where)


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
