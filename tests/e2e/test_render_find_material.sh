#!/usr/bin/env bash
# opaline-render --find-material and --preset-folders (docs/rendering.md, "Finding materials"):
# the folders a scene's preset name is looked up in, in the order loading searches them, and the
# file it finds: the scene's folder first, then OPALINE_PRESETS_PATH's, then the build's presets;
# exit 0 found, 3 not found (the folders still listed), 2 for a scene or a lone --scene-dir; a
# path is found only when it is a file. What --find-material says a scene reads is what loading
# that scene reads (--list-inputs).
set -uo pipefail
source "${OPALINE_SOURCE_DIR:?OPALINE_SOURCE_DIR is not set}/tests/e2e/e2e_support.sh"
e2e_setup render_find_material opaline-render
trap 'rm -rf "$T"' EXIT
P=SVD_S10_Chess4x4
[ -f "${OPALINE_PRESETS_DIR:-}/$P.opm" ] || { echo "skip: the preset $P is not built"; exit 77; }
unset OPALINE_PRESETS_PATH
mkdir -p "$T/scene" "$T/mine" "$T/empty"
cp "$OPALINE_PRESETS_DIR/$P.opm" "$T/mine/$P.opm"
build=$(cd "$OPALINE_PRESETS_DIR" && pwd)

"$R" --preset-folders >"$T/folders" 2>"$T/err" || fail "--preset-folders exited $?"
[ "$(tail -n 1 "$T/folders")" = "$build" ] || fail "the build's presets are not last: $(cat "$T/folders")"
OPALINE_PRESETS_PATH="$T/empty:$T/mine" "$R" --preset-folders --scene-dir "$T/scene" \
    >"$T/folders2" 2>"$T/err" || fail "--preset-folders --scene-dir exited $?"
{ printf '%s\n' "$T/scene" "$T/empty" "$T/mine"; cat "$T/folders"; } | diff - "$T/folders2" ||
  fail "--preset-folders with OPALINE_PRESETS_PATH and --scene-dir"

# The build's copy with no other; OPALINE_PRESETS_PATH's before it; the scene's before both.
(cd "$T/empty" && "$R" --find-material "$P" >"$T/out" 2>"$T/err") || fail "found nothing: exit $?"
{ echo "searched ."; sed 's/^/searched /' "$T/folders"; echo "found $build/$P.opm"; } |
  diff - "$T/out" || fail "--find-material in the build's presets"
OPALINE_PRESETS_PATH="$T/empty:$T/mine" "$R" --find-material "$P" --scene-dir "$T/scene" \
    >"$T/out" 2>"$T/err" || fail "exit $? with OPALINE_PRESETS_PATH"
printf 'searched %s\n' "$T/scene" "$T/empty" "$T/mine" | cat - <(echo "found $T/mine/$P.opm") |
  diff - "$T/out" || fail "--find-material in OPALINE_PRESETS_PATH"
cp "$T/mine/$P.opm" "$T/scene/$P.opm"
OPALINE_PRESETS_PATH="$T/mine" "$R" --find-material "$P" --scene-dir "$T/scene" >"$T/out" 2>"$T/err" ||
  fail "exit $? with a copy in the scene's folder"
printf 'searched %s\nfound %s\n' "$T/scene" "$T/scene/$P.opm" | diff - "$T/out" ||
  fail "the scene's folder is not searched first"

# What loading reads is what --find-material found.
sphere_scene "$T/scene/scene.xml" 8 8 1 \
  "<subsurface type=\"svd\"><string name=\"material\" value=\"$P\"/></subsurface>"
rm "$T/scene/$P.opm"
OPALINE_PRESETS_PATH="$T/mine" "$R" --list-inputs -q "$T/scene/scene.xml" >"$T/inputs" 2>"$T/err" ||
  fail "--list-inputs exited $?"
grep -qx "$T/mine/$P.opm" "$T/inputs" || fail "the scene does not read $T/mine/$P.opm: $(cat "$T/inputs")"
OPALINE_PRESETS_PATH="$T/mine" "$R" --find-material "$P" --scene-dir "$T/scene" | tail -n 1 |
  grep -qx "found $T/mine/$P.opm" || fail "--find-material and loading disagree"

# Not found: exit 3, the folders listed, the error naming them.
"$R" --find-material NoSuchPreset --scene-dir "$T/scene" >"$T/out" 2>"$T/err"
rc=$?
[ $rc -eq 3 ] || fail "a missing preset exited $rc, expected 3"
{ echo "searched $T/scene"; sed 's/^/searched /' "$T/folders"; } | diff - "$T/out" ||
  fail "the folders searched for a missing preset"
grep -q "material preset \"NoSuchPreset\" not found (searched $T/scene, " "$T/err" || fail "the error"

# Paths: relative to --scene-dir, found only when a file.
"$R" --find-material "../mine/$P.opm" --scene-dir "$T/scene" >"$T/out" 2>"$T/err" ||
  fail "a relative .opm path exited $?"
[ "$(cat "$T/out")" = "found $T/scene/../mine/$P.opm" ] || fail "the path: $(cat "$T/out")"
for missing in "$T/nothing.opm" "$T/mine"/; do
  "$R" --find-material "$missing" >"$T/out" 2>"$T/err"
  rc=$?
  [ $rc -eq 3 ] && [ ! -s "$T/out" ] || fail "$missing exited $rc, printed $(cat "$T/out")"
done

# An installed renderer (PREFIX/share/opaline/presets beside PREFIX/bin) searches and names its
# installed presets last, never the folder it was built in.
mkdir -p "$T/inst/bin" "$T/inst/share/opaline/presets"
cp "$R" "$T/inst/bin/opaline-render"
"$T/inst/bin/opaline-render" --preset-folders >"$T/folders3" 2>"$T/err" ||
  fail "installed --preset-folders exited $?"
[ "$(tail -n 1 "$T/folders3")" = "$T/inst/share/opaline/presets" ] ||
  fail "an installed renderer's last folder: $(cat "$T/folders3")"
! grep -qxF "$build" "$T/folders3" || fail "an installed renderer names the build's presets"
(cd "$T/empty" && "$T/inst/bin/opaline-render" --find-material NoSuchPreset >/dev/null 2>"$T/err")
grep -q "not found (searched ., $T/inst/share/opaline/presets; set" "$T/err" ||
  fail "an installed renderer's message: $(cat "$T/err")"

# Bad arguments: exit 2.
for args in "--find-material $P $T/scene/scene.xml" "--scene-dir $T/scene $T/scene/scene.xml" \
            "--find-material $P --preset-folders" "--find-material"; do
  # shellcheck disable=SC2086
  "$R" $args >/dev/null 2>"$T/err"
  rc=$?
  [ $rc -eq 2 ] || fail "$args exited $rc, expected 2"
done
echo "ok"
