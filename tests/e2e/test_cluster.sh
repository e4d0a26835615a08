#!/usr/bin/env bash
# opaline-cluster against a real one-node SLURM cluster (munged, slurmctld, slurmd from Debian's
# packages, every file of theirs in this test's temp folder: cluster/local_cluster.sh): a
# 3-frame animation with a translucent preset, a tiled still merged bit-identically to the
# single render (EXR and PNG), a task killed mid-render and retried, re-submissions that render
# nothing new or only what was damaged, the merge refusing a missing tile by name, a scene that
# names a file outside the shared folder refused. Daemons stopped and the folder removed on any
# exit; the test fails when a process of its own is left. Skips (77) without root or packages.
set -uo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup cluster opaline-render opaline-cluster
e2e_preset SVD_S10_Chess4x4
source "$SRC/cluster/local_cluster.sh"
chmod 755 "$T"
# Processes of this test: every one names $T in its command line (daemons, tasks, renders).
ours() { pgrep -f -- "$T/"; }
cleanup() {
  if [ -n "${SLURM_CONF:-}" ] && [ -f "$SLURM_CONF" ]; then
    local ids
    ids=$(squeue -h -o %A 2>/dev/null | sort -u)
    [ -n "$ids" ] && scancel $ids 2>/dev/null
    for _ in $(seq 1 50); do [ -z "$(squeue -h 2>/dev/null)" ] && break; sleep 0.2; done
  fi
  local_cluster_stop "$T/slurm"
  local left
  for _ in $(seq 1 30); do left=$(ours); [ -z "$left" ] && break; sleep 0.2; done
  if [ -n "$left" ]; then
    echo "FAIL: processes left running: $left"
    kill -9 $left 2>/dev/null
    rm -rf "$T"
    exit 1
  fi
}
trap 'exit 130' INT TERM
fail() {
  echo "FAIL: $*"
  for f in "$T"/out*/.cluster/logs/*.log; do [ -f "$f" ] && { echo "--- $f"; tail -5 "$f"; }; done
  exit 1
}

local_cluster_start "$T/slurm"
rc=$?
[ $rc = 77 ] && exit 77
[ $rc = 0 ] || fail "the local cluster did not start"
t0=$(date +%s)

# wait_until SECONDS COMMAND...: polls COMMAND every 0.3 s.
wait_until() {
  local limit=$1 i
  shift
  for i in $(seq 1 $((limit * 10 / 3))); do "$@" && return 0; sleep 0.3; done
  return 1
}
complete() { "$C" status "$1" | grep -q " $2 of $2 frames complete"; }

TRANS='<subsurface type="svd"><string name="material" value="SVD_S10_Chess4x4"/>
       <integer name="maxPoints" value="3000"/></subsurface>'
# 1. A 3-frame animation (the sphere moves), one task per frame.
mkdir -p "$T/anim"
for f in 1 2 3; do
  sphere_scene "$T/anim/shot_000$f.xml" 24 18 2 "$TRANS"
  sed -i "s/x=\"0\" y=\"0\" z=\"0.5\"/x=\"0.$f\" y=\"0\" z=\"0.5\"/" "$T/anim/shot_000$f.xml"
done
"$C" submit "$T"/anim/shot_000?.xml -o "$T/out_anim" --threads 1 >"$T/sub1" 2>"$T/err" ||
  fail "submit (animation) exited $?: $(cat "$T/err")"
grep -q "^submitted job [0-9]*: 3 frames (0 complete already), 3 render tasks" "$T/sub1" ||
  fail "submit's report: $(cat "$T/sub1")"

# 2. A tiled still, opaque: 4 tiles merged, bit-identical to the single render.
sphere_scene "$T/still.xml" 32 24 4 '<bsdf type="roughplastic"/>'
"$C" submit "$T/still.xml" -o "$T/out_still" --tiles 4 --threads 1 >"$T/sub2" 2>"$T/err" ||
  fail "submit (tiles) exited $?: $(cat "$T/err")"
grep -q "4 render tasks, merge job [0-9]* (1)" "$T/sub2" || fail "tiled submit: $(cat "$T/sub2")"
"$R" -q -t 2 "$T/still.xml" -o "$T/still_single.exr" -o "$T/still_single.png" ||
  fail "the single render"

# 3. The same with a translucent material, when the renderer has the pre-pass cache: one
# pre-pass task, the tiles reading its cache.
CACHE=0
"$R" --help | grep -q -- --sss-cache && CACHE=1
if [ $CACHE = 1 ]; then
  sphere_scene "$T/jade.xml" 32 24 2 "$TRANS"
  "$C" submit "$T/jade.xml" -o "$T/out_jade" --tiles 4 --threads 1 >"$T/sub3" 2>"$T/err" ||
    fail "submit (translucent tiles) exited $?: $(cat "$T/err")"
  grep -q "pre-pass job [0-9]* (1)" "$T/sub3" || fail "no pre-pass job: $(cat "$T/sub3")"
  "$R" -q -t 2 "$T/jade.xml" -o "$T/jade_single.exr" -o "$T/jade_single.png" ||
    fail "the single translucent render"
else
  echo "note: $R has no --sss-cache yet: the translucent tiled still (pre-pass once) is not tested"
fi

wait_until 90 complete "$T/out_anim" 3 || fail "the animation did not finish: $("$C" status -v "$T/out_anim")"
wait_until 60 complete "$T/out_still" 1 || fail "the still did not finish: $("$C" status -v "$T/out_still")"
for f in 1 2 3; do
  "$R" -q -t 2 "$T/anim/shot_000$f.xml" -o "$T/single_$f.exr" || fail "single frame $f"
  cmp -s "$T/single_$f.exr" "$T/out_anim/shot_000$f.exr" ||
    fail "frame $f rendered on the cluster differs from the single render"
  [ -s "$T/out_anim/shot_000$f.png" ] || fail "frame $f has no PNG"
done
cmp "$T/still_single.exr" "$T/out_still/still.exr" || fail "merged EXR differs from the single render"
cmp "$T/still_single.png" "$T/out_still/still.png" || fail "merged PNG differs from the single render"
if [ $CACHE = 1 ]; then
  wait_until 60 complete "$T/out_jade" 1 || fail "the translucent still did not finish"
  cmp "$T/jade_single.exr" "$T/out_jade/jade.exr" || fail "translucent merged EXR differs"
  cmp "$T/jade_single.png" "$T/out_jade/jade.png" || fail "translucent merged PNG differs"
  [ -f "$T/out_jade/.cluster/times/jade.prepass.json" ] || fail "the pre-pass task did not run"
fi
"$C" status "$T/out_anim" | grep -q "frames: 3 done, 0 running, 0 pending, 0 failed" ||
  fail "status: $("$C" status "$T/out_anim")"
echo "ok: animation (3 frames, translucent) and tiled still (bit-identical) in $(( $(date +%s) - t0 )) s"

# 4. Re-submission: nothing new; then only the damaged frame and the damaged tile.
"$C" submit "$T"/anim/shot_000?.xml -o "$T/out_anim" --threads 1 >"$T/sub4" 2>"$T/err" ||
  fail "re-submit exited $?"
grep -q "nothing to render: all 3 frames are complete" "$T/sub4" || fail "re-submit: $(cat "$T/sub4")"
head -c 200 "$T/out_anim/shot_0002.png" > "$T/cut" && cat "$T/cut" > "$T/out_anim/shot_0002.png"
touch -d '1 hour ago' "$T/out_anim/shot_0001.exr"
before=$(stat -c %Y "$T/out_anim/shot_0001.exr")
"$C" submit "$T"/anim/shot_000?.xml -o "$T/out_anim" --threads 1 >"$T/sub5" 2>"$T/err" ||
  fail "re-submit (damaged) exited $?"
grep -q "3 frames (2 complete already), 1 render task" "$T/sub5" || fail "re-submit: $(cat "$T/sub5")"
TILE2=$T/out_still/.cluster/tiles/still/tile_002.exr
head -c 300 "$TILE2" > "$T/cut" && cat "$T/cut" > "$TILE2"   # present, but cut short
"$R" -q "$T/still.xml" --merge-tiles "$T/out_still/.cluster/tiles/still/tiles.txt" \
    -o "$T/m.exr" 2>"$T/err"
[ $? = 2 ] || fail "merge of incomplete tiles did not exit 2"
grep -q "1 of 4 tiles missing or invalid.*tile_002.exr: " "$T/err" ||
  fail "merge's message: $(cat "$T/err")"
[ -e "$T/m.exr" ] && fail "an incomplete merge wrote its output"
rm "$TILE2"
"$R" -q "$T/still.xml" --merge-tiles "$T/out_still/.cluster/tiles/still/tiles.txt" \
    -o "$T/m.exr" 2>"$T/err"
grep -q "tile_002.exr: no such file" "$T/err" || fail "merge's message: $(cat "$T/err")"
head -c 300 "$T/cut" > "$TILE2"
rm "$T/out_still/still.png"
"$C" submit "$T/still.xml" -o "$T/out_still" --tiles 4 --threads 1 >"$T/sub6" 2>"$T/err" ||
  fail "re-submit (tile) exited $?"
grep -q "1 render task, merge job" "$T/sub6" || fail "re-submit (tile): $(cat "$T/sub6")"
wait_until 60 complete "$T/out_anim" 3 || fail "the damaged frame was not rendered again"
wait_until 60 complete "$T/out_still" 1 || fail "the damaged tile was not rendered again"
[ "$(stat -c %Y "$T/out_anim/shot_0001.exr")" = "$before" ] || fail "a complete frame was rendered again"
cmp "$T/still_single.png" "$T/out_still/still.png" || fail "re-merged PNG differs"
echo "ok: re-submissions in $(( $(date +%s) - t0 )) s"

# 5. A task killed mid-render (SIGKILL, as the OOM killer does) is retried.
sphere_scene "$T/slow.xml" 48 36 2048 '<bsdf type="roughplastic"/>'
"$C" submit "$T/slow.xml" -o "$T/out_slow" --threads 1 --retries 1 >"$T/sub7" 2>"$T/err" ||
  fail "submit (slow) exited $?"
wait_until 30 test -s "$T/out_slow/.cluster/pids/slow" || fail "the slow task did not start"
read -r pid attempt _ < "$T/out_slow/.cluster/pids/slow"
[ "$attempt" = 1 ] || fail "first attempt is $attempt"
kill -9 "$pid" || fail "the render had finished before it could be killed"
[ -e "$T/out_slow/slow.exr" ] && fail "a killed render left an output"
wait_until 90 complete "$T/out_slow" 1 || fail "the killed task was not retried: $("$C" status -v "$T/out_slow")"
killed_logged() { grep -q "slow: attempt 1 failed (killed by signal 9)" "$T"/out_slow/.cluster/logs/*.log; }
wait_until 10 killed_logged || fail "the log does not say the first attempt was killed"
# the task records its timing just after the renderer has put the outputs in place
wait_until 10 grep -q '"attempt": 2' "$T/out_slow/.cluster/times/slow.json" ||
  fail "not done by attempt 2"
echo "ok: killed task retried in $(( $(date +%s) - t0 )) s"

# 6. A scene naming a file outside the shared folder is refused before anything is submitted
# (the renderer's own presets folder is on every node: a copy elsewhere is not).
mkdir -p "$T/proj" "$T/elsewhere"
cp "$OPALINE_PRESETS_DIR/SVD_S10_Chess4x4.opm" "$T/elsewhere/chess.opm"
sphere_scene "$T/proj/abs.xml" 8 8 1 \
  "<subsurface type=\"svd\"><string name=\"material\" value=\"$T/elsewhere/chess.opm\"/></subsurface>"
"$C" submit "$T/proj/abs.xml" -o "$T/proj/out" >"$T/sub8" 2>"$T/err"
[ $? = 2 ] || fail "a scene with an absolute path outside the shared folder was not refused"
grep -q "abs.xml: reads $T/elsewhere/chess.opm, outside the shared folder $T/proj" "$T/err" ||
  fail "the refusal: $(cat "$T/err")"
echo "ok: all in $(( $(date +%s) - t0 )) s"
