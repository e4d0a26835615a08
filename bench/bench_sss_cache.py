"""bench_sss_cache.py BUILD [THREADS] [REPEAT] - the subsurface pre-pass with and without
--sss-cache on the paper-style scene (bench/paper_scene.py: Spot, SVD_S10_Chess4x4 from BUILD's
presets, RES x RES, default 512, 16 spp).

Per case, the medians over REPEAT runs (default 3) of the renderer's own figures: the pre-pass
time ("subsurface pre-pass: X s"), the cache's key, read and write times, and the process wall
time. Cases: no cache; a fresh cache (computed and written); the same view reusing it; the camera
moved (a cache of the first view, copied fresh for each run, extended with the new view's
receivers); a crop tile (a quarter of the film) reusing a --sss-cache-only cache. Every cached
image is compared with the uncached one of the same view (bit-identical). Prints a table;
OUT (default BUILD/bench-sss-cache) keeps the scenes and images."""

import os
import re
import shutil
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import paper_scene  # noqa: E402


def run(cmd):
    t = time.monotonic()
    p = subprocess.run(cmd, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    wall = time.monotonic() - t
    if p.returncode:
        sys.exit("failed (%d): %s\n%s" % (p.returncode, " ".join(cmd), p.stderr))
    f = {"wall": wall}
    m = re.search(r"subsurface pre-pass: ([0-9.]+) s", p.stderr)
    f["prepass"] = float(m.group(1)) if m else 0.0
    m = re.search(r"key ([0-9.]+) s, read ([0-9.]+) s", p.stderr)
    f["key"], f["read"] = (float(m.group(1)), float(m.group(2))) if m else (0.0, 0.0)
    m = re.search(r"written \(.*; ([0-9.]+) s\)", p.stderr)
    f["write"] = float(m.group(1)) if m else 0.0
    m = re.search(r"computed (\d+) new", p.stderr)
    f["new"] = int(m.group(1)) if m else -1
    return f


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    build = sys.argv[1]
    threads = sys.argv[2] if len(sys.argv) > 2 else "2"
    repeat = int(sys.argv[3]) if len(sys.argv) > 3 else 3
    res = int(os.environ.get("RES", "512"))
    out = os.environ.get("OUT") or os.path.join(build, "bench-sss-cache")
    os.makedirs(out, exist_ok=True)
    renderer = os.path.join(build, "bin", "opaline-render")
    material = os.path.abspath(os.path.join(build, "presets", "SVD_S10_Chess4x4.opm"))
    mesh = paper_scene.find_mesh(os.path.dirname(HERE))
    xml = paper_scene.scene_xml("svd", material, 16, res, mesh)
    origin = 'origin="2.6, 1.2, 2.4"'
    assert origin in xml
    scenes = {"a": xml, "b": xml.replace(origin, 'origin="1.6, 1.2, 2.9"')}
    for k, text in scenes.items():
        with open(os.path.join(out, "scene_%s.xml" % k), "w") as f:
            f.write(text)
    base = [renderer, "-t", threads]
    scene = {k: os.path.join(out, "scene_%s.xml" % k) for k in scenes}
    img = lambda name: os.path.join(out, name + ".pfm")  # noqa: E731
    cache = os.path.join(out, "cache")
    rows = {}

    def case(name, prepare, cmd, ref):
        figs = []
        for i in range(repeat):
            prepare()
            only = "--sss-cache-only" in cmd
            figs.append(run(cmd if only else cmd + ["-o", img(name)]))
            if ref:
                with open(img(name), "rb") as a, open(img(ref), "rb") as b:
                    if a.read() != b.read():
                        sys.exit("%s: the image differs from %s" % (name, ref))
        rows[name] = {k: statistics.median(f[k] for f in figs) for k in figs[0]}

    def rm(*paths):
        for p in paths:
            if os.path.exists(p):
                os.remove(p)

    case("none_a", lambda: None, base + [scene["a"]], None)
    case("none_b", lambda: None, base + [scene["b"]], None)
    case("fresh_a", lambda: rm(cache), base + ["--sss-cache", cache, scene["a"]], "none_a")
    case("reused_a", lambda: None, base + ["--sss-cache", cache, scene["a"]], "none_a")
    shutil.copy(cache, cache + ".a")
    case("moved_b", lambda: shutil.copy(cache + ".a", cache),
         base + ["--sss-cache", cache, scene["b"]], "none_b")
    only = cache + ".only"
    case("only_a", lambda: rm(only), base + ["--sss-cache", only, "--sss-cache-only", scene["a"]],
         None)
    q = res // 2
    case("tile_a", lambda: None,
         base + ["--sss-cache", only, "--crop", "%d,%d,%d,%d" % (q, q, q, q), scene["a"]], None)
    print("paper scene %dx%d, 16 spp, %s threads, Spot: %s; medians of %d" %
          (res, res, threads, "yes" if mesh else "no (sphere)", repeat))
    print("| case | pre-pass s | key s | read s | write s | wall s | computed new |")
    print("|---|---|---|---|---|---|---|")
    for name, r in rows.items():
        print("| %s | %.3f | %.3f | %.3f | %.3f | %.2f | %s |" % (
            name, r["prepass"], r["key"], r["read"], r["write"], r["wall"],
            int(r["new"]) if r["new"] >= 0 else "-"))


if __name__ == "__main__":
    main()
