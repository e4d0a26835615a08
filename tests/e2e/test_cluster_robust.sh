#!/usr/bin/env bash
# opaline-cluster's refusals and interruptions (--local, no SLURM): bad arguments (--formats '',
# -s 0, --mem -5, run index -1 or past the task file), missing, corrupt or damaged state and task
# files end with a message and exit 2, never a Python traceback; the outside-the-shared-folder
# check sees a $param path, a <spectrum filename> and a mesh named in an included file; --local
# writes its state before its first task (status during the run), SIGTERM stops its renderer
# and exits 130, and SIGKILL leaves no renderer writing.
set -uo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup cluster_robust opaline-render opaline-cluster

mkdir -p "$T/s" "$T/elsewhere"
sphere_scene "$T/s/still.xml" 12 10 1 '<bsdf type="diffuse"/>'
# refused CODE PATTERN ARGS...: opaline-cluster ARGS exits CODE saying PATTERN, no traceback.
refused() {
  local code=$1 pattern=$2
  shift 2
  "$C" "$@" >"$T/out.txt" 2>"$T/err"
  local rc=$?
  [ $rc = "$code" ] || fail "$* exited $rc, not $code: $(cat "$T/err")"
  grep -q "Traceback" "$T/err" && fail "$*: a traceback: $(cat "$T/err")"
  grep -q -- "$pattern" "$T/err" || fail "$*: no '$pattern' in: $(cat "$T/err")"
}
refused 2 "--formats: give at least one" submit "$T/s/still.xml" -o "$T/o" --local --formats ''
refused 2 "^opaline-cluster: error: -s 0: must be at least 1" submit "$T/s/still.xml" -o "$T/o" --local -s 0
refused 2 "--mem -5: must be at least 1" submit "$T/s/still.xml" -o "$T/o" --local --mem -5
refused 2 "no render submitted" status "$T/o"

"$C" submit "$T/s/still.xml" -o "$T/o" --local >"$T/log" 2>&1 || fail "submit exited $?: $(cat "$T/log")"
TF=$T/o/.cluster/sub0-render.json
refused 2 "sub0-render.json: no task -1" run "$T/o" "$TF" -1
refused 2 "sub0-render.json: no task 1 (it has 1" run "$T/o" "$TF" 1
refused 2 "nope.json: no such file" run "$T/o" "$T/o/nope.json" 0
echo '[{"name": 1}]' > "$T/bad.json"
refused 2 "bad.json: a damaged opaline-cluster task file" run "$T/o" "$T/bad.json" 0
printf '[{"na' > "$T/cut.json"
refused 2 "cut.json: not a readable opaline-cluster task file" run "$T/o" "$T/cut.json" 0
cp "$T/o/opaline-cluster.json" "$T/state"
printf '{"frames": 3' > "$T/o/opaline-cluster.json"
refused 2 "opaline-cluster.json: not a readable opaline-cluster state file" status "$T/o"
refused 2 "opaline-cluster.json: not a readable" merge "$T/o"
echo '{"frames": [{"name": "x"}], "submissions": []}' > "$T/o/opaline-cluster.json"
refused 2 "opaline-cluster.json: a damaged opaline-cluster state file" status "$T/o"
cp "$T/state" "$T/o/opaline-cluster.json"
"$C" status "$T/o" >"$T/st" 2>&1 || fail "status exited $?: $(cat "$T/st")"

# The files a scene reads, as the renderer resolves them, must be in the shared folder.
printf 'v -3 -3 0\nv 3 -3 0\nv 3 3 0\nf 1 2 3\n' > "$T/elsewhere/tri.obj"
printf '400 0.5\n700 0.5\n' > "$T/elsewhere/flat.spd"
sphere_scene "$T/s/param.xml" 12 10 1 '<bsdf type="diffuse"/>'
sed -i "s#<scene version=\"0.6.0\">#<scene version=\"0.6.0\">\n  <default name=\"m\" value=\"../elsewhere/tri.obj\"/>\n  <shape type=\"obj\"><string name=\"filename\" value=\"\$m\"/></shape>#" "$T/s/param.xml"
refused 2 "param.xml: reads $T/elsewhere/tri.obj, outside the shared folder $T/s" submit "$T/s/param.xml" -o "$T/o2" --dry-run
sphere_scene "$T/s/spd.xml" 12 10 1 '<bsdf type="diffuse"><spectrum name="reflectance" filename="../elsewhere/flat.spd"/></bsdf>'
refused 2 "spd.xml: reads $T/elsewhere/flat.spd, outside" submit "$T/s/spd.xml" -o "$T/o2" --dry-run
printf '<scene version="0.6.0">\n  <shape type="obj"><string name="filename" value="../elsewhere/tri.obj"/></shape>\n</scene>\n' > "$T/s/part.xml"
sphere_scene "$T/s/inc.xml" 12 10 1 '<bsdf type="diffuse"/>'
sed -i 's#<scene version="0.6.0">#<scene version="0.6.0">\n  <include filename="part.xml"/>#' "$T/s/inc.xml"
refused 2 "inc.xml: reads $T/elsewhere/tri.obj, outside" submit "$T/s/inc.xml" -o "$T/o2" --dry-run
"$C" submit "$T/s/inc.xml" -o "$T/o2" --dry-run --shared "$T" >"$T/log" 2>&1 || fail "--shared: $(cat "$T/log")"

# --local: the state from the first task on; SIGTERM stops the renderer, exit 130; SIGKILL
# leaves no renderer writing.
sphere_scene "$T/s/slow.xml" 160 120 100000 '<bsdf type="diffuse"/>'
# start_slow OUT: a --local submit of slow.xml into OUT in the background ($cpid), and the pid
# of its renderer once it runs ($rpid).
start_slow() {
  "$C" submit "$T/s/slow.xml" -o "$1" --threads 1 --local >"$T/slow.log" 2>&1 &
  cpid=$!
  for _ in $(seq 1 150); do [ -s "$1/.cluster/pids/slow" ] && break; sleep 0.1; done
  read -r rpid _ < "$1/.cluster/pids/slow" || fail "the slow task did not start: $(cat "$T/slow.log")"
}
gone() { for _ in $(seq 1 100); do kill -0 "$1" 2>/dev/null || return 0; sleep 0.1; done; return 1; }
start_slow "$T/o3"
"$C" status "$T/o3" >"$T/st" 2>&1 || true
grep -q "frames: 0 done, 1 running" "$T/st" || fail "status during --local: $(cat "$T/st")"
kill -TERM "$cpid"
wait "$cpid"
rc=$?
[ $rc = 130 ] || fail "SIGTERM: exit $rc, not 130: $(cat "$T/slow.log")"
gone "$rpid" || fail "SIGTERM left the renderer running"
grep -q Traceback "$T/slow.log" && fail "SIGTERM: a traceback: $(cat "$T/slow.log")"
start_slow "$T/o4"
kill -KILL "$cpid"
wait "$cpid" 2>/dev/null
gone "$rpid" || { kill -9 "$rpid"; fail "SIGKILL left the renderer running"; }
ls "$T/o3" "$T/o4" | grep -q "slow\." && fail "an interrupted render left an output"
echo "ok"
