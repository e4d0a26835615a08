"""bench_cluster.py - the figures of bench_cluster.sh (run it, not this: it starts the cluster).

For each tile count, submits the paper-style scene to the running cluster (SLURM_CONF) with
opaline-cluster, waits, and sums the CPU time every task's renderer used (the .cluster/times
records opaline-cluster run writes); compares with one opaline-render of the whole image on
this machine with the same threads. Then an animation of FRAMES frames (the camera circling).
Standard library only."""

import argparse
import glob
import json
import os
import resource
import subprocess
import sys
import time


def single(renderer, xml, out, threads):
    c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.time()
    subprocess.run([renderer, "-q", "-q", "-t", str(threads), xml, "-o", out + ".exr", "-o",
                    out + ".png"], check=True)
    c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.time() - t0, (c1.ru_utime - c0.ru_utime) + (c1.ru_stime - c0.ru_stime)


def cluster(tool, xmls, out, tiles, threads):
    t0 = time.time()
    subprocess.run([tool, "submit"] + xmls + ["-o", out, "--tiles", str(tiles), "--threads",
                   str(threads), "--shared", "/", "--retries", "0"], check=True,
                   stdout=subprocess.DEVNULL)
    while True:
        s = subprocess.run([tool, "status", out], capture_output=True, text=True).stdout
        if " %d of %d frames complete" % (len(xmls), len(xmls)) in s:
            break
        if "failed" in s and " 0 failed" not in s:
            sys.exit("a task failed: %s" % s)
        time.sleep(0.5)
    wall = time.time() - t0
    cpu = {"prepass": 0.0, "tile": 0.0, "frame": 0.0, "merge": 0.0}
    for f in glob.glob(os.path.join(out, ".cluster", "times", "*.json")):
        r = json.load(open(f))
        cpu[r["kind"]] += r["cpu_seconds"]
    return wall, cpu


def same(a, b):
    return open(a, "rb").read() == open(b, "rb").read()


def main():
    ap = argparse.ArgumentParser()
    for k in ("build", "src", "work"):
        ap.add_argument("--" + k, required=True)
    ap.add_argument("--res", type=int)
    ap.add_argument("--spp", type=int)
    ap.add_argument("--frames", type=int)
    ap.add_argument("--tiles")
    ap.add_argument("--threads", type=int)
    a = ap.parse_args()
    sys.path.insert(0, os.path.join(a.src, "bench"))
    import paper_scene
    renderer = os.path.join(a.build, "bin", "opaline-render")
    tool = os.path.join(a.build, "bin", "opaline-cluster")
    opm = os.path.join(a.build, "presets", "SVD_S10_Chess4x4.opm")
    mesh = paper_scene.find_mesh(a.src)
    xml = os.path.join(a.work, "paper.xml")
    with open(xml, "w") as f:
        f.write(paper_scene.scene_xml("svd", opm, a.spp, a.res, mesh))
    cache = "--sss-cache" in subprocess.run([renderer, "--help"], capture_output=True,
                                            text=True).stdout
    print("paper-style scene (%s), %dx%d, %d spp, %d thread(s) per task; renderer %s "
          "--sss-cache" % ("Spot" if mesh else "sphere", a.res, a.res, a.spp, a.threads,
                           "with" if cache else "WITHOUT"))
    wall1, cpu1 = single(renderer, xml, os.path.join(a.work, "single"), a.threads)
    print("%-22s %8s %9s %9s %9s %9s %8s %s" % ("run", "wall s", "CPU s", "pre-pass", "tiles",
                                                 "merge", "CPU/1", "bit-identical"))
    print("%-22s %8.1f %9.1f %9s %9s %9s %8s" % ("single opaline-render", wall1, cpu1, "-", "-",
                                                 "-", "1.000"))
    for n in [int(x) for x in a.tiles.split()]:
        out = os.path.join(a.work, "tiles%d" % n)
        wall, cpu = cluster(tool, [xml], out, n, a.threads)
        total = sum(cpu.values())
        ident = same(os.path.join(out, "paper.exr"), os.path.join(a.work, "single.exr")) and \
            same(os.path.join(out, "paper.png"), os.path.join(a.work, "single.png"))
        print("%-22s %8.1f %9.1f %9.1f %9.1f %9.1f %8.3f %s" % (
            "cluster, %d tile%s" % (n, "s" if n > 1 else ""), wall, total, cpu["prepass"],
            cpu["tile"] + cpu["frame"], cpu["merge"], total / cpu1, "yes" if ident else "NO"))
    # The animation: the camera circles the object, one scene file per frame.
    text = open(xml).read()
    origin = 'origin="2.6, 1.2, 2.4"'
    assert origin in text
    xmls = []
    import math
    for f in range(a.frames):
        ang = 2 * math.pi * f / max(a.frames, 1) / 8
        x, z = 2.6 * math.cos(ang) - 2.4 * math.sin(ang), 2.6 * math.sin(ang) + 2.4 * math.cos(ang)
        p = os.path.join(a.work, "anim", "frame_%04d.xml" % (f + 1))
        os.makedirs(os.path.dirname(p), exist_ok=True)
        with open(p, "w") as fh:
            fh.write(text.replace(origin, 'origin="%.4f, 1.2, %.4f"' % (x, z)))
        xmls.append(p)
    wall, cpu = cluster(tool, xmls, os.path.join(a.work, "anim_out"), 1, a.threads)
    total = sum(cpu.values())
    print("%-22s %8.1f %9.1f   (%.1f s CPU per frame, single frame %.1f s; %.1f frames/min)" % (
        "cluster, %d frames" % a.frames, wall, total, total / a.frames, cpu1,
        60.0 * a.frames / wall))


if __name__ == "__main__":
    main()
