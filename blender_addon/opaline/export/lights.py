"""Blender lights -> opaline (Mitsuba-style) emitters.

The conversion functions at the top are pure Python (no bpy) so tests can check them and
docs/blender-addon.md derives each one. Units on the opaline side are radiometric: point and
spot `intensity` in W/sr, directional `irradiance` in W/m^2, area and constant `radiance` in
W/(m^2 sr). Blender's units are those of Cycles, measured against Cycles 3.4 in
tests/addon/test_cycles_match.py:

- point, power P [W]:     I = P / (4 pi)         (Cycles spreads P over the full sphere)
- spot, power P [W]:      I = P / (4 pi)         (NOT concentrated into the cone: the cone only
                          cuts light away; Cycles <= 3.x also multiplies by cos(angle to axis))
- sun, strength S:        E = S                  (S is already irradiance in W/m^2)
- area, power P, area A:  L = P / (4 A)          Blender < 4.0 (Cycles' old factor of 4)
                          L = P / (pi A)         Blender >= 4.0 (physically right; one-sided
                          Lambertian emitter: P = pi L A)
- world colour c, strength s:  L = c s           (a constant environment radiance)
"""

import math

FOUR_PI = 4.0 * math.pi


def point_intensity(power_w, color=(1.0, 1.0, 1.0)):
    """Radiant intensity [W/sr] of a Blender point light of `power_w` watts."""
    k = power_w / FOUR_PI
    return tuple(k * c for c in color[:3])


def spot_intensity(power_w, color=(1.0, 1.0, 1.0)):
    """Radiant intensity [W/sr] on the axis of a Blender spot light of `power_w` watts."""
    return point_intensity(power_w, color)


def spot_angles(spot_size_rad, spot_blend):
    """(cutoffAngle, beamWidth) in degrees for a Blender spot of full cone angle `spot_size_rad`
    and `spot_blend` in [0, 1].

    Cycles is fully bright where cos(theta) >= cos(half) + (1 - cos(half)) * blend and falls off
    (smoothstep in cos) to zero at the cone's half angle; beamWidth is the angle of that first
    boundary, cutoffAngle the half angle."""
    half = 0.5 * spot_size_rad
    ch = math.cos(half)
    blend = min(max(spot_blend, 0.0), 1.0)
    cb = ch + (1.0 - ch) * blend
    beam = math.acos(min(1.0, max(-1.0, cb)))
    return math.degrees(half), math.degrees(beam)


def sun_irradiance(strength, color=(1.0, 1.0, 1.0)):
    """Irradiance [W/m^2] on a surface facing a Blender sun of `strength`."""
    return tuple(strength * c for c in color[:3])


def area_radiance(power_w, area_m2, color=(1.0, 1.0, 1.0), divisor=4.0):
    """Radiance [W/(m^2 sr)] of a one-sided Blender area light of `power_w` watts and world-space
    area `area_m2` (m^2): P / (divisor A), divisor being the Blender version's
    (compat.area_light_divisor)."""
    if area_m2 <= 0.0:
        raise ValueError("area light with zero area")
    denom = divisor * area_m2
    k = power_w / denom
    return tuple(k * c for c in color[:3])


def area_shape_area(shape, size_x, size_y):
    """Area in m^2 of a Blender area light shape with world-space sizes (size_y is ignored for
    SQUARE and DISK, whose second size equals the first)."""
    if shape == 'SQUARE':
        return size_x * size_x
    if shape == 'RECTANGLE':
        return size_x * size_y
    if shape == 'DISK':
        return math.pi * 0.25 * size_x * size_x
    if shape == 'ELLIPSE':
        return math.pi * 0.25 * size_x * size_y
    raise ValueError("unknown area light shape %r" % (shape,))


def world_radiance(color, strength):
    """Constant environment radiance [W/(m^2 sr)] of a world background colour and strength."""
    return tuple(strength * c for c in color[:3])


# ---------------------------------------------------------------------------------------------
# Blender-facing part.

def _vec(v):
    return (float(v[0]), float(v[1]), float(v[2]))


def _axis_world(matrix, col):
    """The world-space direction of local axis `col` (0, 1, 2) of a 4x4 matrix."""
    return (matrix[0][col], matrix[1][col], matrix[2][col])


def _norm(v):
    n = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    if n == 0.0:
        return (0.0, 0.0, 0.0), 0.0
    return (v[0] / n, v[1] / n, v[2] / n), n


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def export_light(light, matrix, area_divisor, warn, visible_camera=True):
    """The <emitter> or <shape> element for a Blender light datablock `light` placed by the 4x4
    world matrix `matrix` (a sequence of rows). Returns None (after warn()) for lights opaline
    cannot represent. `area_divisor`: the Blender version's (compat.area_light_divisor).
    `warn(msg)` collects messages for the user. `visible_camera` is the light
    object's camera visibility (Object.visible_camera, off by default for lights in Blender 3.x):
    when off, an area light's emitting surface is hidden from camera rays
    (visibleToCamera=false) while it still lights the scene and shows in reflections, as in
    Cycles. Point, spot and sun lights are never seen by the camera anyway."""
    from .xml_writer import Element, transform_lookat, transform_matrix

    color = _vec(light.color)
    loc = (matrix[0][3], matrix[1][3], matrix[2][3])
    down, _ = _norm(tuple(-c for c in _axis_world(matrix, 2)))  # Blender lights point along -Z
    up, _ = _norm(_axis_world(matrix, 1))
    name = light.name
    kind = light.type
    if kind == 'POINT':
        e = Element("emitter", {"type": "point"}, comment="light %s: point %g W" %
                    (name, light.energy))
        e.point("position", loc)
        e.rgb("intensity", point_intensity(light.energy, color))
        return e
    if kind == 'SPOT':
        cutoff, beam = spot_angles(light.spot_size, light.spot_blend)
        if cutoff >= 90.0:
            warn("spot light %s: cone of %.1f degrees clamped to 179.8 (opaline spots emit "
                 "into one hemisphere)" % (name, 2 * cutoff))
            cutoff = min(cutoff, 89.9)
            beam = min(beam, cutoff)
        e = Element("emitter", {"type": "spot"}, comment="light %s: spot %g W" %
                    (name, light.energy))
        target = (loc[0] + down[0], loc[1] + down[1], loc[2] + down[2])
        e.add(transform_lookat("toWorld", loc, target, up))
        e.rgb("intensity", spot_intensity(light.energy, color))
        e.float("cutoffAngle", cutoff)
        e.float("beamWidth", max(beam, 0.01))  # blend 1: a falloff from the axis itself
        return e
    if kind == 'SUN':
        e = Element("emitter", {"type": "directional"}, comment="light %s: sun %g W/m^2" %
                    (name, light.energy))
        e.vector("direction", down)
        e.rgb("irradiance", sun_irradiance(light.energy, color))
        if getattr(light, "angle", 0.0) > math.radians(1.0):
            warn("sun %s: its Angle (%.2f degrees, the soft shadows of a sun of that size) is "
                 "not rendered: opaline has no sun of angular size, so it renders a directional "
                 "light of sharp shadows (below 1 degree: no warning)" %
                 (name, math.degrees(light.angle)))
        return e
    if kind == 'AREA':
        shape = light.shape
        sx = light.size
        sy = light.size_y if shape in ('RECTANGLE', 'ELLIPSE') else light.size
        # World area: the shape's area times the area scale of the light's XY plane (object
        # scale and shear included).
        par = _norm(_cross(_axis_world(matrix, 0), _axis_world(matrix, 1)))[1]
        area = area_shape_area(shape, sx, sy) * par
        if area <= 0.0:
            warn("area light %s has zero area; skipped" % name)
            return None
        if getattr(light, "spread", math.pi) < math.pi - 1e-4:
            warn("area light %s: spread ignored (opaline area lights emit over the hemisphere)"
                 % name)
        shape_type = "rectangle" if shape in ('SQUARE', 'RECTANGLE') else "disk"
        s = Element("shape", {"type": shape_type}, comment="light %s: area %s %g W, %.6g m^2"
                    % (name, shape.lower(), light.energy, area))
        # Local frame: Blender's light plane is XY with emission along -Z; opaline's rectangle
        # [-1,1]^2 and unit disk emit along +Z. M * diag(sx/2, sy/2) * rot_x(180 degrees).
        hx, hy = 0.5 * sx, 0.5 * sy
        rows = [[matrix[r][0] * hx, -matrix[r][1] * hy, -matrix[r][2], matrix[r][3]]
                for r in range(3)] + [[0.0, 0.0, 0.0, 1.0]]
        s.add(transform_matrix("toWorld", rows))
        em = s.add(Element("emitter", {"type": "area"}))
        em.rgb("radiance", area_radiance(light.energy, area, color, area_divisor))
        if not visible_camera:
            em.boolean("visibleToCamera", False)
        # A Cycles light object is invisible from behind, reflects nothing and casts no shadow:
        # a fully transparent mask (the emitter stays one-sided, seen only from its front).
        bs = s.add(Element("bsdf", {"type": "mask"}))
        bs.float("opacity", 0.0)
        return s
    warn("light %s of type %s is not supported; skipped" % (name, kind))
    return None
