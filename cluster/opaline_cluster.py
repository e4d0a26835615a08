#!/usr/bin/env python3
"""opaline-cluster: renders exported opaline scenes on a SLURM cluster (docs/cluster.md).

    opaline-cluster submit SCENE.xml... -o OUTDIR [--tiles N] [--threads T] [--mem MB] ...
    opaline-cluster status OUTDIR
    opaline-cluster merge OUTDIR
    opaline-cluster run OUTDIR TASKFILE INDEX      (what each SLURM task runs)

One frame per scene file (an animation is the batch export's one file per frame), each rendered
whole by one task, or cut into N tiles (opaline-render --crop, --raw-exr) rendered by N tasks
after one task has run the frame's subsurface pre-pass into a cache (--sss-cache), and merged
by a last task (opaline-render --merge-tiles). The job graph is three job arrays linked by
afterok dependencies. Every output is checked (decoded structure, size), never trusted for
being there, and keyed by what it depends on (the renderer's key over the scene's files, -D
values, spp, film and version): a re-submission renders only what is missing, invalid or of
another key. Python 3 standard library only, so that the compute nodes need nothing else.

Exit codes: 0 ok, 1 failure (sbatch refused, a task failed), 2 bad arguments, scene or state
file, 130 interrupted (SIGINT, SIGTERM, SIGHUP).
"""

import argparse
import hashlib
import json
import math
import os
import resource
import shlex
import signal
import struct
import subprocess
import sys
import tempfile
import time
import zlib

STATE = "opaline-cluster.json"
WORK = ".cluster"          # OUTDIR/.cluster: task lists, logs, timings, pids, failure marks
RENDERER = "opaline-render"
TILE_ATTR = "opalineTile"  # a tile's "key=K film=WxH crop=X,Y,W,H" (renderer/cli/tile_merge.h)


class Bad(Exception):
    """Bad input: exit code 2."""


class Failed(Exception):
    """Another failure: exit code 1."""


class Cancelled(Exception):
    """Interrupted by a signal: exit code 130."""


# The renderer running now, and the signal that stopped us (on_signal).
_running = {"child": None, "sig": 0}


def on_signal(sig, _frame):
    """SIGINT, SIGTERM, SIGHUP (SLURM's scancel, Ctrl-C): passed on to the renderer running (its
    own process group), which stops and exits 130; with none running, stop here."""
    _running["sig"] = sig
    p = _running["child"]
    if p is None:
        raise Cancelled("interrupted (signal %d)" % sig)
    try:
        os.killpg(p.pid, sig)
    except OSError:
        pass


def child_env():
    """The renderer's environment: OPALINE_PARENT_PID is this process (never one inherited)."""
    return dict(os.environ, OPALINE_PARENT_PID=str(os.getpid()))


def spawn(argv, started=lambda pid: None):
    """Starts argv in a process group of its own (a terminal's Ctrl-C reaches us only, and we
    pass it on), with OPALINE_PARENT_PID: the renderer stops when this process dies, even by
    SIGKILL (docs/cluster.md); started(its pid) is called once it runs. Returns its exit code
    (negative: killed by that signal)."""
    try:
        p = subprocess.Popen(argv, env=child_env(), start_new_session=True)
    except OSError as e:
        raise Failed("%s: cannot run: %s" % (argv[0], e.strerror))
    _running["child"] = p
    try:
        started(p.pid)
        return p.wait()
    finally:
        _running["child"] = None


def read_json(path, what):
    """The JSON document at path; Bad naming path when it is missing, unreadable or not JSON."""
    try:
        with open(path) as f:
            return json.load(f)
    except FileNotFoundError:
        raise Bad("%s: no such file (%s)" % (path, what))
    except (OSError, ValueError, UnicodeDecodeError) as e:
        raise Bad("%s: not a readable %s: %s" % (path, what, e))


def say(msg):
    print("opaline-cluster: %s" % msg, file=sys.stderr, flush=True)


# ------------------------------------------------------------------ checking image files

def _exr_lines_per_chunk(compression):
    # NONE RLE ZIPS ZIP PIZ PXR24 B44 B44A DWAA DWAB
    return {0: 1, 1: 1, 2: 1, 3: 16, 4: 32, 5: 16, 6: 32, 7: 32, 8: 32, 9: 256}.get(compression)


def check_exr(data, w, h, tag=None):
    """None when data is a whole single-part scanline OpenEXR file of w x h pixels (header,
    offset table, every chunk inside the file, the last ending the file) and, given a tag, a
    tile of that render (its TILE_ATTR), else why not."""
    if data[:4] != b"\x76\x2f\x31\x01":
        return "not an OpenEXR file"
    flags = struct.unpack_from("<I", data, 4)[0]
    if flags & 0x1a00:
        return "tiled, deep or multi-part OpenEXR"
    pos, attrs = 8, {}
    try:
        while data[pos] != 0:
            end = data.index(b"\0", pos)
            name = data[pos:end].decode()
            tend = data.index(b"\0", end + 1)
            size = struct.unpack_from("<i", data, tend + 1)[0]
            attrs[name] = data[tend + 5:tend + 5 + size]
            pos = tend + 5 + size
        pos += 1
        xmin, ymin, xmax, ymax = struct.unpack("<4i", attrs["dataWindow"])
        comp = attrs["compression"][0]
    except (ValueError, IndexError, KeyError, struct.error):
        return "a damaged OpenEXR header"
    if (xmax - xmin + 1, ymax - ymin + 1) != (w, h):
        return "%dx%d, not %dx%d" % (xmax - xmin + 1, ymax - ymin + 1, w, h)
    if tag is not None and attrs.get(TILE_ATTR, b"").decode("latin-1") != tag:
        return "a tile of another render (%s, not %s)" % (
            attrs.get(TILE_ATTR, b"no key").decode("latin-1"), tag)
    lpc = _exr_lines_per_chunk(comp)
    if lpc is None:
        return "an unknown OpenEXR compression"
    n = (h + lpc - 1) // lpc
    if pos + 8 * n > len(data):
        return "truncated (offset table)"
    offsets = struct.unpack_from("<%dQ" % n, data, pos)
    last = 0
    for i, off in enumerate(offsets):
        if off < pos + 8 * n or off + 8 > len(data):
            return "truncated or damaged (chunk %d)" % i
        y, size = struct.unpack_from("<ii", data, off)
        if y != ymin + i * lpc or size <= 0 or off + 8 + size > len(data):
            return "truncated or damaged (chunk %d)" % i
        last = max(last, off + 8 + size)
    if last != len(data):
        return "truncated or damaged (ends at byte %d of %d)" % (last, len(data))
    return None


def check_png(data, w, h):
    """None when data is a whole PNG of w x h pixels (chunk CRCs, image data decompressing to
    its full size), else why not."""
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        return "not a PNG file"
    pos, idat, ihdr, ended = 8, [], None, False
    while pos + 12 <= len(data):
        n, typ = struct.unpack_from(">I4s", data, pos)
        body = data[pos + 8:pos + 8 + n]
        if len(body) != n or pos + 12 + n > len(data):
            return "truncated"
        if zlib.crc32(typ + body) != struct.unpack_from(">I", data, pos + 8 + n)[0]:
            return "damaged (CRC of %s)" % typ.decode("latin-1")
        if typ == b"IHDR":
            ihdr = struct.unpack(">IIBBBBB", body)
        elif typ == b"IDAT":
            idat.append(body)
        elif typ == b"IEND":
            ended = True
            break
        pos += 12 + n
    if not ended or ihdr is None:
        return "truncated"
    pw, ph, depth, ctype, _, _, interlace = ihdr
    if (pw, ph) != (w, h):
        return "%dx%d, not %dx%d" % (pw, ph, w, h)
    chans = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}.get(ctype)
    try:
        raw = zlib.decompress(b"".join(idat))
    except zlib.error:
        return "damaged image data"
    if chans is None or interlace or len(raw) != h * (1 + (w * chans * depth + 7) // 8):
        return "image data of the wrong size"
    return None


def check_pfm(data, w, h):
    parts = data.split(b"\n", 3)
    try:
        ch = {b"PF": 3, b"Pf": 1}[parts[0]]
        pw, ph = map(int, parts[1].split())
    except (KeyError, ValueError, IndexError):
        return "not a PFM file"
    if (pw, ph) != (w, h):
        return "%dx%d, not %dx%d" % (pw, ph, w, h)
    if len(parts) < 4 or len(parts[3]) != 4 * ch * w * h:
        return "truncated"
    return None


def check_output(path, w=None, h=None, tag=None):
    """None when the output at path is whole (an image of w x h pixels, an EXR tile of tag; any
    other file: not empty), else why not."""
    try:
        with open(path, "rb") as f:
            data = f.read()
    except FileNotFoundError:
        return "missing"
    except OSError as e:
        return "unreadable (%s)" % e.strerror
    ext = os.path.splitext(path)[1].lower()
    if w is None or ext not in (".exr", ".png", ".pfm"):
        return None if data else "empty"
    if ext == ".exr":
        return check_exr(data, w, h, tag)
    return {".png": check_png, ".pfm": check_pfm}[ext](data, w, h)


def key_record(o):
    """What output o's key record holds for it as it is now: the key it was made with and a hash
    of its content (another file put there does not inherit the key; a copy or touch keeps it)."""
    h = hashlib.sha256()
    with open(o["path"], "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return {"key": o["key"], "sha256": h.hexdigest()}


def check_key(o):
    """None when output o (whole) was made with its key o['key'] (none asked: None), else why
    not. Tiles carry theirs (o['tag']); other outputs have a record in o['record']."""
    if "key" not in o or "record" not in o:
        return None
    try:
        with open(o["record"]) as f:
            rec = json.load(f)
        now = key_record(o)
    except (OSError, ValueError, UnicodeDecodeError):
        return "made by an earlier render (no key record)"
    if not isinstance(rec, dict) or rec.get("key") != o["key"]:
        return "made from another version of the scene, its files or settings (key %s, now %s)" \
            % (rec.get("key") if isinstance(rec, dict) else "?", o["key"])
    if rec != now:
        return "replaced since it was made (no key record for this file)"
    return None


def task_done(task, keys=True):
    """None when every output of the task is whole and (keys) of the task's key, else
    'PATH: why' of the first that is not."""
    for o in task["outputs"]:
        why = check_output(o["path"], o.get("w"), o.get("h"), o.get("tag")) or \
            (keys and check_key(o))
        if why:
            return "%s: %s" % (o["path"], why)
    return None


def record_keys(task):
    """After the task succeeded: the key records of its outputs (atomically)."""
    for o in task["outputs"]:
        if "key" in o and "record" in o:
            os.makedirs(os.path.dirname(o["record"]), exist_ok=True)
            write_json(o["record"], key_record(o))


# ------------------------------------------------------------------ scenes

def find_renderer(given):
    if given:
        if not (os.path.isfile(given) and os.access(given, os.X_OK)):
            raise Bad("--renderer %s: not an executable file" % given)
        return os.path.abspath(given)
    here = os.path.dirname(os.path.realpath(__file__))
    for d in (here, os.path.join(os.path.dirname(here), "bin")):
        p = os.path.join(d, RENDERER)
        if os.path.isfile(p) and os.access(p, os.X_OK):
            return p
    for d in os.environ.get("PATH", "").split(os.pathsep):
        p = os.path.join(d, RENDERER)
        if d and os.path.isfile(p) and os.access(p, os.X_OK):
            return os.path.abspath(p)
    raise Bad("%s not found beside opaline-cluster or on PATH: give --renderer" % RENDERER)


def run_renderer(renderer, args, what):
    """stdout of `renderer args`; Bad (exit 2) or Failed with its message when it fails."""
    try:
        r = subprocess.run([renderer] + args, capture_output=True, text=True, env=child_env())
    except OSError as e:
        raise Failed("%s: cannot run: %s" % (renderer, e.strerror))
    if r.returncode != 0:
        msg = r.stderr.strip() or "%s %s: exit %d" % (RENDERER, what, r.returncode)
        raise (Bad if r.returncode == 2 else Failed)(msg)
    return r.stdout


def renderer_has(renderer, option):
    return option in run_renderer(renderer, ["--help"], "--help")


def within(path, root):
    path, root = os.path.realpath(path), os.path.realpath(root)
    return path == root or path.startswith(root.rstrip("/") + "/")


def preset_dirs(renderer):
    """The folders where the renderer finds a material preset given by name after the scene's
    own, as it says (opaline-render --preset-folders). Each node's renderer has its own; they
    need not be shared."""
    out = run_renderer(renderer, ["--preset-folders", "-q", "-q"], "--preset-folders")
    return [d for d in out.splitlines() if d]


def check_travels(renderer, scene, extra, shared):
    """Every file the scene reads, as the renderer resolves it (opaline-render --list-inputs:
    includes, $param paths, meshes, images, spectra, materials), must lie in the shared folder,
    so that the nodes find it; presets by name are found by each node's renderer. Returns the
    problems, 'SCENE: reads FILE, ...'."""
    out = run_renderer(renderer, ["--list-inputs", "-q", "-q"] + extra + [scene],
                       "--list-inputs " + scene)
    presets = preset_dirs(renderer)
    return ["%s: reads %s, outside the shared folder %s" % (scene, f, shared)
            for f in out.splitlines()
            if f and not within(f, shared) and not any(within(f, d) for d in presets)]


def estimate(renderer, scene, extra):
    """opaline-render --estimate's fields: the numbers as ints, the key as its string."""
    out = run_renderer(renderer, ["--estimate", "-q", "-q"] + extra + [scene],
                       "--estimate " + scene)
    try:
        fields = dict(kv.split("=", 1) for kv in out.split())
        est = {k: int(float(v)) for k, v in fields.items() if k != "key"}
        est["key"] = fields["key"]
        for k in ("width", "height", "full_width", "full_height", "translucent", "memory_mb"):
            if k not in est:
                raise KeyError(k)
    except (ValueError, KeyError) as e:
        raise Failed("%s --estimate %s printed no %s (an older renderer? give --renderer): %s"
                     % (renderer, scene, e, out.strip()))
    return est


def tile_grid(w, h, n):
    """n rectangles (x, y, w, h) cutting the w x h film: the cols x rows = n grid whose tiles
    are closest to square, sizes differing by at most one pixel, row by row from the top."""
    best = None
    for cols in range(1, min(n, w) + 1):
        if n % cols:
            continue
        rows = n // cols
        if cols > w or rows > h:
            continue
        score = abs(math.log((w / cols) / (h / rows)))
        if best is None or score < best[0]:
            best = (score, cols, rows)
    if best is None:
        raise Bad("--tiles %d: cannot cut a %dx%d film into %d tiles" % (n, w, h, n))
    _, cols, rows = best
    xs = [w * i // cols for i in range(cols + 1)]
    ys = [h * j // rows for j in range(rows + 1)]
    return [(xs[i], ys[j], xs[i + 1] - xs[i], ys[j + 1] - ys[j])
            for j in range(rows) for i in range(cols)]


# ------------------------------------------------------------------ the plan

def _is_task(t):
    return (isinstance(t, dict) and isinstance(t.get("name"), str) and
            isinstance(t.get("argv"), list) and all(isinstance(x, str) for x in t["argv"]) and
            isinstance(t.get("outputs"), list) and
            all(isinstance(o, dict) and isinstance(o.get("path"), str) for o in t["outputs"]))


def load_tasks(path):
    """A task file's tasks; Bad naming it when it is missing, unreadable or damaged."""
    tasks = read_json(path, "opaline-cluster task file")
    if not isinstance(tasks, list) or not all(_is_task(t) for t in tasks):
        raise Bad("%s: a damaged opaline-cluster task file" % path)
    return tasks


def load_state(out):
    """OUTDIR's state (every submission's frames); Bad when there is none or it is damaged."""
    p = os.path.join(out, STATE)
    if not os.path.lexists(p):
        raise Bad("%s: no render submitted to this folder (no %s)" % (out, STATE))
    st = read_json(p, "opaline-cluster state file")
    ok = (isinstance(st, dict) and isinstance(st.get("frames"), list) and
          isinstance(st.get("submissions"), list))
    for fr in st.get("frames", []) if ok else []:
        ok = ok and isinstance(fr, dict) and isinstance(fr.get("name"), str) and \
            isinstance(fr.get("render"), list) and all(_is_task(t) for t in fr["render"]) and \
            all(fr.get(k) is None or _is_task(fr[k]) for k in ("prepass", "merge")) and \
            _is_task({"name": "", "argv": [], "outputs": fr.get("outputs")})
    for sub in st.get("submissions", []) if ok else []:
        ok = ok and isinstance(sub, dict) and isinstance(sub.get("jobs"), dict) and \
            isinstance(sub.get("taskfiles"), dict) and \
            all(isinstance(v, str) for v in sub["taskfiles"].values())
    if not ok:
        raise Bad("%s: a damaged opaline-cluster state file (remove it and submit again)" % p)
    return st


def write_file(path, text, mode=0o644):
    """Written whole or not at all: a new file of a random name in the same folder (never a
    link planted there), renamed over path: os.replace replaces a link at path and never writes
    through it, as the kernel's protected_symlinks rule wants in a sticky world-writable folder."""
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=".tmp",
                               dir=os.path.dirname(path) or ".")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, mode)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def write_json(path, obj):
    write_file(path, json.dumps(obj, indent=1))


def plan_frame(out, scene, est, a, renderer, cache_ok):
    """The tasks of one frame: {'prepass': task or None, 'render': [tasks], 'merge': task or
    None}, each task with its argv and outputs, whatever is already done."""
    stem = os.path.splitext(os.path.basename(scene))[0]
    common = ["-q"] + (["-s", str(a.spp)] if a.spp else [])
    for d in a.define or []:
        common += ["-D", d]
    w, h, key = est["width"], est["height"], est["key"]

    def keyed(path, **more):  # an output made with key, its record under OUTDIR/.cluster/keys
        rel = os.path.relpath(path, out).replace(os.sep, "%")
        return dict(more, path=path, key=key,
                    record=os.path.join(out, WORK, "keys", rel + ".json"))

    outs = [keyed(os.path.join(out, "%s.%s" % (stem, fmt)), w=w, h=h) for fmt in a.formats]
    oargs = sum((["-o", o["path"]] for o in outs), [])
    thr = ["-t", str(a.threads), "--partial", "none"]  # a cancelled task leaves nothing
    if a.tiles <= 1:
        return {"name": stem, "outputs": outs, "prepass": None, "merge": None,
                "render": [{"name": stem, "kind": "frame", "outputs": outs,
                            "argv": [renderer, scene] + thr + common + oargs}]}
    if (w, h) != (est["full_width"], est["full_height"]):
        raise Bad("%s: the film has a crop window; render it untiled (no --tiles)" % scene)
    tdir = os.path.join(out, WORK, "tiles", stem)
    cache = os.path.join(tdir, "sss.cache")
    use_cache = cache_ok and est["translucent"] > 0
    prepass = None
    if use_cache:
        prepass = {"name": stem + ".prepass", "kind": "prepass",
                   "outputs": [keyed(cache)],
                   "argv": [renderer, scene, "--sss-cache", cache, "--sss-cache-only"] + thr +
                   common}
    tiles, lines = [], []
    for i, (x, y, tw, th) in enumerate(tile_grid(w, h, a.tiles)):
        f = os.path.join(tdir, "tile_%03d.exr" % i)
        lines.append("%d %d %d %d %s\n" % (x, y, tw, th, os.path.basename(f)))
        tag = "key=%s film=%dx%d crop=%d,%d,%d,%d" % (key, w, h, x, y, tw, th)
        tiles.append({"name": "%s.tile%03d" % (stem, i), "kind": "tile",
                      "outputs": [{"path": f, "w": tw, "h": th, "tag": tag}],
                      "argv": [renderer, scene, "--crop", "%d,%d,%d,%d" % (x, y, tw, th),
                               "--raw-exr", "-o", f] + thr + common +
                      (["--sss-cache", cache] if use_cache else [])})
    merge = {"name": stem + ".merge", "kind": "merge", "outputs": outs,
             "list": os.path.join(tdir, "tiles.txt"), "lines": lines,
             "argv": [renderer, scene, "--merge-tiles", os.path.join(tdir, "tiles.txt")] +
             common + oargs}
    return {"name": stem, "outputs": outs, "prepass": prepass, "render": tiles, "merge": merge}


def frame_done(fr):
    return task_done(fr) is None


# ------------------------------------------------------------------ submit

def sbatch(a, out, name, taskfile, indices, deps, cpus, mem):
    """Submits one job array running `opaline-cluster run` for the given task indices; returns
    its job id, or None with --dry-run."""
    me = os.path.realpath(__file__)
    logs = os.path.join(out, WORK, "logs")
    script = os.path.join(out, WORK, "task.sh")
    if not os.path.exists(script):
        write_file(script, "#!/bin/sh\n# one task of an opaline-cluster job array\nexec %s %s "
                   "run \"$1\" \"$2\" \"$SLURM_ARRAY_TASK_ID\"\n" % (
                       shlex.quote(sys.executable), shlex.quote(me)), 0o755)
    cmd = [a.sbatch, "--parsable", "--job-name", "opaline-" + name,
           "--array", ",".join(map(str, indices)), "--cpus-per-task", str(cpus),
           "--mem", "%dM" % mem, "--output", os.path.join(logs, "%x_%A_%a.log"),
           "--requeue", "--kill-on-invalid-dep=yes", "--chdir", out]
    if deps:
        cmd += ["--dependency", "afterok:" + ":".join(deps)]
    if a.partition:
        cmd += ["--partition", a.partition]
    if a.account:
        cmd += ["--account", a.account]
    for x in a.sbatch_arg or []:
        cmd += shlex.split(x)
    cmd += [script, out, taskfile]
    if a.dry_run:  # the job id a later job depends on, as a placeholder
        print(" ".join(shlex.quote(c) for c in cmd))
        return "JOB_" + name.upper()
    try:
        r = subprocess.run(cmd, capture_output=True, text=True)
    except OSError as e:
        raise Failed("%s: cannot run: %s" % (a.sbatch, e.strerror))
    if r.returncode != 0:
        raise Failed("sbatch refused the %s job: %s" % (name, r.stderr.strip()))
    return r.stdout.strip().split(";")[0]


def cmd_submit(a):
    out = os.path.abspath(a.output)
    renderer = find_renderer(a.renderer)
    a.formats = [f.strip().lower().lstrip(".") for f in a.formats.split(",") if f.strip()]
    if not a.formats:
        raise Bad("--formats: give at least one of exr, png, pfm, hdr")
    for f in a.formats:
        if f not in ("exr", "png", "pfm", "hdr"):
            raise Bad("--formats: %s is not one of exr, png, pfm, hdr" % f)
    scenes = [os.path.abspath(s) for s in a.scenes]
    stems = [os.path.splitext(os.path.basename(s))[0] for s in scenes]
    if len(set(stems)) != len(stems):
        raise Bad("two scenes have one name: their outputs would collide")
    shared = os.path.abspath(a.shared) if a.shared else None
    extra = (["-s", str(a.spp)] if a.spp else []) + sum((["-D", d] for d in a.define or []), [])
    problems = []
    for s in scenes:
        if not os.path.isfile(s):
            raise Bad("%s: no such file" % s)
        problems += check_travels(renderer, s, extra, shared or os.path.dirname(s))
    if problems:
        for p in problems:
            say(p)
        if not a.allow_outside:
            raise Bad("the scenes read files outside the shared folder, which the nodes may not "
                      "see: export with Collect Materials, give --shared DIR, or "
                      "--allow-outside-shared")
    cache_ok = renderer_has(renderer, "--sss-cache")
    ests = [estimate(renderer, s, extra) for s in scenes]
    mem = a.mem or int(math.ceil((max(e["memory_mb"] for e in ests) * 1.25 + 64) / 64) * 64)
    if a.tiles > 1 and not cache_ok and any(e["translucent"] for e in ests):
        say("warning: %s has no --sss-cache: each tile runs the subsurface pre-pass of its "
            "own crop, and a few pixels may differ from the single render" % renderer)
    for d in ("logs", "times", "pids", "failed", "tiles", "keys"):
        os.makedirs(os.path.join(out, WORK, d), exist_ok=True)
    frames = []
    for s, e in zip(scenes, ests):
        frames.append(plan_frame(out, s, e, a, renderer, cache_ok))

    # What is left: frames whose outputs are whole and of their key are skipped; of the others,
    # the tiles that are not, and the pre-pass when its cache is not or no tile is left.
    pre, ren, mer = [], [], []
    for fr in frames:
        why = task_done(fr)
        if why is None:
            continue
        if not why.endswith(": missing"):
            say("%s: rendering it again: %s" % (fr["name"], why))
        if fr["merge"] is None:
            ren += fr["render"]
            continue
        todo = []
        for t in fr["render"]:
            twhy = task_done(t)
            if twhy:
                todo.append(t)
                if not twhy.endswith(": missing"):
                    say("%s: rendering it again: %s" % (t["name"], twhy))
        if todo and fr["prepass"] and task_done(fr["prepass"]):
            pre.append(fr["prepass"])
        ren += todo
        m = fr["merge"]
        os.makedirs(os.path.dirname(m["list"]), exist_ok=True)
        write_file(m["list"], "# X Y W H FILE: the tiles of %s (opaline-render --merge-tiles)\n"
                   % fr["name"] + "".join(m["lines"]))
        mer.append(m)
    # Every submission's frames are kept (an animation submitted in parts into one folder); a
    # frame submitted again replaces its old entry.
    st = {"version": 2, "renderer": renderer, "out": out, "frames": [], "submissions": []}
    try:
        old = load_state(out)
        st["submissions"] = old["submissions"]
        st["frames"] = old["frames"]
    except Bad as e:
        if os.path.lexists(os.path.join(out, STATE)):
            say("warning: %s; starting a new one" % e)
    names = {fr["name"] for fr in frames}
    st["frames"] = [fr for fr in st["frames"] if fr["name"] not in names] + frames
    st.update(threads=a.threads, mem_mb=mem, retries=a.retries)
    n_done = sum(1 for fr in frames if frame_done(fr))
    if not (pre or ren or mer):
        write_json(os.path.join(out, STATE), st)
        print("nothing to render: all %d frames are complete in %s" % (len(frames), out))
        return 0
    sub = {"time": time.time(), "jobs": {}, "taskfiles": {}}
    if a.local:  # status tells its tasks pending or running while this process lives
        sub["local"] = {"pid": os.getpid(), "host": os.uname().nodename}
    k = len(st["submissions"])
    groups = []
    for name, tasks, cpus in (("prepass", pre, a.threads), ("render", ren, a.threads),
                              ("merge", mer, 1)):
        if not tasks:
            continue
        if len(tasks) > a.max_array:
            raise Bad("%d %s tasks in one job array: over --max-array %d (the cluster's "
                      "MaxArraySize); submit fewer frames at a time" % (len(tasks), name,
                                                                         a.max_array))
        tf = os.path.join(out, WORK, "sub%d-%s.json" % (k, name))
        for t in tasks:
            t["retries"] = a.retries
        write_json(tf, tasks)
        sub["taskfiles"][name] = tf
        groups.append((name, tasks, cpus, tf))
    if a.local:  # the state first, so that status sees the run from its first task
        st["submissions"].append(sub)
        write_json(os.path.join(out, STATE), st)
        for name, tasks, cpus, tf in groups:
            for i in range(len(tasks)):
                rc = run_task(out, tf, i)
                if rc == 130:
                    raise Cancelled("%s: interrupted" % tasks[i]["name"])
                if rc != 0:
                    raise (Bad if rc == 2 else Failed)("%s failed (log above)" % tasks[i]["name"])
        print("rendered %d frames here (%d were complete)" % (len(frames) - n_done, n_done))
        return 0
    deps = []
    for name, tasks, cpus, tf in groups:
        jid = sbatch(a, out, name, tf, range(len(tasks)), deps, cpus, mem)
        sub["jobs"][name] = jid
        if jid:
            deps = [jid]
    if a.dry_run:
        return 0
    st["submissions"].append(sub)
    write_json(os.path.join(out, STATE), st)
    jobs = sub["jobs"]
    print("submitted job %s: %d frame%s (%d complete already), %d render task%s, %s%s" % (
        jobs.get("render") or jobs.get("merge"), len(frames), "s" if len(frames) != 1 else "",
        n_done, len(ren), "s" if len(ren) != 1 else "",
        "pre-pass job %s (%d), " % (jobs["prepass"], len(pre)) if pre else "",
        "merge job %s (%d)" % (jobs["merge"], len(mer)) if mer else "no merge"))
    print("jobs: " + " ".join("%s=%s" % kv for kv in jobs.items()))
    return 0


# ------------------------------------------------------------------ run (one task)

def run_task(out, taskfile, index):
    """Runs task `index` of taskfile: nothing when its outputs are whole and of its key already;
    else its command, again up to `retries` times when it fails or is killed; a last failure
    leaves a mark in OUTDIR/.cluster/failed/. A signal is passed to the renderer and ends the
    task (130), not retried. Returns the exit code."""
    tasks = load_tasks(taskfile)
    if not 0 <= index < len(tasks):
        raise Bad("%s: no task %d (it has %d: 0 to %d)" % (taskfile, index, len(tasks),
                                                           len(tasks) - 1))
    task = tasks[index]
    name = task["name"]
    work = os.path.join(out, WORK)
    failmark = os.path.join(work, "failed", name)
    why = task_done(task)
    if why is None:
        say("%s: already done" % name)
        return 0
    try:
        attempts = int(task.get("retries", 2)) + 1
    except (TypeError, ValueError):
        raise Bad("%s: a damaged opaline-cluster task file (task %d)" % (taskfile, index))
    pidfile = os.path.join(work, "pids", name)
    for d in ("pids", "times", "failed", "keys"):
        os.makedirs(os.path.join(work, d), exist_ok=True)
    for attempt in range(1, attempts + 1):
        say("%s: attempt %d of %d: %s" % (name, attempt, attempts,
                                           " ".join(shlex.quote(c) for c in task["argv"])))
        t0 = time.time()
        c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        try:
            rc = spawn(task["argv"], lambda pid: write_file(pidfile, "%d %d %s\n" % (
                pid, attempt, os.uname().nodename)))
        finally:
            try:
                os.unlink(pidfile)
            except OSError:
                pass
        c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        why = task_done(task, keys=False)
        if rc == 0 and why is None:
            record_keys(task)
            write_json(os.path.join(work, "times", name + ".json"), {
                "name": name, "kind": task.get("kind"), "start": t0,
                "seconds": time.time() - t0,
                "cpu_seconds": (c1.ru_utime - c0.ru_utime) + (c1.ru_stime - c0.ru_stime),
                "attempt": attempt, "host": os.uname().nodename,
                "job": os.environ.get("SLURM_JOB_ID")})
            try:
                os.unlink(failmark)
            except OSError:
                pass
            say("%s: done in %.1f s" % (name, time.time() - t0))
            return 0
        what = ("killed by signal %d" % -rc if rc < 0 else
                "exit %d" % rc if rc else "exit 0 but %s" % why)
        say("%s: attempt %d failed (%s)" % (name, attempt, what))
        if _running["sig"]:
            say("%s: cancelled (signal %d): not retried" % (name, _running["sig"]))
            return 130
        if rc == 2:
            break  # bad input: the same again would fail the same way
    write_file(failmark, "%s after %d attempt%s\n" % (what, attempt, "s" if attempt > 1 else ""))
    return 1


# ------------------------------------------------------------------ status and merge

def queue_states(st):
    """{(job id, array index): state} of the submissions' tasks still in the queue."""
    ids = [str(j) for s in st["submissions"] for j in s["jobs"].values() if j]
    if not ids:
        return {}
    try:
        r = subprocess.run(["squeue", "-h", "-r", "-j", ",".join(ids), "-o", "%i %T"],
                           capture_output=True, text=True)
    except FileNotFoundError:
        return {}
    res = {}
    for line in r.stdout.splitlines():
        try:
            jid, state = line.split()
            job, _, idx = jid.partition("_")
            if idx.isdigit():
                res[(job, int(idx))] = state
            elif idx.startswith("["):  # pending tasks not yet split off: [0-3,5%2]
                for part in idx.strip("[]").split("%")[0].split(","):
                    lo, _, hi = part.partition("-")
                    for i in range(int(lo), int(hi or lo) + 1):
                        res[(job, i)] = state
        except ValueError:
            continue
    return res


def alive(pid):
    try:
        os.kill(int(pid), 0)
        return True
    except PermissionError:
        return True
    except (OSError, TypeError, ValueError):
        return False


def running_here(out, name):
    """Whether the task's renderer runs on this host (its pid file, OUTDIR/.cluster/pids/)."""
    try:
        with open(os.path.join(out, WORK, "pids", name)) as f:
            pid, _, host = f.read().split()[:3]
    except (OSError, ValueError):
        return False
    return host == os.uname().nodename and alive(pid)


def cmd_status(a):
    out = os.path.abspath(a.output)
    st = load_state(out)
    queue = queue_states(st)
    where = {}  # task name -> queue state, for the latest submission that has it
    here = os.uname().nodename
    for s in st["submissions"]:
        loc = s.get("local")  # a --local run still going: its tasks are pending
        live = isinstance(loc, dict) and loc.get("host") == here and alive(loc.get("pid"))
        for kind, tf in s["taskfiles"].items():
            jid = s["jobs"].get(kind)
            try:
                tasks = load_tasks(tf)
            except Bad:
                continue
            for i, t in enumerate(tasks):
                where[t["name"]] = queue.get((jid, i)) if jid else "PENDING" if live else None
    counts = {"done": 0, "running": 0, "pending": 0, "failed": 0, "missing": 0}
    secs, lines = [], []
    for fr in st["frames"]:
        complete = frame_done(fr)
        units = fr["render"]
        for t in units + ([fr["merge"]] if fr["merge"] else []):
            tp = os.path.join(out, WORK, "times", t["name"] + ".json")
            try:
                with open(tp) as f:
                    secs.append((t.get("kind"), float(json.load(f)["seconds"])))
            except (OSError, ValueError, KeyError, TypeError):
                pass
        for t in units:
            q = where.get(t["name"])
            if q == "PENDING" and running_here(out, t["name"]):
                q = "RUNNING"
            if complete or not task_done(t):
                s = "done"
            elif q in ("RUNNING", "COMPLETING", "CONFIGURING"):
                s = "running"
            elif q in ("PENDING", "REQUEUED", "REQUEUE_HOLD", "SUSPENDED"):
                s = "pending"
            elif os.path.exists(os.path.join(out, WORK, "failed", t["name"])):
                s = "failed"
            else:
                s = "missing"
            counts[s] += 1
            if a.verbose and s != "done":
                lines.append("  %s: %s" % (t["name"], s))
        if a.verbose:
            lines.append("  frame %s: %s" % (fr["name"], "complete" if complete else "not yet"))
    total = sum(counts.values())
    nframes = len(st["frames"])
    fdone = sum(1 for fr in st["frames"] if frame_done(fr))
    kind = "tiles" if any(fr["merge"] for fr in st["frames"]) else "frames"
    print("%s: %d of %d frames complete; %s: %d done, %d running, %d pending, %d failed, "
          "%d not queued (of %d)" % (out, fdone, nframes, kind, counts["done"],
                                     counts["running"], counts["pending"], counts["failed"],
                                     counts["missing"], total))
    left = counts["running"] + counts["pending"]
    rsecs = [s for k, s in secs if k in ("frame", "tile")]
    if left and rsecs:
        par = max(1, counts["running"])
        eta = sum(rsecs) / len(rsecs) * left / par
        print("ETA: about %.0f s (%.1f s per task, %d running)" % (eta, sum(rsecs) / len(rsecs),
                                                                 counts["running"]))
    elif left:
        print("ETA: unknown until a task has finished")
    for l in lines:
        print(l)
    if counts["failed"] or counts["missing"]:
        print("re-submit (the same submit command) to render what failed or is missing")
    return 0 if fdone == nframes else (1 if (counts["failed"] or counts["missing"]) and not left
                                       else 0)


def cmd_merge(a):
    out = os.path.abspath(a.output)
    st = load_state(out)
    bad = 0
    for fr in st["frames"]:
        m = fr["merge"]
        if m is None or frame_done(fr):
            continue
        rc = spawn(m["argv"])
        if rc == 0:
            record_keys(m)
        elif _running["sig"]:
            raise Cancelled("%s: interrupted" % m["name"])
        else:
            bad = max(bad, 2 if rc == 2 else 1)
    return bad


# ------------------------------------------------------------------ main

def main(argv):
    ap = argparse.ArgumentParser(prog="opaline-cluster",
                                 description="Render opaline scenes on a SLURM cluster")
    sp = ap.add_subparsers(dest="cmd", required=True)
    s = sp.add_parser("submit", help="submit frames (one scene file each) as job arrays")
    s.add_argument("scenes", nargs="+", metavar="SCENE.xml")
    s.add_argument("-o", "--output", required=True, help="output folder (on the shared "
                   "filesystem)")
    s.add_argument("--tiles", type=int, default=1, help="tiles per frame (default 1: whole)")
    s.add_argument("--threads", type=int, default=4, help="threads (CPUs) per task")
    s.add_argument("--mem", type=int, help="memory per task in MB (default: estimated)")
    s.add_argument("-s", "--spp", type=int, help="samples per pixel (default: the scene's)")
    s.add_argument("-D", "--define", action="append", help="name=value, passed to the renderer")
    s.add_argument("--formats", default="exr,png", help="output formats (default exr,png)")
    s.add_argument("--retries", type=int, default=2, help="retries of a failed task")
    s.add_argument("--partition")
    s.add_argument("--account")
    s.add_argument("--sbatch-arg", action="append", help="more sbatch arguments (repeatable)")
    s.add_argument("--sbatch", default=os.environ.get("OPALINE_SBATCH", "sbatch"),
                   help="the sbatch program (default: $OPALINE_SBATCH, else sbatch)")
    s.add_argument("--max-array", type=int, default=1000, help="most tasks in one job array")
    s.add_argument("--renderer", help="opaline-render on the nodes (default: beside this "
                   "program, else on PATH)")
    s.add_argument("--shared", help="the folder the nodes share (default: each scene's)")
    s.add_argument("--allow-outside-shared", dest="allow_outside", action="store_true")
    s.add_argument("--dry-run", action="store_true", help="print the sbatch commands only")
    s.add_argument("--local", action="store_true", help="no SLURM: run every task here, in "
                   "order")
    t = sp.add_parser("status", help="done, running, pending, failed and the ETA")
    t.add_argument("output", metavar="OUTDIR")
    t.add_argument("-v", "--verbose", action="store_true")
    m = sp.add_parser("merge", help="merge the tiles of the frames not yet merged, here")
    m.add_argument("output", metavar="OUTDIR")
    r = sp.add_parser("run", help="run one task (what each SLURM task runs)")
    r.add_argument("output", metavar="OUTDIR")
    r.add_argument("taskfile")
    r.add_argument("index", type=int)
    a = ap.parse_args(argv)
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        if signal.getsignal(sig) != signal.SIG_IGN:  # one ignored at start (nohup) stays so
            signal.signal(sig, on_signal)
    try:
        if a.cmd == "submit":
            for opt, v, lo in (("--tiles", a.tiles, 1), ("--threads", a.threads, 1),
                               ("--retries", a.retries, 0), ("-s", a.spp, 1), ("--mem", a.mem, 1),
                               ("--max-array", a.max_array, 1)):
                if v is not None and v < lo:
                    raise Bad("%s %d: must be at least %d" % (opt, v, lo))
            return cmd_submit(a)
        if a.cmd == "status":
            return cmd_status(a)
        if a.cmd == "merge":
            return cmd_merge(a)
        return run_task(os.path.abspath(a.output), a.taskfile, a.index)
    except Bad as e:
        say("error: %s" % e)
        return 2
    except Failed as e:
        say("error: %s" % e)
        return 1
    except Cancelled as e:
        say("%s" % e)
        return 130
    except OSError as e:
        say("error: %s" % e)
        return 1
    except Exception as e:  # no input ends in a traceback: a damaged file no check foresaw
        say("error: unexpected %s: %s (a damaged file in the output folder?)" % (
            type(e).__name__, e))
        return 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
