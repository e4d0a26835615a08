"""Blender side of scripts/addon-screenshots.sh (run inside Blender 3.4+, never on its own).

  blender -b --factory-startup --python addon-screenshots.py -- setup SCENE.blend
      builds the scene: a UV sphere with the Jade preset, a cube without UVs with the layered
      wax preset (an export warning), a floor, a light and a camera; opaline as the engine
      with a low Irradiance Point Cap (a renderer warning).
  blender --factory-startup SCENE.blend --python addon-screenshots.py -- shoot OUTDIR
      under a real (virtual) display: saves OUTDIR/material.png (the Material tab beside the
      viewport's Material Preview), chooser.png (the preset chooser open), render-prepass.png
      and render-tiles.png (the F12 render window during the subsurface pre-pass and while
      tiles arrive), info.png (the Info editor after a successful F12 with warnings and a
      failing one), writes OUTDIR/info.txt (every report the Info editor holds) and
      OUTDIR/result.txt ("ok", or the problems found, one a line), then quits.

The add-on is taken from OPALINE_SOURCE_DIR/blender_addon; the renderer and the presets from
OPALINE_BIN_DIR and OPALINE_PRESETS_DIR (set by the shell script).
"""

import math
import os
import sys
import time

import bpy

SRC = os.environ["OPALINE_SOURCE_DIR"]
sys.path.insert(0, os.path.join(SRC, "blender_addon"))

JADE = "TUCKER_T16_P4_Jade"
WAX = "SVD_S10_LayeredWax"
MISSING = "NoSuchPreset_ForTheErrorReport"
POINT_CAP = 50000   # the sphere needs ~87000 for one per material pixel: a warning


def enable_addon():
    import addon_utils
    if bpy.context.preferences.addons.get("opaline") is None:
        addon_utils.enable("opaline", default_set=True, handle_error=None)
    assert hasattr(bpy.types.Material, "opaline"), "the add-on failed to register"


def setup(path):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    enable_addon()
    sc = bpy.context.scene
    sc.render.engine = 'OPALINE'
    sc.render.resolution_x, sc.render.resolution_y = 480, 320
    sc.render.resolution_percentage = 100
    sc.opaline.samples = 16
    sc.opaline.irr_samples = 64   # a pre-pass long enough to be seen
    sc.opaline.max_sss_points = POINT_CAP
    sc.world = bpy.data.worlds.new("World")
    sc.world.color = (0.05, 0.05, 0.06)

    def material(name, preset):
        m = bpy.data.materials.new(name)
        m.use_nodes = True
        m.opaline.enabled = True
        m.opaline.preset = preset
        m.opaline.scale = 1.0
        return m

    # Objects of a few cm, as the material samples are (5 to 25 cm).
    bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=0.1,
                                         location=(0.0, 0.0, 0.1))
    sphere = bpy.context.object
    sphere.name = "Jade sphere"
    bpy.ops.object.shade_smooth()
    sphere.data.materials.append(material("Jade", JADE))
    bpy.ops.mesh.primitive_cube_add(size=0.1, location=(0.2, 0.08, 0.05))
    cube = bpy.context.object
    cube.name = "Wax cube"
    while cube.data.uv_layers:
        cube.data.uv_layers.remove(cube.data.uv_layers[0])
    cube.data.materials.append(material("Wax", WAX))
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    floor = bpy.context.object
    floor.name = "Floor"
    fm = bpy.data.materials.new("Floor")
    fm.diffuse_color = (0.5, 0.5, 0.5, 1.0)
    floor.data.materials.append(fm)
    bpy.ops.object.light_add(type='AREA', location=(0.2, -0.2, 0.4))
    light = bpy.context.object
    light.data.energy = 2.0
    light.data.size = 0.2
    bpy.ops.object.camera_add(location=(0.52, -0.52, 0.34))
    cam = bpy.context.object
    cam.data.clip_start = 0.01
    track = cam.constraints.new('TRACK_TO')
    track.target = sphere
    track.track_axis = 'TRACK_NEGATIVE_Z'
    track.up_axis = 'UP_Y'
    sc.camera = cam
    for ob in bpy.context.view_layer.objects:
        ob.select_set(False)
    sphere.select_set(True)
    bpy.context.view_layer.objects.active = sphere
    bpy.ops.wm.save_as_mainfile(filepath=path)


# ------------------------------------------------------------------------- under the display

class Shooter:
    """A timer-driven sequence of steps (a generator: each `yield` gives the seconds to wait);
    its problems end up in result.txt."""

    def __init__(self, out):
        self.out = out
        self.problems = []
        self.stats = []        # render status texts seen
        self.done = False
        os.makedirs(out, exist_ok=True)
        self.steps = self.run()

    def tick(self):
        try:
            return next(self.steps)
        except StopIteration:
            pass
        except Exception as e:  # noqa: BLE001: every failure goes into result.txt
            import traceback
            traceback.print_exc()
            self.problems.append("driver failed: %s: %s" % (type(e).__name__, e))
        self.finish()
        return None

    def finish(self):
        with open(os.path.join(self.out, "result.txt"), "w") as f:
            f.write("\n".join(self.problems) + "\n" if self.problems else "ok\n")
        bpy.ops.wm.quit_blender()

    # -- helpers

    def window(self):
        return bpy.context.window_manager.windows[0]

    def area(self, kind, window=None):
        w = window or self.window()
        areas = [a for a in w.screen.areas if a.type == kind]
        return max(areas, key=lambda a: a.width * a.height) if areas else None

    def shot(self, name, window=None, box=None, width=None):
        """Saves the window (or `box` = (x, y, w, h) of it, y from the bottom) as NAME.png,
        scaled to `width` pixels wide."""
        w = window or self.window()
        path = os.path.join(self.out, name + ".png")
        with bpy.context.temp_override(window=w, screen=w.screen, area=w.screen.areas[0]):
            bpy.ops.screen.screenshot(filepath=path)
        if box is not None or width is not None:
            crop_scale(path, box, width)
        print("addon-screenshots: saved %s" % path)

    def info_lines(self, info):
        """The reports the Info editor area `info` shows, one a line (copied through the
        clipboard, as a user would)."""
        w = self.window()
        reg = [r for r in info.regions if r.type == 'WINDOW'][0]
        with bpy.context.temp_override(window=w, screen=w.screen, area=info, region=reg):
            bpy.ops.info.select_all(action='SELECT')
            bpy.ops.info.report_copy()
            bpy.ops.info.select_all(action='DESELECT')
        text = bpy.context.window_manager.clipboard
        return [ln.strip() for ln in text.splitlines() if ln.strip()]

    def wait_for(self, cond, timeout, step=0.2):
        t0 = time.monotonic()
        while not cond():
            if time.monotonic() - t0 > timeout:
                return False
            yield step
        return True

    # -- the sequence

    def run(self):
        enable_addon()
        import opaline.engine as E
        bpy.context.preferences.view.render_display_type = 'SCREEN'
        w = self.window()
        yield 1.0
        # The viewport split: Material Preview on the left, the Material tab on the right.
        v3d = self.area('VIEW_3D')
        with bpy.context.temp_override(window=w, screen=w.screen, area=v3d):
            bpy.ops.screen.area_split(direction='VERTICAL', factor=0.5)
        yield 0.5
        left, right = sorted([a for a in w.screen.areas if a.type == 'VIEW_3D'],
                             key=lambda a: a.x)[:2]
        right.type = 'PROPERTIES'
        yield 0.5   # its tabs exist once it has been drawn
        right.spaces[0].context = 'MATERIAL'
        sp = left.spaces[0]
        sp.shading.type = 'MATERIAL'
        sp.overlay.show_overlays = False
        r3d = sp.region_3d
        r3d.view_perspective = 'PERSP'
        r3d.view_location = (0.09, 0.03, 0.08)
        r3d.view_distance = 0.55
        from mathutils import Euler
        r3d.view_rotation = Euler((math.radians(68), 0.0, math.radians(48))).to_quaternion()
        for a in w.screen.areas:
            if a.type == 'PROPERTIES' and a != right:
                a.spaces[0].context = 'RENDER'
        yield 15.0   # Material Preview compiles EEVEE's shaders (software GL: seconds)
        top = max(a.y + a.height for a in (left, right))
        bottom = min(a.y for a in (left, right))
        self.shot("material", box=(left.x, bottom, right.x + right.width - left.x, top - bottom),
                  width=900)

        # The chooser, opened where the preset button is.
        reg = [r for r in right.regions if r.type == 'WINDOW'][0]
        mat = bpy.data.materials["Jade"]
        w.cursor_warp(right.x + 40, right.y + right.height - 40)
        with bpy.context.temp_override(window=w, screen=w.screen, area=right, region=reg,
                                       material=mat):
            bpy.ops.wm.call_panel(name="OPALINE_PT_preset_chooser", keep_open=True)
        yield 0.5
        w.cursor_warp(right.x + 60, right.y + right.height - 70)  # on a heading: no tooltip
        yield 1.5
        self.shot("chooser", width=900)
        w.cursor_warp(5, 5)   # off the popover: it closes
        yield 1.0

        # F12: the render window during the pre-pass and while tiles arrive.
        with bpy.context.temp_override(window=w, screen=w.screen, area=v3d):
            bpy.ops.render.render('INVOKE_DEFAULT')
        yield 0.5
        got = {"prepass": False, "tiles": False}
        t0 = time.monotonic()
        zoomed = False
        while bpy.app.is_job_running('RENDER') and time.monotonic() - t0 < 300:
            last = E.last_status[0]
            if not self.stats or self.stats[-1] != last:
                self.stats.append(last)
            image = self.area('IMAGE_EDITOR')
            if image is not None and not zoomed:
                reg = [r for r in image.regions if r.type == 'WINDOW'][0]
                with bpy.context.temp_override(window=w, screen=w.screen, area=image,
                                               region=reg):
                    bpy.ops.image.view_zoom_ratio(ratio=2.0)
                zoomed = True
            # The pre-pass: at once, and again once a stage is a third done (when the
            # machine is slow enough to see it).
            pct = last.rsplit(" ", 2)[-2] if last.endswith(" %") else "0"
            if "Subsurface pre-pass: " in last and (
                    not got["prepass"] or (got["prepass"] == 1 and int(pct) >= 30)):
                yield 0.2
                self.shot("render-prepass", width=900)
                got["prepass"] = 2 if int(pct) >= 30 else 1
            elif not got["tiles"] and "Path tracing" in last and " 0/" not in last and \
                    "tiles" in last and int(last.split("Path tracing ")[1].split()[0]) >= 60:
                yield 0.2
                self.shot("render-tiles", width=900)
                got["tiles"] = True
            yield 0.05
        for k, v in got.items():
            if not v:
                self.problems.append("no screenshot of the render's %s (status texts seen: %s)"
                                     % (k, "; ".join(self.stats[-6:])))
        if bpy.app.is_job_running('RENDER'):
            self.problems.append("the F12 render did not end within 300 s")
        warned = [m for k, m in E.last_reports if k == 'WARNING']
        yield 1.5

        # A failing F12: a preset that does not exist.
        bpy.data.materials["Wax"].opaline.preset = MISSING
        image = self.area('IMAGE_EDITOR')
        with bpy.context.temp_override(window=w, screen=w.screen, area=image):
            bpy.ops.render.render('INVOKE_DEFAULT')
        yield 0.5
        yield from self.wait_for(lambda: not bpy.app.is_job_running('RENDER'), 60)
        yield 1.0
        image = self.area('IMAGE_EDITOR')
        with bpy.context.temp_override(window=w, screen=w.screen, area=image):
            bpy.ops.render.view_cancel()   # back to the layout (Esc)
        yield 1.0
        failed = [m for k, m in E.last_reports if k == 'ERROR']

        # The Info editor: every report once. F12's operator moves its reports there when
        # it sees the render has ended, on its next event: the mouse moves meanwhile.
        info = self.area('VIEW_3D')
        info.type = 'INFO'
        yield 0.5
        expected = [m.splitlines()[0] for m in warned + failed]
        t0 = time.monotonic()
        while True:
            lines = self.info_lines(info)
            if all(any(e in ln for ln in lines) for e in expected) or \
                    time.monotonic() - t0 > 20:
                break
            w.cursor_warp(200 + int(20 * (time.monotonic() - t0)) % 400, 300)
            yield 0.5
        print("addon-screenshots: the Info editor had every report after %.1f s"
              % (time.monotonic() - t0))
        yield 2.0   # and nothing more arrives later
        lines = self.info_lines(info)
        with open(os.path.join(self.out, "info.txt"), "w") as f:
            f.write("\n".join(lines) + "\n")
        if not warned:
            self.problems.append("the successful F12 gave no warning (expected the no-UV and "
                                 "the irradiance point cap warnings)")
        if not any("capped at" in m for m in warned):
            self.problems.append("no 'capped at' warning from the renderer: %s" % warned)
        if len(failed) != 1:
            self.problems.append("the failing F12 gave %d errors: %s" % (len(failed), failed))
        for first in expected:
            n = sum(1 for ln in lines if first in ln)
            print("addon-screenshots: the Info editor holds %d x %s" % (n, first))
            if n != 1:
                self.problems.append("the Info editor holds %d copies of '%s'" % (n, first))
        yield 1.0
        self.shot("info", box=(info.x, info.y, info.width, info.height))


def crop_scale(path, box, width):
    """Crops the PNG at path to box (x, y, w, h; y from the bottom), scales it to `width`
    pixels wide, and saves it in place (8-bit RGB, best compression)."""
    im = bpy.data.images.load(path)
    W, H = im.size
    if box is not None:
        x, y, bw, bh = box
        x, y = max(0, x), max(0, y)
        bw, bh = min(bw, W - x), min(bh, H - y)
        px = list(im.pixels)
        out = []
        for row in range(y, y + bh):
            out.extend(px[4 * (row * W + x):4 * (row * W + x + bw)])
        bpy.data.images.remove(im)
        im = bpy.data.images.new("crop", bw, bh)
        im.pixels = out
        W, H = bw, bh
    if width is not None and width < W:
        im.scale(width, max(1, round(H * width / W)))
    sc = bpy.context.scene
    st = sc.render.image_settings
    st.file_format, st.color_mode, st.color_depth, st.compression = 'PNG', 'RGB', '8', 100
    vs = sc.view_settings
    vs.view_transform, vs.look, vs.exposure, vs.gamma = 'Standard', 'None', 0.0, 1.0
    im.save_render(path, scene=sc)
    bpy.data.images.remove(im)


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if len(argv) != 2 or argv[0] not in ("setup", "shoot"):
        sys.exit("usage: blender ... --python addon-screenshots.py -- setup SCENE.blend | "
                 "shoot OUTDIR")
    if argv[0] == "setup":
        setup(argv[1])
        return
    enable_addon()
    shooter = Shooter(argv[1])
    bpy.app.timers.register(shooter.tick, first_interval=1.0)


main()
