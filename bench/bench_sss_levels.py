"""bench_sss_levels.py AFTER_BUILD [BEFORE_BUILD] [THREADS] [REPEAT] - large dipole objects seen
close up: the points laid in levels around the view (docs/subsurface-rendering.md, *Large
objects*) against laying every point at the profile's spacing, and against BEFORE (another
build, e.g. main's, which capped such shapes at maxPoints).

Cases (a millimetre scene, scale 1000, 128 x 128 at 4 spp, a spot of radius 20 mm, the camera
over a 30 mm strip from its edge outwards):
- marble-1m: a 1 m square of Marble (7.37e6 points at the profile's 0.37 mm);
- skin1-200mm: a 200 mm square of Skin1 (4.54e6 at 0.094 mm);
- marble-sphere: a Marble sphere of radius 0.5 m (2.31e7 points) seen over 40 mm from 0.15 m
  under a point light: no reference (laying every point would take some 8 GB).

Per run: the points laid, the pre-pass seconds, the process's CPU (user + sys) and peak
resident MiB (medians of REPEAT runs, default 3, the builds interleaved), and the image's
relative RMSE per channel (and its worst pixel) against the run that lays every point
(`--limit sss-max-points=1e7`, once). Needs only python3 and GNU time. OUT (default
AFTER_BUILD/bench-sss-levels) keeps the scenes and images."""

import os
import statistics
import sys

_BENCH = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [_BENCH, os.path.join(os.path.dirname(_BENCH), "tests")]
import pfm  # noqa: E402
from bench_sss_scaling import render  # noqa: E402

CAMERA = """<sensor type="perspective"><float name="fov" value="{fov}"/>
  <transform name="toWorld"><lookat origin="{origin}" target="{target}" up="{up}"/></transform>
  <sampler type="independent"><integer name="sampleCount" value="4"/></sampler>
  <film type="hdrfilm"><integer name="width" value="128"/><integer name="height" value="128"/>
  <rfilter type="box"/></film></sensor>"""

SPOT = """<emitter type="spot"><transform name="toWorld"><lookat origin="0,0,200" target="0,0,0"/>
  </transform><spectrum name="intensity" value="40000"/><float name="cutoffAngle" value="5.71"/>
  <float name="beamWidth" value="5.71"/></emitter>"""


def square(medium, half_mm):
    cam = CAMERA.format(fov=28.07, origin="30,0,60", target="30,0,0", up="0,1,0")
    return f"""<scene version="0.6.0"><integrator type="path"/> {cam} {SPOT}
 <shape type="rectangle"><transform name="toWorld"><scale x="{half_mm}" y="{half_mm}" z="1"/>
  </transform><subsurface type="dipole"><string name="material" value="{medium}"/>
  <float name="sceneUnitsPerMetre" value="1000"/><integer name="irrSamples" value="1"/></subsurface></shape>
</scene>
"""


def sphere(medium):
    cam = CAMERA.format(fov=15, origin="0,-150,1000", target="0,0,1000", up="0,0,1")
    return f"""<scene version="0.6.0"><integrator type="path"/> {cam}
 <emitter type="point"><point name="position" x="300" y="-1000" z="1500"/>
  <spectrum name="intensity" value="3e6"/></emitter>
 <shape type="sphere"><point name="center" x="0" y="500" z="1000"/><float name="radius" value="500"/>
  <subsurface type="dipole"><string name="material" value="{medium}"/>
  <float name="sceneUnitsPerMetre" value="1000"/><integer name="irrSamples" value="1"/></subsurface></shape>
</scene>
"""


CASES = [("marble-1m", square("Marble", 500), True),
         ("skin1-200mm", square("Skin1", 100), True),
         ("marble-sphere", sphere("Marble"), False)]
DEFAULT = ("sss-points=1e9",)
EVERY = ("sss-points=1e9", "sss-max-points=1e7")


def image_error(path, ref):
    """Per channel: relative RMSE against ref, and the worst relative pixel difference."""
    a, b = pfm.read(path).samples, pfm.read(ref).samples
    out = []
    for c in range(3):
        num = den = worst = 0.0
        for i in range(c, len(a), 3):
            num += (a[i] - b[i]) ** 2
            den += b[i] ** 2
            if b[i] > 1e-6:
                worst = max(worst, abs(a[i] / b[i] - 1.0))
        out.append((100.0 * (num / den) ** 0.5 if den > 0 else float("nan"), 100.0 * worst))
    return out


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    after = sys.argv[1]
    before = sys.argv[2] if len(sys.argv) > 2 and sys.argv[2] else None
    threads = int(sys.argv[3]) if len(sys.argv) > 3 else 2
    repeat = int(sys.argv[4]) if len(sys.argv) > 4 else 3
    out = os.environ.get("OUT", os.path.join(after, "bench-sss-levels"))
    os.makedirs(out, exist_ok=True)
    builds = [("levels", after)] + ([("before", before)] if before else [])
    print("| case | build | points laid | pre-pass s | CPU s | peak MiB | image rel. RMSE % "
          "R, G, B (worst pixel %) |")
    print("|---|---|---|---|---|---|---|")
    for name, text, has_ref in CASES:
        scene = os.path.join(out, name + ".xml")
        with open(scene, "w") as f:
            f.write(text)
        ref = None
        if has_ref:
            pre, pts, mib, cpu = render(after, scene, threads, EVERY, ".every")
            ref = scene + "." + os.path.basename(after.rstrip("/")) + ".every.pfm"
            print("| %s | every point (sss-max-points=1e7) | %d | %.2f | %.2f | %.0f | (reference) |"
                  % (name, pts, pre, cpu, mib))
        runs = {label: [] for label, _ in builds}
        for _ in range(repeat):
            for label, build in builds:
                runs[label].append(render(build, scene, threads, DEFAULT, "." + label))
        for label, build in builds:
            r = runs[label]
            err = ""
            if ref:
                img = scene + "." + os.path.basename(build.rstrip("/")) + "." + label + ".pfm"
                e = image_error(img, ref)
                err = "%s (%s)" % (", ".join("%.3g" % x for x, _ in e),
                                   ", ".join("%.3g" % w for _, w in e))
            print("| %s | %s | %d | %.2f | %.2f | %.0f | %s |"
                  % (name, label, r[0][1], statistics.median(x[0] for x in r),
                     statistics.median(x[3] for x in r), statistics.median(x[2] for x in r), err))


if __name__ == "__main__":
    main()
