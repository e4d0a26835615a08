#!/usr/bin/env bash
# Screenshots of the Blender add-on under a real (virtual) display: opens Blender under Xvfb
# with a small scene (a jade sphere and a wax cube), saves the Material tab, the preset chooser
# open, the F12 render window during the subsurface pre-pass and while tiles arrive, and the
# Info editor after a successful F12 with warnings and a failing one; checks that each warning
# and error reaches the Info editor exactly once. Not a test of the suite (a minute or two).
#
#   scripts/addon-screenshots.sh [BUILD [OUTDIR]]
#
# BUILD: a build folder with bin/opaline-render and presets/ (default: build); OUTDIR: where
# the PNGs go (default: docs/blender-addon). Installs Xvfb (install-deps.sh --screenshots)
# when it is missing. Exit: 0 the screenshots were saved and every report was in the Info
# editor once; 1 a screenshot is missing or a report was missing or repeated (the PNGs made
# are still saved); 2 usage, no Blender, or the build lacks the renderer or presets.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
BUILD=$(cd "${1:-$ROOT/build}" 2>/dev/null && pwd) || { echo "addon-screenshots: no build folder '${1:-$ROOT/build}'" >&2; exit 2; }
OUTDIR=${2:-$ROOT/docs/blender-addon}
[ -x "$BUILD/bin/opaline-render" ] && ls "$BUILD"/presets/*.opm >/dev/null 2>&1 ||
  { echo "addon-screenshots: $BUILD has no bin/opaline-render or presets/*.opm: build it first (cmake --build $BUILD)" >&2; exit 2; }
command -v blender >/dev/null || { echo "addon-screenshots: blender is not installed (scripts/install-deps.sh)" >&2; exit 2; }
if ! command -v xvfb-run >/dev/null; then
  bash "$ROOT/scripts/install-deps.sh" --screenshots
fi

T=$(mktemp -d "${TMPDIR:-/tmp}/opaline-screenshots.XXXXXX")
trap 'rm -rf "$T"' EXIT
export OPALINE_SOURCE_DIR=$ROOT OPALINE_BIN_DIR=$BUILD/bin OPALINE_PRESETS_DIR=$BUILD/presets
export TMPDIR=$T   # the add-on's F12 export folders too
driver=$ROOT/scripts/addon-screenshots.py

blender --background --factory-startup --python-exit-code 1 --python "$driver" -- setup "$T/scene.blend" \
  > "$T/setup.log" 2>&1 || { cat "$T/setup.log" >&2; echo "addon-screenshots: the scene could not be made" >&2; exit 1; }
# The add-on enabled before the file loads (its engine is the scene's), from this checkout.
mkdir -p "$T/scripts/addons"
ln -s "$ROOT/blender_addon/opaline" "$T/scripts/addons/opaline"
# -a: a free display number; the window fills the 1280 x 800 screen.
BLENDER_USER_SCRIPTS=$T/scripts timeout 600 xvfb-run -a -s "-screen 0 1280x800x24" \
  blender --factory-startup --addons opaline "$T/scene.blend" --python "$driver" -- shoot "$T/shots" \
  > "$T/shoot.log" 2>&1 || true
grep -E "^addon-screenshots:|Error|Traceback" "$T/shoot.log" || true
if [ ! -f "$T/shots/result.txt" ]; then
  tail -40 "$T/shoot.log" >&2
  echo "addon-screenshots: Blender ended before the driver finished" >&2
  exit 1
fi
mkdir -p "$OUTDIR"
for png in "$T"/shots/*.png; do
  [ -e "$png" ] || continue
  cp "$png" "$OUTDIR/.$(basename "$png").tmp" && mv "$OUTDIR/.$(basename "$png").tmp" "$OUTDIR/$(basename "$png")"
  echo "addon-screenshots: $OUTDIR/$(basename "$png") ($(( $(stat -c %s "$png") / 1024 )) KB)"
done
echo "addon-screenshots: the Info editor holds:"
sed 's/^/  /' "$T/shots/info.txt" 2>/dev/null || true
if [ "$(cat "$T/shots/result.txt")" != ok ]; then
  sed 's/^/addon-screenshots: FAILED: /' "$T/shots/result.txt" >&2
  exit 1
fi
echo "addon-screenshots: ok: every warning and error reached the Info editor once"
