#!/usr/bin/env bash
# Packaging, end to end: `cmake --install` the build into a temporary prefix and move the
# prefix elsewhere (relocatable); the moved opaline-render renders a scene naming a preset with
# no OPALINE_* variable (found in the moved share/opaline/presets); the add-on package of this
# Blender (the zip for 3.4 to 4.1, the extension for 4.2+) is installed into a fresh Blender
# user folder in the temporary folder (never the user's), with the moved bin on PATH; there the
# add-on finds the renderer and the preset by itself, F12 renders a camera, a light and a cube
# of that preset, and the command-line render of the same scene's export matches it. Then the
# add-on without a renderer: the shipped presets stay listed and the errors blame the renderer.
# Skips (77) only when Blender is not installed (or the build has no presets to install).
set -euo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup install opaline-render opaline-factor opaline-cluster
BUILD=$(cd "$BIN/.." && pwd)
PRESET=SVD_S10_Chess4x4
e2e_need blender
e2e_preset $PRESET
for f in "$BUILD/opaline-blender-addon.zip" "$BUILD/opaline-blender-extension.zip"; do
  [ -f "$f" ] || { echo "FAIL: the build made no $f"; exit 1; }
done
BLENDER=$(command -v blender)

# Every OPALINE_* variable of the harness and its PYTHONPATH unset: the installed tree must need
# none.
clean=(env)
for v in $(compgen -e); do
  case $v in OPALINE_*|PYTHONPATH) clean+=(-u "$v") ;; esac
done

cmake --install "$BUILD" --prefix "$T/first" >"$T/install.log" ||
  { cat "$T/install.log"; echo "FAIL: cmake --install"; exit 1; }
mkdir -p "$T/moved"
mv "$T/first" "$T/moved/prefix"
P=$T/moved/prefix
for f in bin/opaline-render bin/opaline-factor bin/opaline-cluster share/opaline/presets/$PRESET.opm \
         share/opaline/presets/$PRESET.png share/opaline/presets/$PRESET.json \
         share/opaline/blender_addon/opaline/__init__.py \
         share/opaline/blender_addon/opaline-blender-addon.zip \
         share/opaline/blender_addon/opaline-blender-extension.zip share/doc/opaline/README.md; do
  [ -e "$P/$f" ] || { echo "FAIL: $f not installed"; exit 1; }
done
if find "$P" -name __pycache__ -o -name '*.pyc' | grep -q .; then
  echo "FAIL: __pycache__ installed"; exit 1
fi
python3 - "$P/share/opaline/blender_addon" <<'PY'
import sys, zipfile
d = sys.argv[1]
legacy = zipfile.ZipFile(d + "/opaline-blender-addon.zip").namelist()
ext = zipfile.ZipFile(d + "/opaline-blender-extension.zip").namelist()
assert "opaline/__init__.py" in legacy and "opaline/export/scene.py" in legacy, legacy
assert "blender_manifest.toml" in ext and "__init__.py" in ext and "export/scene.py" in ext, ext
for names in (legacy, ext):
    assert not [n for n in names if "__pycache__" in n or n.endswith(".pyc")], names
PY

# The moved renderer, a preset by name, no environment: found in the moved prefix.
mkdir -p "$T/cli"
sphere_scene "$T/cli/scene.xml" 48 36 2 \
  "<subsurface type=\"svd\"><string name=\"material\" value=\"$PRESET\"/><float name=\"sceneUnitsPerMetre\" value=\"15\"/><integer name=\"irrSamples\" value=\"1\"/><integer name=\"maxPoints\" value=\"3000\"/></subsurface>"
(cd "$T" && "${clean[@]}" "$P/bin/opaline-render" -v -v -t 2 -o "$T/cli/out.pfm" \
   "$T/cli/scene.xml") 2>"$T/cli/log" || { cat "$T/cli/log"; echo "FAIL: CLI render"; exit 1; }
grep -qF "material preset \"$PRESET\" is $P/share/opaline/presets/$PRESET.opm" "$T/cli/log" ||
  { cat "$T/cli/log"; echo "FAIL: the preset was not taken from the moved prefix"; exit 1; }
python3 - "$T/cli/out.pfm" <<'PY'
import math, sys
import pfm
im = pfm.read(sys.argv[1])
w, h = im.width, im.height
assert all(math.isfinite(v) for v in im.samples), "NaN or inf in the image"
def lum(x, y):  # y from the top
    return sum(im.pixel(x, y)) / 3
sphere, corner = lum(w // 2, h // 2), lum(0, 0)
print("CLI render: sphere %.4f, corner %.4f" % (sphere, corner))
assert sphere > 0.02 and sphere > corner, "the sphere is not lit"
PY
# A missing preset's error names the moved prefix's presets folder among those searched.
sed "s/\"$PRESET\"/\"NO_SUCH_PRESET\"/" "$T/cli/scene.xml" > "$T/cli/missing.xml"
rc=0
"${clean[@]}" "$P/bin/opaline-render" --check "$T/cli/missing.xml" 2>"$T/cli/missing.log" || rc=$?
[ "$rc" = 2 ] && grep -qF "$P/share/opaline/presets" "$T/cli/missing.log" ||
  { cat "$T/cli/missing.log"; echo "FAIL: missing preset: exit $rc, searched list"; exit 1; }

# A fresh Blender user folder inside $T; the moved bin first on PATH; no OPALINE_* variable.
U=$T/blender-user
mkdir -p "$U/config" "$U/scripts" "$U/datafiles" "$U/extensions" "$T/home"
benv=("${clean[@]}" HOME="$T/home" XDG_CONFIG_HOME="$T/home/.config"
      BLENDER_USER_RESOURCES="$U" BLENDER_USER_CONFIG="$U/config"
      BLENDER_USER_SCRIPTS="$U/scripts" BLENDER_USER_DATAFILES="$U/datafiles"
      BLENDER_USER_EXTENSIONS="$U/extensions" PATH="$P/bin:/usr/bin:/bin")
version=$("${benv[@]}" "$BLENDER" --version 2>/dev/null | awk '/^Blender / { print $2; exit }')
major=${version%%.*}
minor=${version#*.}; minor=${minor%%.*}
if [ "$major" -gt 4 ] || { [ "$major" = 4 ] && [ "$minor" -ge 2 ]; }; then
  package=$P/share/opaline/blender_addon/opaline-blender-extension.zip
  "${benv[@]}" "$BLENDER" --command extension install-file -r user_default -e "$package" \
    >"$T/addon-install.log" 2>&1 || { cat "$T/addon-install.log"; echo "FAIL: extension install"; exit 1; }
else
  package=$P/share/opaline/blender_addon/opaline-blender-addon.zip
  cat > "$T/addon_install.py" <<'PY'
import sys, addon_utils, bpy
bpy.ops.preferences.addon_install(filepath=sys.argv[-1], overwrite=True)
addon_utils.enable("opaline", default_set=True, handle_error=None)
bpy.ops.wm.save_userpref()
PY
  "${benv[@]}" "$BLENDER" --background --python-exit-code 1 --python "$T/addon_install.py" \
    -- "$package" >"$T/addon-install.log" 2>&1 ||
    { cat "$T/addon-install.log"; echo "FAIL: add-on install"; exit 1; }
fi
echo "Blender $version: installed $(basename "$package")"

cat > "$T/f12.py" <<'PY'
import importlib, math, os, subprocess, sys, traceback
import bpy

P, T, PRESET, TESTS = sys.argv[-4:]
sys.path.insert(0, TESTS)
import pfm
renderer_want = os.path.join(P, "bin", "opaline-render")
key = next((k for k in bpy.context.preferences.addons.keys()
            if k == "opaline" or k.endswith(".opaline")), None)
assert key is not None, "the installed add-on is not enabled: %s" % list(
    bpy.context.preferences.addons.keys())
mod = importlib.import_module(key)
assert os.path.realpath(mod.__file__).startswith(os.path.realpath(os.path.join(T, "blender-user"))), \
    "the add-on runs from %s, not from the user folder" % mod.__file__
prefs_mod = importlib.import_module(key + ".preferences")
chooser_mod = importlib.import_module(key + ".chooser")
OpalineError = importlib.import_module(key + ".errors").OpalineError
found = prefs_mod.find_renderer(bpy.context, required=False)
assert found == renderer_want, "the add-on found the renderer %r, not %r" % (found, renderer_want)
names = {p.name: p for p in chooser_mod.current(bpy.context, refresh=True)}
assert PRESET in names, "preset %s not listed: %s" % (PRESET, sorted(names))
assert names[PRESET].folder == os.path.join(P, "share", "opaline", "presets"), names[PRESET].folder
print("add-on %s: renderer %s, %d presets" % (key, found, len(names)))

# A camera, a light and a cube of the preset (and a dim world).
for ob in list(bpy.data.objects):
    bpy.data.objects.remove(ob, do_unlink=True)
sc = bpy.context.scene
sc.render.engine = 'OPALINE'
sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 40, 30, 100
sc.cycles.samples = 4
sc.render.image_settings.file_format = 'OPEN_EXR'
sc.render.image_settings.color_depth = '32'
sc.view_settings.view_transform = 'Standard'
cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
cam.location = (0.0, -2.0, 1.1)
cam.rotation_euler = (math.radians(64), 0.0, 0.0)
sc.collection.objects.link(cam)
sc.camera = cam
light = bpy.data.objects.new("key", bpy.data.lights.new("key", 'POINT'))
light.data.energy = 300.0
light.location = (1.0, -1.5, 2.5)
sc.collection.objects.link(light)
world = sc.world or bpy.data.worlds.new("World")
sc.world = world
world.use_nodes = True
world.node_tree.nodes["Background"].inputs[0].default_value = (0.05, 0.05, 0.05, 1.0)
me = bpy.data.meshes.new("cube")
s = 0.2
me.from_pydata([(x, y, z) for x in (-s, s) for y in (-s, s) for z in (0.0, 2 * s)], [],
               [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)])
me.update()
cube = bpy.data.objects.new("cube", me)
sc.collection.objects.link(cube)
mat = bpy.data.materials.new("measured")
mat.opaline.enabled = True
mat.opaline.kind = 'PRESET'
mat.opaline.preset = PRESET
mat.opaline.scale = 40.0
me.materials.append(mat)

# F12 through the engine, then the command-line render of the File > Export of the same scene.
sc.render.filepath = os.path.join(T, "f12.exr")
bpy.ops.render.render(write_still=True)
xml = os.path.join(T, "export", "scene.xml")
assert bpy.ops.export_scene.opaline(filepath=xml) == {'FINISHED'}
text = open(xml).read()
assert 'value="%s"' % PRESET in text, "the export names the preset by path, not by name"
env = {k: v for k, v in os.environ.items() if not k.startswith("OPALINE_")}
cli = os.path.join(T, "cli.pfm")
r = subprocess.run([renderer_want, "-q", "-t", "2", "-o", cli, xml], env=env,
                   stdout=subprocess.PIPE, stderr=subprocess.PIPE)
assert r.returncode == 0, r.stderr.decode(errors="replace")

im = bpy.data.images.load(sc.render.filepath)
w, h = im.size
f12 = list(im.pixels)  # RGBA, bottom row first
cli_image = pfm.read(cli)
cw, ch = cli_image.width, cli_image.height
ref = cli_image.samples  # RGB, bottom row first
assert (w, h) == (cw, ch) == (40, 30), (w, h, cw, ch)
worst = 0.0
total = 0.0
for i in range(w * h):
    for c in range(3):
        a, b = f12[4 * i + c], ref[3 * i + c]
        assert math.isfinite(a) and math.isfinite(b)
        worst = max(worst, abs(a - b) / max(1.0, abs(b)))
        total += b
mean = total / (3 * w * h)
cube_px = sum(ref[3 * ((h // 2) * w + w // 2):3 * ((h // 2) * w + w // 2) + 3]) / 3
corner = sum(ref[0:3]) / 3
print("F12 vs command line: worst relative difference %.3g, mean %.4f, cube centre %.4f, "
      "corner %.4f" % (worst, mean, cube_px, corner))
assert cube_px > 0.02 and cube_px > corner, "the cube is not lit (%.4f)" % cube_px
# The same scene file, renderer, seed and sample count: F12 and the command line compute the same
# floats (per-pixel random streams, no dependence on threads); 2e-3 leaves room for nothing more
# than storage rounding, as in tests/addon/test_engine.py.
assert worst < 2e-3, "F12 and the command line differ by %g" % worst

bpy.ops.wm.save_as_mainfile(filepath=os.path.join(T, "scene.blend"))  # for the batch run below

# No renderer: a wrong path set. The presets installed with the renderer on PATH stay listed,
# and F12 says the renderer is missing.
prefs = bpy.context.preferences.addons[key].preferences
prefs.renderer_path = os.path.join(T, "no-such", "opaline-render")
assert prefs_mod.find_renderer(bpy.context, required=False) is None
names = [p.name for p in chooser_mod.current(bpy.context)]
assert PRESET in names, "the shipped presets vanished with the renderer path set wrong: %s" % names
try:
    bpy.ops.render.render(write_still=False)
    raise AssertionError("F12 without a renderer succeeded")
except RuntimeError as e:
    assert "opaline-render not found at" in str(e), str(e)
# No renderer anywhere (not on PATH, no path set): the export blames the renderer, not the
# preset; the preferences say where they looked.
prefs.renderer_path = ""
os.environ["PATH"] = "/usr/bin:/bin"
assert prefs_mod.find_renderer(bpy.context, required=False) is None
msg = prefs_mod.renderer_missing_message(bpy.context)
assert msg.startswith("opaline-render not found (searched ") and "/usr/bin" in msg, msg
try:
    bpy.ops.export_scene.opaline(filepath=os.path.join(T, "export2", "scene.xml"))
    raise AssertionError("the export of a preset nobody provides succeeded")
except RuntimeError as e:
    assert "because opaline-render not found" in str(e), str(e)
    assert "unknown opaline preset" not in str(e), str(e)
print("OK")
sys.exit(0)  # a failed render (above, on purpose) would otherwise make Blender's status 1
PY
"${benv[@]}" "$BLENDER" --background --python-exit-code 1 --python "$T/f12.py" -- "$P" "$T" "$PRESET" "$SRC/tests" \
  >"$T/f12.log" 2>&1 || { cat "$T/f12.log"; echo "FAIL: F12 in Blender $version"; exit 1; }
grep -E "^(add-on|F12 vs|OK)" "$T/f12.log"

# Batch export with the installed add-on's batch.py run as a script (a second copy of the package,
# named "opaline", while the enabled one may be the extension bl_ext.user_default.opaline): it
# must find that add-on's preferences. The renderer is only in the preferences (not on PATH), so
# the preset can be named only if they were found.
cat > "$T/set_pref.py" <<'PY'
import sys, bpy
key = next(k for k in bpy.context.preferences.addons.keys() if k == "opaline" or k.endswith(".opaline"))
bpy.context.preferences.addons[key].preferences.renderer_path = sys.argv[-1]
bpy.ops.wm.save_userpref()
PY
"${benv[@]}" "$BLENDER" --background --python-exit-code 1 --python "$T/set_pref.py" --   "$P/bin/opaline-render" >"$T/pref.log" 2>&1 || { cat "$T/pref.log"; echo "FAIL: setting the preference"; exit 1; }
batch=$(find "$U" -name batch.py -path '*/opaline/batch.py' | head -n 1)
[ -n "$batch" ] || { echo "FAIL: the installed add-on has no batch.py"; exit 1; }
nopath=("${benv[@]}" PATH=/usr/bin:/bin)
"${nopath[@]}" "$BLENDER" -b "$T/scene.blend" --python "$batch" -- --out "$T/batch" --frames 1 \
  >"$T/batch.log" 2>&1 || { cat "$T/batch.log"; echo "FAIL: batch.py with the installed add-on"; exit 1; }
grep -q "value=\"$PRESET\"" "$T"/batch/*_0001.xml ||
  { cat "$T/batch.log"; echo "FAIL: the batch export does not name the preset"; exit 1; }
echo "batch.py ($(basename "$(dirname "$(dirname "$batch")")")) found the add-on's preferences"
