#!/usr/bin/env python3
"""A hostile run: several hundred inputs and situations that a hostile user, a shared render host
and a studio farm produce, thrown at opaline-render, opaline-factor and opaline-cluster. Every
case must end cleanly (docs/limits.md):

  - an exit code the case allows (0, 1, 2 or 130; never a signal, never a hang past --timeout);
  - a failure says why: an "opaline: error:" (or "opaline-cluster:") line, no Python traceback;
  - no sanitizer report (run it on the sanitizer build: the README's test build);
  - bounded memory (peak RSS below --max-rss-mb; the sanitizer adds its own share);
  - nothing left behind (no *.tmp-opaline-* file) and nothing lost: every file a case guards
    (its inputs, a link's target, an old output) is unchanged, or, for an output, old or whole.

    hostile_run.py --bin BUILD/bin --out DIR [--only CATEGORY,...] [--timeout S] [--jobs N]

Writes DIR/hostile.csv (category, case, exit, seconds, peak MiB, verdict, why) and DIR/hostile.md
(the counts per category and every failure), prints the counts, exits 1 when any case fails.
Needs python3 only; the planted-link cases need root (skipped, and counted so, otherwise).
"""

import argparse
import concurrent.futures
import csv
import hashlib
import os
import random
import resource
import shutil
import signal
import socket
import stat
import subprocess
import sys
import tempfile
import threading
import time

SANITIZER = ("ERROR: AddressSanitizer", "ERROR: LeakSanitizer", "runtime error:",
             "ERROR: UndefinedBehaviorSanitizer")

SCENE = """<?xml version="1.0"?>
<scene version="0.6.0">
  <integrator type="path"><integer name="maxDepth" value="{maxDepth}"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="{fov}"/>
    <transform name="toWorld"><lookat origin="{origin}" target="0, 0, 0" up="{up}"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="{spp}"/></sampler>
    <film type="hdrfilm"><integer name="width" value="{width}"/>
      <integer name="height" value="{height}"/></film>
  </sensor>
  <emitter type="point"><point name="position" x="{lx}" y="-2" z="3"/>
    <spectrum name="intensity" value="{intensity}"/></emitter>
  <shape type="sphere"><point name="center" x="0" y="0" z="0"/>
    <float name="radius" value="{radius}"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="{reflectance}"/></bsdf></shape>
  <shape type="obj"><string name="filename" value="mesh.obj"/>
    <transform name="toWorld"><scale value="{scale}"/></transform></shape>
</scene>
"""
FIELDS = dict(maxDepth="4", fov="40", origin="0, -4, 1", up="0, 0, 1", spp="2", width="24",
              height="16", lx="0", intensity="10", radius="0.5", reflectance="0.5", scale="1")
MESH = "v -1 -1 -1\nv 1 -1 -1\nv 0 1 -1\nf 1 2 3\n"
BAD_NUMBERS = ["nan", "inf", "-inf", "1e400", "-1e400", "1e-310", "0", "-1", "2147483648",
               "99999999999999999999", "", "abc", "1,2", "0x10", " 1 ", "1e-45", "-0"]


class Case:
    """One command in a fresh folder. files: name -> bytes or str to write first; guard: names
    whose contents must not change; whole: output -> reference name (the output must end old or
    equal to the reference); allow: exit codes allowed; setup: f(dir) run before; signal_after:
    (signal, seconds) sent to the process group."""

    def __init__(self, category, name, argv, files=None, guard=(), whole=None, allow=(0, 2),
                 setup=None, signal_after=None, stdin=None, env=None, limit_fsize=None):
        self.category, self.name, self.argv = category, name, argv
        self.files, self.guard, self.whole = files or {}, guard, whole or {}
        self.allow, self.setup, self.signal_after = allow, setup, signal_after
        self.stdin, self.env, self.limit_fsize = stdin, env or {}, limit_fsize


def digest(path):
    try:
        with open(path, "rb") as f:
            return hashlib.sha256(f.read()).hexdigest()
    except OSError as e:
        return "unreadable: %s" % e.strerror


def run_case(case, bins, timeout, max_rss_mb, root):
    d = tempfile.mkdtemp(prefix="case.", dir=root)
    try:
        return _run_case(case, bins, timeout, max_rss_mb, d)
    finally:
        subprocess.run(["chattr", "-R", "-i", d], stderr=subprocess.DEVNULL, check=False)
        shutil.rmtree(d, ignore_errors=True)


def _run_case(case, bins, timeout, max_rss_mb, d):
    tmpdir = os.path.join(d, "tmpdir")
    os.mkdir(tmpdir)
    for name, data in case.files.items():
        p = os.path.join(d, name)
        os.makedirs(os.path.dirname(p), exist_ok=True)
        with open(p, "wb") as f:
            f.write(data.encode() if isinstance(data, str) else data)
    if case.setup:
        try:
            why = case.setup(d)
        except (OSError, subprocess.SubprocessError) as e:
            return ("FAIL", None, 0.0, 0.0, "the case's setup failed: %s" % e)
        if why:
            return ("skip", None, 0.0, 0.0, why)
    before = {g: digest(os.path.join(d, g)) for g in case.guard}
    old = {o: digest(os.path.join(d, o)) for o in case.whole}
    argv = [bins.get(a, a) if isinstance(a, str) else a for a in case.argv]
    env = dict(os.environ)
    env["TMPDIR"] = tmpdir
    env.update(case.env)

    def pre():
        os.setsid()
        if case.limit_fsize:
            resource.setrlimit(resource.RLIMIT_FSIZE, (case.limit_fsize, case.limit_fsize))
        for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP, signal.SIGPIPE, signal.SIGXFSZ):
            signal.signal(s, signal.SIG_DFL)

    t0 = time.monotonic()
    try:
        p = subprocess.Popen(argv, cwd=d, env=env, stdin=subprocess.DEVNULL if case.stdin is None
                             else subprocess.PIPE, stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, preexec_fn=pre)
    except OSError as e:
        return ("FAIL", None, 0.0, 0.0, "cannot start: %s" % e)
    chunks = {1: [], 2: []}
    readers = [threading.Thread(target=lambda f, k: chunks[k].append(f.read()), args=(f, k))
               for f, k in ((p.stdout, 1), (p.stderr, 2))]
    for t in readers:
        t.start()
    if case.stdin is not None:
        p.stdin.write(case.stdin)
        p.stdin.close()
    hung, signalled, status, usage = False, False, None, None
    while status is None:  # os.wait4: this child's own peak memory
        pid, st, ru = os.wait4(p.pid, os.WNOHANG)
        if pid:
            status, usage = st, ru
            break
        elapsed = time.monotonic() - t0
        if case.signal_after and not signalled and elapsed >= case.signal_after[1]:
            os.killpg(p.pid, case.signal_after[0])
            signalled = True
        if elapsed > timeout and not hung:
            os.killpg(p.pid, signal.SIGKILL)
            hung = True
        time.sleep(0.005)
    p.returncode = os.waitstatus_to_exitcode(status)
    for t in readers:
        t.join()
    err = b"".join(chunks[2])
    secs = time.monotonic() - t0
    rss = usage.ru_maxrss / 1024.0
    rc = p.returncode
    text = err.decode(errors="replace")
    why = []
    if hung:
        why.append("no end within %d s" % timeout)
    if rss > max_rss_mb:
        why.append("peak memory %.0f MiB over %.0f" % (rss, max_rss_mb))
    elif rc < 0:
        why.append("killed by signal %d" % -rc)
    elif rc not in case.allow:
        why.append("exit %d (allowed %s)" % (rc, "/".join(map(str, case.allow))))
    if rc not in (0, None) and not hung and rc > 0 and not (
            "opaline: error:" in text or "opaline-cluster:" in text or
            "opaline: warning: interrupted" in text):
        why.append("exit %d without an error message" % rc)
    if "Traceback (most recent call last)" in text:
        why.append("a Python traceback")
    for s in SANITIZER:
        if s in text:
            why.append("sanitizer: " + s)
            break
    left = [os.path.join(r, f) for r, _, fs in os.walk(d) for f in fs if ".tmp-opaline-" in f]
    if left:
        why.append("temporary files left: " + ", ".join(os.path.relpath(x, d) for x in left))
    for g, h in before.items():
        if digest(os.path.join(d, g)) != h:
            why.append("%s changed" % g)
    for o, ref in case.whole.items():
        now = digest(os.path.join(d, o))
        if now != old[o] and now != digest(os.path.join(d, ref)):
            why.append("%s neither old nor whole" % o)
    verdict = "FAIL" if why else "ok"
    line = text.strip().splitlines()
    detail = "; ".join(why) if why else (line[-1][:160] if line else "")
    return (verdict, rc, secs, rss, detail)


# ------------------------------------------------------------------ the cases

def write(d, name, text):
    """Writes text to d/name; returns None (a setup that did not skip)."""
    with open(os.path.join(d, name), "w") as f:
        f.write(text)


def scene(**over):
    f = dict(FIELDS)
    f.update(over)
    return SCENE.format(**f)


def base_files(**over):
    return {"scene.xml": scene(**over), "mesh.obj": MESH}


def cases_numbers():
    out = []
    for field in FIELDS:
        for v in BAD_NUMBERS:
            files = base_files(**{field: v})
            out.append(Case("scene numbers", "%s=%r --check" % (field, v),
                            ["opaline-render", "--check", "scene.xml"], files,
                            guard=("scene.xml", "mesh.obj")))
            out.append(Case("scene numbers", "%s=%r render" % (field, v),
                            ["opaline-render", "-q", "-t", "2", "scene.xml", "-o", "out.png"],
                            files, guard=("scene.xml", "mesh.obj")))
    return out


def nested_includes(k, depth):
    files = {}
    for level in range(depth):
        inner = "".join('<include filename="f%d.xml"/>' % (level + 1) for _ in range(k))
        files["f%d.xml" % level] = '<scene version="0.6.0">%s</scene>' % (
            inner if level + 1 < depth else "")
    files["scene.xml"] = scene().replace("</scene>", '<include filename="f0.xml"/></scene>')
    return files


def default_bomb(levels, fan):
    defs = ['<default name="d0" value="xxxxxxxxxx"/>']
    for i in range(1, levels):
        defs.append('<default name="d%d" value="%s"/>' % (i, ("$d%d" % (i - 1)) * fan))
    body = "".join(defs) + '<default name="x" value="$d%d"/>' % (levels - 1)
    return scene().replace('<scene version="0.6.0">', '<scene version="0.6.0">' + body)


def cases_structure(rng):
    c = []

    def check(name, files, allow=(0, 2), extra=()):
        files = dict(files)
        files.setdefault("mesh.obj", MESH)
        c.append(Case("scene structure", name, ["opaline-render", "--check", "scene.xml",
                                                 *extra], files, allow=allow))
        c.append(Case("scene structure", name + " --estimate",
                      ["opaline-render", "--estimate", "scene.xml", *extra], files, allow=allow))

    s = scene()
    inc = lambda body: s.replace("</scene>", body + "</scene>")
    check("include itself", {"scene.xml": inc('<include filename="scene.xml"/>')}, (2,))
    check("include cycle a-b", {"scene.xml": inc('<include filename="a.xml"/>'),
                                "a.xml": '<scene version="0.6.0"><include filename="b.xml"/></scene>',
                                "b.xml": '<scene version="0.6.0"><include filename="a.xml"/></scene>'}, (2,))
    for k, depth in ((10, 5), (30, 5), (100, 4), (1000, 2)):
        check("include fan-out %d^%d" % (k, depth), nested_includes(k, depth))
    for src in ("/dev/zero", "/dev/null", "/etc", "missing.xml", "/dev/stdin"):
        check("include %s" % src, {"scene.xml": inc('<include filename="%s"/>' % src)}, (2,))
    # A regular file the system refuses to read (EIO): a failure of the system, 1 (limits.md).
    check("include /proc/self/mem", {"scene.xml": inc('<include filename="/proc/self/mem"/>')}, (1, 2))
    for levels, fan in ((9, 10), (12, 10), (30, 2), (6, 1000)):
        check("default bomb %d levels x%d" % (levels, fan), {"scene.xml": default_bomb(levels, fan)})
    check("200000 defaults", {"scene.xml": s.replace('<scene version="0.6.0">', '<scene version="0.6.0">' +
                                                    "".join('<default name="d%d" value="1"/>' % i
                                                            for i in range(200000)))})
    check("2500 spheres", {"scene.xml": inc('<shape type="sphere"/>' * 2500)})
    check("20000 spheres", {"scene.xml": inc('<shape type="sphere"/>' * 20000)})
    check("1e5 nested shapes", {"scene.xml": inc("<shape type='sphere'>" * 100000 + "</shape>" * 100000)})
    check("deep nesting 1e6", {"scene.xml": inc("<a>" * 1000000 + "</a>" * 1000000)})
    check("XXE file", {"scene.xml": '<?xml version="1.0"?><!DOCTYPE s [<!ENTITY x SYSTEM "/etc/passwd">]>'
                       + s.split("?>", 1)[1].replace('value="40"', 'value="&x;"')}, (2,))
    check("XXE parameter entity", {"scene.xml": '<?xml version="1.0"?><!DOCTYPE s [<!ENTITY % p SYSTEM "http://127.0.0.1:9/x">%p;]>'
                                   + s.split("?>", 1)[1]})
    check("billion laughs entities", {"scene.xml": '<?xml version="1.0"?><!DOCTYPE s [<!ENTITY a "aaaaaaaaaa">'
                                      + "".join('<!ENTITY %s "%s">' % (chr(98 + i), ("&%s;" % chr(97 + i)) * 10) for i in range(9))
                                      + ']>' + s.split("?>", 1)[1].replace('value="40"', 'value="&j;"')}, (2,))
    check("XInclude", {"scene.xml": s.replace('<scene version="0.6.0">', '<scene version="0.6.0" xmlns:xi="http://www.w3.org/2001/XInclude"><xi:include href="/etc/passwd" parse="text"/>')})
    check("10 MB attribute", {"scene.xml": s.replace('value="40"', 'value="%s"' % ("1" * 10000000))})
    check("UTF-16", {"scene.xml": s.replace('<?xml version="1.0"?>', '<?xml version="1.0" encoding="UTF-16"?>').encode("utf-16")})
    check("BOM", {"scene.xml": b"\xef\xbb\xbf" + s.encode()})
    check("empty file", {"scene.xml": ""}, (2,))
    check("NUL bytes", {"scene.xml": s.encode().replace(b"sensor", b"sen\0sor", 1)}, (2,))
    check("unknown plugins", {"scene.xml": inc('<shape type="teapot"/><bsdf type="magic"/><emitter type="laser"/>')}, (2,))
    check("ref to a missing id", {"scene.xml": inc('<shape type="sphere"><ref id="nope"/></shape>')}, (2,))
    check("duplicate ids", {"scene.xml": inc('<bsdf type="diffuse" id="a"/><bsdf type="diffuse" id="a"/>')})
    for v in ("0.4.0", "0.5.0", "2.0.0", "3.0.0", "99", "", "x"):
        check("version %r" % v, {"scene.xml": s.replace('version="0.6.0"', 'version="%s"' % v)})
    check("-D 64 KB value", {"scene.xml": s}, extra=("-D", "x=" + "1" * 65536))
    data = s.encode()
    for i in range(24):
        cut = rng.randrange(1, len(data))
        check("truncated at %d" % cut, {"scene.xml": data[:cut]}, (2,))
    for i in range(16):
        b = bytearray(data)
        for _ in range(rng.randrange(1, 8)):
            b[rng.randrange(len(b))] = rng.randrange(256)
        check("bytes flipped #%d" % i, {"scene.xml": bytes(b)})
    for i in range(8):
        check("random bytes #%d" % i, {"scene.xml": bytes(rng.randrange(256) for _ in range(2000))}, (2,))
    return c


def cases_meshes(rng):
    c = []
    objs = {
        "nan vertex": "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        "inf vertex": "v inf 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        "huge vertex": "v 1e30 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        "index out of range": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99\n",
        "index 0": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
        "negative index": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -3\n",
        "index overflow": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999\n",
        "no faces": "v 0 0 0\n",
        "empty": "",
        "degenerate": "v 0 0 0\nv 0 0 0\nv 0 0 0\nf 1 2 3\n",
        "1000-gon": "".join("v %f %f 0\n" % (i, i % 7) for i in range(1000)) + "f " + " ".join(str(i + 1) for i in range(1000)) + "\n",
        "garbage": "\x00\x01\x02 v f vt vn\n" * 100,
        "bad normal index": "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//5 2//1 3//1\n",
        "long line": "v " + "1" * 1000000 + " 0 0\n",
    }
    for name, text in objs.items():
        c.append(Case("meshes", "obj " + name, ["opaline-render", "-q", "-t", "2", "scene.xml", "-o", "o.png"],
                      {"scene.xml": scene(), "mesh.obj": text}, guard=("mesh.obj",)))
    ply_head = "ply\nformat binary_little_endian 1.0\nelement vertex %s\nproperty float x\nproperty float y\nproperty float z\nelement face %s\nproperty list uchar int vertex_indices\nend_header\n"
    plys = {
        "2^40 vertices": ply_head % ("1099511627776", "1"),
        "negative count": ply_head % ("-5", "1"),
        "truncated body": ply_head % ("3", "1") + "\0" * 10,
        "bad index": (ply_head % ("3", "1")).encode() + b"\0" * 36 + b"\x03" + (99).to_bytes(4, "little") * 3,
        "ascii nan": "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\nnan 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
        "no end_header": "ply\nformat ascii 1.0\nelement vertex 3\n",
        "big endian": (ply_head % ("3", "1")).replace("little", "big"),
        "list of 255": (ply_head % ("3", "1")).encode() + b"\0" * 36 + b"\xff" + b"\0" * 8,
    }
    for name, data in plys.items():
        files = {"scene.xml": scene().replace("mesh.obj", "mesh.ply").replace('type="obj"', 'type="ply"'),
                 "mesh.ply": data, "mesh.obj": MESH}
        c.append(Case("meshes", "ply " + name, ["opaline-render", "-q", "-t", "2", "scene.xml", "-o", "o.png"],
                      files, guard=("mesh.ply",)))
    return c


def png_header(w, h):
    import zlib
    raw = b"".join(b"\0" + b"\x80" * 3 for _ in range(1))
    ihdr = w.to_bytes(4, "big") + h.to_bytes(4, "big") + b"\x08\x02\0\0\0"
    chunk = lambda t, d: len(d).to_bytes(4, "big") + t + d + zlib.crc32(t + d).to_bytes(4, "big")
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")


def cases_images(rng):
    c = []
    imgs = {
        "png 16384x16384 header": png_header(16384, 16384),
        "png 1x1 truncated": png_header(1, 1)[:40],
        "png 0x0": png_header(0, 0),
        "png 2^31 wide": png_header(2 ** 31 - 1, 1),
        "pfm negative size": b"PF\n-5 -5\n-1.0\n",
        "pfm huge": b"PF\n100000 100000\n-1.0\n" + b"\0" * 100,
        "pfm nan scale": b"PF\n1 1\nnan\n" + b"\0" * 12,
        "exr garbage": b"\x76\x2f\x31\x01" + bytes(rng.randrange(256) for _ in range(500)),
        "hdr garbage": b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 99999 +X 99999\n" + b"\x02\x02" * 50,
        "not an image": b"hello",
    }
    for name, data in imgs.items():
        ext = name.split()[0]
        tex = scene().replace('<rgb name="reflectance" value="0.5"/>',
                              '<texture type="bitmap" name="reflectance"><string name="filename" value="t.%s"/></texture>' % ext)
        c.append(Case("images", "texture " + name, ["opaline-render", "-q", "-t", "2", "scene.xml", "-o", "o.png"],
                      {"scene.xml": tex, "mesh.obj": MESH, "t." + ext: data}, guard=("t." + ext,)))
        env = scene().replace("</scene>", '<emitter type="envmap"><string name="filename" value="t.%s"/></emitter></scene>' % ext)
        c.append(Case("images", "envmap " + name, ["opaline-render", "-q", "-t", "2", "scene.xml", "-o", "o.png"],
                      {"scene.xml": env, "mesh.obj": MESH, "t." + ext: data}, guard=("t." + ext,)))
    return c


def cases_outputs(is_root):
    c = []
    files = base_files()
    R = ["opaline-render", "-q", "-t", "2", "scene.xml"]

    def mk(name, extra, allow, setup=None, guard=("scene.xml", "mesh.obj"), whole=None, **kw):
        c.append(Case("outputs", name, R + extra, dict(files), guard=guard, allow=allow,
                      setup=setup, whole=whole, **kw))

    def planted(target_name):
        def setup(d):
            if not is_root:
                return "needs root"
            os.mkdir(os.path.join(d, "shared"))
            os.chmod(os.path.join(d, "shared"), 0o1777)
            with open(os.path.join(d, "precious"), "w") as f:
                f.write("precious")
            link = os.path.join(d, "shared", target_name)
            os.symlink(os.path.join(d, "precious"), link)
            os.lchown(link, 65534, 65534)
        return setup

    for out in ("x.png", "x.exr", "x.pfm", "x.hdr", "x.partial.png"):
        mk("planted link " + out, ["-o", "shared/" + out], (1,), planted(out), guard=("precious",))
    mk("planted link as cache", ["-o", "ok.png", "--sss-cache", "shared/c.bin"], (1,), planted("c.bin"), guard=("precious",))
    mk("-o a directory", ["-o", "adir"], (1,), lambda d: os.mkdir(os.path.join(d, "adir")))
    mk("-o a socket", ["-o", "sock"], (1,), lambda d: socket.socket(socket.AF_UNIX).bind(os.path.join(d, "sock")))
    mk("-o a block device", ["-o", "blk"], (1,), lambda d: None if is_root and not os.mknod(os.path.join(d, "blk"), 0o600 | stat.S_IFBLK, os.makedev(7, 200)) else "needs root")
    mk("-o /dev/full", ["-o", "/dev/full"], (1,))
    mk("-o /dev/full beside a file", ["-o", "keep.png", "-o", "/dev/full"], (1,), lambda d: write(d, "keep.png", "old"), guard=("keep.png",))
    mk("-o missing folder", ["-o", "no/such/x.png"], (1,))
    mk("-o /proc", ["-o", "/proc/version.png"], (1,))
    mk("-o /sys (read-only)", ["-o", "/sys/x.png"], (1,))
    mk("-o the scene", ["-o", "scene.xml"], (2,))
    mk("-o the mesh", ["-o", "mesh.obj"], (2,))
    mk("-o twice", ["-o", "a.png", "-o", "./a.png"], (2,))
    mk("-o empty name", ["-o", ""], (1, 2))
    mk("-o name ending in /", ["-o", "x.png/"], (1, 2))
    mk("-o name too long", ["-o", "x" * 5000 + ".png"], (1, 2))
    mk("-o name with escapes", ["-o", "\x1b[31mred\n.png"], (0,))
    mk("-o unknown extension", ["-o", "x.tiff"], (2,))
    def immutable(d):
        write(d, "imm.png", "old")
        if subprocess.run(["chattr", "+i", os.path.join(d, "imm.png")],
                          stderr=subprocess.DEVNULL).returncode != 0:
            return "chattr +i not supported here"
        return None
    mk("-o immutable file", ["-o", "imm.png"], (1,), immutable, guard=("imm.png",))
    mk("-o 0444 file", ["-o", "ro.png"], (0,), lambda d: write(d, "ro.png", "old") or os.chmod(os.path.join(d, "ro.png"), 0o444))
    mk("-o /dev/stdout", ["-o", "/dev/stdout"], (0,))
    mk("-o /dev/fd/9 (closed)", ["-o", "/dev/fd/9"], (1,))
    mk("ulimit -f 4 KiB", ["-o", "big.pfm"], (1,), lambda d: write(d, "big.pfm", "old"), guard=("big.pfm",), limit_fsize=4096)
    mk("TMPDIR missing", ["-o", "/dev/null"], (1,), env={"TMPDIR": "/no/such/dir"})
    mk("OPALINE_PARENT_PID garbage", ["--stream"], (0,), env={"OPALINE_PARENT_PID": "x1"})
    for sig, name in ((signal.SIGINT, "INT"), (signal.SIGTERM, "TERM"), (signal.SIGHUP, "HUP")):
        for after in (0.02, 0.1, 0.3, 0.6, 1.0):
            def setup(d):
                with open(os.path.join(d, "scene.xml"), "w") as f:
                    f.write(scene(width="320", height="240", spp="64"))
                shutil.copy(os.path.join(d, "scene.xml"), os.path.join(d, "scene.keep"))
            c.append(Case("signals", "render SIG%s after %.2f s" % (name, after),
                          ["opaline-render", "-t", "2", "scene.xml", "-o", "out.exr", "-o", "out.png"],
                          dict(files), guard=("scene.xml",), allow=(0, 130), setup=setup,
                          signal_after=(sig, after)))
            c.append(Case("signals", "factor SIG%s after %.2f s" % (name, after),
                          ["opaline-factor", "dataset", "chess4x4", "--pixels", "96x96", "--kernel", "21",
                           "-t", "2", "-o", "d.opm"], {}, allow=(0, 130), signal_after=(sig, after)))
    return c


def cases_factor(rng, bins, root):
    c = []
    d = tempfile.mkdtemp(dir=root)
    path = os.path.join(d, "d.opm")
    subprocess.run([bins["opaline-factor"], "dataset", "chess4x4", "--pixels", "16x16", "--kernel", "7",
                    "-t", "2", "-o", path], check=True, stderr=subprocess.DEVNULL)
    data = open(path, "rb").read()
    shutil.rmtree(d)
    F = ["opaline-factor", "factor", "d.opm", "--method", "svd", "-T", "4", "-t", "2", "-o", "m.opm"]
    for i in range(16):
        cut = rng.randrange(1, len(data))
        c.append(Case("factor", "dataset truncated at %d" % cut, F, {"d.opm": data[:cut]}, guard=("d.opm",), allow=(2,)))
    for i in range(16):
        b = bytearray(data)
        for _ in range(rng.randrange(1, 6)):
            b[rng.randrange(min(len(b), 4096))] = rng.randrange(256)
        c.append(Case("factor", "dataset header bytes flipped #%d" % i, F, {"d.opm": bytes(b)}, guard=("d.opm",)))
    for i in range(8):
        b = bytearray(data)
        b[rng.randrange(4096, len(b))] ^= 0x40
        c.append(Case("factor", "dataset body bit flipped #%d" % i, F, {"d.opm": bytes(b)}, guard=("d.opm",), allow=(2,)))
    bad_args = [["-T", "0"], ["-T", "-1"], ["-T", "1000000000"], ["--method", "xyz"], ["-t", "0"], ["-t", "100000"],
                ["--degree", "99"], ["-T"], ["--report"], ["--albedo-png", "d.opm"], ["--report", "m.opm"],
                ["-o", "d.opm"], ["--report", "/dev/full"], ["--albedo-png", "no/dir/a.png"], ["--bogus"]]
    for extra in bad_args:
        c.append(Case("factor", "factor " + " ".join(extra), F + extra, {"d.opm": data}, guard=("d.opm",), allow=(1, 2)))
    for method in ("tucker", "kcta", "nmf"):
        for extra in (["-T", "1"], ["-T", "9999"]):
            c.append(Case("factor", "factor %s %s" % (method, " ".join(extra)),
                          ["opaline-factor", "factor", "d.opm", "--method", method, "-t", "2", "-o", "m.opm", *extra],
                          {"d.opm": data}, guard=("d.opm",)))
    # A size of 1e-300 cm makes a valid file that a scene refuses (limits.md): 0 is clean too.
    c.append(Case("factor", "dataset --size-cm 1e-300x1",
                  ["opaline-factor", "dataset", "chess4x4", "--pixels", "8x8", "--kernel", "5", "-t", "2",
                   "-o", "x.opm", "--size-cm", "1e-300x1"], {}, allow=(0, 2)))
    ds_args = [["--pixels", "0x0"], ["--pixels", "100000x100000"], ["--kernel", "0"], ["--kernel", "2"],
               ["--size-cm", "nan,1"], ["--photons", "0"], ["--seed", "-1"],
               ["--media", "a,b"], ["--eta", "inf"], ["--generator", "x"], ["-o", "/dev/full"]]
    for extra in ds_args:
        c.append(Case("factor", "dataset " + " ".join(extra),
                      ["opaline-factor", "dataset", "chess4x4", "--pixels", "8x8", "--kernel", "5", "-t", "2", "-o", "x.opm", *extra],
                      {}, allow=(1, 2)))
    c.append(Case("factor", "import npy header bomb", ["opaline-factor", "import", "a.npy", "-o", "x.opm"],
                  {"a.npy": b"\x93NUMPY\x01\x00\xff\xff" + b"{" * 65535, "a.json": '{"size_cm": [1, 1]}'}, allow=(2,)))
    c.append(Case("factor", "import -o the npy", ["opaline-factor", "import", "a.npy", "-o", "a.npy"],
                  {"a.npy": b"\x93NUMPY", "a.json": "{}"}, guard=("a.npy",), allow=(2,)))
    return c


def cases_render_args():
    c = []
    files = base_files()
    R = ["opaline-render", "-q", "-t", "2"]
    args = [["-s", "0"], ["-s", "-1"], ["-s", "99999999999"], ["-t", "0"], ["-t", "abc"],
            ["--crop", "0,0,0,0"], ["--crop", "20,10,100,100"], ["--crop", "-1,0,1,1"],
            ["--crop", "4294967296,0,1,1"], ["--limit", "coordinate=-1"], ["--limit", "nope=1"],
            ["--limit", "coordinate=nan"], ["-D", "noequals"], ["-D", "=x"], ["--bogus"],
            ["scene.xml"], ["--partial", "maybe"], ["--sss-cache", ""], ["--sss-cache-only"],
            ["--merge-tiles"], ["--stream", "--merge-tiles", "t.txt"]]
    for a in args:
        c.append(Case("render arguments", " ".join(a)[:60], R + ["scene.xml", *a, "-o", "o.png"], dict(files), allow=(2,)))
    tile_lists = {
        "X 2^32+16": "4294967312 0 24 16 tile.exr\n",
        "negative": "-1 0 24 16 tile.exr\n",
        "missing file": "0 0 24 16 nope.exr\n",
        "overlap": "0 0 24 16 tile.exr\n0 0 24 16 tile.exr\n",
        "uncovered": "0 0 12 16 tile.exr\n",
        "file twice": "0 0 12 16 tile.exr\n12 0 12 16 tile.exr\n",
        "garbage": "\x00\x01 hello\n",
        "empty": "",
        "the list itself": "0 0 24 16 t.txt\n",
    }
    for name, text in tile_lists.items():
        def setup(d):
            subprocess.run([BINS["opaline-render"], "-q", "-t", "2", "scene.xml", "--raw-exr", "-o", "tile.exr"],
                           cwd=d, check=True, stderr=subprocess.DEVNULL)
        c.append(Case("render arguments", "merge list " + name,
                      R + ["scene.xml", "--merge-tiles", "t.txt", "-o", "m.exr"], dict(files, **{"t.txt": text}),
                      guard=("t.txt",), allow=(2,), setup=setup))
    for name, make in (("a directory", lambda d: os.mkdir(os.path.join(d, "c.bin"))),
                       ("garbage", lambda d: write(d, "c.bin", "garbage")),
                       ("a FIFO", lambda d: os.mkfifo(os.path.join(d, "c.bin")))):
        c.append(Case("render arguments", "--sss-cache " + name,
                      R + ["scene.xml", "--sss-cache", "c.bin", "-o", "o.png"], dict(files), allow=(0, 2), setup=make))
    return c


def cases_cluster():
    c = []
    files = base_files()
    C = ["opaline-cluster"]
    for name, args in (("formats empty", ["submit", "scene.xml", "-o", "out", "--local", "--formats", ""]),
                       ("formats unknown", ["submit", "scene.xml", "-o", "out", "--local", "--formats", "gif"]),
                       ("-s 0", ["submit", "scene.xml", "-o", "out", "--local", "-s", "0"]),
                       ("--mem -5", ["submit", "scene.xml", "-o", "out", "--local", "--mem", "-5"]),
                       ("--tiles 0", ["submit", "scene.xml", "-o", "out", "--local", "--tiles", "0"]),
                       ("--threads 0", ["submit", "scene.xml", "-o", "out", "--local", "--threads", "0"]),
                       ("missing scene", ["submit", "nope.xml", "-o", "out", "--local"]),
                       ("scene is a directory", ["submit", "out", "-o", "out2", "--local"]),
                       ("status of nothing", ["status", "nowhere"]),
                       ("merge of nothing", ["merge", "nowhere"]),
                       ("run index -1", ["run", "out", "out/.cluster/tasks.txt", "-1"]),
                       ("run missing taskfile", ["run", "out", "nope.txt", "0"]),
                       ("run index huge", ["run", "out", "t.txt", "99999999999999999999"]),
                       ("no command", []),
                       ("bad command", ["frobnicate"])):
        c.append(Case("cluster", name, C + args, dict(files, **{"t.txt": "x\n"}), allow=(1, 2),
                      setup=lambda d: os.makedirs(os.path.join(d, "out"), exist_ok=True)))
    for name, state in (("corrupt state", "{not json"), ("state is a list", "[]"), ("state empty", ""),
                        ("state binary", "\x00\xff")):
        def setup(d, state=state):
            os.makedirs(os.path.join(d, "out"), exist_ok=True)
            with open(os.path.join(d, "out", "opaline-cluster.json"), "w") as f:
                f.write(state)
        for cmd in ("status", "merge"):
            c.append(Case("cluster", "%s with %s" % (cmd, name), C + [cmd, "out"], dict(files), allow=(1, 2), setup=setup))
    return c


BINS = {}


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", required=True, help="the folder of opaline-render, -factor, -cluster")
    ap.add_argument("--out", required=True)
    ap.add_argument("--only", help="categories (comma-separated prefixes)")
    ap.add_argument("--timeout", type=float, default=60.0)
    ap.add_argument("--max-rss-mb", type=float, default=4096.0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--seed", type=int, default=26)
    a = ap.parse_args(argv)
    for p in ("opaline-render", "opaline-factor", "opaline-cluster"):
        BINS[p] = os.path.abspath(os.path.join(a.bin, p))
        if not os.access(BINS[p], os.X_OK):
            sys.exit("hostile_run.py: %s is not built" % BINS[p])
    os.makedirs(a.out, exist_ok=True)
    root = tempfile.mkdtemp(prefix="hostile.", dir=os.environ.get("OPALINE_TEST_TMP"))
    rng = random.Random(a.seed)
    is_root = os.geteuid() == 0
    cases = (cases_numbers() + cases_structure(rng) + cases_meshes(rng) + cases_images(rng) +
             cases_outputs(is_root) + cases_factor(rng, BINS, root) + cases_render_args() +
             cases_cluster())
    if a.only:
        want = a.only.split(",")
        cases = [k for k in cases if any(k.category.startswith(w) for w in want)]
    rows = []
    try:
        with concurrent.futures.ThreadPoolExecutor(a.jobs) as ex:
            futs = [(k, ex.submit(run_case, k, BINS, a.timeout, a.max_rss_mb, root)) for k in cases]
            for k, f in futs:
                verdict, rc, secs, rss, why = f.result()
                rows.append((k.category, k.name, rc, secs, rss, verdict, why))
                if verdict == "FAIL":
                    print("FAIL %s: %s: %s" % (k.category, k.name.encode("unicode_escape").decode(), why), flush=True)
    finally:
        shutil.rmtree(root, ignore_errors=True)
    with open(os.path.join(a.out, "hostile.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["category", "case", "exit", "seconds", "peak_mib", "verdict", "why"])
        for r in rows:
            w.writerow([r[0], r[1].encode("unicode_escape").decode(), r[2], "%.2f" % r[3], "%.0f" % r[4], r[5], r[6]])
    cats = {}
    for r in rows:
        t = cats.setdefault(r[0], [0, 0, 0, 0.0])
        t[0] += 1
        t[1] += r[5] == "ok"
        t[2] += r[5] == "skip"
        t[3] = max(t[3], r[3])
    lines = ["| category | cases | clean | skipped | failed | slowest (s) |", "|---|---|---|---|---|---|"]
    for cat, (n, ok, sk, slow) in cats.items():
        lines.append("| %s | %d | %d | %d | %d | %.1f |" % (cat, n, ok, sk, n - ok - sk, slow))
    total = len(rows)
    ok = sum(r[5] == "ok" for r in rows)
    sk = sum(r[5] == "skip" for r in rows)
    lines.append("| all | %d | %d | %d | %d | |" % (total, ok, sk, total - ok - sk))
    fails = ["- %s: %s: %s" % (r[0], r[1].encode("unicode_escape").decode(), r[6]) for r in rows if r[5] == "FAIL"]
    with open(os.path.join(a.out, "hostile.md"), "w") as f:
        f.write("\n".join(lines) + "\n\n" + ("\n".join(fails) + "\n" if fails else "no failure\n"))
    print("\n".join(lines))
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
