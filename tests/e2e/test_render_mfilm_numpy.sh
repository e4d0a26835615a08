#!/usr/bin/env bash
# mfilm's NumPy output (Mitsuba 0.6's fileFormat="numpy"): a NumPy 1.0 .npy file of float32
# values, C order, shape (height, width) for one channel and (height, width, channels) for more,
# as Mitsuba writes it; the header is read back by NumPy's own rules (magic, version, a
# length that puts the data at a multiple of 64 bytes, a Python dict literal), the values
# compared with the same render's PFM. Checked:
#  - the irradiancemeter of test_render_mfilm.sh with fileFormat numpy: its default output is
#    SCENE.npy, a 1 x 1 array holding pi times the view factor of the two disks;
#  - a 5 x 3 rgb mfilm written with -o x.npy and -o x.pfm from the same render: shape (3, 5, 3)
#    and the PFM's values (rows from the top);
#  - numpy.load reads the files back the same, where NumPy is installed.
set -uo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup render_mfilm_numpy opaline-render
FAILS=0
fail() { echo "FAIL: $*"; FAILS=$((FAILS + 1)); }
cat >"$T/meter.xml" <<'XML'
<scene version="0.5.0">
  <integrator type="path"><integer name="maxDepth" value="1"/></integrator>
  <shape type="disk">
    <transform name="toWorld"><translate z="-1"/></transform>
    <sensor type="irradiancemeter">
      <sampler type="independent"><integer name="sampleCount" value="200000"/></sampler>
      <film type="mfilm"><string name="fileFormat" value="numpy"/></film>
    </sensor>
  </shape>
  <shape type="disk">
    <boolean name="flipNormals" value="true"/>
    <transform name="toWorld"><translate z="1"/></transform>
    <emitter type="area"><spectrum name="radiance" value="1"/></emitter>
  </shape>
</scene>
XML
cat >"$T/image.xml" <<'XML'
<scene version="0.5.0">
  <integrator type="path"><integer name="maxDepth" value="2"/></integrator>
  <sensor type="perspective">
    <transform name="toWorld"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="4"/></sampler>
    <film type="mfilm"><integer name="width" value="5"/><integer name="height" value="3"/>
      <string name="pixelFormat" value="rgb"/><string name="fileFormat" value="numpy"/></film>
  </sensor>
  <shape type="sphere"><transform name="toWorld"><translate x="0.7" y="0.9"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.4, 0.2"/></bsdf></shape>
  <emitter type="constant"><spectrum name="radiance" value="1"/></emitter>
</scene>
XML
(cd "$T" && "$R" -q -t 2 meter.xml) || fail "meter.xml: exit $?"
[ -f "$T/meter.npy" ] || fail "no meter.npy (the numpy mfilm's default output) was written"
"$R" -q -t 2 -o "$T/image.npy" -o "$T/image.pfm" "$T/image.xml" || fail "image.xml: exit $?"
python3 - "$T" <<'PY' || fail "the .npy files"
import ast, math, os, struct, sys
import pfm

T = sys.argv[1]
failed = []

def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failed.append(what)

def read_npy(path):
    """NumPy's format 1.0 by its specification: magic, version, header length, dict, data."""
    b = open(path, "rb").read()
    check(b[:6] == b"\x93NUMPY" and b[6:8] == b"\x01\x00", "%s: magic and version 1.0" % path)
    n = struct.unpack("<H", b[8:10])[0]
    check((10 + n) % 64 == 0 and b[10 + n - 1:10 + n] == b"\n",
          "%s: the data start at a multiple of 64, after a newline" % path)
    d = ast.literal_eval(b[10:10 + n].decode("latin1"))
    check(d.get("descr") == "<f4" and d.get("fortran_order") is False,
          "%s: little-endian float32 in C order" % path)
    shape = d["shape"]
    count = 1
    for s in shape:
        count *= s
    data = b[10 + n:]
    check(len(data) == 4 * count, "%s: %d values for shape %s" % (path, count, shape))
    return shape, struct.unpack("<%df" % count, data[:4 * count])

shape, v = read_npy(os.path.join(T, "meter.npy"))
x = 2.0 + 2.0 ** 2
expect = math.pi * (x - math.sqrt(x * x - 4.0)) / 2.0
check(shape == (1, 1), "meter.npy: shape (1, 1), got %s" % (shape,))
check(abs(v[0] - expect) < 0.011, "meter.npy: irradiance %.6f, pi F = %.6f" % (v[0], expect))

shape, v = read_npy(os.path.join(T, "image.npy"))
check(shape == (3, 5, 3), "image.npy: shape (3, 5, 3), got %s" % (shape,))
img = pfm.read(os.path.join(T, "image.pfm"))
same = (img.width, img.height, img.channels) == (5, 3, 3) and all(
    v[(y * 5 + x) * 3 + c] == img.pixel(x, y)[c] for y in range(3) for x in range(5)
    for c in range(3))
# the sphere sits up and to the right: the image differs from its mirror images, so the order
# of rows and columns is seen
flipped = all(v[(y * 5 + x) * 3] == v[((2 - y) * 5 + x) * 3] for y in range(3) for x in range(5))
mirrored = all(v[(y * 5 + x) * 3] == v[(y * 5 + 4 - x) * 3] for y in range(3) for x in range(5))
check(same and not flipped and not mirrored, "image.npy: the PFM's values, rows from the top")

try:
    import numpy
except ImportError:
    print("skip numpy.load: NumPy is not installed")
else:
    a = numpy.load(os.path.join(T, "image.npy"))
    check(a.shape == (3, 5, 3) and a.dtype == numpy.float32 and
          a.flatten().tolist() == list(v), "numpy.load reads image.npy the same")
sys.exit(1 if failed else 0)
PY
[ $FAILS = 0 ] && echo "ok   mfilm numpy"
exit $((FAILS > 0))
