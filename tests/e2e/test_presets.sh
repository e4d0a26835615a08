#!/usr/bin/env bash
# The preset library as built: every recipe in presets/ is documented in docs/presets.md, and
# every documented preset is in $OPALINE_PRESETS_DIR with its .opm, .png (thumbnail) and .json
# (report), and the documented pixels, physical size, file size, error and category match what
# the build made (the category: the recipe's, copied beside the preset as NAME.recipe). Reads
# the built presets only (the build makes them), so it is fast.
set -euo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup presets opaline-factor
e2e_presets
DIR=$PRESETS
ls "$DIR"/*.opm >/dev/null 2>&1 || { echo "FAIL: no presets built in $DIR"; exit 1; }

for opm in "$DIR"/*.opm; do
  "$BIN/opaline-factor" info "$opm" > "$T/$(basename "$opm" .opm).info"
done

python3 - "$SRC" "$DIR" "$T" <<'PY'
import glob, json, os, re, struct, sys
src, built, infos = sys.argv[1:4]
doc_path = os.path.join(src, "docs", "presets.md")
if not os.path.exists(doc_path):
    sys.exit("docs/presets.md is missing: the presets are not documented")
# Rows of the library table: | `NAME` | material | method | pixels, K | size cm | MB | error % | ...
rows = {}
for line in open(doc_path, encoding="utf-8"):
    m = re.match(r"\|\s*`([A-Za-z0-9_]+)`\s*\|(.*)\|\s*$", line)
    if m:
        cells = [c.strip() for c in m.group(2).split("|")]
        rows[m.group(1)] = cells
recipes = sorted(os.path.basename(p)[:-7] for p in glob.glob(os.path.join(src, "presets", "*.recipe")))
problems = []
for r in recipes:
    if r not in rows:
        problems.append("presets/%s.recipe is not documented in docs/presets.md" % r)
for chess in ("SVD_S10_Chess4x4", "SVD_S10_Chess8x8", "TUCKER_T10_P4_Chess8x8", "TUCKER_T15_P7_Chess4x4"):
    if chess not in rows:
        problems.append("the original plugin's preset %s is not documented" % chess)
if len(rows) < 9:
    problems.append("docs/presets.md lists %d presets, expected the 4 chessboards and at least 5 materials" % len(rows))
for name, cells in sorted(rows.items()):
    if name not in recipes:
        problems.append("%s is documented but has no presets/%s.recipe" % (name, name))
    paths = {ext: os.path.join(built, name + ext) for ext in (".opm", ".png", ".json")}
    missing = [p for p in paths.values() if not os.path.isfile(p) or os.path.getsize(p) == 0]
    if missing:
        problems.append("%s: not built: %s" % (name, ", ".join(missing)))
        continue
    report = json.load(open(paths[".json"]))
    png = open(paths[".png"], "rb").read(33)
    if png[:8] != b"\x89PNG\r\n\x1a\n" or png[12:16] != b"IHDR":
        problems.append("%s.png is not a PNG" % name)
        continue
    pw, ph = struct.unpack(">II", png[16:24])
    if (pw, ph) != (report["width"], report["height"]):
        problems.append("%s.png is %d x %d, the material %d x %d" % (name, pw, ph, report["width"], report["height"]))
    info = open(os.path.join(infos, name + ".info")).read()
    phys = re.search(r"physical:\s*([0-9.]+) x ([0-9.]+) cm", info)
    try:
        _, method, pixels, size_cm, mb, err = cells[:6]
    except ValueError:
        problems.append("%s: table row has %d cells, expected at least 7" % (name, len(cells) + 1))
        continue
    if method.split()[0].lower() != report["method"]:
        problems.append("%s: documented method %s, report says %s" % (name, method, report["method"]))
    want_pixels = "%d x %d, K %d" % (report["width"], report["height"], report["kernel"])
    if pixels != want_pixels:
        problems.append("%s: documented pixels '%s', built '%s'" % (name, pixels, want_pixels))
    dx, dy = (float(v) for v in re.findall(r"[0-9.]+", size_cm)[:2])
    if abs(dx - float(phys.group(1))) > 0.01 or abs(dy - float(phys.group(2))) > 0.01:
        problems.append("%s: documented size %s cm, built %s x %s cm" % (name, size_cm, phys.group(1), phys.group(2)))
    size_mb = os.path.getsize(paths[".opm"]) / 1e6
    if abs(float(mb) - size_mb) > 0.051:
        problems.append("%s: documented %s MB, built %.2f MB" % (name, mb, size_mb))
    got = 100 * report["relative_rmse"]
    doc_err = float(err.rstrip("% "))
    # Another compiler or libm moves the error a little, never by a fifth.
    if abs(got - doc_err) > 0.2 * doc_err + 0.05:
        problems.append("%s: documented error %s, the report says %.2f %%" % (name, err, got))
    # The category: the recipe's, documented in the last column, and the recipe copied beside
    # the preset (where the Blender add-on reads it).
    recipe = os.path.join(src, "presets", name + ".recipe")
    cat = None
    if os.path.isfile(recipe):
        text = open(recipe, encoding="utf-8").read()
        m = re.search(r"^[ \t]*category[ \t]*=(.*)$", text, re.M)
        cat = m.group(1).strip() if m and m.group(1).strip() else None
        copy = os.path.join(built, name + ".recipe")
        if not os.path.isfile(copy) or open(copy, encoding="utf-8").read() != text:
            problems.append("%s: the build did not copy presets/%s.recipe beside the preset" % (name, name))
    if cat is None:
        problems.append("%s: presets/%s.recipe has no category" % (name, name))
    elif cells[-1] != cat:
        problems.append("%s: documented category '%s', the recipe says '%s'" % (name, cells[-1], cat))
    print("%-28s %-8s %5.2f MB  error %5.2f %%  %-14s %s" % (name, report["method"], size_mb, got, want_pixels, cat))
if problems:
    sys.exit("\n".join(problems))
print("%d presets documented and built" % len(rows))
PY
