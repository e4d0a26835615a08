#!/usr/bin/env bash
# opaline-render --stream stops when the process that started it dies (Blender killed while
# rendering): the renderer is started by a short-lived intermediate shell, the shell is killed
# with SIGKILL once the renderer has begun the image (its stream's begin record), and the
# renderer must stop long before its image is done, having cancelled the way an interrupt does
# ("interrupted (SIGTERM)", its temporary output removed). A parent already gone
# before the renderer could ask to follow it (OPALINE_PARENT_PID names another process) stops it
# too, with exit 130.
set -uo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup render_parent_death opaline-render
[ "$(uname -s)" = Linux ] || e2e_skip "the parent-death signal is Linux only"
RPID=
cleanup() { [ -z "$RPID" ] || kill -KILL "$RPID" 2>/dev/null; }

# Tens of seconds of work on one thread: a renderer that does not follow its parent finishes the
# image (and the test fails on its log) instead of hanging.
cat > "$T/scene.xml" <<'XML'
<scene version="0.6.0">
  <integrator type="path"><integer name="maxDepth" value="8"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="toWorld"><lookat origin="0, -4, 2" target="0, 0, 0.5" up="0, 0, 1"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="10000"/></sampler>
    <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="64"/></film>
  </sensor>
  <emitter type="point"><point name="position" x="0" y="-1" z="4"/><spectrum name="intensity" value="20"/></emitter>
  <shape type="sphere"><float name="radius" value="0.5"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.7"/></bsdf></shape>
</scene>
XML

sh -c '"$1" --stream -t 1 -o "$2/out.exr" "$2/scene.xml" >"$2/stream" 2>"$2/err" &
       echo $! >"$2/pid.tmp"; mv "$2/pid.tmp" "$2/pid"; wait' sh "$R" "$T" &
SHPID=$!
e2e_wait "$SHPID" file "$T/pid" || fail "the intermediate shell did not start the renderer"
RPID=$(cat "$T/pid")
e2e_wait "$RPID" stream "$T/stream" begin || fail "the renderer ended before its parent was killed"
kill -KILL "$SHPID"
wait "$SHPID" 2>/dev/null
e2e_wait "$RPID" ended
RPID=
grep -q "interrupted (SIGTERM)" "$T/err" || fail "the renderer did not cancel as on SIGTERM"
ls "$T" | grep -q "tmp-opaline" && fail "a temporary output was left: $(ls "$T")"

# The parent gone before the renderer's request (it was reparented): exit 130 at once.
OPALINE_PARENT_PID=1 "$R" --stream -t 1 "$T/scene.xml" >/dev/null 2>"$T/err"
rc=$?
[ $rc -eq 130 ] || fail "with its parent already gone the renderer exited $rc, expected 130"
grep -q "interrupted (SIGTERM)" "$T/err" || fail "no interrupt message with the parent gone"
echo "ok"
