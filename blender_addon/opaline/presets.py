"""Material presets: folders holding NAME.opm (the material), NAME.png (albedo thumbnail),
NAME.json (the factor report) and NAME.recipe (the build's recipe, presets/NAME.recipe: the
preset's category), as the build writes them into <build>/presets/.

The folders and their order are opaline-render's (--preset-folders; docs/rendering.md, "Finding
materials"): the add-on adds the extra folders of its preferences through OPALINE_PRESETS_PATH
and asks the renderer, so that what the chooser lists is what the renderer finds. The first
folder holding a name wins. No bpy here: chooser.py is the Blender side.
"""

import json
import os

from . import locations
from .opm import meta as opm_meta  # the META dict of a .opm, {} when unreadable

# The measured subsurface types opaline-render accepts (<subsurface type="...">), i.e. the
# methods of the .opm container (docs/formats.md); `dipole` is not a file method.
METHODS = ("svd", "tucker", "kcta", "nmf", "raw")

# The chooser's group of a preset without a category (no NAME.recipe beside it, or none in it):
# listed after every named category.
OTHER = "Other"



class Preset:
    """One preset found on disk; `report` is the parsed NAME.json (or {})."""

    __slots__ = ("name", "folder", "opm", "png", "report", "_size_cm", "_category")

    def __init__(self, name, folder, report):
        self.name = name
        self.folder = folder
        self.opm = os.path.join(folder, name + ".opm")
        png = os.path.join(folder, name + ".png")
        self.png = png if os.path.isfile(png) else None
        self.report = report
        self._size_cm = False
        self._category = None

    @property
    def method(self):
        """One of METHODS: from the report, else the .opm's META, else the name's prefix."""
        return method_of(self.opm, self.report)

    @property
    def label(self):
        """A short label that tells presets apart when the chooser cuts it: the material's
        name first, then the method and its parameters ("Chess4x4 (SVD S10)")."""
        return display_label(self.name)

    @property
    def category(self):
        """The chooser's group: the recipe's `category` (NAME.recipe beside the .opm), else
        OTHER."""
        if self._category is None:
            c = recipe_keys(os.path.join(self.folder, self.name + ".recipe")).get("category")
            self._category = c or OTHER
        return self._category

    @property
    def size_cm(self):
        """(width, height) of the material sample in cm, from the .opm's META, or None."""
        if self._size_cm is False:
            self._size_cm = opm_size_cm(self.opm)
        return self._size_cm

    def file_bytes(self):
        if "size_bytes" in self.report:
            return int(self.report["size_bytes"])
        try:
            return os.path.getsize(self.opm)
        except OSError:
            return None

    def brief(self):
        """The chooser's two lines under the name: method and parameters; size in MB and error
        ("TUCKER T16 P4", "3.0 MB, 4.39 %")."""
        n = self.file_bytes()
        parts = [megabytes(n)] if n is not None else []
        if "relative_rmse" in self.report:
            parts.append("%.2f %%" % (100.0 * float(self.report["relative_rmse"])))
        return display_parts(self.name)[1] or self.method.upper(), ", ".join(parts)

    def summary_lines(self):
        """Two lines for the panel: method, terms, size in MB; the error and the sample's
        physical size."""
        r = self.report
        parts = [self.method.upper()]
        if "terms" in r:
            parts.append("%s terms" % r["terms"])
        n = self.file_bytes()
        if n is not None:
            parts.append(megabytes(n))
        if "compression_ratio" in r:
            parts.append("%.0fx smaller" % float(r["compression_ratio"]))
        if "relative_rmse" in r:
            err = "error %.2f %% (rel. RMSE)" % (100.0 * float(r["relative_rmse"]))
        elif "rmse" in r:
            err = "error %.3g (RMSE)" % float(r["rmse"])
        else:
            err = "error unknown (no report)"
        return ", ".join(parts), "%s, %s" % (err, physical_size_text(self.size_cm))

    def summary(self):
        """One line for tool tips and the search: method, terms, size in MB, error, the
        sample's physical size."""
        return ", ".join(self.summary_lines())


def megabytes(n):
    """n bytes in MB (1 MB = 2^20 bytes), e.g. '11.5 MB'."""
    mb = float(n) / (1 << 20)
    return ("%.1f MB" if mb >= 0.1 else "%.2f MB") % mb


def physical_size_text(size_cm):
    if size_cm is None:
        return "sample size unknown"
    return "sample %.3g x %.3g cm" % size_cm


def display_parts(name):
    """(material, method) of a preset name: 'SVD_S10_Chess4x4' -> ('Chess4x4', 'SVD S10');
    a name without a method prefix -> (name, '')."""
    toks = name.split("_")
    if len(toks) < 2 or toks[0].lower() not in METHODS:
        return name, ""
    i = 1
    while i < len(toks) - 1 and toks[i][:1].isalpha() and toks[i].rstrip("0123456789") != toks[i] \
            and toks[i].rstrip("0123456789").isalpha():
        i += 1
    return "_".join(toks[i:]), " ".join([toks[0].upper()] + toks[1:i])


def display_label(name):
    """name as the chooser shows it: 'SVD_S10_Chess4x4' -> 'Chess4x4 (SVD S10)' (method prefix
    and its parameters moved after the material's name); other names unchanged."""
    material, method = display_parts(name)
    return "%s (%s)" % (material, method) if method else name


def recipe_keys(path):
    """The `key = value` lines of a preset recipe (presets/CMakeLists.txt: '#' comments and
    blank lines skipped) as a dict, or {} when the file cannot be read."""
    out = {}
    try:
        with open(path, "r", encoding="utf-8") as fh:
            for line in fh:
                line = line.strip()
                if not line or line.startswith("#"):
                    continue
                k, sep, v = line.partition("=")
                if sep:
                    out[k.strip()] = v.strip()
    except (OSError, ValueError):
        return {}
    return out


def group(presets, text=""):
    """The presets whose name, label, category or summary contain every word of `text` (any
    case), grouped by category for the chooser: [(category, [preset, ...]), ...], categories
    in alphabetical order with OTHER last, presets by label within each."""
    words = text.lower().split()
    groups = {}
    for p in presets:
        if words:
            hay = " ".join((p.name, p.label, p.category, p.summary())).lower()
            if not all(w in hay for w in words):
                continue
        groups.setdefault(p.category, []).append(p)
    order = sorted(groups, key=lambda c: (c == OTHER, c.lower()))
    return [(c, sorted(groups[c], key=lambda p: (p.label.lower(), p.name))) for c in order]


def opm_meta_method(path):
    """The `method` of the .opm's META (lower case), or None."""
    m = opm_meta(path).get("method")
    return m.lower() if m else None


def opm_size_cm(path):
    """(width, height) in cm of the material sample in the .opm at path (META size_x_cm,
    size_y_cm), or None when the file does not say."""
    meta = opm_meta(path)
    try:
        w, h = float(meta["size_x_cm"]), float(meta["size_y_cm"])
    except (KeyError, ValueError):
        return None
    return (w, h) if w > 0.0 and h > 0.0 else None


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


def search_folders(renderer_path=None, extra_folders=()):
    """The preset folders in the renderer's search order (locations.preset_folders; the
    extra folders of the add-on preferences among them), existing ones only, no duplicates."""
    out = []
    for c in locations.preset_folders(renderer_path, extra_folders):
        c = os.path.abspath(os.path.expanduser(c))
        if os.path.isdir(c) and c not in out:
            out.append(c)
    return out


def renderer_finds(preset, renderer_path, scene_dir):
    """Whether opaline-render, for a scene in scene_dir, finds this preset's file by its name
    alone (in its environment, without the add-on's extra folders): then a scene may name it."""
    if not renderer_path:
        return False
    found, _ = locations.find_material(renderer_path, preset.name, scene_dir)
    return found is not None and os.path.realpath(found) == os.path.realpath(preset.opm)


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
