"""The proof that the light and world conversions are right: a small Lambertian scene (a
diffuse floor seen from above) rendered by Cycles and by opaline from its export agree in mean
pixel value within 5 % for each light type (point, spot, sun, area square / rectangle / disk)
and for the world colour, and with an area light facing the camera, its surface seen or hidden
by the light object's camera visibility (visibleToCamera).

Each case also evaluates the exported XML analytically (direct light on a Lambertian plane,
Mitsuba's emitter definitions, area lights integrated numerically) and compares that with
Cycles, so the conversions are checked even where opaline-render is not built; the opaline
comparison is skipped only then. 48x48 pixels, 16 samples, CPU: a few seconds per case."""

import math
import os
import sys
import unittest
import xml.etree.ElementTree as ET

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_support as S  # noqa: E402


RES = 48
ALBEDO = 0.8
HEIGHT = 4.0
TOL = 0.05


def _f(s):
    return [float(x) for x in s.replace(",", " ").split()]


def _sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _norm(a):
    n = math.sqrt(_dot(a, a))
    return [c / n for c in a]


def _prop(el, tag, name):
    for c in el:
        if c.tag == tag and c.get("name") == name:
            return c
    return None


def _rgb(el, name):
    return _f(_prop(el, "rgb", name).get("value"))


def analytic_mean(xml_path):
    """Mean (over pixels and RGB) of the image of the exported scene, computed analytically:
    a Lambertian floor z = 0 of albedo ALBEDO lit directly by the scene's emitters."""
    root = ET.parse(xml_path).getroot()
    sensor = root.find("sensor")
    fov = float(_prop(sensor, "float", "fov").get("value"))
    la = sensor.find("transform").find("lookat")
    org, tgt, up = _f(la.get("origin")), _f(la.get("target")), _f(la.get("up"))
    fwd = _norm(_sub(tgt, org))
    right = _norm(_cross(fwd, up))
    upv = _cross(right, fwd)
    film = sensor.find("film")
    w = int(_prop(film, "integer", "width").get("value"))
    h = int(_prop(film, "integer", "height").get("value"))
    t = math.tan(math.radians(fov) / 2)  # fovAxis x, square image
    lights = []
    for e in root.iter("emitter"):
        lights.append(e)
    area_shapes = [s for s in root.iter("shape") if s.find("emitter") is not None]
    # Area light sample points: (position, normal, dA, radiance).
    area_pts = []
    n = 16
    for s in area_shapes:
        m = _f(s.find("transform").find("matrix").get("value"))
        M = [m[0:4], m[4:8], m[8:12]]
        c0 = [M[i][0] for i in range(3)]
        c1 = [M[i][1] for i in range(3)]
        c2 = [M[i][2] for i in range(3)]
        o = [M[i][3] for i in range(3)]
        nrm = _norm(c2)
        jac = math.sqrt(_dot(_cross(c0, c1), _cross(c0, c1)))
        rad = _rgb(s.find("emitter"), "radiance")
        for i in range(n):
            for j in range(n):
                if s.get("type") == "rectangle":
                    u, v = -1 + (2 * i + 1) / n, -1 + (2 * j + 1) / n
                    dA = jac * 4.0 / (n * n)
                else:
                    r = (i + 0.5) / n
                    ph = 2 * math.pi * (j + 0.5) / n
                    u, v = r * math.cos(ph), r * math.sin(ph)
                    dA = jac * r * (1.0 / n) * (2 * math.pi / n)
                p = [o[k] + c0[k] * u + c1[k] * v for k in range(3)]
                area_pts.append((p, nrm, dA, rad))
    total = 0.0
    for j in range(h):
        for i in range(w):
            x = (2 * (i + 0.5) / w - 1) * t
            y = (1 - 2 * (j + 0.5) / h) * t * h / w
            d = [fwd[k] + right[k] * x + upv[k] * y for k in range(3)]
            if d[2] >= 0:
                continue
            s = -org[2] / d[2]
            p = [org[k] + s * d[k] for k in range(3)]
            E = [0.0, 0.0, 0.0]
            Lc = [0.0, 0.0, 0.0]
            for e in lights:
                typ = e.get("type")
                if typ in ("point", "spot"):
                    if typ == "point":
                        lp = _f(" ".join(_prop(e, "point", "position").get(k) for k in "xyz"))
                    else:
                        l2 = e.find("transform").find("lookat")
                        lp = _f(l2.get("origin"))
                    v = _sub(lp, p)
                    d2 = _dot(v, v)
                    cos = v[2] / math.sqrt(d2)
                    if cos <= 0:
                        continue
                    fall = 1.0
                    if typ == "spot":
                        axis = _norm(_sub(_f(l2.get("target")), lp))
                        ang = math.degrees(math.acos(max(-1, min(1, -_dot(axis, v) /
                                                                 math.sqrt(d2)))))
                        cut = float(_prop(e, "float", "cutoffAngle").get("value"))
                        beam = float(_prop(e, "float", "beamWidth").get("value"))
                        fall = 0.0 if ang >= cut else (1.0 if ang <= beam else
                                                       (cut - ang) / (cut - beam))
                    inten = _rgb(e, "intensity")
                    for k in range(3):
                        E[k] += inten[k] * fall * cos / d2
                elif typ == "directional":
                    dd = _norm(_f(" ".join(_prop(e, "vector", "direction").get(k)
                                           for k in "xyz")))
                    irr = _rgb(e, "irradiance")
                    for k in range(3):
                        E[k] += irr[k] * max(0.0, -dd[2])
                elif typ == "constant":
                    Lc = _rgb(e, "radiance")
            for (q, nrm, dA, rad) in area_pts:
                v = _sub(p, q)
                d2 = _dot(v, v)
                dl = math.sqrt(d2)
                cl = _dot(nrm, v) / dl
                cp = -v[2] / dl
                if cl <= 0 or cp <= 0:
                    continue
                g = cl * cp * dA / d2
                for k in range(3):
                    E[k] += rad[k] * g
            for k in range(3):
                total += ALBEDO / math.pi * E[k] + ALBEDO * Lc[k]
    return total / (3 * w * h)


class TestCyclesMatch(unittest.TestCase):
    def build(self, name):
        self.sc = S.empty_scene((RES, RES))
        self.sc.cycles.max_bounces = 0
        self.sc.opaline.max_bounces = 0
        S.add_floor(50.0, (ALBEDO,) * 3)
        S.add_camera((0.0, 0.0, HEIGHT))
        self.dir = S.tmpdir("cycles-" + name)
        return self.sc

    def compare(self, name, expect_tol=TOL):
        xml = os.path.join(self.dir, "scene.xml")
        S.export(xml, samples=16)
        cyc = S.mean_rgb_rgba(S.load_image_rgba(S.render_cycles(
            os.path.join(self.dir, "cycles.exr"), samples=16))[2])
        ana = analytic_mean(xml)
        print("%-10s Cycles %.5f  export (analytic) %.5f  ratio %.4f" % (name, cyc, ana,
                                                                        ana / cyc))
        self.assertGreater(cyc, 1e-3, "Cycles image is black")
        self.assertLess(S.approx_rel(ana, cyc), expect_tol,
                        "%s: export evaluated analytically %.5f vs Cycles %.5f" %
                        (name, ana, cyc))
        out = S.render_cli(self, xml, os.path.join(self.dir, "opaline.pfm"), samples=16)
        ren = S.mean_rgb_rows(S.read_pfm(out)[2])
        print("%-10s opaline %.5f  ratio to Cycles %.4f" % (name, ren, ren / cyc))
        self.assertLess(S.approx_rel(ren, cyc), TOL, "%s: opaline %.5f vs Cycles %.5f" %
                        (name, ren, cyc))

    def test_point(self):
        self.build("point")
        S.add_light('POINT', (0.3, -0.2, 2.0), energy=200.0, shadow_soft_size=0.0,
                    color=(1.0, 0.8, 0.6))
        self.compare("point")

    def test_spot(self):
        self.build("spot")
        S.add_light('SPOT', (0.2, 0.0, 3.0), (math.radians(8), 0, 0), energy=500.0,
                    shadow_soft_size=0.0, spot_size=math.radians(30), spot_blend=0.2)
        self.compare("spot")

    def test_sun(self):
        self.build("sun")
        S.add_light('SUN', (0, 0, 5), (math.radians(30), math.radians(10), 0), energy=2.0,
                    angle=0.0)
        self.compare("sun")

    def test_area_square(self):
        self.build("square")
        S.add_light('AREA', (0.2, 0.1, 1.5), (math.radians(15), 0, 0), energy=100.0,
                    shape='SQUARE', size=0.5)
        self.compare("square")

    def test_area_rectangle(self):
        self.build("rectangle")
        ob = S.add_light('AREA', (-0.3, 0.2, 1.2), (0, math.radians(-20), 0.4), energy=150.0,
                         shape='RECTANGLE', size=0.8, size_y=0.3)
        ob.scale = (1.5, 1.0, 1.0)
        self.compare("rectangle")

    def test_area_disk(self):
        self.build("disk")
        S.add_light('AREA', (0.0, 0.0, 1.0), energy=60.0, shape='DISK', size=0.6)
        self.compare("disk")

    def seen_light(self, name, visible):
        """A disk light facing the camera (its front fills ~13 % of the image) over a floor lit
        by a sun; the light object's camera visibility on or off (Blender 3.4's default)."""
        self.build(name)
        S.add_light('SUN', (0, 0, 5), (math.radians(20), 0, 0), energy=2.0, angle=0.0)
        ob = S.add_light('AREA', (0.0, 0.0, 2.0), (math.pi, 0, 0), energy=40.0, shape='DISK',
                         size=1.0)
        ob.visible_camera = visible
        xml = os.path.join(self.dir, "scene.xml")
        S.export(xml, samples=16)
        text = open(xml).read()
        self.assertEqual('name="visibleToCamera" value="false"' in text, not visible)
        S.need_renderer(self)
        cyc = S.mean_rgb_rgba(S.load_image_rgba(S.render_cycles(
            os.path.join(self.dir, "cycles.exr"), samples=16))[2])
        out = S.render_cli(self, xml, os.path.join(self.dir, "opaline.pfm"), samples=16)
        ren = S.mean_rgb_rows(S.read_pfm(out)[2])
        print("%-10s Cycles %.5f  opaline %.5f  ratio %.4f" % (name, cyc, ren, ren / cyc))
        self.assertLess(S.approx_rel(ren, cyc), TOL, "%s: opaline %.5f vs Cycles %.5f" %
                        (name, ren, cyc))
        return ren

    def test_area_seen_by_camera(self):
        shown = self.seen_light("seen", True)
        hidden = self.seen_light("unseen", False)
        # the disk's front (radiance 40 / (4 pi 0.25) ~ 12.7) shows only when visible
        self.assertGreater(shown, hidden * 1.5)

    def test_world(self):
        sc = self.build("world")
        bg = sc.world.node_tree.nodes["Background"]
        bg.inputs[0].default_value = (0.3, 0.5, 0.7, 1.0)
        bg.inputs[1].default_value = 1.5
        self.compare("world")


if __name__ == "__main__":
    S.run_tests(TestCyclesMatch)
