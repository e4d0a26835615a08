"""The "opaline" render engine: F12 exports the scene to a temporary folder, runs opaline-render
in a subprocess with --stream, shows its progress, draws tiles into the Render Result as they
finish, stops the renderer on cancel (SIGINT, then SIGKILL), and reports failures through
RenderEngine.report/error_set instead of tracebacks.

The tile stream (docs: notes/interfaces, "Tile stream") is parsed by `StreamReader`, a pure
Python class so tests can feed it bytes.
"""

import array
import os
import queue
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import threading
import time

import bpy

from .errors import OpalineError

MAGIC = b"OPTS"
T_BEGIN, T_TILE, T_PROGRESS, T_END = 1, 2, 3, 4
_HDR = struct.Struct("<4sIQ")
MAX_PAYLOAD = 1 << 34


class StreamError(Exception):
    pass


class StreamReader:
    """Reads records from a binary file object. `next()` returns (type, value) with value:
    BEGIN (w, h, channels); TILE (x, y, w, h, array('f') of w*h*4 floats, rows top to bottom);
    PROGRESS fraction; END status; or None at a clean end of file. Raises StreamError on a
    malformed stream (bad magic, short payload, unknown record, inconsistent sizes)."""

    def __init__(self, f):
        self.f = f
        self.width = self.height = None

    def _read(self, n):
        chunks = []
        got = 0
        while got < n:
            c = self.f.read(n - got)
            if not c:
                break
            chunks.append(c)
            got += len(c)
        return b"".join(chunks)

    def next(self):
        h = self._read(_HDR.size)
        if not h:
            return None
        if len(h) < _HDR.size:
            raise StreamError("truncated record header")
        magic, typ, n = _HDR.unpack(h)
        if magic != MAGIC:
            raise StreamError("bad magic %r (is this renderer writing the tile stream?)" % magic)
        if n > MAX_PAYLOAD:
            raise StreamError("record of %d bytes is too large" % n)
        p = self._read(n)
        if len(p) < n:
            raise StreamError("truncated record payload")
        if typ == T_BEGIN:
            if n < 12:
                raise StreamError("short BEGIN record")
            w, hh, ch = struct.unpack_from("<3I", p)
            if ch != 4:
                raise StreamError("BEGIN with %d channels (expected 4)" % ch)
            self.width, self.height = w, hh
            return T_BEGIN, (w, hh, ch)
        if typ == T_TILE:
            if n < 16:
                raise StreamError("short TILE record")
            x, y, w, hh = struct.unpack_from("<4I", p)
            if n != 16 + 16 * w * hh:
                raise StreamError("TILE %dx%d with %d payload bytes" % (w, hh, n))
            if self.width is not None and (x + w > self.width or y + hh > self.height):
                raise StreamError("TILE at %d,%d size %dx%d outside the %dx%d image" %
                                  (x, y, w, hh, self.width, self.height))
            a = array.array('f')
            a.frombytes(p[16:])
            if sys.byteorder != "little":
                a.byteswap()
            return T_TILE, (x, y, w, hh, a)
        if typ == T_PROGRESS:
            if n < 8:
                raise StreamError("short PROGRESS record")
            return T_PROGRESS, struct.unpack_from("<d", p)[0]
        if typ == T_END:
            if n < 4:
                raise StreamError("short END record")
            return T_END, struct.unpack_from("<I", p)[0]
        raise StreamError("unknown record type %d" % typ)


def flip_rows(a, w, h):
    """Rows top-to-bottom -> bottom-to-top (Blender's order), for a flat RGBA float array."""
    out = array.array('f')
    row = 4 * w
    for r in range(h - 1, -1, -1):
        out.extend(a[r * row:(r + 1) * row])
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

    def _fail(self, msg):
        msg = "opaline: " + msg
        self.report({'ERROR'}, msg)
        if hasattr(self, "error_set"):
            self.error_set(msg)
        print(msg, file=sys.stderr)

    def _render(self, depsgraph):
        from . import preferences, presets
        from .export import scene as scene_export
        scene = depsgraph.scene
        scale = scene.render.resolution_percentage / 100.0
        width = int(scene.render.resolution_x * scale)
        height = int(scene.render.resolution_y * scale)
        renderer = preferences.find_renderer(bpy.context, required=True)
        settings = getattr(scene.original if hasattr(scene, "original") else scene, "opaline",
                           None)
        keep = bool(settings and settings.keep_temp)
        tmp = tempfile.mkdtemp(prefix="opaline-f12-")
        try:
            self.update_stats("", "opaline: exporting")
            xml = os.path.join(tmp, "scene.xml")
            res = scene_export.export_scene(depsgraph, xml, bpy.context, renderer)
            for w in res.warnings:
                self.report({'WARNING'}, "opaline: " + w)
            out = os.path.join(tmp, "render.exr")
            cmd = [renderer, "--stream", "-o", out]
            if settings is not None and settings.threads > 0:
                cmd += ["-t", str(settings.threads)]
            cmd.append(xml)
            env = dict(os.environ)
            folders = presets.search_folders(
                [f.path for f in (preferences.get(bpy.context).preset_folders
                                  if preferences.get(bpy.context) else [])], renderer)
            env["OPALINE_PRESETS_PATH"] = ":".join(
                [p for p in env.get("OPALINE_PRESETS_PATH", "").split(":") if p] + folders)
            self._run(cmd, env, out, width, height)
            if keep:
                self.report({'INFO'}, "opaline: exported files kept in %s" % tmp)
        finally:
            if not keep:
                shutil.rmtree(tmp, ignore_errors=True)

    def _run(self, cmd, env, out_path, width, height):
        self.update_stats("", "opaline: rendering")
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env,
                                start_new_session=True)
        events = queue.Queue()
        errlines = []

        def read_stdout():
            reader = StreamReader(proc.stdout)
            try:
                while True:
                    rec = reader.next()
                    if rec is None:
                        break
                    events.put(rec)
            except StreamError as e:
                events.put(("error", str(e)))
            except (OSError, ValueError):
                pass
            events.put(("eof", None))

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
                typ, val = events.get(timeout=0.1)
            except queue.Empty:
                continue
            if typ == "eof":
                eof = True
            elif typ == "error":
                stream_error = val
            elif typ == T_BEGIN:
                if (val[0], val[1]) != (width, height):
                    stream_error = "renderer image is %dx%d, Blender expects %dx%d" % (
                        val[0], val[1], width, height)
            elif typ == T_TILE:
                x, y, w, h, a = val
                if x + w > width or y + h > height:
                    continue
                by = height - (y + h)
                result = self.begin_result(x, by, w, h)
                _set_rect(result.layers[0].passes["Combined"], flip_rows(a, w, h), w, h)
                self.end_result(result)
                tiles += 1
            elif typ == T_PROGRESS:
                self.update_progress(max(0.0, min(1.0, val)))
            elif typ == T_END:
                end_status = val
        rc = proc.wait()
        t2.join(timeout=2.0)
        if cancelled:
            return
        tail = "\n".join(errlines[-8:])
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
            finally:
                self.end_result(result)
        self.update_progress(1.0)


def compatible_panels():
    """The standard property panels whose settings opaline uses (lights, world colour, camera,
    output format, frame range, colour management, the material preview; the material slots
    and Surface are the add-on's own panels). One panel per setting: the EEVEE panels, which
    exist in every supported version; not Cycles' (their settings are Cycles' own, and they
    share one COMPAT_ENGINES set). The names are the same in Blender 3.4 (BLENDER_EEVEE), 4.2 to
    4.5 (EEVEE Next, BLENDER_EEVEE_NEXT, whose panels kept the EEVEE_ / DATA_PT_EEVEE_ names)
    and 5.x (BLENDER_EEVEE again)."""
    want = {"DATA_PT_context_light", "DATA_PT_EEVEE_light", "DATA_PT_spot",
            "MATERIAL_PT_preview",
            "WORLD_PT_context_world", "EEVEE_WORLD_PT_surface",
            "DATA_PT_context_camera", "DATA_PT_lens", "DATA_PT_camera", "DATA_PT_camera_display",
            "RENDER_PT_format", "RENDER_PT_frame_range", "RENDER_PT_color_management"}
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
