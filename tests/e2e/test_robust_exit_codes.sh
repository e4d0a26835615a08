#!/usr/bin/env bash
# The exit-code contract of docs/limits.md, case by case, for both programs: 0 success, 1 a
# failure while doing valid work (a refused output), 2 bad input or usage (including any input
# file that is missing), 130 interrupted (tested by the signal tests). Each error is printed once,
# as "opaline: error: ...", and names the file at fault.
set -uo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup exit_codes opaline-factor opaline-render
failed=0 passed=0

# expect CODE NEEDLE DESCRIPTION -- COMMAND...: runs COMMAND, checks its exit code, that stderr
# has exactly one error line and that it contains NEEDLE (when not empty).
expect() {
  local want=$1 needle=$2 what=$3; shift 4
  local got errs
  "$@" >"$T/out.txt" 2>"$T/err.txt" </dev/null; got=$?
  errs=$(grep -c '^opaline: error:' "$T/err.txt")
  if [ "$got" != "$want" ]; then
    echo "FAIL $what: exit $got, expected $want"; sed 's/^/    /' "$T/err.txt" | head -5
    failed=$((failed + 1)); return
  fi
  if [ "$want" != 0 ] && [ "$errs" != 1 ]; then
    echo "FAIL $what: $errs 'opaline: error:' lines, expected 1"; sed 's/^/    /' "$T/err.txt" | head -5
    failed=$((failed + 1)); return
  fi
  if [ -n "$needle" ] && ! grep -qF -- "$needle" "$T/err.txt"; then
    echo "FAIL $what: the message does not name '$needle'"; sed 's/^/    /' "$T/err.txt" | head -5
    failed=$((failed + 1)); return
  fi
  echo "ok   $what (exit $got)"; passed=$((passed + 1))
}

"$F" dataset chess4x4 --pixels 8x8 --kernel 5 -o "$T/d.opm" 2>/dev/null || { echo "FAIL: dataset"; exit 1; }
"$F" factor "$T/d.opm" --method svd -T 2 -o "$T/m.opm" 2>/dev/null || { echo "FAIL: factor"; exit 1; }
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' > "$T/tri.obj"
scene() { # scene FILE SHAPE-AND-EMITTER-XML
  cat > "$1" <<XML
<scene version="0.6.0">
  <sensor type="perspective">
    <transform name="toWorld"><lookat origin="0, 0, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="1"/></sampler>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
  </sensor>
  $2
</scene>
XML
}
scene "$T/ok.xml" '<emitter type="constant"/><shape type="obj"><string name="filename" value="tri.obj"/></shape>'
scene "$T/noobj.xml" '<emitter type="constant"/><shape type="obj"><string name="filename" value="missing.obj"/></shape>'
scene "$T/noenv.xml" '<emitter type="envmap"><string name="filename" value="missing.exr"/></emitter><shape type="sphere"/>'
scene "$T/nopng.xml" '<emitter type="constant"/><shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="missing.png"/></texture></bsdf></shape>'
scene "$T/nomat.xml" '<emitter type="constant"/><shape type="sphere"><subsurface type="svd"><string name="material" value="NoSuchPreset"/></subsurface></shape>'
scene "$T/nomatfile.xml" '<emitter type="constant"/><shape type="sphere"><subsurface type="svd"><string name="material" value="missing.opm"/></subsurface></shape>'
mkdir "$T/ro" && chmod 0555 "$T/ro"

# opaline-render
expect 0 ""              "render: a valid scene"          -- "$R" -q -t 1 -o "$T/ok.png" "$T/ok.xml"
expect 2 "--bogus"       "render: unknown option"         -- "$R" --bogus "$T/ok.xml"
expect 2 "missing.xml"   "render: missing scene"          -- "$R" --check "$T/missing.xml"
expect 2 "missing.obj"   "render: missing OBJ"            -- "$R" --check "$T/noobj.xml"
expect 2 "missing.exr"   "render: missing envmap"         -- "$R" --check "$T/noenv.xml"
expect 2 "missing.png"   "render: missing texture"        -- "$R" --check "$T/nopng.xml"
expect 2 "NoSuchPreset"  "render: missing preset"         -- "$R" --check "$T/nomat.xml"
expect 2 "missing.opm"   "render: missing material file"  -- "$R" --check "$T/nomatfile.xml"
if [ "$(id -u)" != 0 ]; then
  expect 1 "ro/out.png"  "render: unwritable output"      -- "$R" -q -t 1 -o "$T/ro/out.png" "$T/ok.xml"
fi
expect 1 "nodir/out.png" "render: output folder missing"  -- "$R" -q -t 1 -o "$T/nodir/out.png" "$T/ok.xml"

# opaline-factor
expect 2 ""              "factor: no command"             -- "$F"
expect 2 "frobnicate"    "factor: unknown command"        -- "$F" frobnicate
expect 2 "missing.opm"   "factor: missing dataset"        -- "$F" factor "$T/missing.opm" --method svd -T 2 -o "$T/x.opm"
expect 2 "missing.opm"   "info: missing file"             -- "$F" info "$T/missing.opm"
expect 2 "missing.npy"   "import: missing .npy"           -- "$F" import "$T/missing.npy" -o "$T/x.opm"
expect 2 "nosuch"        "factor: unknown method"         -- "$F" factor "$T/d.opm" --method nosuch -o "$T/x.opm"
expect 2 "ok.xml"        "factor: a scene is no dataset"  -- "$F" factor "$T/ok.xml" --method svd -T 2 -o "$T/x.opm"
expect 1 "nodir/x.opm"   "factor: output folder missing"  -- "$F" factor "$T/d.opm" --method svd -T 2 -o "$T/nodir/x.opm"
expect 1 "nodir/d.opm"   "dataset: output folder missing" -- "$F" dataset chess4x4 --pixels 8x8 --kernel 5 -o "$T/nodir/d.opm"
expect 0 ""              "info: a material"               -- "$F" info "$T/m.opm"

echo "$passed passed, $failed failed"
[ "$failed" = 0 ]
