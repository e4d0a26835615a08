#!/usr/bin/env bash
# The thin path end to end: simulate a small chess4x4 dataset, factor it with SVD, render a
# scene that uses the factored material on a sphere over a floor under a spot light, and check
# the image: nothing NaN, the floor's radiance against its closed form and the object's against
# its measured figures. Needs only the built commands and python3.
set -euo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup thin_path opaline-factor opaline-render

"$BIN/opaline-factor" dataset chess4x4 --pixels 24x24 --kernel 9 -o "$T/d.opm"
"$BIN/opaline-factor" factor "$T/d.opm" --method svd -T 4 -o "$T/m.opm"

sphere_scene "$T/scene.xml" 64 48 4 \
  '<subsurface type="svd"><string name="material" value="m.opm"/><float name="sceneUnitsPerMetre" value="5"/><integer name="irrSamples" value="2"/></subsurface>'

"$BIN/opaline-render" --check "$T/scene.xml"
"$BIN/opaline-render" -q -t 2 -o "$T/out.pfm" "$T/scene.xml"

# The figures a 10x energy error anywhere would break. The floor region (near the camera,
# inside the spot's beam) against the closed form of a point light over a Lambertian plane,
# 0.5 / pi * I * cos(theta) / d^2 averaged over the pixel centres (the indirect light from the
# sphere adds about 0.5 %). The object region (the sphere's lit top) against the figures
# measured when this test was written (0.3075 0.2406 0.2080 per channel at 4 spp; a diffuse
# sphere of reflectance 0.5 gives 0.243 there), within 15 %.
python3 - "$T/out.pfm" <<'PY'
import math, sys
import pfm
im = pfm.read(sys.argv[1])
assert im.channels == 3, im.channels
w, h, px, at = im.width, im.height, im.samples, im.pixel  # at(x, y): y from the top
assert all(math.isfinite(v) for v in px), "NaN or inf in the image"
assert min(px) >= 0.0, "negative radiance"
def mean(region):
    return [sum(at(x, y)[c] for x, y in region) / len(region) for c in range(3)]
obj_px = [(x, y) for x in range(w // 2 - 3, w // 2 + 3) for y in range(h // 2 - 8, h // 2 - 2)]
floor_px = [(x, y) for x in range(2, 10) for y in range(h - 6, h - 1)]
obj, floor = mean(obj_px), mean(floor_px)

# the camera of sphere_scene: from (0, -4, 2) to (0, 0, 0.5), up +z, 40 degrees across x
def unit(v):
    n = math.sqrt(sum(c * c for c in v))
    return [c / n for c in v]
def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
eye = (0.0, -4.0, 2.0)
fwd = unit([0.0 - eye[0], 0.0 - eye[1], 0.5 - eye[2]])
right = unit(cross(fwd, (0.0, 0.0, 1.0)))
up = cross(right, fwd)
tx = math.tan(math.radians(20.0))
ty = tx * h / w
def floor_radiance(x, y):
    sx, sy = 2.0 * (x + 0.5) / w - 1.0, 2.0 * (y + 0.5) / h - 1.0
    d = [fwd[i] + sx * tx * right[i] - sy * ty * up[i] for i in range(3)]
    p = [eye[i] - eye[2] / d[2] * d[i] for i in range(3)]  # on z = 0
    to_light = (-p[0], -p[1], 6.0)
    d2 = sum(c * c for c in to_light)
    cos_t = 6.0 / math.sqrt(d2)
    theta = math.degrees(math.acos(cos_t))
    falloff = 1.0 if theta <= 30.0 else max(0.0, (40.0 - theta) / 10.0)  # beam 0.75 cutoff
    return 0.5 / math.pi * 60.0 * falloff * cos_t / d2
floor_expect = sum(floor_radiance(x, y) for x, y in floor_px) / len(floor_px)
obj_expect = (0.3075, 0.2406, 0.2080)
print("object %s (expected %s)" % (" ".join("%.4f" % v for v in obj),
                                   " ".join("%.4f" % v for v in obj_expect)))
print("floor %s (closed form %.4f)" % (" ".join("%.4f" % v for v in floor), floor_expect))
for c in range(3):
    assert abs(floor[c] - floor_expect) <= 0.05 * floor_expect, "the floor is off"
    assert abs(obj[c] - obj_expect[c]) <= 0.15 * obj_expect[c], "the translucent object is off"
PY
echo "thin path OK"
