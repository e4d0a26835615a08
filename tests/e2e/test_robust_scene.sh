#!/usr/bin/env bash
# Bad scenes and resource bombs through opaline-render: `--check` and rendering agree
# on a camera or light too far for single precision (exit 2 naming the line, never Embree's
# abort), an attribute with 20000 entity references is refused in well under 2 s, a PNG whose
# header says 16384 x 16384 is refused before decoding, `--limit` raises and lowers a limit,
# and `$$` reaches a file with a `$` in its name. Bounded work from a small scene: an include
# fan-out, a <default> billion laughs and a 40000 x 40000 film are refused by --check and
# --estimate (exit 2 naming the limit), 2,500 spheres in 60 KB are checked in bounded memory
# (one shared mesh), a zero up is refused. Needs the built opaline-render and python3.
set -euo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup robust_scene opaline-render

fail() { echo "FAIL: $*"; exit 1; }

# expect CODE WORDS -- ARGS...: runs opaline-render ARGS, checks the exit code and that stderr
# holds WORDS (a fixed string): the message of a limit checked before the work it bounds.
expect() {
  local code=$1 words=$2
  shift 3
  local rc=0
  "$R" -q "$@" >"$T/out" 2>"$T/err" || rc=$?
  [ "$rc" = "$code" ] || { cat "$T/err"; fail "opaline-render $*: exit $rc, expected $code"; }
  # words may list alternatives separated by ' || ' (a newer libxml2 refuses some files itself)
  local w found=0
  while IFS= read -r w; do grep -qF -- "$w" "$T/err" && found=1; done <<<"${words// || /$'\n'}"
  [ "$found" = 1 ] || { cat "$T/err"; fail "opaline-render $*: no '$words'"; }
  echo "ok: exit $rc: $(head -c 200 "$T/err")"
}

head='<scene version="0.6.0">
<integrator type="path"><integer name="maxDepth" value="2"/></integrator>
<shape type="sphere"/>'
film='<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
<sampler type="independent"><integer name="sampleCount" value="1"/></sampler>'

# a camera at x = 1e19 (line 4): refused by --check and by rendering alike
cat > "$T/far_camera.xml" <<XML
$head
<sensor type="perspective">
  <transform name="toWorld"><translate x="1e19"/></transform>
  $film
</sensor>
<emitter type="constant"/>
</scene>
XML
for mode in --check render; do
  args=("$T/far_camera.xml"); [ "$mode" = render ] && args+=(-o "$T/far.exr") || args+=(--check)
  expect 2 "far_camera.xml:4: <sensor type=\"perspective\">: the camera's position (1e+19, 0, 0) is beyond the coordinate limit" -- "${args[@]}"
done
[ ! -e "$T/far.exr" ] || fail "an image was written for a refused scene"

# a point light at 1e39 (line 9)
cat > "$T/far_light.xml" <<XML
$head
<sensor type="perspective">
  <transform name="toWorld"><lookat origin="0,0,-4" target="0,0,0"/></transform>
  $film
</sensor>
<emitter type="point"><point name="position" x="0" y="1e39" z="0"/></emitter>
</scene>
XML
expect 2 "far_light.xml:9: <emitter type=\"point\">: the light's position" -- "$T/far_light.xml" --check
expect 2 "far_light.xml:9: <emitter type=\"point\">: the light's position" -- "$T/far_light.xml" -o "$T/l.exr"
# raising the limit far enough is not possible: 1e39 is not even a float
expect 2 "coordinate limit of 1e+15" -- "$T/far_light.xml" --check --limit coordinate=1e15

# a shape at 2e7 is beyond the default; --limit coordinate=1e8 lets it render
cat > "$T/far_shape.xml" <<XML
<scene version="0.6.0">
<sensor type="perspective">
  <transform name="toWorld"><lookat origin="2e7,0,-400" target="2e7,0,0"/></transform>
  $film
</sensor>
<shape type="rectangle"><transform name="toWorld"><scale value="100"/><translate x="2e7"/></transform></shape>
<emitter type="constant"/>
</scene>
XML
expect 2 "far_shape.xml:2: <sensor type=\"perspective\">: the camera's position (2e+07, 0, -400)" -- "$T/far_shape.xml" --check
"$R" -q "$T/far_shape.xml" --limit coordinate=1e8 -o "$T/shape.pfm" || fail "raised coordinate limit: render failed"
[ -s "$T/shape.pfm" ] || fail "raised coordinate limit: no image"
expect 2 "expected NAME=VALUE with NAME one of coordinate, image-pixels, kernel, sss-points" -- "$T/far_shape.xml" --check --limit radius=3
expect 2 "limit coordinate: 'x' is not a number" -- "$T/far_shape.xml" --check --limit coordinate=x

# 20000 references to a 500-character entity in one attribute (60 KB): refused at once
python3 - "$T/entity.xml" <<'PY'
import sys
refs = "&a;" * 20000
open(sys.argv[1], "w").write('<?xml version="1.0"?>\n<!DOCTYPE scene [<!ENTITY a "%s">]>\n'
    '<scene version="0.6.0">\n<shape type="sphere" id="%s"/>\n</scene>\n' % ("x" * 500, refs))
PY
# (libxml2 2.13 and later refuse the file itself: "Maximum entity amplification factor exceeded")
expect 2 "entity.xml:4: <shape type=\"sphere\" id=\"&...;\">: attribute id: entity references (&name;) are not supported || entity.xml:4: malformed XML: Maximum entity amplification" -- "$T/entity.xml" --check

# a 16384 x 16384 PNG of a few KB (1-bit grey, all zero): refused from its header
python3 - "$T/bomb.png" "$T/small.png" <<'PY'
import struct, sys, zlib
def png(path, w, h, depth, colour, row_bytes):
    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))
    raw = (b"\0" + b"\0" * row_bytes) * h
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, colour, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))
png(sys.argv[1], 16384, 16384, 1, 0, 2048)
png(sys.argv[2], 64, 32, 8, 2, 64 * 3)
PY
[ "$(stat -c %s "$T/bomb.png")" -lt 200000 ] || fail "the bomb PNG is not small"
for img in bomb small; do
cat > "$T/$img.xml" <<XML
<scene version="0.6.0">
<sensor type="perspective">
  <transform name="toWorld"><lookat origin="0,0,-4" target="0,0,0"/></transform>
  $film
</sensor>
<shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" name="reflectance">
  <string name="filename" value="$img.png"/></texture></bsdf></shape>
<emitter type="constant"/>
</scene>
XML
done
expect 2 "bomb.png: PNG image of 16384 x 16384 = 268435456 pixels is over the limit of 134217728 pixels (image-pixels)" -- "$T/bomb.xml" --check
expect 2 "small.png: PNG image of 64 x 32 = 2048 pixels is over the limit of 2047 pixels" -- "$T/small.xml" --check --limit image-pixels=2047
"$R" -q "$T/small.xml" --check --limit image-pixels=2048 || fail "image-pixels=2048: refused"

# $$ is a literal $: m$a.obj is reached as m$$a.obj
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' > "$T/m\$a.obj"
cat > "$T/dollar.xml" <<'XML'
<scene version="0.6.0">
<shape type="obj"><string name="filename" value="m$$a.obj"/></shape>
</scene>
XML
"$R" -q "$T/dollar.xml" --check || fail "m\$\$a.obj was not found"
sed -i 's/m\$\$a/m$a/' "$T/dollar.xml"
expect 2 "dollar.xml:2: <string name=\"filename\">: attribute value: undefined parameter '\$a'" -- "$T/dollar.xml" --check
# Bounded work from a small scene: exit codes, messages and a memory bound
# include fan-out: five small files, each including the next 30 times (837,930 includes)
python3 - "$T" <<'PY'
import sys
d = sys.argv[1]
for level in range(1, 5):
    body = "".join('<include filename="fan%d.xml"/>\n' % (level + 1) for _ in range(30)) if level < 4 \
        else '<bsdf type="diffuse"/>\n'
    open("%s/fan%d.xml" % (d, level), "w").write('<scene version="0.6.0">\n%s</scene>\n' % body)
open(d + "/fan.xml", "w").write('<scene version="0.6.0">\n<shape type="sphere"/>\n'
    + '<include filename="fan1.xml"/>\n' * 30 + '</scene>\n')
PY
for mode in --check --estimate; do
  expect 2 "more than 100000 <include> elements are read (include-count, nested ones counted each time; raise it with --limit include-count=VALUE)" -- "$T/fan.xml" $mode
done
expect 2 "fan2.xml:2: <include>: more than 2 <include> elements" -- "$T/fan.xml" --check --limit include-count=2
expect 2 "the scene file and its includes add up to more than the limit of 2000 bytes (include-bytes; raise it with --limit include-bytes=VALUE)" -- "$T/fan.xml" --check --limit include-bytes=2000

# a <default> billion laughs: d9 would be 10 GB from a file of under 1 KB
python3 - "$T/laughs.xml" <<'PY'
import sys
lines = ['<scene version="0.6.0">', '<default name="d0" value="0123456789"/>']
for i in range(1, 10):
    lines.append('<default name="d%d" value="%s"/>' % (i, ("$d%d" % (i - 1)) * 10))
lines += ['<shape type="sphere" id="$d9"/>', '</scene>', '']
open(sys.argv[1], "w").write("\n".join(lines))
PY
[ "$(stat -c %s "$T/laughs.xml")" -lt 1000 ] || fail "the default bomb is not small"
for mode in --check --estimate; do
  expect 2 "laughs.xml:10: <default name=\"d8\">: attribute value: the attribute values after \$parameter expansion add up to more than the limit of 268435456 bytes (attribute-bytes; raise it with --limit attribute-bytes=VALUE)" -- "$T/laughs.xml" $mode
done
expect 2 "laughs.xml:6: <default name=\"d4\">: attribute value: the attribute values after \$parameter expansion add up to more than the limit of 100000 bytes" -- "$T/laughs.xml" --check --limit attribute-bytes=100000

# 2,500 spheres in about 60 KB: one shared unit sphere, placed 2,500 times (not 2,500 tessellated
# copies in the BVH); a generous bound on the peak memory of --check
python3 - "$T/spheres.xml" <<'PY'
import sys
s = ['<scene version="0.6.0">']
s += ['<shape type="sphere"><point name="center" x="%d" y="%d" z="9"/></shape>' % (i % 50, i // 50)
      for i in range(2500)]
s += ['<emitter type="constant"/>', '</scene>', '']
open(sys.argv[1], "w").write("\n".join(s))
PY
if [ -x /usr/bin/time ]; then
  /usr/bin/time -f "%M" -o "$T/rss" "$R" -q "$T/spheres.xml" --check || fail "2,500 spheres: --check failed"
  rss_mb=$(( $(cat "$T/rss") / 1024 ))
  echo "2,500 spheres: --check peaked at $rss_mb MiB"
  [ "$rss_mb" -lt 1024 ] || fail "2,500 spheres: --check peaked at $rss_mb MiB"
else
  "$R" -q "$T/spheres.xml" --check || fail "2,500 spheres: --check failed"
fi
"$R" -q "$T/spheres.xml" --estimate > "$T/est" || fail "2,500 spheres: --estimate failed"
expect 2 "<shape type=\"sphere\">: with its 16128 triangles the scene holds more than the limit of 1000 triangles (triangles; raise it with --limit triangles=VALUE)" -- "$T/spheres.xml" --check --limit triangles=1000
expect 2 "<shape type=\"sphere\">: with its triangles (2322432 bytes) the scene is estimated to take 2322432 bytes to load, more than the limit of 1000000 bytes (load-memory; raise it with --limit load-memory=VALUE)" -- "$T/spheres.xml" --estimate --limit load-memory=1e6

# a 40000 x 40000 film: the render could never hold the image; --check and --estimate refuse it
cat > "$T/film.xml" <<'XML'
<scene version="0.6.0">
<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="40000"/><integer name="height" value="40000"/></film></sensor>
<shape type="sphere"/>
</scene>
XML
for mode in --check --estimate; do
  expect 2 "film.xml:2: <film>: size 40000x40000 = 1600000000 pixels is more than the 1073741824 pixels (2^30) an image can hold" -- "$T/film.xml" $mode
done

# a zero up, and one parallel to the view
for up in "0,0,0" "2,4,6" "1,2,3.0000000000005"; do
cat > "$T/up.xml" <<XML
<scene version="0.6.0">
<sensor type="perspective"><transform name="toWorld"><lookat origin="0,0,0" target="1,2,3" up="$up"/></transform></sensor>
</scene>
XML
  expect 2 "up.xml:2: <lookat>: degenerate look-at: target equals origin, or up is zero or parallel to the viewing direction" -- "$T/up.xml" --check
done
# a denormal number is the number it is
cat > "$T/denormal.xml" <<'XML'
<scene version="0.6.0">
<shape type="sphere"><transform name="toWorld"><translate x="1e-310"/></transform></shape>
</scene>
XML
"$R" -q "$T/denormal.xml" --check || fail "a denormal number was refused"
echo "all robust scene checks passed"
