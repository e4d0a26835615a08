"""The ground truth for subsurface (run through bench/bench_sss_truth.sh): opaline's subsurface
models against a volumetric rendering of the same medium, per region of the image.

Each object is rendered three ways with the same camera, lights and boundary:
  - `volume`: the shape's interior is a homogeneous medium of the media table (the dipole's
    reduced coefficients, isotropic phase: `<medium type="homogeneous">` with `material` and
    `scale`), behind a smooth `dielectric` of the medium's index, under `volpath` at VOL_SPP
    samples per pixel: the reference;
  - `dipole`: `<subsurface type="dipole">` of the same medium beside the same `dielectric`
    (docs/subsurface-rendering.md, *The surface's reflection*), under `path`;
  - the measured methods (`raw`; in the full mode also `svd`, T = 4): a homogeneous dataset of
    the same medium made by the Monte Carlo generator (`opaline-factor dataset homogeneous
    --generator montecarlo --medium NAME`: every order of scattering, the medium's index at
    the surface), beside the same `dielectric`, under `path`.
Scene units are centimetres (`sceneUnitsPerMetre` 100; the medium's `scale` 0.1: the table's
1/mm values x 100 per unit x 0.1). Objects are about 2 cm across, floating (no floor), lit by
a 6 x 6 cm area light about 6 cm away (a smooth boundary hides point lights from a volume: a
path inside refracts out and must hit the light) and a dim uniform sky; box reconstruction
filter, independent sampler.

Regions (per pixel, from three auxiliary renders of the same view; a partition of the pixels
wholly on the object, first match wins):
  - `shadow edge`: within R pixels (R = max(1, res / 32): about 1 mm) of the contour where the
    area light's direct irradiance on an opaque copy of the object (`direct` integrator, white
    diffuse) crosses 10 % of its largest value on the object: terminators and cast shadows;
  - `thin`: the camera ray's chord through the object is below THIN_CM (0.4 cm), the chord read
    from a render of the object as a pure absorber (sigma_a 1 per cm, index-matched) against a
    uniform sky: L = exp(-chord);
  - `curved`: the shading normal turns by more than CURVED_PER_CM (0.5 rad per cm: radius of
    curvature below 2 cm) between a pixel and one of its four neighbours, the angle divided by
    the pixel's footprint at the object's distance (grazing views overstate it: they count as
    curved);
  - `flat`: the rest.
Pixels on the object are those whose mean shading normal (16 samples, box filter) has length
above 0.98 and whose eight neighbours are on the object too: silhouettes and hard edges (a
pixel straddling two faces) are left out of every region but counted in `all` (every pixel the
object covers at all).

Figures, per model, medium, shape and region of at least 10 pixels, over the region's pixels
and the three channels (v the model's image, r the reference):
  - relative bias = (sum v - sum r) / sum r;
  - relative RMSE = sqrt(mean (v - r)^2) / mean r (the model's own camera noise included; the
    models render at MODEL_SPP);
  - reference noise: the reference's own RMSE relative to mean r, estimated from its two
    halves. The VOL_SPP image reuses the VOL_SPP / 2 image's samples (the sampler's numbers
    depend on pixel and sample index only, the box filter keeps each sample in its pixel), so
    its second half is 2 I_N - I_(N/2), independent of the first, and the noise of I_N is
    sqrt(mean (first - second)^2) / 2. A model's RMSE well above it is its own error.

Everything goes to OUT: datasets/, scenes/, images/ (PFM of every render, PNG strips:
reference | dipole | raw | dipole's relative error, red above, blue below, full scale +-50 %),
results.csv, and the table on stdout."""

import argparse
import csv
import math
import os
import struct
import subprocess
import sys
import time
import zlib

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                                "tests"))
import pfm  # noqa: E402

# name in the media table, relative index of refraction (the table's: docs/datasets.md, "One
# media table"), dataset pixel pitch in mm and kernel side: the kernel spans about two
# diffusion lengths of the longest channel each way (Marble's reach is cut at 15 mm, most of
# its objects' size), the pitch resolves the shortest.
MEDIA = {
    "skin1": ("Skin1", 1.3, 0.4, 31),
    "marble": ("Marble", 1.5, 1.0, 31),
    "ketchup": ("Ketchup", 1.3, 0.5, 31),
    "vein": ("Vein", 1.5, 0.1, 15),  # low albedo: sigma_s'/sigma_t' about 0.3
}
SHAPES = ("sphere", "slab", "fin", "bunny", "cow")
REGIONS = ("flat", "curved", "thin", "shadow edge", "all")
THIN_CM, CURVED_PER_CM, EDGE_LEVEL, MIN_PIXELS = 0.4, 0.5, 0.10, 10
FOV, EYE = 30.0, (0.0, 2.0, 7.0)
MESHES = {"bunny": "stanford-bunny.obj", "cow": "spot.obj"}

A = None
RENDER = FACTOR = None


def log(msg):
    print(msg, flush=True)


def args():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--build", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--mode", choices=["quick", "full"], default="quick")
    p.add_argument("--media", default=None, help="space-separated subset of %s" % " ".join(MEDIA))
    p.add_argument("--shapes", default=None, help="space-separated subset of %s" % " ".join(SHAPES))
    p.add_argument("--res", type=int, default=None)
    p.add_argument("--vol-spp", type=int, default=None)
    p.add_argument("--model-spp", type=int, default=None)
    p.add_argument("--photons", type=int, default=None)
    p.add_argument("--meshes", default=None, help="the folder holding stanford-bunny.obj, spot.obj")
    a = p.parse_args()
    quick = a.mode == "quick"
    a.media = (a.media or ("skin1 vein" if quick else " ".join(MEDIA))).split()
    a.shapes = (a.shapes or ("sphere fin" if quick else " ".join(SHAPES))).split()
    a.res = a.res or (48 if quick else 128)
    a.vol_spp = a.vol_spp or (256 if quick else 4096)
    a.model_spp = a.model_spp or (64 if quick else 256)
    a.photons = a.photons or (1000 if quick else 4000)
    a.methods = ["dipole", "raw"] if quick else ["dipole", "raw", "svd"]
    for m in a.media:
        if m not in MEDIA:
            sys.exit("bench_sss_truth: unknown medium %r (known: %s)" % (m, " ".join(MEDIA)))
    for s in a.shapes:
        if s not in SHAPES:
            sys.exit("bench_sss_truth: unknown shape %r (known: %s)" % (s, " ".join(SHAPES)))
    if a.res < 16 or a.vol_spp < 2 or a.vol_spp % 2 or a.model_spp < 1:
        sys.exit("bench_sss_truth: need --res >= 16, an even --vol-spp >= 2, --model-spp >= 1")
    return a


# ---------------------------------------------------------------- scenes

def mesh_transform(path):
    """A toWorld that centres the obj at path on the origin, its largest side 2 (cm)."""
    lo, hi = [1e30] * 3, [-1e30] * 3
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                v = [float(t) for t in line.split()[1:4]]
                lo = [min(a, b) for a, b in zip(lo, v)]
                hi = [max(a, b) for a, b in zip(hi, v)]
    c = [(a + b) / 2 for a, b in zip(lo, hi)]
    s = 2.0 / max(b - a for a, b in zip(lo, hi))
    return ('<translate x="%.6g" y="%.6g" z="%.6g"/><scale value="%.6g"/>'
            '<rotate y="1" angle="-30"/>' % (-c[0], -c[1], -c[2], s))


def shape_open(shape):
    """The opening tag and transform of shape (without its closing tag)."""
    if shape == "slab":  # 2.4 x 2.4 x 0.8 cm, tilted towards camera and light
        return ('<shape type="cube"><transform name="toWorld"><scale x="1.2" y="1.2" z="0.4"/>'
                '<rotate x="1" angle="-35"/><rotate y="1" angle="25"/></transform>')
    if shape == "sphere":
        return '<shape type="sphere"><float name="radius" value="1"/>'
    if shape == "fin":  # 2.4 x 2 cm, 1 mm thick, its face to the camera, lit from behind it
        return ('<shape type="cube"><transform name="toWorld"><scale x="1.2" y="1" z="0.05"/>'
                '<rotate y="1" angle="-40"/></transform>')
    path = os.path.join(A.meshes, MESHES[shape])
    return ('<shape type="obj"><string name="filename" value="%s"/>'
            '<transform name="toWorld">%s</transform>' % (path, mesh_transform(path)))


def scene(integrator, spp, shape, inner, lights=True, sky=0.1):
    """The view (perspective, A.res square, box filter, independent sampler), the area light
    (lights), a sky of radiance `sky`, and shape holding `inner`."""
    light = ('<shape type="rectangle"><transform name="toWorld"><scale value="3"/>'
             '<lookat origin="4, 4, 3" target="0, 0, 0" up="0, 1, 0"/></transform>'
             '<emitter type="area"><rgb name="radiance" value="2"/></emitter></shape>'
             if lights else "")
    env = ('<emitter type="constant"><rgb name="radiance" value="%g"/></emitter>' % sky
           if sky > 0 else "")
    return """<scene version="0.6.0">
  <integrator type="%s"/>
  <sensor type="perspective">
    <float name="fov" value="%g"/>
    <transform name="toWorld">
      <lookat origin="%g, %g, %g" target="0, 0, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="%d"/></sampler>
    <film type="hdrfilm"><integer name="width" value="%d"/><integer name="height" value="%d"/>
      <rfilter type="box"/></film>
  </sensor>
  %s%s
  %s%s</shape>
</scene>
""" % (integrator, FOV, EYE[0], EYE[1], EYE[2], spp, A.res, A.res, light, env,
       shape_open(shape), inner)


def dielectric(eta):
    return ('<bsdf type="dielectric"><float name="intIOR" value="%g"/>'
            '<float name="extIOR" value="1"/></bsdf>' % eta)


def model_inner(method, medium, material):
    name, eta = MEDIA[medium][0], MEDIA[medium][1]
    mat = name if method == "dipole" else material
    return ('<subsurface type="%s"><string name="material" value="%s"/>'
            '<float name="sceneUnitsPerMetre" value="100"/></subsurface>%s'
            % (method, mat, dielectric(eta)))


def volume_inner(medium):
    name, eta = MEDIA[medium][0], MEDIA[medium][1]
    return ('%s<medium type="homogeneous" name="interior"><string name="material" value="%s"/>'
            '<float name="scale" value="0.1"/></medium>' % (dielectric(eta), name))


def render(xml_text, label):
    """Writes the scene, renders it (cached while the scene text and renderer are unchanged);
    returns (pfm Image, seconds)."""
    sp = os.path.join(A.out, "scenes", label + ".xml")
    ip = os.path.join(A.out, "images", label + ".pfm")
    tp = ip[:-4] + ".seconds"
    old = None
    if os.path.exists(sp):
        with open(sp) as f:
            old = f.read()
    if (old != xml_text or not os.path.exists(ip) or not os.path.exists(tp)
            or os.path.getmtime(ip) < os.path.getmtime(RENDER)):
        with open(sp, "w") as f:
            f.write(xml_text)
        t0 = time.perf_counter()
        p = subprocess.run([RENDER, "-q", "-t", str(A.threads), "-o", ip, sp],
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        if p.returncode != 0:
            raise RuntimeError("%s failed (exit %d):\n%s" % (sp, p.returncode, p.stderr[-2000:]))
        with open(tp, "w") as f:
            f.write("%.3f\n" % (time.perf_counter() - t0))
    with open(tp) as f:
        return pfm.read(ip), float(f.read())


# ---------------------------------------------------------------- materials

def dataset(medium):
    name, eta, pitch, k = MEDIA[medium]
    n = 16
    path = os.path.join(A.out, "datasets", "%s_mc%d.opm" % (name, A.photons))
    if not os.path.exists(path) or os.path.getmtime(path) < os.path.getmtime(FACTOR):
        log("dataset: homogeneous %s, %d x %d pixels of %g mm, kernel %d, %d photons"
            % (name, n, n, pitch, k, A.photons))
        size = n * pitch / 10.0
        subprocess.run([FACTOR, "dataset", "homogeneous", "--medium", name, "--generator",
                        "montecarlo", "--photons", str(A.photons), "--pixels", "%dx%d" % (n, n),
                        "--size-cm", "%gx%g" % (size, size), "--kernel", str(k), "-t",
                        str(A.threads), "-o", path], check=True,
                       stdout=subprocess.DEVNULL)
    return path


def material(method, medium):
    if method == "dipole":
        return None
    ds = dataset(medium)
    if method == "raw":
        return ds
    path = ds[:-4] + "_svd4.opm"
    if not os.path.exists(path) or os.path.getmtime(path) < os.path.getmtime(ds):
        subprocess.run([FACTOR, "factor", ds, "-o", path, "--method", "svd", "-T", "4",
                        "--log-a", "100", "--log-b", "1", "-q"], check=True,
                       stdout=subprocess.DEVNULL)
    return path


# ---------------------------------------------------------------- regions

def grid(img, c=None):
    """The image as rows top-down of per-pixel tuples (c None) or of channel c."""
    w, h, ch = img.width, img.height, img.channels
    out = []
    for y in range(h):
        row = []
        for x in range(w):
            i = ((h - 1 - y) * w + x) * ch
            row.append(img.samples[i:i + ch] if c is None else img.samples[i + c])
        out.append(row)
    return out


def regions(shape):
    """{region: set of (x, y)}, and the auxiliary renders' seconds."""
    n = A.res
    normals, t1 = render(scene("field", 16, shape, ""), "aux_%s_normals" % shape)
    chord, t2 = render(scene("volpath", 16, shape,
                             '<bsdf type="null"/><medium type="homogeneous" name="interior">'
                             '<rgb name="sigmaA" value="1"/><rgb name="sigmaS" value="0"/>'
                             '</medium>', lights=False, sky=1.0), "aux_%s_chord" % shape)
    direct, t3 = render(scene("direct", 64, shape,
                              '<bsdf type="diffuse"><rgb name="reflectance" value="1"/></bsdf>',
                              sky=0.0), "aux_%s_direct" % shape)
    nrm, lch, dl = grid(normals), grid(chord, 0), grid(direct, 1)
    length = [[math.sqrt(sum(v * v for v in nrm[y][x])) for x in range(n)] for y in range(n)]
    touched = {(x, y) for y in range(n) for x in range(n) if length[y][x] > 0.05}
    full = {(x, y) for (x, y) in touched if length[y][x] > 0.98}
    inside = {(x, y) for (x, y) in full
              if all((x + dx, y + dy) in full for dx in (-1, 0, 1) for dy in (-1, 0, 1))}
    # footprint of a pixel (cm) at the origin's distance
    foot = 2.0 * math.tan(math.radians(FOV) / 2) * math.sqrt(sum(e * e for e in EYE)) / n
    unit = {p: [v / length[p[1]][p[0]] for v in nrm[p[1]][p[0]]] for p in full}
    peak = max([dl[y][x] for (x, y) in full] or [0.0])
    lit = {(x, y) for (x, y) in full if dl[y][x] > EDGE_LEVEL * peak}
    contour = {(x, y) for (x, y) in full if any(
        ((x + dx, y + dy) in full) and (((x + dx, y + dy) in lit) != ((x, y) in lit))
        for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)))}
    r = max(1, n // 32)
    edge = {(x + dx, y + dy) for (x, y) in contour
            for dx in range(-r, r + 1) for dy in range(-r, r + 1)}
    out = {k: set() for k in REGIONS}
    out["all"] = touched
    for p in inside:
        x, y = p
        chord_cm = -math.log(max(lch[y][x], 1e-30))
        bend = 0.0
        for q in ((x + 1, y), (x - 1, y), (x, y + 1), (x, y - 1)):
            if q in unit:
                dot = sum(a * b for a, b in zip(unit[p], unit[q]))
                bend = max(bend, math.acos(max(-1.0, min(1.0, dot))))
        if p in edge:
            out["shadow edge"].add(p)
        elif chord_cm < THIN_CM:
            out["thin"].add(p)
        elif bend / foot > CURVED_PER_CM:
            out["curved"].add(p)
        else:
            out["flat"].add(p)
    return out, t1 + t2 + t3


# ---------------------------------------------------------------- figures

def figures(model, ref, half, region):
    """(relative bias, relative RMSE, reference noise) over region's pixels and channels; None
    when the region has fewer than MIN_PIXELS pixels or is dark."""
    if len(region) < MIN_PIXELS:
        return None
    sv = sr = se = sn = 0.0
    cnt = 0
    for (x, y) in region:
        for c in range(3):
            v, r, h = model[y][x][c], ref[y][x][c], half[y][x][c]
            second = 2.0 * r - h
            sv += v
            sr += r
            se += (v - r) ** 2
            sn += (h - second) ** 2
            cnt += 1
    if sr <= 0:
        return None
    mean = sr / cnt
    return (sv - sr) / sr, math.sqrt(se / cnt) / mean, math.sqrt(sn / cnt) / 2.0 / mean


# ---------------------------------------------------------------- PNG strips

def png(path, rows):
    """Writes rows (top-down lists of (r, g, b) bytes) as an 8-bit RGB PNG."""
    h, w = len(rows), len(rows[0])
    raw = b"".join(b"\x00" + bytes(v for px in row for v in px) for row in rows)

    def chunk(tag, data):
        return (struct.pack(">I", len(data)) + tag + data
                + struct.pack(">I", zlib.crc32(tag + data) & 0xffffffff))
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def srgb(v, scale):
    v = max(0.0, v * scale)
    v = 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055
    return max(0, min(255, int(round(255 * v))))


def strip(path, ref, models, mask):
    """reference | each model | the first model's relative error (luminance; red above, blue
    below the reference, full at +-50 %; grey off the object)."""
    n = A.res
    vals = sorted(sum(ref[y][x]) / 3 for (x, y) in mask) or [1.0]
    scale = 0.8 / max(vals[int(0.98 * (len(vals) - 1))], 1e-9)
    rows = []
    for y in range(n):
        row = []
        for img in [ref] + models:
            row += [tuple(srgb(v, scale) for v in img[y][x]) for x in range(n)]
        for x in range(n):
            if (x, y) not in mask:
                row.append((64, 64, 64))
                continue
            r, m = sum(ref[y][x]), sum(models[0][y][x])
            e = max(-1.0, min(1.0, (m - r) / max(r, 1e-9) / 0.5))
            row.append((255, int(255 * (1 - e)), int(255 * (1 - e))) if e > 0 else
                       (int(255 * (1 + e)), int(255 * (1 + e)), 255))
        rows.append(row)
    png(path, rows)


# ---------------------------------------------------------------- main

def main():
    global A, RENDER, FACTOR
    A = args()
    RENDER = os.path.join(A.build, "bin", "opaline-render")
    FACTOR = os.path.join(A.build, "bin", "opaline-factor")
    for tool in (RENDER, FACTOR):
        if not os.access(tool, os.X_OK):
            sys.exit("bench_sss_truth: %s is not built" % tool)
    for d in ("datasets", "scenes", "images"):
        os.makedirs(os.path.join(A.out, d), exist_ok=True)
    shapes = []
    for s in A.shapes:
        if s in MESHES and not (A.meshes and os.path.isfile(os.path.join(A.meshes, MESHES[s]))):
            log("skip %s: %s is absent (../shared/meshes is not beside the checkout)"
                % (s, MESHES[s]))
            continue
        shapes.append(s)
    log("mode %s: %d x %d, volume %d spp, models %d spp, media %s, shapes %s, methods %s"
        % (A.mode, A.res, A.res, A.vol_spp, A.model_spp, " ".join(A.media), " ".join(shapes),
           " ".join(A.methods)))
    t_start = time.perf_counter()
    rows = []
    for shape in shapes:
        reg, ta = regions(shape)
        log("%s: regions %s (auxiliary renders %.1f s)"
            % (shape, ", ".join("%s %d" % (k, len(reg[k])) for k in REGIONS), ta))
        for medium in A.media:
            base = "%s_%s" % (medium, shape)
            vol = volume_inner(medium)
            half, th = render(scene("volpath", A.vol_spp // 2, shape, vol), base + "_volume_half")
            ref, tr = render(scene("volpath", A.vol_spp, shape, vol), base + "_volume")
            refg, halfg = grid(ref), grid(half)
            log("%s: volume %.1f s (+ half %.1f s)" % (base, tr, th))
            imgs = []
            for method in A.methods:
                inner = model_inner(method, medium, material(method, medium))
                img, tm = render(scene("path", A.model_spp, shape, inner), base + "_" + method)
                g = grid(img)
                imgs.append(g)
                for region in REGIONS:
                    f = figures(g, refg, halfg, reg[region])
                    if f is None:
                        continue
                    rows.append({"model": method, "medium": MEDIA[medium][0], "shape": shape,
                                 "region": region, "pixels": len(reg[region]),
                                 "bias": f[0], "rmse": f[1], "ref_noise": f[2],
                                 "model_s": tm, "volume_s": tr + th})
                log("%s: %s %.1f s" % (base, method, tm))
                write_results(rows)
            strip(os.path.join(A.out, "images", base + ".png"), refg, imgs, reg["all"])
    log("")
    with open(os.path.join(A.out, "table.md")) as f:
        log(f.read())
    log("total %.0f s; images, scenes, results.csv and table.md in %s"
        % (time.perf_counter() - t_start, A.out))


def write_results(rows):
    """results.csv and table.md in OUT, rewritten after every model's render (a run cut short
    keeps what it measured)."""
    with open(os.path.join(A.out, "results.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()) if rows else ["model"])
        w.writeheader()
        w.writerows(rows)
    with open(os.path.join(A.out, "table.md"), "w") as f:
        f.write("| model | medium | shape | region | pixels | rel. bias | rel. RMSE "
                "| ref. noise |\n|---|---|---|---|---|---|---|---|\n")
        for r in rows:
            f.write("| %s | %s | %s | %s | %d | %+.1f %% | %.1f %% | %.1f %% |\n"
                    % (r["model"], r["medium"], r["shape"], r["region"], r["pixels"],
                       100 * r["bias"], 100 * r["rmse"], 100 * r["ref_noise"]))


if __name__ == "__main__":
    main()
