"""The "opaline" render engine: F12 exports the scene to this Blender session's folder (kept
between renders, so unchanged meshes are not rewritten), runs opaline-render in a subprocess
with --stream (only the Render Region when there is one; with --sss-cache in that folder, so
that a render where only the camera moved reuses the subsurface pre-pass), shows every stage's
progress, draws
tiles into the Render Result as they finish, stops the renderer on cancel (SIGINT, then
SIGKILL), and reports the renderer's warnings and failures through RenderEngine.report (the
Info editor and the status bar) instead of tracebacks.

The tile stream (docs/rendering.md, "Tile stream") is read by stream.StreamReader, which has no
bpy, so plain Python tests feed it bytes.
"""

import array
import atexit
import os
import queue
import re
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import threading
import time

import bpy

from . import locations, preferences
from . import stream as S
from .errors import OpalineError
from .export import scene as scene_export

# The reports of the last F12 (type, message), newest last: what the Info editor got.
last_reports = []
last_log = []  # the last F12's renderer LOG records, (level, text): what its pre-pass cache did
last_stats = [None]  # the last F12's STATS record (stream.Stats), None when none came
last_export = None  # the ExportResult of the last F12
last_status = [""]  # the status text the last F12 showed last ("opaline: Path tracing 25 %...")
_EOF = object()  # the stream reader's last event: the renderer closed its stdout


def _f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


def render_region(render):
    """The pixels Blender renders for `render` (scene.render): (full_w, full_h, x, y, w, h) with
    x, y the region's top-left corner counted from the image's top-left (the renderer's
    --crop), computed as Blender does (float border times the size, truncated; its y goes
    up). Without a Render Region the region is the whole image."""
    fw = render.resolution_x * render.resolution_percentage // 100
    fh = render.resolution_y * render.resolution_percentage // 100
    if not render.use_border:
        return fw, fh, 0, 0, fw, fh
    x0 = int(_f32(_f32(render.border_min_x) * fw))
    x1 = int(_f32(_f32(render.border_max_x) * fw))
    y0 = int(_f32(_f32(render.border_min_y) * fh))
    y1 = int(_f32(_f32(render.border_max_y) * fh))
    x0, x1 = max(0, min(x0, fw)), max(0, min(x1, fw))
    y0, y1 = max(0, min(y0, fh)), max(0, min(y1, fh))
    if x1 <= x0 or y1 <= y0:
        raise OpalineError("the Render Region is empty (%dx%d pixels): draw a larger one "
                           "(Ctrl+B) or clear it (Ctrl+Alt+B)" % (max(0, x1 - x0),
                                                                  max(0, y1 - y0)))
    return fw, fh, x0, fh - y1, x1 - x0, y1 - y0


# ---------------------------------------------------------------- the session folder

SESSION_PREFIX = "opaline-blender-"
KEEP_MARKER = "KEEP"  # in a session folder: "Keep exported files" was on; never removed
SSS_CACHE_NAME = "prepass.sssc"  # in a session folder: opaline-render --sss-cache
_session = {"dir": None, "keep": False}


def _pid_alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True  # exists, owned by someone else
    return True


def remove_stale_folders(base=None):
    """Removes the session folders (SESSION_PREFIX + pid + "-...") in `base` (default: the
    temporary folder) whose Blender is no longer running, except those kept on request (a
    KEEP_MARKER file inside: "Keep exported files"). Returns the removed paths."""
    base = base or tempfile.gettempdir()
    removed = []
    try:
        names = os.listdir(base)
    except OSError:
        return removed
    for name in names:
        m = re.match(re.escape(SESSION_PREFIX) + r"(\d+)-", name)
        if not m or int(m.group(1)) == os.getpid() or _pid_alive(int(m.group(1))):
            continue
        path = os.path.join(base, name)
        if (os.path.isdir(path) and not os.path.islink(path) and
                not os.path.exists(os.path.join(path, KEEP_MARKER))):
            shutil.rmtree(path, ignore_errors=True)
            removed.append(path)
    return removed


def session_folder():
    """This Blender's export folder, kept from one F12 to the next (meshes are content-
    addressed there, so an unchanged one is not written again) and removed when Blender quits
    (or, if Blender dies, by the next session's first F12)."""
    d = _session["dir"]
    if d is None or not os.path.isdir(d):
        remove_stale_folders()
        d = tempfile.mkdtemp(prefix="%s%d-" % (SESSION_PREFIX, os.getpid()))
        _session["dir"] = d
    return d


@atexit.register
def _remove_session_folder():
    d = _session["dir"]
    if d and not _session["keep"]:
        shutil.rmtree(d, ignore_errors=True)


# ---------------------------------------------------------------- progress

PREPASS_STAGES = {"irradiance points": "irradiance points", "irradiance": "irradiance",
                  "subsurface": "scattering", "scattering": "scattering"}


class Progress:
    """Turns the renderer's stage progress into one fraction of the whole render and a status
    text like Cycles'. The stages are weighted by their usual share of a render: with a
    subsurface pre-pass, loading 5 %, the pre-pass's stages 50 % together, the camera pass the
    rest; without one, loading 5 % and the camera pass 95 %."""

    def __init__(self, prepass, spp, tiles=0):
        self.spans = {"load": (0.0, 0.05)}
        if prepass:
            self.spans.update({"irradiance points": (0.05, 0.10), "irradiance": (0.10, 0.35),
                               "scattering": (0.35, 0.55), "render": (0.55, 1.0)})
        else:
            self.spans["render"] = (0.05, 1.0)
        self.spp = spp
        self.tiles = tiles
        self.tiles_done = 0
        self.total = 0.0

    def stage(self, label, fraction):
        """Returns (whole-render fraction, status text) for a stage's fraction."""
        fraction = max(0.0, min(1.0, fraction))
        name = PREPASS_STAGES.get(label, label)
        lo, hi = self.spans.get(name, (self.total, self.total))
        self.total = max(self.total, lo + (hi - lo) * fraction)
        if name in PREPASS_STAGES.values():
            text = "Subsurface pre-pass: %s %d %%" % (name, int(100 * fraction))
        elif name == "render":
            text = self.render_text(fraction)
        else:
            text = "%s %d %%" % (name.capitalize(), int(100 * fraction))
        return self.total, text

    def render_text(self, fraction):
        return "Path tracing %d %%, %d/%d tiles, %d samples" % (
            int(100 * fraction), min(self.tiles_done, self.tiles), self.tiles, self.spp)


def flip_rows(a, w, h):
    """Rows top-to-bottom -> bottom-to-top (Blender's order), for a flat RGBA float array."""
    out = array.array('f')
    row = 4 * w
    for r in range(h - 1, -1, -1):
        out.extend(a[r * row:(r + 1) * row])
    return out


def opaque(a):
    """A copy of the flat RGBA array `a` with every alpha 1: Film > Transparent is off, so the
    world counts as covering every pixel (the renderer's alpha is the coverage of surfaces)."""
    out = array.array('f', a)
    out[3::4] = array.array('f', [1.0]) * (len(a) // 4)
    return out


def _set_rect(rpass, a, w, h):
    """Fills a render pass from a flat RGBA array (bottom row first)."""
    rpass.rect = [a[4 * i:4 * i + 4] for i in range(w * h)]


class OpalineRenderEngine(bpy.types.RenderEngine):
    bl_idname = "OPALINE"
    bl_label = "opaline"
    bl_use_preview = False
    bl_use_eevee_viewport = True
    bl_use_postprocess = True

    def render(self, depsgraph):
        try:
            self._render(depsgraph)
        except OpalineError as e:
            self._fail(str(e))
        except OSError as e:
            self._fail("cannot run opaline-render: %s" % e)
        except Exception as e:  # a bug: readable report, traceback on the console
            import traceback
            traceback.print_exc()
            self._fail("internal error (%s: %s); details on the console" %
                       (type(e).__name__, e))

    def _report(self, kind, msg):
        """A report of the render: F12's render operator moves it to the window manager's
        reports when the render ends (the Info editor and the status bar, once each;
        scripts/addon-screenshots.sh checks it under a real display); a RuntimeError of
        bpy.ops.render.render for errors in the background. (A report of an operator called
        from Python, e.g. from a timer, never reaches the Info editor: Python holds those.)"""
        last_reports.append((kind, msg))
        self.report({kind}, msg)

    def _status(self, text):
        """The render's status text (the render window's header), also kept in last_status."""
        last_status[0] = text
        self.update_stats("", text)

    def _fail(self, msg):
        msg = "opaline: " + msg
        self._report('ERROR', msg)
        if hasattr(self, "error_set"):
            self.error_set(msg)
        print(msg, file=sys.stderr)

    def _render(self, depsgraph):
        global last_export
        del last_reports[:]
        del last_log[:]
        last_stats[0] = None
        last_status[0] = ""
        scene = depsgraph.scene
        self._transparent = bool(scene.render.film_transparent)
        full_w, full_h, cx, cy, width, height = render_region(scene.render)
        probe = self.begin_result(0, 0, full_w, full_h)  # clamped to Blender's result
        if probe is not None:
            size = (probe.resolution_x, probe.resolution_y)
            self.end_result(probe, cancel=True)
            if size != (width, height):
                raise OpalineError("Blender renders %dx%d pixels, the Render Region gives "
                                   "%dx%d: clear the Render Region (Ctrl+Alt+B) and draw it "
                                   "again" % (size + (width, height)))
        renderer = preferences.find_renderer(bpy.context, required=True)
        settings = getattr(scene.original if hasattr(scene, "original") else scene, "opaline",
                           None)
        keep = bool(settings and settings.keep_temp)
        tmp = session_folder()
        if keep and not _session["keep"]:
            _session["keep"] = True
            with open(os.path.join(tmp, KEEP_MARKER), "w") as f:
                f.write("Blender's opaline F12 exports, kept (Keep exported files): delete this "
                        "folder when done\n")
        self._status("opaline: exporting")
        xml = os.path.join(tmp, "scene.xml")
        res = scene_export.export_scene(depsgraph, xml, bpy.context, renderer,
                                        progress=self._export_progress)
        last_export = res
        for w in res.warnings:
            self._report('WARNING', "opaline: " + w)
        out = os.path.join(tmp, "render.exr")
        cmd = [renderer, "--stream", "--stream-log", "-o", out]
        if settings is not None and settings.threads > 0:
            cmd += ["-t", str(settings.threads)]
        if (cx, cy, width, height) != (0, 0, full_w, full_h):
            cmd += ["--crop", "%d,%d,%d,%d" % (cx, cy, width, height)]
        with open(xml, encoding="utf-8") as f:
            prepass = "<subsurface" in f.read()
        if prepass:
            # the subsurface pre-pass's results, reused by the next F12 or animation frame
            # while only the camera (or nothing) changed (docs/subsurface-rendering.md)
            cmd += ["--sss-cache", os.path.join(tmp, SSS_CACHE_NAME)]
        cmd.append(xml)
        env = locations.renderer_env()  # the scene names only the presets it finds so
        env["OPALINE_PARENT_PID"] = str(os.getpid())
        progress = Progress(prepass, scene_export.render_samples(
            scene.original if hasattr(scene, "original") else scene)[0])
        self._run(cmd, env, out, width, height, progress)
        if keep:
            self._report('INFO', "opaline: exported files kept in %s" % tmp)

    def _export_progress(self, fraction, name):
        """export_scene's progress: the share of the faces exported, in the status text."""
        self._status("opaline: exporting meshes %d %%%s" % (
            int(100 * fraction), " (%s)" % name if name else ""))

    def _log(self, level, text):
        """A renderer's LOG record: warnings and errors to the reports, the rest to the
        console."""
        if level == "warning":
            self._report('WARNING', "opaline-render: " + text)
        elif level != "error":  # errors: in the failure's report, with the exit status
            print("opaline-render: %s: %s" % (level, text), file=sys.stderr)
        last_log.append((level, text))

    def _stats(self, stats):
        """The renderer's STATS record: a shape given fewer irradiance points than it needs
        (each also warned in a LOG record) points at the setting that raises the cap."""
        last_stats[0] = stats
        if stats.sss_shapes_capped > 0:
            self._report('WARNING', "opaline: %d translucent object%s got fewer irradiance "
                         "points than %s material needs: raise the Irradiance Point Cap "
                         "(opaline render settings, scene.opaline.max_sss_points)" % (
                             stats.sss_shapes_capped,
                             "s" if stats.sss_shapes_capped != 1 else "",
                             "their" if stats.sss_shapes_capped != 1 else "its"))

    def _draw_tile(self, tile, width, height):
        """Puts a TILE record into the Render Result (its rows flipped: Blender's go up)."""
        by = height - (tile.y + tile.height)
        result = self.begin_result(tile.x, by, tile.width, tile.height)
        if result is None:
            raise OpalineError("Blender refused the tile %dx%d at %d,%d of the %dx%d result" %
                               (tile.width, tile.height, tile.x, by, width, height))
        rgba = tile.rgba if self._transparent else opaque(tile.rgba)
        _set_rect(result.layers[0].passes["Combined"], flip_rows(rgba, tile.width, tile.height),
                  tile.width, tile.height)
        self.end_result(result)

    def _run(self, cmd, env, out_path, width, height, progress):
        self._status("opaline: loading the scene")
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env,
                                start_new_session=True)
        events = queue.Queue()
        errlines = []

        def read_stdout():
            try:
                for rec in S.StreamReader(proc.stdout):
                    events.put(rec)
            except S.StreamError as e:
                events.put(e)
            except (OSError, ValueError):
                pass
            events.put(_EOF)

        def read_stderr():
            for line in iter(proc.stderr.readline, b""):
                errlines.append(line.decode("utf-8", "replace").rstrip())
                del errlines[:-200]

        t1 = threading.Thread(target=read_stdout, daemon=True)
        t2 = threading.Thread(target=read_stderr, daemon=True)
        t1.start()
        t2.start()
        tiles = 0
        stream_error = None
        cancelled = False
        end_status = None
        eof = False
        stop_sent = None
        errors = []  # the renderer's error messages, from its LOG records
        while not eof:
            if not cancelled and self.test_break():
                cancelled = True
                stop_sent = time.monotonic()
                try:
                    os.killpg(proc.pid, signal.SIGINT)
                except OSError:
                    pass
            if cancelled and stop_sent is not None and time.monotonic() - stop_sent > 5.0:
                try:
                    os.killpg(proc.pid, signal.SIGKILL)
                except OSError:
                    pass
                stop_sent = None
            try:
                rec = events.get(timeout=0.1)
            except queue.Empty:
                continue
            if rec is _EOF:
                eof = True
            elif isinstance(rec, S.StreamError):
                stream_error = str(rec)
            elif isinstance(rec, S.Begin):
                if (rec.width, rec.height) != (width, height):
                    stream_error = "renderer image is %dx%d, Blender expects %dx%d" % (
                        rec.width, rec.height, width, height)
                progress.tiles = S.tile_count(rec.width, rec.height, rec.tile_size)
            elif isinstance(rec, S.Tile):
                if rec.x + rec.width > width or rec.y + rec.height > height:
                    continue
                self._draw_tile(rec, width, height)
                tiles += 1
                progress.tiles_done = tiles
            elif isinstance(rec, S.Progress):
                total, text = progress.stage(rec.label, rec.fraction)
                self.update_progress(total)
                self._status("opaline: " + text)
            elif isinstance(rec, S.Log):
                if rec.level == "error":
                    errors.append(rec.text)
                self._log(rec.level, rec.text)
            elif isinstance(rec, S.Stats):
                self._stats(rec)
            elif isinstance(rec, S.End):
                end_status = rec.status
        rc = proc.wait()
        t2.join(timeout=2.0)
        if cancelled:
            return
        tail = "\n".join(errors or [ln for ln in errlines if ": error: " in ln][-8:] or
                         errlines[-8:])
        if rc != 0:
            raise OpalineError("opaline-render failed (exit %d):\n%s" % (rc, tail or "(no "
                                                                             "message)"))
        if stream_error:
            raise OpalineError("bad tile stream from opaline-render: %s" % stream_error)
        if end_status not in (None, 0):
            raise OpalineError("opaline-render reported status %d:\n%s" % (end_status, tail))
        if tiles == 0:
            # No stream: take the finished image from the output file.
            if not os.path.isfile(out_path):
                raise OpalineError("opaline-render wrote no image (%s)" % (tail or out_path))
            result = self.begin_result(0, 0, width, height)
            try:
                result.load_from_file(out_path)
                if not self._transparent:
                    rpass = result.layers[0].passes["Combined"]
                    rpass.rect = [(p[0], p[1], p[2], 1.0) for p in rpass.rect]
            finally:
                self.end_result(result)
        self.update_progress(1.0)


def compatible_panels():
    """The standard property panels whose settings opaline uses (lights, world colour, camera,
    output format, frame range, colour management, Film > Transparent; the material slots,
    Surface and Preview are the add-on's own panels). One panel per setting: the EEVEE panels,
    which exist in every supported version, and Workbench's Film panel, which holds only
    Transparent; not Cycles' (their settings are Cycles' own, and they
    share one COMPAT_ENGINES set). The names are the same in Blender 3.4 (BLENDER_EEVEE), 4.2 to
    4.5 (EEVEE Next, BLENDER_EEVEE_NEXT, whose panels kept the EEVEE_ / DATA_PT_EEVEE_ names)
    and 5.x (BLENDER_EEVEE again)."""
    want = {"DATA_PT_context_light", "DATA_PT_EEVEE_light", "DATA_PT_spot",
            "WORLD_PT_context_world", "EEVEE_WORLD_PT_surface",
            "DATA_PT_context_camera", "DATA_PT_lens", "DATA_PT_camera", "DATA_PT_camera_display",
            "RENDER_PT_format", "RENDER_PT_frame_range", "RENDER_PT_color_management",
            "RENDER_PT_opengl_film"}
    out = []
    for p in bpy.types.Panel.__subclasses__():
        if getattr(p, "COMPAT_ENGINES", None) is not None and p.__name__ in want:
            out.append(p)
    return out


# Panels whose COMPAT_ENGINES is inherited (a set shared with a base class and its other
# panels, as Cycles' are) get a set of their own, which unregister_engine removes again.
_OWN_SETS = []


def register_engine():
    bpy.utils.register_class(OpalineRenderEngine)
    for p in compatible_panels():
        if "COMPAT_ENGINES" in p.__dict__:
            p.COMPAT_ENGINES.add('OPALINE')
        else:
            p.COMPAT_ENGINES = set(p.COMPAT_ENGINES) | {'OPALINE'}
            _OWN_SETS.append(p)


def unregister_engine():
    for p in compatible_panels():
        if p in _OWN_SETS:
            del p.COMPAT_ENGINES
        else:
            p.COMPAT_ENGINES.discard('OPALINE')
    _OWN_SETS.clear()
    bpy.utils.unregister_class(OpalineRenderEngine)
