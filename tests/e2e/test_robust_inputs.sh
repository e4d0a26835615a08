#!/usr/bin/env bash
# Input files under hostile conditions: every reader of both programs, given a
# directory, a FIFO, /dev/zero or a missing file, refuses at once with exit 2 and a message
# naming the file and what it is; a material truncated while a render has it mapped ends with
# exit 2 and a message (not SIGBUS); a material with CRLF META opens; bad section tags, absurd
# raw Rd values and escape sequences in names get clear messages, and escapes never reach the
# terminal. Needs the built commands and python3.
set -uo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup robust_inputs opaline-factor opaline-render
e2e_need mkfifo
[ -c /dev/zero ] || e2e_skip "no /dev/zero"
FACTOR=$F RENDER=$R
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

# expect CODE TEXT... -- COMMAND...: runs COMMAND (10 s at most), checks its exit code and that
# its stderr holds every TEXT.
expect() {
  local code=$1 texts=() rc
  shift
  while [ "$1" != "--" ]; do texts+=("$1"); shift; done
  shift
  timeout 10 "$@" >"$T/out" 2>"$T/err" </dev/null
  rc=$?
  if [ "$rc" != "$code" ]; then
    fail "$* -> exit $rc, expected $code: $(tail -c 400 "$T/err")"
    return
  fi
  for t in "${texts[@]}"; do
    grep -qF -- "$t" "$T/err" || fail "$* -> message lacks '$t': $(tail -c 400 "$T/err")"
  done
}

# ---------------------------------------------------------------- non-regular and missing inputs
mkdir "$T/adir"
mkfifo "$T/afifo"
declare -A what=([adir]="is a directory, not a file" [afifo]="is a FIFO (named pipe), not a file"
                 [/dev/zero]="is a character device, not a file" [absent]="no such file")
path_of() { case $1 in /*) echo "$1" ;; *) echo "$T/$1" ;; esac; }

"$FACTOR" dataset chess4x4 --pixels 6 --kernel 3 -o "$T/good.opm" 2>/dev/null ||
  fail "cannot make a dataset"
cat > "$T/head.xml" <<'XML'
<scene version="0.6.0">
  <sensor type="perspective"><sampler type="independent"><integer name="sampleCount" value="1"/></sampler>
    <film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film></sensor>
XML
# scene KIND PATH: a scene whose KIND reader reads PATH.
scene() {
  local body
  case $1 in
    include) body="<include filename=\"$2\"/>" ;;
    obj | ply) body="<shape type=\"$1\"><string name=\"filename\" value=\"$2\"/></shape>" ;;
    texture) body="<shape type=\"sphere\"><bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\"><string name=\"filename\" value=\"$2\"/></texture></bsdf></shape>" ;;
    envmap) body="<emitter type=\"envmap\"><string name=\"filename\" value=\"$2\"/></emitter>" ;;
    spectrum) body="<shape type=\"sphere\"><bsdf type=\"diffuse\"><spectrum name=\"reflectance\" filename=\"$2\"/></bsdf></shape>" ;;
    material) body="<shape type=\"sphere\"><subsurface type=\"raw\"><string name=\"material\" value=\"$2\"/></subsurface></shape>" ;;
  esac
  { cat "$T/head.xml"; echo "  $body"; echo "</scene>"; } > "$T/scene-$1.xml"
}
for name in adir afifo /dev/zero absent; do
  p=$(path_of "$name")
  # The scene itself, then every file a scene can name.
  expect 2 "$p: ${what[$name]}" -- "$RENDER" --check "$p"
  for kind in include obj ply texture envmap spectrum material; do
    target=$p
    case $kind in obj | ply) [ "$name" = absent ] && target=$p.$kind ;; esac
    [ "$name" = adir ] && case $kind in obj | ply) mkdir -p "$T/adir.$kind"; target=$T/adir.$kind ;; esac
    [ "$name" = afifo ] && case $kind in obj | ply) mkfifo "$T/afifo.$kind" 2>/dev/null; target=$T/afifo.$kind ;; esac
    [ "$name" = /dev/zero ] && case $kind in obj | ply) ln -sf /dev/zero "$T/zero.$kind"; target=$T/zero.$kind ;; esac
    scene "$kind" "$target"
    expect 2 "$target: ${what[$name]}" -- "$RENDER" --check "$T/scene-$kind.xml"
  done
  # The factorizer's inputs: materials and datasets, .npy arrays and their JSON sidecars.
  expect 2 "$p: ${what[$name]}" -- "$FACTOR" info "$p"
  expect 2 "$p: ${what[$name]}" -- "$FACTOR" factor "$p" --method svd -T 1 -o "$T/f.opm"
done
printf '{"size_cm": [1, 1]}' > "$T/ok.json"
: > "$T/present.npy" # a regular file: the .npy is opened first, so the sidecar's fault shows
for name in adir afifo /dev/zero absent; do
  p=$(path_of "$name")
  expect 2 "$p: ${what[$name]}" -- "$FACTOR" import "$p" --sidecar "$T/ok.json" -o "$T/i.opm"
  expect 2 "$p: ${what[$name]}" -- "$FACTOR" import "$T/present.npy" --sidecar "$p" -o "$T/i.opm"
done
[ -e "$T/f.opm" ] || [ -e "$T/i.opm" ] && fail "a refused input left an output"

# ---------------------------------------------------------------- materials written by hand
# opm.py OUT META [TAG=KIND ...]: writes a material container (docs/formats.md) with META as
# given (\r and \x1b escapes allowed) and sections: RD.Y=good (rows summing to 0.45),
# RD.Y=huge (one value 3.4e38), RD.Y=bright (rows summing to 2), or a raw tag spelled in
# Python escapes; "dup" repeats the previous section; "misalign" shifts the last offset.
cat > "$T/opm.py" <<'PY'
import struct, sys, zlib
out, meta = sys.argv[1], sys.argv[2].encode().decode("unicode_escape").encode("latin-1")
w, h, k = 3, 2, 3
def rd(kind):
    v = [0.05] * (w * h * k * k)
    if kind == "huge": v[13] = 3.4e38
    if kind == "bright": v = [2.0 / (k * k)] * len(v)
    return struct.pack("<%df" % len(v), *v)
secs = [(b"META", meta)]
misalign = False
for arg in sys.argv[3:]:
    if arg == "dup": secs.append(secs[-1]); continue
    if arg == "misalign": misalign = True; continue
    tag, kind = arg.split("=")
    secs.append((tag.encode().decode("unicode_escape").encode("latin-1"), rd(kind)))
body, table, pos = b"", b"", 64
for tag, data in secs:
    pad = (-pos) % 64
    body += b"\0" * pad; pos += pad
    off = pos + (8 if misalign and (tag, data) == secs[-1] else 0)
    table += tag.ljust(8, b"\0") + struct.pack("<QQII", off, len(data), zlib.crc32(data), 0)
    body += data; pos += len(data)
pad = (-pos) % 64
body += b"\0" * pad; pos += pad
size = pos + len(table)
head = b"OPALINEM" + struct.pack("<IIQQI", 1, len(secs), size, pos, zlib.crc32(table))
head += struct.pack("<I", zlib.crc32(head)) + b"\0" * 24
open(out, "wb").write(head + body + table)
PY
opm() { python3 "$T/opm.py" "$@" || fail "opm.py $*"; }
META='method=raw\nwidth=3\nheight=2\nkernel=3\nchannels=1\nsize_x_cm=1\nsize_y_cm=1\n'

opm "$T/lf.opm" "${META}name=plain\n" RD.Y=good
expect 0 -- "$FACTOR" info "$T/lf.opm"
grep -q "^name: *plain$" "$T/out" || fail "info of a hand-written material: $(cat "$T/out")"
# CRLF line ends (an editor's) are read like LF.
opm "$T/crlf.opm" "$(printf '%s' "${META}name=crlf\n" | sed 's/\\n/\\r\\n/g')" RD.Y=good
expect 0 -- "$FACTOR" info "$T/crlf.opm"
grep -q "^method: *raw$" "$T/out" && grep -q "^name: *crlf$" "$T/out" ||
  fail "CRLF META misread: $(cat "$T/out")"

# Section tags: a non-printable byte, a duplicate, a misaligned offset.
opm "$T/tag.opm" "$META" 'RD\x01Y=good'
expect 2 "section 1 tag 'RD\\x01Y': byte 2 is not a printable ASCII character" -- "$FACTOR" info "$T/tag.opm"
opm "$T/dup.opm" "$META" RD.Y=good dup
expect 2 "sections 1 and 2 have the same tag 'RD.Y'" -- "$FACTOR" info "$T/dup.opm"
opm "$T/mis.opm" "$META" RD.Y=good misalign
expect 2 "section 'RD.Y' starts at byte 200, not a multiple of 64" -- "$FACTOR" info "$T/mis.opm"
grep -q "out of bounds" "$T/err" && fail "a section message still says 'out of bounds'"

# Physically impossible raw data: one absurd value, rows whose albedo is 2.
opm "$T/huge.opm" "$META" RD.Y=huge
expect 2 "section 'RD.Y' row 1 (incident pixel x 1, y 0) sums to 3.4e+38 (largest value 3.4e+38 in column 4)" \
  -- "$FACTOR" info "$T/huge.opm"
opm "$T/bright.opm" "$META" RD.Y=bright
expect 2 "row 0 (incident pixel x 0, y 0) sums to 2" "at most 1.5" -- "$FACTOR" info "$T/bright.opm"
scene material "$T/bright.opm"
expect 2 "bright.opm: section 'RD.Y' row 0" -- "$RENDER" --check "$T/scene-material.xml"

# Factored materials: stored albedos, per-row maxima and NMF row scales above 1e6 are
# refused, above 1.5 warned about (patch.py FILE TAG INDEX VALUE sets one float32 and fixes
# the checksums).
cat > "$T/patch.py" <<'PY'
import struct, sys, zlib
path, want, index, value = sys.argv[1], sys.argv[2].encode(), int(sys.argv[3]), float(sys.argv[4])
b = bytearray(open(path, "rb").read())
count, = struct.unpack_from("<I", b, 12); table, = struct.unpack_from("<Q", b, 24)
for i in range(count):
    e = table + 32 * i
    if bytes(b[e:e + 8]).rstrip(b"\0") == want:
        off, size = struct.unpack_from("<QQ", b, e + 8)
        struct.pack_into("<f", b, off + 4 * index, value)
        struct.pack_into("<I", b, e + 24, zlib.crc32(b[off:off + size]))
struct.pack_into("<I", b, 32, zlib.crc32(b[table:table + 32 * count]))
struct.pack_into("<I", b, 36, zlib.crc32(b[:36]))
open(path, "wb").write(b)
PY
"$FACTOR" factor "$T/good.opm" --method svd -T 1 -o "$T/svd.opm" >/dev/null 2>&1 || fail "factor svd"
"$FACTOR" factor "$T/good.opm" --method nmf -T 1 --iters 3 -o "$T/nmf.opm" >/dev/null 2>&1 || fail "factor nmf"
cp "$T/svd.opm" "$T/svd-max.opm"
python3 "$T/patch.py" "$T/svd-max.opm" MAX.G 7 1e30
expect 2 "section 'MAX.G' value 7 (row 7: incident pixel x 1, y 1) is 1e+30" -- "$FACTOR" info "$T/svd-max.opm"
cp "$T/svd.opm" "$T/svd-albedo.opm"
python3 "$T/patch.py" "$T/svd-albedo.opm" ALBEDO 40 3e6
expect 2 "section 'ALBEDO' value 40 (channel 1, row 4: incident pixel x 4, y 0) is 3e+06" -- "$FACTOR" info "$T/svd-albedo.opm"
cp "$T/svd.opm" "$T/svd-bright.opm"
python3 "$T/patch.py" "$T/svd-bright.opm" ALBEDO 3 2.5
expect 0 "warning: $T/svd-bright.opm: section 'ALBEDO' value 3 (channel 0, row 3: incident pixel x 3, y 0) is 2.5, but an albedo cannot exceed 1" \
  -- "$FACTOR" info "$T/svd-bright.opm"
python3 "$T/patch.py" "$T/nmf.opm" SCALE.B 2 1e20
expect 2 "section 'SCALE.B' value 2 (row 2: incident pixel x 2, y 0) is 1e+20" -- "$FACTOR" info "$T/nmf.opm"

# Escape sequences from a file: shown escaped by info and in error messages, never raw.
opm "$T/esc.opm" "${META}name=red\x1b[31mX\x9b2J\ngenerator=bell\x07\n" RD.Y=good
expect 0 -- "$FACTOR" info "$T/esc.opm"
grep -qF 'name:        red\x1b[31mX\x9b2J' "$T/out" && grep -qF 'generator:   bell\x07' "$T/out" ||
  fail "info does not escape the name: $(cat -v "$T/out")"
opm "$T/escmeta.opm" "method=\x1b]0;owned\x07\n" RD.Y=good
expect 2 "unknown method '\\x1b]0;owned\\x07'" -- "$FACTOR" info "$T/escmeta.opm"
for f in "$T/out" "$T/err"; do
  LC_ALL=C grep -q $'[\x01-\x08\x0b-\x1f\x7f\x9b]' "$f" && fail "control bytes reached $f: $(cat -v "$f")"
done

# ---------------------------------------------------------------- truncated while mapped
# A render that reads a raw material for about a second: truncating the material once the
# renderer has it mapped ends the render with exit 2 and a message naming the file (SIGBUS
# before). /proc/PID/maps says when it is mapped; retried once if the render won the race.
"$FACTOR" dataset chess4x4 --pixels 48 --kernel 15 -o "$T/big.opm" 2>/dev/null || fail "dataset"
sphere_scene "$T/trunc.xml" 96 72 64 \
  '<subsurface type="raw"><string name="material" value="mapped.opm"/><float name="sceneUnitsPerMetre" value="5"/></subsurface>'
truncated_render() {
  cp "$T/big.opm" "$T/mapped.opm"
  "$RENDER" -q -t 2 -o "$T/trunc.pfm" "$T/trunc.xml" 2>"$T/err" &
  local pid=$! i
  for i in $(seq 500); do
    grep -q mapped.opm "/proc/$pid/maps" 2>/dev/null && break
    sleep 0.01
  done
  truncate -s 4096 "$T/mapped.opm"
  wait "$pid"
}
truncated_render
rc=$?
[ "$rc" = 0 ] && { truncated_render; rc=$?; }
[ "$rc" = 2 ] || fail "render of a material truncated while mapped: exit $rc, expected 2: $(tail -c 300 "$T/err")"
[ "$(grep -cF "mapped.opm: the file was truncated or changed while in use" "$T/err")" = 1 ] ||
  fail "not one message for the truncated material: $(tail -c 300 "$T/err")"

[ "$failures" = 0 ] || { echo "$failures failure(s)"; exit 1; }
echo "all input-file checks passed"
