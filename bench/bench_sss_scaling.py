"""bench_sss_scaling.py AFTER_BUILD [BEFORE_BUILD] [THREADS] [REPEAT] - how the subsurface
pre-pass's time and memory grow with the number of irradiance points and with the kernel size.

Three series (SERIES="points k", the default, or one of them), each rendered by every build
given (AFTER and, for the comparison, BEFORE: another build of opaline, e.g. main's), the
builds' runs interleaved so both see the same machine load; no point cap (sss-max-points 5e7):

- points: a flat square of the dipole medium Marble (a millimetre scene, scale 1000) under a
  point light, seen whole by a 32 x 32 camera. The square's side doubles from size to size
  (SIDES, SIDES_BEFORE in mm): each build lays its own number of points (its own spacing), and
  the exponent n of time ~ N^n is fitted (least squares in log-log) over the sizes.
- kernel size K, the dipole: a 160 mm Marble square at density 1/16 .. 1 (points per square
  of the profile's spacing s): the profile's footprint in point spacings, K = 2 x reach /
  (s / sqrt(density)) + 1 (reach: the largest 0.001 % radius, 68 mm), grows from 93 to 371
  while the points grow with density; time per point against K is what the hierarchy bounds.
- kernel size K, measured: `opaline-factor dataset homogeneous --kernel K` (Marble, 64 x 64
  pixels of 0.78 mm) for K = 9, 17, 29, 41 (KS), rendered raw on a 100 mm square (the same
  16384 points for every K).

Per run: the renderer's own "subsurface pre-pass: X s", the points it laid (from -v), the
process's CPU time (user + sys) and peak resident memory (GNU time). Medians over REPEAT runs (default 3). Prints a table
and the fitted exponents. OUT (default AFTER_BUILD/bench-sss-scaling) keeps the
scenes."""

import math
import os
import re
import statistics
import subprocess
import sys

POINT_SIDES_MM = [10, 20, 40, 80, 160, 320]
DIPOLE_DENSITIES = [1 / 16, 1 / 8, 1 / 4, 1 / 2, 1]
DIPOLE_REACH_MM, DIPOLE_SPACING_MM = 68.0, 0.368  # Marble (docs/subsurface-rendering.md)
MEASURED_KS = [9, 17, 29, 41]


NO_CAP = ("sss-points=1e9", "kernel=255", "sss-max-points=5e7")


def render(build, scene, threads, limits=NO_CAP, tag=""):
    """Renders scene with build's opaline-render (-v, the --limit values given) to
    SCENE.BUILD[TAG].pfm; returns the pre-pass seconds, the points laid, the peak resident MiB
    and the process's CPU seconds (user + sys)."""
    cmd = ["/usr/bin/time", "-f", "MAXRSS %M CPU %U %S", os.path.join(build, "bin", "opaline-render"),
           "-v", "-t", str(threads)]
    for lim in limits:
        cmd += ["--limit", lim]
    cmd += [scene, "-o", scene + "." + os.path.basename(build.rstrip("/")) + tag + ".pfm"]
    p = subprocess.run(cmd, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    if p.returncode:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), p.stderr[-2000:]))
    pre = float(re.search(r"subsurface pre-pass: ([0-9.]+) s", p.stderr).group(1))
    pts = int(re.search(r": ([0-9]+) irradiance points", p.stderr).group(1))
    m = re.search(r"MAXRSS ([0-9]+) CPU ([0-9.]+) ([0-9.]+)", p.stderr)
    return pre, pts, int(m.group(1)) / 1024.0, float(m.group(2)) + float(m.group(3))


def scene_text(side_mm, subsurface):
    h = side_mm / 2.0
    return f"""<scene version="0.6.0"><integrator type="path"/>
 <sensor type="perspective"><float name="fov" value="{2 * math.degrees(math.atan(0.5)):.6f}"/>
  <transform name="toWorld"><lookat origin="0,0,{2 * h}" target="0,0,0" up="0,1,0"/></transform>
  <sampler type="independent"><integer name="sampleCount" value="1"/></sampler>
  <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/>
  <rfilter type="box"/></film></sensor>
 <emitter type="point"><point name="position" x="{0.2 * h}" y="0" z="{0.5 * h}"/>
  <spectrum name="intensity" value="{h * h}"/></emitter>
 <shape type="rectangle"><transform name="toWorld"><scale value="{h}"/></transform>
  {subsurface}</shape>
</scene>
"""


def fit(xs, ys):
    lx = [math.log(x) for x in xs]
    ly = [math.log(y) for y in ys]
    mx, my = statistics.mean(lx), statistics.mean(ly)
    if len(set(lx)) < 2:
        return float("nan")
    return sum((a - mx) * (b - my) for a, b in zip(lx, ly)) / sum((a - mx) ** 2 for a in lx)


def series(builds, sides, scenes, threads, repeat):
    """rows[side] = {build: (points, median pre-pass s, median peak MiB, median process CPU s)}
    for the builds that run that side (sides[build]); the builds' runs interleaved."""
    rows = {}
    for side, scene in scenes:
        runs = {b: [] for b in builds if side in sides[b]}
        for _ in range(repeat):
            for b in runs:
                runs[b].append(render(b, scene, threads))
        rows[side] = {b: (r[0][1], statistics.median(x[0] for x in r),
                          statistics.median(x[2] for x in r),
                          statistics.median(x[3] for x in r)) for b, r in runs.items()}
    return rows


def table(title, label, keys, rows, builds, names):
    print(title)
    print(f"| {label} |" + "".join(f" {n} points | {n} pre-pass s | {n} CPU s | {n} peak MiB |"
                                  for n in names))
    print("|---" * (1 + 4 * len(builds)) + "|")
    for key, text in keys:
        cells = []
        for b in builds:
            v = rows[key].get(b)
            cells.append(f" {v[0]} | {v[1]:.3f} | {v[3]:.2f} | {v[2]:.0f} |" if v else " | | | |")
        print(f"| {text} |" + "".join(cells))


def k_axis(builds, names, out, threads, repeat):
    """The two kernel-size series (see the module's text)."""
    scenes = []
    for d in [float(v) for v in os.environ.get("DENSITIES", " ".join(
            map(str, DIPOLE_DENSITIES))).split()]:
        path = os.path.join(out, f"marble_160mm_d{d:.4f}.xml")
        with open(path, "w") as f:
            f.write(scene_text(160, '<subsurface type="dipole"><string name="material" '
                               'value="Marble"/><float name="sceneUnitsPerMetre" value="1000"/>'
                               f'<float name="density" value="{d:.6g}"/>'
                               '<integer name="irrSamples" value="4"/></subsurface>'))
        k = 2.0 * DIPOLE_REACH_MM / (DIPOLE_SPACING_MM / math.sqrt(d)) + 1
        scenes.append((d, path, k))
    factor = os.path.join(builds[0], "bin", "opaline-factor")
    mscenes = []
    for K in [int(v) for v in os.environ.get("KS", " ".join(map(str, MEASURED_KS))).split()]:
        opm = os.path.join(out, f"homogeneous_k{K}.opm")
        if not os.path.exists(opm):
            subprocess.run([factor, "dataset", "homogeneous", "--kernel", str(K), "-o", opm,
                            "-t", str(threads)], check=True, stdout=subprocess.DEVNULL)
        path = os.path.join(out, f"raw_k{K}.xml")
        with open(path, "w") as f:
            f.write(scene_text(100, f'<subsurface type="raw"><string name="material" '
                               f'value="{os.path.abspath(opm)}"/><float name="sceneUnitsPerMetre" '
                               'value="1000"/><integer name="irrSamples" value="4"/>'
                               '</subsurface>'))
        mscenes.append((K, path))
    every = {b: [d for d, _, _ in scenes] for b in builds}
    rows = series(builds, every, [(d, p) for d, p, _ in scenes], threads, repeat)
    table(f"Pre-pass against the dipole's footprint K in point spacings: a 160 mm Marble "
          f"square, density 1/16 .. 1, {threads} threads, medians of {repeat}", "density, K",
          [(d, f"{d:.4g}, {k:.0f}") for d, _, k in scenes], rows, builds, names)
    for b, n in zip(builds, names):
        ks = [k for _, _, k in scenes]
        per = [rows[d][b][3] / rows[d][b][0] for d, _, _ in scenes]
        print(f"{n}: CPU per point ~ K^{fit(ks, per):.2f}, CPU ~ K^{fit(ks, [rows[d][b][3] for d, _, _ in scenes]):.2f}")
    every = {b: [K for K, _ in mscenes] for b in builds}
    rows = series(builds, every, mscenes, threads, repeat)
    table(f"Pre-pass against a measured material's kernel size K: raw homogeneous Marble, "
          f"100 mm square, {threads} threads, medians of {repeat}", "K",
          [(K, str(K)) for K, _ in mscenes], rows, builds, names)
    for b, n in zip(builds, names):
        ks = [K for K, _ in mscenes]
        print(f"{n}: CPU ~ K^{fit(ks, [rows[K][b][3] for K in ks]):.2f}, pre-pass ~ "
              f"K^{fit(ks, [max(rows[K][b][1], 1e-4) for K in ks]):.2f}")


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    after = sys.argv[1]
    before = sys.argv[2] if len(sys.argv) > 2 and sys.argv[2] != "-" else None
    threads = int(sys.argv[3]) if len(sys.argv) > 3 else 2
    repeat = int(sys.argv[4]) if len(sys.argv) > 4 else 3
    builds = [after] + ([before] if before else [])
    names = ["after"] + (["before"] if before else [])
    out = os.environ.get("OUT", os.path.join(after, "bench-sss-scaling"))
    os.makedirs(out, exist_ok=True)
    sides = {after: [int(v) for v in os.environ.get("SIDES", " ".join(map(str, POINT_SIDES_MM))).split()]}
    if before:
        sides[before] = [int(v) for v in os.environ.get("SIDES_BEFORE", " ".join(
            map(str, sides[after]))).split()]
    scenes = []
    for side in sorted(set(sum(sides.values(), []))):
        path = os.path.join(out, f"marble_{side}mm.xml")
        with open(path, "w") as f:
            f.write(scene_text(side, '<subsurface type="dipole"><string name="material" '
                               'value="Marble"/><float name="sceneUnitsPerMetre" value="1000"/>'
                               '<integer name="irrSamples" value="4"/></subsurface>'))
        scenes.append((side, path))
    if os.environ.get("SERIES", "points k").find("points") >= 0:
        rows = series(builds, sides, scenes, threads, repeat)
        table(f"Pre-pass against irradiance points: a Marble square (dipole) seen whole by a "
              f"32 x 32 camera, {threads} threads, medians of {repeat}", "square",
              [(side, f"{side} mm") for side, _ in scenes], rows, builds, names)
        for b, n in zip(builds, names):
            pts = [rows[side][b] for side, _ in scenes if b in rows[side]]
            xs = [v[0] for v in pts]
            ys = [max(v[1], 1e-4) for v in pts]
            cs = [max(v[3], 1e-4) for v in pts]
            print(f"{n}: pre-pass ~ N^{fit(xs, ys):.2f}, process CPU ~ N^{fit(xs, cs):.2f}, "
                  f"peak memory ~ N^{fit(xs, [v[2] for v in pts]):.2f} over N = {xs[0]} .. "
                  f"{xs[-1]}; {1e6 * ys[-1] / xs[-1]:.2f} us per point at the largest")
    if os.environ.get("SERIES", "points k").find("k") >= 0:
        k_axis(builds, names, out, threads, repeat)


if __name__ == "__main__":
    main()
