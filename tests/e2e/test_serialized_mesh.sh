#!/usr/bin/env bash
# Mitsuba serialized meshes through opaline-render: files written by tests/serialized_mesh.py
# (shapeIndex selection, an index out of range or negative, a mesh over the triangles limit
# refused by --check and --estimate before it is loaded), and, when ../shared is present,
# every mesh of the published .serialized files of scenes/mitsuba loaded by --check from a
# scene of this test's own that names the shared file by a relative path, its vertex and
# triangle counts equal to those of tests/serialized_mesh.py's independent reader. Needs the
# built opaline-render and python3.
set -euo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup serialized_mesh opaline-render

fail() { echo "FAIL: $*"; exit 1; }

# scene FILE SHAPES: a scene of SHAPES (XML) in FILE, with a camera, a film and a light.
scene() {
  cat > "$1" <<XML
<scene version="0.6.0">
  <sensor type="perspective"><transform name="toWorld"><lookat origin="0, -6, 3" target="0, 0, 0" up="0, 0, 1"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="1"/></sampler>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film></sensor>
  <emitter type="constant"/>
  $2
</scene>
XML
}

# shape FILE INDEX: a serialized shape's XML.
shape() {
  echo "<shape type=\"serialized\"><string name=\"filename\" value=\"$1\"/><integer name=\"shapeIndex\" value=\"$2\"/></shape>"
}

# expect CODE WORDS ARGS...: opaline-render ARGS exits CODE with WORDS on stderr.
expect() {
  local code=$1 words=$2 rc=0
  shift 2
  "$R" -q "$@" >"$T/out" 2>"$T/err" || rc=$?
  [ "$rc" = "$code" ] || { cat "$T/err"; fail "opaline-render $*: exit $rc, expected $code"; }
  grep -qF -- "$words" "$T/err" || { cat "$T/err"; fail "opaline-render $*: no '$words'"; }
  echo "ok: exit $rc: $(head -c 200 "$T/err")"
}

# loaded_counts SCENE: "PATH VERTICES TRIANGLES" of every mesh --check -v loads.
loaded_counts() {
  "$R" -v --check "$1" 2>&1 | sed -n 's/^opaline: debug: loaded \(.*\): \([0-9]*\) vertices, \([0-9]*\) triangles$/\1 \2 \3/p'
}

python3 - "$T/two.serialized" <<'PY'
import sys
import serialized_mesh as s
quad = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
tri = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
data = s.file_bytes([s.mesh_bytes(tri, [(0, 1, 2)], name='tri'),
                     s.mesh_bytes(quad, [(0, 1, 2), (0, 2, 3)], normals=[(0, 0, 1)] * 4,
                                  double=True, name='quad')])
open(sys.argv[1], 'wb').write(data)
PY
for i in 0 1; do
  scene "$T/index$i.xml" "$(shape two.serialized $i)"
  "$R" -q --check "$T/index$i.xml" || fail "--check of shapeIndex $i"
done
counts=$(loaded_counts "$T/index1.xml")
[ "$counts" = "$T/two.serialized 4 2" ] || fail "shapeIndex 1 loaded as '$counts', not 4 vertices and 2 triangles"
"$R" -q -o "$T/index1.exr" "$T/index1.xml" || fail "rendering shapeIndex 1"
echo "ok: shapeIndex 0 and 1 load, 1 is the quad, and renders"

scene "$T/index2.xml" "$(shape two.serialized 2)"
expect 2 "two.serialized: shape index 2: out of range: the file holds 2 meshes (shape index 0 to 1)" --check "$T/index2.xml"
scene "$T/negative.xml" "$(shape two.serialized -1)"
expect 2 "parameter 'shapeIndex': -1 is not in 0..4294967295" --check "$T/negative.xml"
expect 2 "(triangles; raise it with --limit triangles=VALUE)" --limit triangles=1 --check "$T/index1.xml"
expect 2 "(triangles; raise it with --limit triangles=VALUE)" --limit triangles=1 --estimate "$T/index1.xml"
printf 'PK\003\004 not a mesh' > "$T/bad.serialized"
scene "$T/bad.xml" "$(shape bad.serialized 0)"
expect 2 "bad.serialized: shape index 0: the file has no serialized mesh header" --check "$T/bad.xml"

shared=${OPALINE_SHARED_DIR:-$SRC/../shared}/scenes/mitsuba
[ -d "$shared" ] || e2e_skip "the generated files pass; $shared is absent, so the published meshes were not tried"
files=$(cd "$shared" && find . -name '*.serialized' | sort)
[ -n "$files" ] || fail "no .serialized file under $shared"
seen=" "
for f in $files; do
  abs=$shared/${f#./}
  sum=$(md5sum < "$abs" | cut -c1-32)
  case $seen in *" $sum "*) echo "ok: $f: the same bytes as a file tried above"; continue ;; esac
  seen+="$sum "
  rel=$(python3 -c 'import os, sys; print(os.path.relpath(sys.argv[1], sys.argv[2]))' "$abs" "$T")
  want=$(python3 "$SRC/tests/serialized_mesh.py" counts "$abs" | sed "s|^|$T/$rel |")
  shapes="" n=$(wc -l <<<"$want")
  for ((i = 0; i < n; i++)); do shapes+="$(shape "$rel" "$i")"; done
  scene "$T/shared.xml" "$shapes"
  got=$(loaded_counts "$T/shared.xml")
  [ "$got" = "$want" ] || { printf 'opaline:\n%s\npython:\n%s\n' "$got" "$want"; fail "$f: counts differ"; }
  echo "ok: $f: $n meshes load, counts as tests/serialized_mesh.py reads them"
done
