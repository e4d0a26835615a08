"""Blender's world -> opaline's environment emitter.

`export_world(world, textures, transparent, warn)` returns the <emitter> of the world, or None
when it gives no light:
- a Background node of constant colour -> `constant` (radiance = Color x Strength);
- a Background node whose Color is an Environment Texture (equirectangular) -> `envmap`, its
  image written by the export's TextureWriter (textures.py: EXR copied byte for byte, other
  images saved from Blender's pixels), `scale` = Strength, and `toWorld` the rotation that puts
  the map where Blender puts it (envmap_to_world), a Mapping node on the texture's vector
  included (its rotation; location and non-uniform scale do not map onto directions: warned);
- anything else (a Sky Texture included: opaline's `sky` is Mitsuba's Hosek-Wilkie model, whose
  units and sun are not Blender's) -> warned, naming the node; the Background's own colour.
With `transparent` (Film > Transparent) the emitter carries visibleToCamera = false: the
background seen directly is black with alpha 0, as Cycles renders it, while the world still
lights the scene.

Blender's equirectangular map (Cycles' direction_to_equirectangular): u = 0.5 - atan2(y, x) /
2 pi (the image's centre faces +X, u = 0.25 faces +Y), v = 0.5 + asin(z) / pi from the bottom
row (the top row is +Z). opaline's envmap (Mitsuba's): u = atan2(x, -z) / 2 pi, v = acos(y) / pi
from the top row (+Y up) in the map's frame. The map frame of a world direction d is therefore
(d.y, d.z, d.x), i.e. toWorld = BLENDER_AXES; a Mapping node looks the map up at R d (Point and
Vector types) or R^-1 d (Texture type), R its Euler rotation, so toWorld = R^T BLENDER_AXES or
R BLENDER_AXES. (Type Normal rotates as Vector: it only differs for a non-uniform scale.)
"""

import math

from . import lights as lights_mod
from . import textures as textures_mod
from .xml_writer import Element, transform_matrix
from .. import compat

# rows of the rotation taking opaline's envmap frame to Blender's world (see the docstring)
BLENDER_AXES = ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0))


def _matmul(a, b):
    return tuple(tuple(sum(a[r][k] * b[k][c] for k in range(3)) for c in range(3))
                 for r in range(3))


def _transpose(a):
    return tuple(tuple(a[c][r] for c in range(3)) for r in range(3))


def euler_xyz(rx, ry, rz):
    """Blender's rotation matrix of XYZ Euler angles (radians): Rz Ry Rx."""
    cx, sx, cy, sy, cz, sz = (math.cos(rx), math.sin(rx), math.cos(ry), math.sin(ry),
                              math.cos(rz), math.sin(rz))
    rx_m = ((1, 0, 0), (0, cx, -sx), (0, sx, cx))
    ry_m = ((cy, 0, sy), (0, 1, 0), (-sy, 0, cy))
    rz_m = ((cz, -sz, 0), (sz, cz, 0), (0, 0, 1))
    return _matmul(rz_m, _matmul(ry_m, rx_m))


def envmap_to_world(rotation=None, inverse=False):
    """The envmap's toWorld (3x3 rows) for Blender's equirectangular lookup at R d (R the XYZ
    Euler `rotation` in radians, None for none), or at R^-1 d when `inverse`."""
    if rotation is None:
        return BLENDER_AXES
    r = euler_xyz(*rotation)
    return _matmul(r if inverse else _transpose(r), BLENDER_AXES)


def _to_world(rows):
    """<transform name="toWorld"> of a 3x3 rotation (rows); tiny round-off written as 0."""
    m = [[0.0 if abs(rows[r][c]) < 1e-12 else rows[r][c] for c in range(3)] + [0.0]
         for r in range(3)]
    return transform_matrix("toWorld", m + [[0.0, 0.0, 0.0, 1.0]])


def _mapping_rotation(node, warn):
    """(rotation, inverse) of a Mapping node in front of the Environment Texture, or None
    (warned) when it cannot be told as a rotation of directions."""
    vt = getattr(node, "vector_type", "POINT")
    rot, loc, scl = (node.inputs.get("Rotation"), node.inputs.get("Location"),
                     node.inputs.get("Scale"))
    if any(s is not None and s.is_linked for s in (rot, loc, scl)):
        warn("world: the Mapping node '%s' has linked inputs; only a constant rotation is "
             "exported, the map is not rotated" % node.name)
        return None
    s = [float(x) for x in scl.default_value] if scl is not None else [1.0, 1.0, 1.0]
    if not (s[0] > 0.0 and abs(s[1] - s[0]) <= 1e-6 * s[0] and abs(s[2] - s[0]) <= 1e-6 * s[0]):
        warn("world: the Mapping node '%s' scales directions by (%g, %g, %g), which bends the "
             "map; only its rotation is exported" % (node.name, s[0], s[1], s[2]))
    if vt in ('POINT', 'TEXTURE') and loc is not None and max(abs(x) for x in
                                                                  loc.default_value) > 1e-9:
        warn("world: the Mapping node '%s' moves directions by its Location, which bends the "
             "map; only its rotation is exported" % node.name)
    r = rot.default_value if rot is not None else (0.0, 0.0, 0.0)
    return (float(r[0]), float(r[1]), float(r[2])), vt == 'TEXTURE'


def _direction_source(socket, warn, unlinked_ok=True):
    """Whether `socket` (the Environment Texture's Vector input, or its Mapping node's) gives
    the view direction: a Texture Coordinate's Generated or Object output, or nothing when
    unlinked_ok (the texture's own default; a Mapping node's is the point 0, warned)."""
    node, out = textures_mod.linked_source(socket)
    if node is None:
        if not unlinked_ok:
            warn("world: the Mapping node before the environment texture has no Vector input "
                 "(Cycles then looks up one point of the map); the map is exported as looked "
                 "up by direction")
        return unlinked_ok
    if node.bl_idname == "ShaderNodeTexCoord" and out is not None and out.name in (
            "Generated", "Object"):
        return True
    warn("world: the environment texture's vector comes from %s, not a direction; the map is "
         "exported as looked up by direction" % (
             "%s's %s" % (node.name, out.name) if out is not None else node.name))
    return False


def _envmap(env, strength, textures, warn):
    """The <emitter type="envmap"> of an Environment Texture node, or None (warned)."""
    image = env.image
    if image is None:
        warn("world: the Environment Texture '%s' has no image; the world is exported black"
             % env.name)
        return None
    if getattr(env, "projection", "EQUIRECTANGULAR") != "EQUIRECTANGULAR":
        warn("world: the Environment Texture '%s' uses the %s projection; opaline reads "
             "equirectangular maps only, so it is exported as one" % (
                 env.name, env.projection.replace("_", " ").lower()))
    got = textures.image_file(image, warn, "world")
    if got is None:
        return None
    rotation, inverse = None, False
    node, _ = textures_mod.linked_source(env.inputs.get("Vector"))
    if node is not None and node.bl_idname == "ShaderNodeMapping":
        m = _mapping_rotation(node, warn)
        if m is not None:
            rotation, inverse = m
        _direction_source(node.inputs.get("Vector"), warn, unlinked_ok=False)
    else:
        _direction_source(env.inputs.get("Vector"), warn)
    e = Element("emitter", {"type": "envmap"}, comment="world: environment texture %s"
                % image.name)
    e.string("filename", got[0])
    e.float("scale", strength)
    e.add(_to_world(envmap_to_world(rotation, inverse)))
    return e


def export_world(world, textures, transparent, warn):
    """The <emitter> of `world` (a constant or an envmap), or None when it gives no light;
    textures: the export's TextureWriter; transparent: Film > Transparent."""
    if world is None:
        return None
    col, strength, e = (world.color[0], world.color[1], world.color[2]), 1.0, None
    if compat.uses_nodes(world):
        out = None
        for n in world.node_tree.nodes:
            if n.bl_idname == "ShaderNodeOutputWorld" and n.is_active_output:
                out = n
        if out is None or not out.inputs["Surface"].is_linked:
            return None
        node = out.inputs["Surface"].links[0].from_node
        if node.bl_idname != "ShaderNodeBackground":
            warn("world: shader node '%s' is not supported; the world is exported black" %
                 node.bl_idname)
            return None
        s = node.inputs["Strength"]
        if s.is_linked:
            warn("world: the background strength is linked; its default value is used")
        strength = float(s.default_value)
        c = node.inputs["Color"]
        col = (c.default_value[0], c.default_value[1], c.default_value[2])
        src, src_out = textures_mod.linked_source(c)
        if src is not None and src.bl_idname == "ShaderNodeTexEnvironment" and (
                src_out is None or src_out.name == "Color"):
            if strength <= 0.0:
                return None
            e = _envmap(src, strength, textures, warn)
            if e is None:
                return None
        elif src is not None and src.bl_idname == "ShaderNodeTexSky":
            warn("world: the Sky Texture '%s' (ShaderNodeTexSky, %s) is not exported: opaline "
                 "has no sky model of Blender's scale; the Background's own colour is used "
                 "(an Environment Texture of a baked sky renders)" % (
                     src.name, getattr(src, "sky_type", "?").title()))
        elif src is not None:
            warn("world: the background colour comes from %s '%s', which is not exported; "
                 "the Background's own colour is used" % (src.bl_idname, src.name))
    if e is None:
        rad = lights_mod.world_radiance(col, strength)
        if max(rad) <= 0.0:
            return None
        e = Element("emitter", {"type": "constant"}, comment="world background")
        e.rgb("radiance", rad)
    if transparent:
        e.boolean("visibleToCamera", False)
    return e
