# Sourced by the end-to-end tests: their preamble (e2e_setup) and what several of them share.
# A test skips (exit 77, which ctest shows as "Skipped") only for what this build does not make
# or this machine lacks, after printing why; a program or preset that the build makes but that
# is missing fails it.

# e2e_skip REASON: the test skips.
e2e_skip() {
  echo "skip: $*"
  exit 77
}

# e2e_setup NAME [PROGRAM...]: fails unless every PROGRAM is built in $OPALINE_BIN_DIR; skips
# unless python3 is found; then sets SRC (the checkout), BIN, R (opaline-render), C
# (opaline-cluster), F (opaline-factor) and T, a fresh temporary folder NAME.XXXXXX, and puts
# tests/ on PYTHONPATH (python3 parts `import pfm`, the tests' PFM reader). On exit the
# script's own `cleanup` function runs when it defines one, then T is removed (unless KEEP is
# set).
e2e_setup() {
  local name=$1 p
  shift
  SRC=${OPALINE_SOURCE_DIR:-$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)}
  BIN=${OPALINE_BIN_DIR:?OPALINE_BIN_DIR is not set}
  R=$BIN/opaline-render
  C=$BIN/opaline-cluster
  F=$BIN/opaline-factor
  for p in "$@"; do
    [ -x "$BIN/$p" ] || { echo "FAIL: $BIN/$p is not built"; exit 1; }
  done
  command -v python3 >/dev/null || e2e_skip "python3 not found"
  export PYTHONPATH=$SRC/tests${PYTHONPATH:+:$PYTHONPATH}
  T=$(mktemp -d "${OPALINE_TEST_TMP:-/tmp}/$name.XXXXXX")
  trap e2e_exit EXIT
}

# e2e_setup's EXIT trap; keeps the script's exit status.
e2e_exit() {
  local rc=$?
  if declare -F cleanup >/dev/null; then cleanup; fi
  [ -n "${KEEP:-}" ] || { chmod -R u+w "$T" 2>/dev/null || true; rm -rf "$T"; }
  exit $rc
}

# e2e_need COMMAND...: skips unless every COMMAND is found.
e2e_need() {
  local c
  for c in "$@"; do
    command -v "$c" >/dev/null || e2e_skip "$c not found"
  done
}

# e2e_presets: sets PRESETS to the build's presets folder; skips when the build makes none
# (OPALINE_PRESETS_DIR empty).
e2e_presets() {
  PRESETS=${OPALINE_PRESETS_DIR:-}
  [ -n "$PRESETS" ] || e2e_skip "the build makes no presets (OPALINE_BUILD_PRESETS=OFF)"
}

# e2e_preset NAME: e2e_presets, then sets OPM to the built preset NAME.opm; fails when the build
# made presets but not this one.
e2e_preset() {
  e2e_presets
  OPM=$PRESETS/$1.opm
  [ -f "$OPM" ] || { echo "FAIL: the preset $OPM is not built"; exit 1; }
}

# e2e_wait PID WHAT...: waits until process PID has reached WHAT, by its own account, and
# returns 0; returns 1 when it ended first. No delay: a signal or a kill sent after it lands in
# the stage it names. WHAT is one of
#   handler SIG            its handler of SIG is installed (SigCgt of /proc/PID/status);
#   file FILE              FILE exists;
#   line FILE TEXT         FILE, its standard error, holds the fixed string TEXT;
#   stream FILE begin      FILE, the tile stream it writes (opaline-render --stream), holds the
#                          begin record;
#   stream FILE stage S    ... a progress record of stage S (irradiance, subsurface, render);
#   stream FILE done S     ... stage S's record of 100 %;
#   stream FILE tiles N    ... N tile records;
#   ended                  its end (PID need not be a child: an unreaped zombie has ended).
# After PID has ended it tells whether it had reached WHAT. In --stream mode the progress goes
# into the stream, not to standard error.
e2e_wait() {
  python3 - "$@" <<'PY'
import os, signal, struct, sys, time
pid, what, args = int(sys.argv[1]), sys.argv[2], sys.argv[3:]

def read(path):
    try:
        with open(path, "rb") as f:
            return f.read()
    except FileNotFoundError:
        return b""

def stream_holds(data, kind, arg):
    pos = tiles = 0
    while pos + 16 <= len(data):
        magic, typ, n = struct.unpack_from("<4sIQ", data, pos)
        if magic != b"OPTS":
            sys.exit("%s: not a tile stream at byte %d" % (args[0], pos))
        if pos + 16 + n > len(data):
            break
        body = data[pos + 16:pos + 16 + n]
        pos += 16 + n
        if kind == "begin" and typ == 1:
            return True
        if kind in ("stage", "done") and typ == 3 and body[12:].decode() == arg and (
                kind == "stage" or struct.unpack_from("<d", body)[0] == 1.0):
            return True
        tiles += typ == 2
    return kind == "tiles" and tiles >= int(arg)

def reached():
    if what == "ended":
        return not running()
    if what == "handler":
        bit = 1 << (signal.Signals["SIG" + args[0]].value - 1)
        for line in read("/proc/%d/status" % pid).decode().splitlines():
            if line.startswith("SigCgt:"):
                return int(line.split()[1], 16) & bit != 0
        return False
    if what == "file":
        return os.path.exists(args[0])
    if what == "line":
        return args[1].encode() in read(args[0])
    if what == "stream":
        return stream_holds(read(args[0]), args[1], args[2] if len(args) > 2 else None)
    sys.exit("e2e_wait: unknown WHAT %r" % what)

def running():  # a zombie (ended, not yet reaped by the shell) is not
    stat = read("/proc/%d/stat" % pid)
    return bool(stat) and stat.rsplit(b")", 1)[1].split()[0] not in (b"Z", b"X")

while not reached():
    if not running():
        sys.exit(1)
    time.sleep(0.01)
PY
}

# fail MESSAGE: the test fails with MESSAGE and the head of $T/err (stderr of the last command
# that saved it there). Tests that have more to show define their own after sourcing this file.
fail() {
  echo "FAIL: $*"
  [ -f "$T/err" ] && sed 's/^/  stderr: /' "$T/err" | head -20
  exit 1
}

# dipole_sphere_scene DIR [FLOOR-XML]: writes DIR/scene.xml, a 48 x 40 film (2 spp, Gaussian
# filter) of a sphere of radius 0.5 resting at z = 0.5 with a dipole subsurface medium, on a
# grey 6 x 6 floor (DIR/floor.obj, a mesh file), lit by a point light at (1, -2, lightz), seen from
# (camx, -4, 2); camx (0), lightz (4) and medium (Skin1) are scene defaults (-D name=value).
# FLOOR-XML (optional) goes into the floor's <bsdf>.
dipole_sphere_scene() {
  cat > "$1/scene.xml" <<XML
<scene version="0.6.0">
  <default name="camx" value="0"/>
  <default name="lightz" value="4"/>
  <default name="medium" value="Skin1"/>
  <integrator type="path"><integer name="maxDepth" value="4"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="30"/>
    <transform name="toWorld"><lookat origin="\$camx, -4, 2" target="0, 0, 0.5" up="0, 0, 1"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="2"/></sampler>
    <film type="hdrfilm"><integer name="width" value="48"/><integer name="height" value="40"/>
      <rfilter type="gaussian"/></film>
  </sensor>
  <emitter type="point">
    <point name="position" x="1" y="-2" z="\$lightz"/>
    <spectrum name="intensity" value="30"/>
  </emitter>
  <shape type="sphere">
    <point name="center" x="0" y="0" z="0.5"/>
    <float name="radius" value="0.5"/>
    <subsurface type="dipole"><string name="material" value="\$medium"/></subsurface>
  </shape>
  <shape type="obj">
    <string name="filename" value="floor.obj"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/>${2:-}</bsdf>
  </shape>
</scene>
XML
  printf 'v -3 -3 0\nv 3 -3 0\nv 3 3 0\nv -3 3 0\nf 1 2 3\nf 1 3 4\n' > "$1/floor.obj"
}

# sphere_scene FILE WIDTH HEIGHT SPP SURFACE-XML: writes the tests' small paper-style scene to
# FILE: a sphere of radius 0.5 resting at z = 0.5 that carries SURFACE-XML (a <subsurface> or
# <bsdf> element), on a grey 6 x 6 diffuse floor, under a 40 degree spot light from 6 above,
# seen from (0, -4, 2); path tracing to depth 4, independent sampler with SPP samples.
sphere_scene() {
  cat > "$1" <<XML
<scene version="0.6.0">
  <integrator type="path"><integer name="maxDepth" value="4"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="toWorld"><lookat origin="0, -4, 2" target="0, 0, 0.5" up="0, 0, 1"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="$4"/></sampler>
    <film type="hdrfilm"><integer name="width" value="$2"/><integer name="height" value="$3"/></film>
  </sensor>
  <emitter type="spot">
    <transform name="toWorld"><lookat origin="0, 0, 6" target="0, 0, 0"/></transform>
    <float name="cutoffAngle" value="40"/>
    <spectrum name="intensity" value="60"/>
  </emitter>
  <shape type="sphere">
    <point name="center" x="0" y="0" z="0.5"/>
    <float name="radius" value="0.5"/>
    $5
  </shape>
  <shape type="rectangle">
    <transform name="toWorld"><scale value="3"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>
  </shape>
</scene>
XML
}

# hold_lock FILE: holds an flock on FILE, as a live opaline writer holds its temporary file,
# until killed (one process, with no output, so that killing it ends everything it holds).
hold_lock() {
  exec python3 -c 'import fcntl, sys, time
f = open(sys.argv[1])
fcntl.flock(f, fcntl.LOCK_EX)
time.sleep(600)' "$1" >/dev/null 2>&1
}
