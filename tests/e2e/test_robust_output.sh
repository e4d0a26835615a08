#!/usr/bin/env bash
# Output never destroys what it replaces, and an interrupted opaline-factor leaves nothing behind
# (docs/limits.md "Output files and interruption"):
#  - a character device (made with mknod here) and a FIFO are written through, never replaced;
#  - a symlink stays a link and its target is replaced (a dangling one gets its target made);
#  - a 0600 file keeps its mode (and, as root, its owner);
#  - a write error (a /dev/full node, stdout on it, a pipe closed early) exits 1 and leaves the old
#    material intact;
#  - the temporary file of a SIGKILLed run is removed by the next run to the same output, one a
#    live process holds locked is kept;
#  - SIGINT, SIGTERM and SIGHUP during dataset, import and factor (while computing, and while the
#    temporary file exists) exit 130 with one line, no sanitizer report, no temporary file left
#    and the previous output unchanged.
set -uo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup robust_output opaline-factor
cleanup() { jobs -p | xargs -r kill -KILL 2>/dev/null; }
# Job control: background commands then get SIGINT (a non-interactive shell makes them ignore it).
set -m
export TMPDIR=$T/tmpdir # where outputs written through keep their data until commit
mkdir "$TMPDIR" "$T/sub"
FAILS=0
fail() { echo "FAIL: $*"; FAILS=$((FAILS + 1)); }
# Every temporary file anywhere under $T (the old names too), listed.
temps() { find "$T" \( -name '*.tmp-*' -o -name '*.unverified' \) -print; }
no_temps() {
  local left
  left=$(temps)
  [ -z "$left" ] || { fail "$1: temporary files left: $left"; rm -f $left; }
}
small=(chess4x4 --pixels 24x24 --kernel 9 -t 2)
"$F" dataset "${small[@]}" -o "$T/ref.opm" 2>/dev/null || { echo "FAIL: dataset"; exit 1; }

# ---- a character device: written through, stays a device
if mknod "$T/null" c 1 3 2>/dev/null && mknod "$T/full" c 1 7 2>/dev/null; then
  FULL=$T/full
  "$F" dataset "${small[@]}" -o "$T/null" 2>/dev/null || fail "dataset -o null: exit $?"
  "$F" factor "$T/ref.opm" --method svd -T 4 -t 2 -o "$T/null" --report "$T/null" \
    --albedo-png "$T/null" >/dev/null 2>&1 || fail "factor -o null: exit $?"
  [ -c "$T/null" ] || fail "the character device $T/null was replaced: $(ls -l "$T/null")"
else
  echo "note: mknod failed (no privilege): the device-node part is skipped, /dev/full used"
  FULL=/dev/full
fi
no_temps "character device"

# ---- a FIFO with a reader: written through, stays a FIFO
mkfifo "$T/fifo"
timeout 20 cat "$T/fifo" >"$T/fifo.out" &
reader=$!
timeout 20 "$F" dataset "${small[@]}" -o "$T/fifo" 2>/dev/null || fail "dataset -o fifo: exit $?"
wait $reader || fail "the FIFO's reader got nothing (exit $?)"
[ -p "$T/fifo" ] || fail "the FIFO was replaced: $(ls -l "$T/fifo")"
cmp -s "$T/fifo.out" "$T/ref.opm" || fail "the FIFO's reader did not get the dataset"
no_temps "FIFO"

# ---- a symlink stays a link; its target (in another folder) is replaced
echo old >"$T/sub/target.opm"
ln -s sub/target.opm "$T/link.opm"
"$F" dataset "${small[@]}" -o "$T/link.opm" 2>/dev/null || fail "dataset -o link: exit $?"
[ -L "$T/link.opm" ] && [ "$(readlink "$T/link.opm")" = sub/target.opm ] ||
  fail "the symlink was replaced: $(ls -l "$T/link.opm")"
cmp -s "$T/sub/target.opm" "$T/ref.opm" || fail "the symlink's target was not updated"
# ---- a dangling symlink: its target is created, the link stays
ln -s sub/new.opm "$T/dangling.opm"
"$F" dataset "${small[@]}" -o "$T/dangling.opm" 2>/dev/null || fail "dataset -o dangling: exit $?"
[ -L "$T/dangling.opm" ] || fail "the dangling symlink was replaced: $(ls -l "$T/dangling.opm")"
cmp -s "$T/sub/new.opm" "$T/ref.opm" || fail "the dangling symlink's target was not created"
no_temps "symlink"

# ---- a 0600 file keeps its mode, and its owner when we are root
echo old >"$T/secret.opm"
chmod 600 "$T/secret.opm"
owner=$(stat -c %u:%g "$T/secret.opm")
[ "$(id -u)" = 0 ] && chown 1234:4321 "$T/secret.opm" && owner=1234:4321
"$F" dataset "${small[@]}" -o "$T/secret.opm" 2>/dev/null || fail "dataset -o secret: exit $?"
[ "$(stat -c %a "$T/secret.opm")" = 600 ] || fail "0600 became $(stat -c %a "$T/secret.opm")"
[ "$(stat -c %u:%g "$T/secret.opm")" = "$owner" ] ||
  fail "owner $owner became $(stat -c %u:%g "$T/secret.opm")"
cmp -s "$T/secret.opm" "$T/ref.opm" || fail "the 0600 file was not updated"
# ---- a new file gets 0666 less the umask
(umask 027 && "$F" dataset "${small[@]}" -o "$T/new.opm" 2>/dev/null) || fail "dataset -o new"
[ "$(stat -c %a "$T/new.opm")" = 640 ] || fail "umask 027 gave mode $(stat -c %a "$T/new.opm")"

# ---- write errors exit 1 and leave the old material intact
"$F" dataset "${small[@]}" -o "$FULL" 2>"$T/err" && fail "dataset -o full: exit 0"
grep -q "No space left" "$T/err" || fail "dataset -o full: no message: $(cat "$T/err")"
echo "the old material" >"$T/m.opm"
cp "$T/m.opm" "$T/m.old"
for out in "--report $FULL" "--albedo-png $FULL" "stdout"; do
  if [ "$out" = stdout ]; then
    "$F" factor "$T/ref.opm" --method svd -T 4 -t 2 -o "$T/m.opm" >"$FULL" 2>"$T/err"
  else
    "$F" factor "$T/ref.opm" --method svd -T 4 -t 2 -o "$T/m.opm" $out >/dev/null 2>"$T/err"
  fi
  rc=$?
  [ $rc = 1 ] || fail "factor with $out on a full disk: exit $rc, expected 1"
  grep -q "No space left" "$T/err" || fail "factor with $out: no message: $(tail -2 "$T/err")"
  cmp -s "$T/m.opm" "$T/m.old" || fail "factor with $out failing replaced the old material"
done
[ "$FULL" = /dev/full ] || [ -c "$FULL" ] || fail "$FULL was replaced: $(ls -l "$FULL")"
# A reader that leaves early: EPIPE (the 560 KB dataset outgrows the pipe's buffer), exit 1.
mkfifo "$T/pipe"
timeout 20 head -c 10 "$T/pipe" >/dev/null &
reader=$!
timeout 20 "$F" dataset "${small[@]}" -o "$T/pipe" 2>"$T/err"
rc=$?
[ $rc = 1 ] || fail "dataset into a closed pipe: exit $rc, expected 1"
grep -q "Broken pipe" "$T/err" || fail "dataset into a closed pipe: no message: $(tail -1 "$T/err")"
wait $reader
[ -p "$T/pipe" ] || fail "the FIFO was replaced: $(ls -l "$T/pipe")"
no_temps "write errors"

# ---- a dataset that takes about a second, and a .npy of the same size
big=(chess4x4 --pixels 128x128 --kernel 21 -t 2)
"$F" dataset "${big[@]}" -o "$T/big.opm" 2>/dev/null || { echo "FAIL: big dataset"; exit 1; }
python3 - "$T/big.npy" <<'EOF'
import struct, sys
d = "{'descr': '<f4', 'fortran_order': False, 'shape': (3, 128, 128, 21, 21), }"
h = d + " " * (64 - (10 + len(d) + 1) % 64) + "\n"
with open(sys.argv[1], "wb") as f:
    f.write(b"\x93NUMPY\x01\x00" + struct.pack("<H", len(h)) + h.encode())
    f.write(bytes(3 * 128 * 128 * 21 * 21 * 4))
EOF
echo '{"size_cm": [5, 5]}' >"$T/big.json"

# Waits (at most 30 s) until a temporary file for $1 of at least $3 bytes (default 0) exists
# while process $2 runs.
wait_for_temp() {
  local f
  for _ in $(seq 3000); do
    for f in "$1".tmp-*; do
      [ -f "$f" ] && [ "$(stat -c %s "$f" 2>/dev/null || echo -1)" -ge "${3:-0}" ] && return 0
    done
    kill -0 "$2" 2>/dev/null || return 1
    sleep 0.01
  done
  return 1
}

# ---- SIGKILL leaves a temporary file; the next run to the same output removes it, but not
# ---- one whose process is alive (this shell's)
echo "previous" >"$T/k.opm"
"$F" dataset "${big[@]}" -o "$T/k.opm" 2>/dev/null &
pid=$!
if wait_for_temp "$T/k.opm" $pid; then
  kill -KILL $pid
  wait $pid 2>/dev/null
  stale=$(compgen -G "$T/k.opm.tmp-*")
  live=$T/k.opm.tmp-opaline-$$-abcdef
  echo x >"$live"
  hold_lock "$live" & # a live writer holds its temporary file locked
  locker=$!
  for _ in $(seq 200); do flock -n "$live" true || break; sleep 0.05; done
  "$F" dataset "${small[@]}" -o "$T/k.opm" 2>"$T/err" || fail "dataset after SIGKILL: exit $?"
  [ -e "$stale" ] && fail "the stale temporary file $stale was not removed"
  grep -q "removed .*no longer running" "$T/err" || fail "no message about the stale file"
  [ -e "$live" ] || fail "the temporary file of a live process was removed"
  kill $locker
  wait $locker 2>/dev/null
  rm -f "$live"
else
  fail "dataset never made a temporary file"
  wait $pid
fi
no_temps "SIGKILL"

# ---- signals: $1 signal, $2 point (handler: once the program has installed its handlers, before
# ---- which a signal would kill it the default way, which is not what is tested; temp: once
# ---- the temporary file exists; temp+N: once it holds N bytes), $3 output, then the command
interrupt() {
  local sig=$1 point=$2 out=$3
  shift 3
  echo "previous output" >"$out"
  cp "$out" "$T/previous"
  "$@" >/dev/null 2>"$T/err" &
  local pid=$!
  if [ "${point%%+*}" = temp ]; then
    local min=0
    [ "$point" = temp ] || min=${point#temp+}
    wait_for_temp "$out" $pid $min || fail "$* made no temporary file of $min bytes before it ended"
  else
    e2e_wait $pid handler "$sig" || fail "$* never installed its $sig handler"
  fi
  kill -"$sig" $pid 2>/dev/null
  wait $pid
  local rc=$? what="SIG$sig at $point during $2"
  [ $rc = 130 ] || fail "$what: exit $rc, expected 130 ($(tail -1 "$T/err"))"
  [ "$(grep -c "interrupted by SIG$sig" "$T/err")" = 1 ] ||
    fail "$what: no single 'interrupted' line: $(tail -2 "$T/err")"
  grep -E "AddressSanitizer|LeakSanitizer|runtime error" "$T/err" && fail "$what: sanitizer report"
  cmp -s "$out" "$T/previous" || fail "$what: the previous output was changed"
  no_temps "$what"
}
# While computing: a Monte Carlo dataset of seconds on any machine, whose temporary file (its
# header) is made before the photons are traced, which the signal ends at once.
slow=(chess4x4 --pixels 16x16 --kernel 7 -t 2 --generator montecarlo --photons 2000)
interrupt INT temp "$T/out.opm" "$F" dataset "${slow[@]}" -o "$T/out.opm"
interrupt TERM temp "$T/out.opm" "$F" dataset "${big[@]}" -o "$T/out.opm"
interrupt HUP temp "$T/out.opm" "$F" dataset "${big[@]}" -o "$T/out.opm"
interrupt TERM temp "$T/out.opm" "$F" import "$T/big.npy" -o "$T/out.opm"
interrupt INT temp+1 "$T/out.opm" "$F" import "$T/big.npy" -o "$T/out.opm"
factor=(factor "$T/big.opm" --method svd -T 4 -t 2 -o "$T/out.opm" --report "$T/out.json"
        --albedo-png "$T/out.png")
# factor: starting (handlers in, loading); factoring (the material's temporary file holds its
# header); verifying it
interrupt HUP handler "$T/out.opm" "$F" "${factor[@]}"
interrupt INT temp "$T/out.opm" "$F" "${factor[@]}"
interrupt TERM temp+100000 "$T/out.opm" "$F" "${factor[@]}"
[ -e "$T/out.json" ] || [ -e "$T/out.png" ] && fail "an interrupted factor left its report or png"

[ $FAILS = 0 ] || { echo "$FAILS failure(s)"; exit 1; }
echo "ok: device, FIFO, symlinks, modes, write errors, stale temporary files, signals"
