"""paper_scene.py - the paper-style subsurface scene shared by the benchmarks.

One translucent object carrying a measured material (Spot the cow from ../shared/meshes/spot.obj,
or a built-in sphere of about its size where ../shared is absent) on a diffuse floor under a spot
light and a dim constant sky, path tracer with maxDepth 4, rendered by opaline-render with its
default seed (so equal samples give equal random streams: images differ only by the material).
Used by bench_subsurface.py and the methods_bench package; standard library only.

Contract: scene_xml() returns the whole scene text; render() runs opaline-render once and returns
its figures; compare() gives the image error against a reference of the same size."""

import math
import os
import resource
import subprocess
import time

SCALE = 19  # scene units per metre of material: Chess4x4 (12.6 cm) spans Spot's uv chart


def find_mesh(root):
    """Absolute path of Spot (meshes/spot.obj under OPALINE_SHARED_DIR, else ROOT/../shared, else
    ROOT/../../shared for a worktree under wt/), or None when absent."""
    env = os.environ.get("OPALINE_SHARED_DIR")
    dirs = [env] if env else [os.path.join(root, "..", "shared"),
                              os.path.join(root, "..", "..", "shared")]
    for d in dirs:
        p = os.path.join(d, "meshes", "spot.obj")
        if os.path.isfile(p):
            return os.path.abspath(p)
    return None


def scene_xml(method, material, spp, res, mesh=None, scale=SCALE, sampler="independent"):
    """The scene: `material` (absolute .opm path) of subsurface type `method` on `mesh` (an .obj
    path; None: a sphere of radius 0.8 standing where Spot stands, with Mitsuba's uv), res x res
    pixels at spp samples per pixel from `sampler` (a Mitsuba sampler type: independent, or
    sobol for opaline's low-discrepancy numbers, which bench_subsurface uses)."""
    sub = """    <subsurface type="%s">
      <string name="material" value="%s"/>
      <float name="sceneUnitsPerMetre" value="%g"/>
    </subsurface>""" % (method, material, scale)
    if mesh:
        shape = """  <shape type="obj">
    <string name="filename" value="%s"/>
%s
  </shape>""" % (mesh, sub)
    else:
        shape = """  <shape type="sphere">
    <point name="center" x="0" y="0.063" z="0.1"/>
    <float name="radius" value="0.8"/>
%s
  </shape>""" % sub
    return """<scene version="0.6.0">
  <integrator type="path"><integer name="maxDepth" value="4"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="35"/>
    <transform name="toWorld"><lookat origin="2.6, 1.2, 2.4" target="0, 0.05, 0.1" up="0, 1, 0"/></transform>
    <sampler type="%s"><integer name="sampleCount" value="%d"/></sampler>
    <film type="hdrfilm"><integer name="width" value="%d"/><integer name="height" value="%d"/></film>
  </sensor>
  <emitter type="spot">
    <transform name="toWorld"><lookat origin="1.5, 3.5, 2.0" target="0, 0, 0"/></transform>
    <spectrum name="intensity" value="30"/>
    <float name="cutoffAngle" value="40"/>
  </emitter>
  <emitter type="constant"><spectrum name="radiance" value="0.05"/></emitter>
%s
  <shape type="rectangle">
    <transform name="toWorld"><rotate x="1" angle="-90"/><scale value="4"/><translate y="-0.737"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>
  </shape>
</scene>
""" % (sampler, spp, res, res, shape)


def parse_time_v(text):
    """(wall seconds, peak resident MiB) from GNU time -v's report, None where absent."""
    wall = rss = None
    for line in text.splitlines():
        line = line.strip()
        if line.startswith("Elapsed (wall clock) time"):
            s = 0.0
            for part in line.rsplit(": ", 1)[1].split(":"):
                s = s * 60 + float(part)
            wall = s
        elif line.startswith("Maximum resident set size"):
            rss = int(line.rsplit(": ", 1)[1]) / 1024.0
    return wall, rss


def grab(text, key):
    """The number after 'key' on the last line holding it, or None."""
    v = None
    for line in text.splitlines():
        i = line.find(key)
        if i >= 0:
            v = float(line[i + len(key):].split()[0])
    return v


def render(renderer, xml, images, threads, prefix=()):
    """Runs `prefix + renderer -t threads -o IMAGE... xml` once (images: output paths, the first
    a .pfm); raises RuntimeError with the log's tail on failure. Returns the process's wall and
    CPU seconds (user + system of the child), the renderer's own `subsurface pre-pass: X s` and
    `camera pass: X s` (0 and None where it printed none) and its stderr."""
    cmd = list(prefix) + [renderer, "-t", str(threads)]
    for img in images:
        cmd += ["-o", img]
    cmd.append(xml)
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        raise RuntimeError("%s failed (exit %d):\n%s" % (" ".join(cmd), p.returncode,
                                                         p.stderr[-2000:]))
    return {"wall_s": wall,
            "cpu_s": (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime),
            "prepass_s": grab(p.stderr, "subsurface pre-pass: ") or 0.0,
            "render_s": grab(p.stderr, "camera pass: "), "stderr": p.stderr}


def compare(a, ref):
    """RMSE, relative RMSE (to the reference's mean) and PSNR (peak = its largest value; inf when
    equal) of image a against ref."""
    if len(a) != len(ref):
        raise ValueError("images of different sizes (%d and %d samples)" % (len(a), len(ref)))
    mse = sum((x - y) ** 2 for x, y in zip(a, ref)) / len(ref)
    rmse, mean, peak = math.sqrt(mse), sum(ref) / len(ref), max(ref)
    psnr = float("inf") if rmse == 0 else 20 * math.log10(peak / rmse)
    return rmse, (rmse / mean if mean > 0 else float("inf")), psnr
