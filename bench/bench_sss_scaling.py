"""bench_sss_scaling.py AFTER_BUILD [BEFORE_BUILD] [THREADS] [REPEAT] - how the subsurface
pre-pass's time and memory grow with the number of irradiance points and with the kernel size.

One series, rendered by every build given (AFTER and, for the comparison, BEFORE: another
build of opaline, e.g. main's), runs interleaved so both see the same machine load:

- points: a flat square of the dipole medium Marble (a millimetre scene, scale 1000) under a
  point light, seen whole by a 32 x 32 camera, so every point is a receiver. The square's side
  doubles from size to size: each build lays its own number of points (its own spacing), and the
  exponent n of time ~ N^n is fitted (least squares in log-log) over the sizes.

Per run: the renderer's own "subsurface pre-pass: X s", the points it laid (from -v), and the
process's peak resident memory (GNU time %M). Medians over REPEAT runs (default 3). Prints a table
and the fitted exponents. OUT (default AFTER_BUILD/bench-sss-scaling) keeps the
scenes."""

import math
import os
import re
import statistics
import subprocess
import sys

POINT_SIDES_MM = [20, 40, 80, 160, 320]


def render(build, scene, threads):
    cmd = ["/usr/bin/time", "-f", "MAXRSS %M", os.path.join(build, "bin", "opaline-render"),
           "-v", "-t", str(threads), "--limit", "sss-points=1e9", "--limit", "kernel=255",
           scene, "-o", scene + "." + os.path.basename(build.rstrip("/")) + ".pfm"]
    p = subprocess.run(cmd, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    if p.returncode:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), p.stderr[-2000:]))
    pre = float(re.search(r"subsurface pre-pass: ([0-9.]+) s", p.stderr).group(1))
    pts = int(re.search(r": ([0-9]+) irradiance points", p.stderr).group(1))
    rss = int(re.search(r"MAXRSS ([0-9]+)", p.stderr).group(1)) / 1024.0
    return pre, pts, rss


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
    return sum((a - mx) * (b - my) for a, b in zip(lx, ly)) / sum((a - mx) ** 2 for a in lx)


def series(builds, sides, scenes, threads, repeat):
    """rows[side] = {build: (points, median pre-pass s, median peak MiB)} for the builds that
    run that side (sides[build]); the builds' runs interleaved."""
    rows = {}
    for side, scene in scenes:
        runs = {b: [] for b in builds if side in sides[b]}
        for _ in range(repeat):
            for b in runs:
                runs[b].append(render(b, scene, threads))
        rows[side] = {b: (r[0][1], statistics.median(x[0] for x in r),
                          statistics.median(x[2] for x in r)) for b, r in runs.items()}
    return rows


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
            map(str, POINT_SIDES_MM + [640, 1280]))).split()]
    scenes = []
    for side in sorted(set(sum(sides.values(), []))):
        path = os.path.join(out, f"marble_{side}mm.xml")
        with open(path, "w") as f:
            f.write(scene_text(side, '<subsurface type="dipole"><string name="material" '
                               'value="Marble"/><float name="scale" value="1000"/>'
                               '<integer name="irrSamples" value="4"/></subsurface>'))
        scenes.append((side, path))
    rows = series(builds, sides, scenes, threads, repeat)
    print(f"Pre-pass against irradiance points: a Marble square (dipole), every point a receiver, "
          f"{threads} threads, medians of {repeat}")
    print("| square |" + "".join(f" {n} points | {n} pre-pass s | {n} peak MiB |" for n in names))
    print("|---" * (1 + 3 * len(builds)) + "|")
    for side, _ in scenes:
        cells = []
        for b in builds:
            v = rows[side].get(b)
            cells.append(f" {v[0]} | {v[1]:.3f} | {v[2]:.0f} |" if v else " | | |")
        print(f"| {side} mm |" + "".join(cells))
    for b, n in zip(builds, names):
        pts = [rows[side][b] for side, _ in scenes if b in rows[side]]
        xs = [v[0] for v in pts]
        ys = [max(v[1], 1e-4) for v in pts]
        print(f"{n}: time ~ N^{fit(xs, ys):.2f} over N = {xs[0]} .. {xs[-1]}, "
              f"N^{fit(xs[1:], ys[1:]):.2f} without the smallest; "
              f"{1e6 * ys[-1] / xs[-1]:.2f} us per point at the largest")


if __name__ == "__main__":
    main()
