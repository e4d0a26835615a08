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
being there: a re-submission renders only what is missing or invalid. Python 3 standard
library only, so that the compute nodes need nothing else.

Exit codes: 0 ok, 1 failure (sbatch refused, a task failed), 2 bad arguments or scene.
"""

import argparse
import json
import math
import os
import resource
import shlex
import signal
import struct
import subprocess
import sys
import time
import xml.parsers.expat
import zlib

STATE = "opaline-cluster.json"
WORK = ".cluster"          # OUTDIR/.cluster: task lists, logs, timings, pids, failure marks
RENDERER = "opaline-render"


class Bad(Exception):
    """Bad input: exit code 2."""


class Failed(Exception):
    """Another failure: exit code 1."""


def say(msg):
    print("opaline-cluster: %s" % msg, file=sys.stderr, flush=True)


# ------------------------------------------------------------------ checking image files

def _exr_lines_per_chunk(compression):
    # NONE RLE ZIPS ZIP PIZ PXR24 B44 B44A DWAA DWAB
    return {0: 1, 1: 1, 2: 1, 3: 16, 4: 32, 5: 16, 6: 32, 7: 32, 8: 32, 9: 256}.get(compression)


def check_exr(data, w, h):
    """None when data is a whole single-part scanline OpenEXR file of w x h pixels (header,
    offset table, every chunk inside the file, the last ending the file), else why not."""
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


def check_output(path, w=None, h=None):
    """None when the output at path is whole (an image of w x h pixels; any other file: not
    empty), else why not."""
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
    return {".exr": check_exr, ".png": check_png, ".pfm": check_pfm}[ext](data, w, h)


def task_done(task):
    """None when every output of the task is whole, else 'PATH: why' of the first that is not."""
    for o in task["outputs"]:
        why = check_output(o["path"], o.get("w"), o.get("h"))
        if why:
            return "%s: %s" % (o["path"], why)
    return None


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


def renderer_has(renderer, option):
    out = subprocess.run([renderer, "--help"], capture_output=True, text=True).stdout
    return option in out


def within(path, root):
    path, root = os.path.realpath(path), os.path.realpath(root)
    return path == root or path.startswith(root.rstrip("/") + "/")


def check_travels(scene, shared):
    """Every file the scene names (a filename, an include, a material given as a path) must
    lie in the shared folder, so that the nodes find it. Returns the problems, 'FILE:LINE: ...'."""
    problems = []
    parser = xml.parsers.expat.ParserCreate()

    def start(tag, attrs):
        name, value = attrs.get("name"), attrs.get("value")
        if tag == "include":
            value = attrs.get("filename")
        elif tag != "string" or name not in ("filename", "material"):
            return
        if value is None or "$" in value:
            return
        if name == "material" and "/" not in value and not value.endswith(".opm"):
            return  # a preset by name: the renderer on the node finds it
        full = value if os.path.isabs(value) else os.path.join(os.path.dirname(scene), value)
        if not within(full, shared):
            problems.append("%s:%d: '%s' is %s outside the shared folder %s" % (
                scene, parser.CurrentLineNumber, value,
                "an absolute path" if os.path.isabs(value) else "a relative path", shared))

    parser.StartElementHandler = start
    try:
        with open(scene, "rb") as f:
            parser.ParseFile(f)
    except xml.parsers.expat.ExpatError as e:
        raise Bad("%s: %s" % (scene, e))
    return problems


def estimate(renderer, scene, extra):
    r = subprocess.run([renderer, "--estimate", "-q", "-q"] + extra + [scene],
                       capture_output=True, text=True)
    if r.returncode != 0:
        msg = r.stderr.strip() or "%s --estimate %s: exit %d" % (RENDERER, scene, r.returncode)
        raise (Bad if r.returncode == 2 else Failed)(msg)
    fields = dict(kv.split("=", 1) for kv in r.stdout.split())
    return {k: int(float(v)) for k, v in fields.items()}


def tile_grid(w, h, n):
    """n rectangles (x, y, w, h) cutting the w x h film: the cols x rows = n grid whose tiles
    are closest to square, sizes differing by at most one pixel, row by row from the top."""
    best = None
    for cols in range(1, n + 1):
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

def load_state(out):
    p = os.path.join(out, STATE)
    try:
        with open(p) as f:
            return json.load(f)
    except FileNotFoundError:
        raise Bad("%s: no render submitted to this folder (no %s)" % (out, STATE))
    except (OSError, ValueError) as e:
        raise Bad("%s: %s" % (p, e))


def write_json(path, obj):
    """Written whole or not at all (temp + rename)."""
    tmp = "%s.tmp-%d" % (path, os.getpid())
    with open(tmp, "w") as f:
        json.dump(obj, f, indent=1)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def plan_frame(out, scene, est, a, renderer, cache_ok):
    """The tasks of one frame: {'prepass': task or None, 'render': [tasks], 'merge': task or
    None}, each task with its argv and outputs, whatever is already done."""
    stem = os.path.splitext(os.path.basename(scene))[0]
    common = ["-q"] + (["-s", str(a.spp)] if a.spp else [])
    for d in a.define or []:
        common += ["-D", d]
    w, h = est["width"], est["height"]
    outs = [{"path": os.path.join(out, "%s.%s" % (stem, fmt)), "w": w, "h": h}
            for fmt in a.formats]
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
                   "outputs": [{"path": cache}],
                   "argv": [renderer, scene, "--sss-cache", cache, "--sss-cache-only"] + thr +
                   common}
    tiles, lines = [], []
    for i, (x, y, tw, th) in enumerate(tile_grid(w, h, a.tiles)):
        f = os.path.join(tdir, "tile_%03d.exr" % i)
        lines.append("%d %d %d %d %s\n" % (x, y, tw, th, os.path.basename(f)))
        tiles.append({"name": "%s.tile%03d" % (stem, i), "kind": "tile",
                      "outputs": [{"path": f, "w": tw, "h": th}],
                      "argv": [renderer, scene, "--crop", "%d,%d,%d,%d" % (x, y, tw, th),
                               "--raw-exr", "-o", f] + thr + common +
                      (["--sss-cache", cache] if use_cache else [])})
    merge = {"name": stem + ".merge", "kind": "merge", "outputs": outs,
             "list": os.path.join(tdir, "tiles.txt"), "lines": lines,
             "argv": [renderer, scene, "--merge-tiles", os.path.join(tdir, "tiles.txt")] +
             common + oargs}
    return {"name": stem, "outputs": outs, "prepass": prepass, "render": tiles, "merge": merge}


def frame_done(fr):
    return all(not check_output(o["path"], o["w"], o["h"]) for o in fr["outputs"])


# ------------------------------------------------------------------ submit

def sbatch(a, out, name, taskfile, indices, deps, cpus, mem):
    """Submits one job array running `opaline-cluster run` for the given task indices; returns
    its job id, or None with --dry-run."""
    me = os.path.realpath(__file__)
    logs = os.path.join(out, WORK, "logs")
    script = os.path.join(out, WORK, "task.sh")
    if not os.path.exists(script):
        with open(script + ".tmp", "w") as f:
            f.write("#!/bin/sh\n# one task of an opaline-cluster job array\nexec %s %s run "
                    "\"$1\" \"$2\" \"$SLURM_ARRAY_TASK_ID\"\n" % (
                        shlex.quote(sys.executable), shlex.quote(me)))
        os.chmod(script + ".tmp", 0o755)
        os.replace(script + ".tmp", script)
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
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise Failed("sbatch refused the %s job: %s" % (name, r.stderr.strip()))
    return r.stdout.strip().split(";")[0]


def cmd_submit(a):
    out = os.path.abspath(a.output)
    renderer = find_renderer(a.renderer)
    a.formats = [f.strip().lower().lstrip(".") for f in a.formats.split(",") if f.strip()]
    for f in a.formats:
        if f not in ("exr", "png", "pfm", "hdr"):
            raise Bad("--formats: %s is not one of exr, png, pfm, hdr" % f)
    scenes = [os.path.abspath(s) for s in a.scenes]
    stems = [os.path.splitext(os.path.basename(s))[0] for s in scenes]
    if len(set(stems)) != len(stems):
        raise Bad("two scenes have one name: their outputs would collide")
    shared = os.path.abspath(a.shared) if a.shared else None
    problems = []
    for s in scenes:
        if not os.path.isfile(s):
            raise Bad("%s: no such file" % s)
        problems += check_travels(s, shared or os.path.dirname(s))
    if problems:
        for p in problems:
            say(p)
        if not a.allow_outside:
            raise Bad("the scenes name files outside the shared folder, which the nodes may not "
                      "see: export with Collect Materials, give --shared DIR, or "
                      "--allow-outside-shared")
    cache_ok = renderer_has(renderer, "--sss-cache")
    extra = (["-s", str(a.spp)] if a.spp else []) + sum((["-D", d] for d in a.define or []), [])
    ests = [estimate(renderer, s, extra) for s in scenes]
    mem = a.mem or int(math.ceil((max(e["memory_mb"] for e in ests) * 1.25 + 64) / 64) * 64)
    if a.tiles > 1 and not cache_ok and any(e["translucent"] for e in ests):
        say("warning: %s has no --sss-cache: each tile runs the subsurface pre-pass of its "
            "own crop, and a few pixels may differ from the single render" % renderer)
    for d in ("logs", "times", "pids", "failed", "tiles"):
        os.makedirs(os.path.join(out, WORK, d), exist_ok=True)
    frames = []
    for s, e in zip(scenes, ests):
        frames.append(plan_frame(out, s, e, a, renderer, cache_ok))

    # What is left: frames whose outputs are whole are skipped; of the others, the tiles whose
    # files are whole, and the pre-pass when its cache is there or no tile is left.
    pre, ren, mer = [], [], []
    for fr in frames:
        if frame_done(fr):
            continue
        if fr["merge"] is None:
            ren += fr["render"]
            continue
        todo = [t for t in fr["render"] if task_done(t)]
        if todo and fr["prepass"] and task_done(fr["prepass"]):
            pre.append(fr["prepass"])
        ren += todo
        m = fr["merge"]
        os.makedirs(os.path.dirname(m["list"]), exist_ok=True)
        with open(m["list"] + ".tmp", "w") as f:
            f.write("# X Y W H FILE: the tiles of %s (opaline-render --merge-tiles)\n" % fr["name"])
            f.writelines(m["lines"])
        os.replace(m["list"] + ".tmp", m["list"])
        mer.append(m)
    st = {"version": 1, "renderer": renderer, "out": out, "tiles": a.tiles,
          "threads": a.threads, "mem_mb": mem, "retries": a.retries,
          "frames": frames, "submissions": []}
    try:
        old = load_state(out)
        st["submissions"] = old.get("submissions", [])
    except Bad:
        pass
    n_done = sum(1 for fr in frames if frame_done(fr))
    if not (pre or ren or mer):
        write_json(os.path.join(out, STATE), st)
        print("nothing to render: all %d frames are complete in %s" % (len(frames), out))
        return 0
    sub = {"time": time.time(), "jobs": {}, "taskfiles": {}}
    k = len(st["submissions"])
    deps = []
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
        if a.local:
            for i in range(len(tasks)):
                if run_task(out, tf, i) != 0:
                    raise Failed("%s failed (log above)" % tasks[i]["name"])
            continue
        jid = sbatch(a, out, name, tf, range(len(tasks)), deps, cpus, mem)
        sub["jobs"][name] = jid
        if jid:
            deps = [jid]
    if not a.dry_run:
        st["submissions"].append(sub)
        write_json(os.path.join(out, STATE), st)
    if a.local:
        print("rendered %d frames here (%d were complete)" % (len(frames) - n_done, n_done))
        return 0
    if a.dry_run:
        return 0
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
    """Runs task `index` of taskfile: nothing when its outputs are whole already; else its
    command, again up to `retries` times when it fails or is killed; a last failure leaves a
    mark in OUTDIR/.cluster/failed/. Returns the exit code."""
    with open(taskfile) as f:
        task = json.load(f)[int(index)]
    name = task["name"]
    work = os.path.join(out, WORK)
    failmark = os.path.join(work, "failed", name)
    why = task_done(task)
    if why is None:
        say("%s: already done" % name)
        return 0
    attempts = int(task.get("retries", 2)) + 1
    stop = {"sig": 0}
    child = {"p": None}

    def on_signal(sig, _frame):  # SLURM cancelled the job: pass it on, do not retry
        stop["sig"] = sig
        if child["p"] is not None:
            child["p"].send_signal(sig)

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    pidfile = os.path.join(work, "pids", name)
    for attempt in range(1, attempts + 1):
        say("%s: attempt %d of %d: %s" % (name, attempt, attempts,
                                           " ".join(shlex.quote(c) for c in task["argv"])))
        t0 = time.time()
        c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        p = subprocess.Popen(task["argv"])
        child["p"] = p
        with open(pidfile + ".tmp", "w") as f:
            f.write("%d %d\n" % (p.pid, attempt))
        os.replace(pidfile + ".tmp", pidfile)
        rc = p.wait()
        child["p"] = None
        c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        try:
            os.unlink(pidfile)
        except OSError:
            pass
        why = task_done(task) if rc == 0 else None
        if rc == 0 and why is None:
            write_json(os.path.join(work, "times", name + ".json"), {
                "name": name, "kind": task["kind"], "start": t0, "seconds": time.time() - t0,
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
        if stop["sig"]:
            say("%s: cancelled (signal %d): not retried" % (name, stop["sig"]))
            return 130
        if rc == 2:
            break  # bad input: the same again would fail the same way
    os.makedirs(os.path.dirname(failmark), exist_ok=True)
    with open(failmark, "w") as f:
        f.write("%s after %d attempt%s\n" % (what, attempt, "s" if attempt > 1 else ""))
    return 1


# ------------------------------------------------------------------ status and merge

def queue_states(st):
    """{(job id, array index): state} of the submissions' tasks still in the queue."""
    ids = [j for s in st["submissions"] for j in s["jobs"].values() if j]
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


def cmd_status(a):
    out = os.path.abspath(a.output)
    st = load_state(out)
    queue = queue_states(st)
    where = {}  # task name -> queue state, for the latest submission that has it
    for s in st["submissions"]:
        for kind, tf in s["taskfiles"].items():
            jid = s["jobs"].get(kind)
            try:
                with open(tf) as f:
                    tasks = json.load(f)
            except (OSError, ValueError):
                continue
            for i, t in enumerate(tasks):
                where[t["name"]] = queue.get((jid, i)) if jid else None
    counts = {"done": 0, "running": 0, "pending": 0, "failed": 0, "missing": 0}
    secs, lines = [], []
    for fr in st["frames"]:
        complete = frame_done(fr)
        units = fr["render"]
        for t in units + ([fr["merge"]] if fr["merge"] else []):
            tp = os.path.join(out, WORK, "times", t["name"] + ".json")
            try:
                with open(tp) as f:
                    secs.append((t["kind"], json.load(f)["seconds"]))
            except (OSError, ValueError, KeyError):
                pass
        for t in units:
            q = where.get(t["name"])
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
    kind = "tiles" if st.get("tiles", 1) > 1 else "frames"
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
        r = subprocess.run(m["argv"])
        if r.returncode != 0:
            bad = max(bad, 2 if r.returncode == 2 else 1)
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
    try:
        if a.cmd == "submit":
            if a.tiles < 1 or a.threads < 1 or a.retries < 0:
                raise Bad("--tiles and --threads must be at least 1, --retries at least 0")
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
    except OSError as e:
        say("error: %s" % e)
        return 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
