#!/usr/bin/env bash
# opaline-render -a FOLDER[:FOLDER...] (docs/rendering.md; docs/scene-format.md, "Files and
# paths"): a file the scene names by a relative name is found in the search folders after the
# scene's own folder and its <path> folders and before the working directory (Mitsuba's order),
# the folders in the order given (one -a with ':' or -a repeated); a search folder that is missing, not a folder or
# empty is refused with exit 2 naming it; -a takes a scene.
set -uo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup render_search_folders opaline-render

fail() { echo "FAIL: $*"; [ -f "$T/err" ] && cat "$T/err"; exit 1; }

mkdir -p "$T/scene" "$T/work" "$T/a1" "$T/a2" "$T/empty" "$T/p"
cat > "$T/scene/scene.xml" <<XML
<scene version="0.6.0">
  <sensor type="perspective"><transform name="toWorld"><lookat origin="0, -6, 3" target="0, 0, 0" up="0, 0, 1"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="1"/></sampler>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film></sensor>
  <emitter type="constant"/>
  <shape type="obj"><string name="filename" value="only.obj"/></shape>
</scene>
XML
sed 's|<emitter|<path value="../p"/>\n  <emitter|' "$T/scene/scene.xml" > "$T/scene/with_path.xml"
printf 'v -1 -1 0\nv 1 -1 0\nv 0 1 0\nf 1 2 3\n' > "$T/a2/only.obj"
touch "$T/plain_file"
cd "$T/work"

# inputs ARGS...: the mesh --list-inputs says the scene reads with ARGS (exit 0 expected).
inputs() {
  "$R" --list-inputs -q "$@" >"$T/out" 2>"$T/err" || fail "--list-inputs $* exited $?"
  grep 'only\.obj$' "$T/out"
}

# Not found without -a: exit 2 naming the file.
"$R" --check -q "$T/scene/scene.xml" >/dev/null 2>"$T/err"
rc=$?
[ $rc -eq 2 ] || fail "a mesh in no searched folder: exit $rc, expected 2"
grep -q "only.obj" "$T/err" || fail "the error does not name only.obj"

# Found through -a, with ':' or -a repeated; --check loads it, a render reads it.
[ "$(inputs -a "$T/empty:$T/a2" "$T/scene/scene.xml")" = "$T/a2/only.obj" ] || fail "-a EMPTY:A2"
[ "$(inputs -a "$T/empty" -a "$T/a2" "$T/scene/scene.xml")" = "$T/a2/only.obj" ] ||
  fail "-a repeated"
"$R" --check -q -a "$T/a2" "$T/scene/scene.xml" 2>"$T/err" || fail "--check -a exited $?"
"$R" -q -a "$T/a2" -o "$T/work/r.pfm" "$T/scene/scene.xml" 2>"$T/err" || fail "render -a exited $?"
[ -s "$T/work/r.pfm" ] || fail "no image rendered"

# The order: the folders as given; the scene's folder and <path> first, the working directory last.
cp "$T/a2/only.obj" "$T/a1/only.obj"
[ "$(inputs -a "$T/a1:$T/a2" "$T/scene/scene.xml")" = "$T/a1/only.obj" ] || fail "order a1:a2"
[ "$(inputs -a "$T/a2" -a "$T/a1" "$T/scene/scene.xml")" = "$T/a2/only.obj" ] || fail "order a2 a1"
cp "$T/a2/only.obj" "$T/p/only.obj"
[ "$(inputs -a "$T/a1" "$T/scene/with_path.xml")" = "$T/p/only.obj" ] || fail "<path> before -a"
cp "$T/a2/only.obj" "$T/work/only.obj"
[ "$(inputs -a "$T/a1" "$T/scene/scene.xml")" = "$T/a1/only.obj" ] ||
  fail "-a after the working directory"
rm "$T/a1/only.obj"
[ "$(inputs -a "$T/a2" "$T/scene/scene.xml")" = "$T/a2/only.obj" ] || fail "-a a2 after the working directory"
rm "$T/a2/only.obj" "$T/p/only.obj"
[ "$(inputs "$T/scene/scene.xml")" = "$T/work/only.obj" ] || fail "the working directory not searched"
cp "$T/work/only.obj" "$T/a2/only.obj"
cp "$T/a2/only.obj" "$T/scene/only.obj"
[ "$(inputs -a "$T/a1" "$T/scene/scene.xml")" = "$T/scene/only.obj" ] ||
  fail "the scene's folder before -a"

# Refused, exit 2, naming the folder: missing, a plain file, an empty name; -a without a scene.
refused() { # refused MESSAGE ARGS...
  local msg=$1 rc
  shift
  "$R" --check -q "$@" >/dev/null 2>"$T/err"
  rc=$?
  [ $rc -eq 2 ] || fail "$* exited $rc, expected 2"
  grep -qF -- "$msg" "$T/err" || fail "$*: the message lacks '$msg'"
}
refused "search folder $T/nosuch: No such file or directory" -a "$T/a1:$T/nosuch" "$T/scene/scene.xml"
refused "search folder $T/plain_file: not a folder" -a "$T/plain_file" "$T/scene/scene.xml"
refused "-a $T/a1:: an empty folder name" -a "$T/a1:" "$T/scene/scene.xml"
refused "-a needs a value" "$T/scene/scene.xml" -a
refused "-a goes with a scene" --preset-folders -a "$T/a1"
echo "ok"
