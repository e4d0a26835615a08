"""The preset's albedo map in Material Preview: a few nodes the add-on manages in the material's
node tree (an Image Texture of the preset's NAME.png, a Diffuse BSDF and an EEVEE-only Material
Output, which EEVEE prefers over an output for all engines). The user's nodes, links and outputs
are never changed: Cycles and the exporter keep using them.

`sync(material)` creates, updates or removes the managed nodes to match material.opaline; the
property update callbacks call it. Managed nodes are named with the PREFIX and tagged with the
custom property TAG, and only nodes carrying both are touched.
"""

import os

import bpy

from . import chooser, compat

PREFIX = "opaline preview "
TAG = "opaline_managed"
_ROLES = ("albedo", "bsdf", "output")


def managed_nodes(mat):
    """{role: node} of the nodes the add-on manages in mat's node tree."""
    out = {}
    nt = getattr(mat, "node_tree", None)
    if nt is None:
        return out
    for n in nt.nodes:
        if n.name.startswith(PREFIX) and n.get(TAG):
            out[n.get(TAG)] = n
    return out


def albedo_path(mat, context=None):
    """The albedo map (PNG) of mat's opaline material, or None: a preset's NAME.png, or the
    NAME.png beside a material file."""
    s = mat.opaline
    if not s.enabled:
        return None
    if s.kind == 'PRESET' and s.preset:
        p = chooser.find(s.preset, context)
        return p.png if p is not None else None
    if s.kind == 'FILE' and s.filepath:
        png = os.path.splitext(bpy.path.abspath(s.filepath))[0] + ".png"
        return png if os.path.isfile(png) else None
    return None


def remove(mat):
    nt = getattr(mat, "node_tree", None)
    for n in managed_nodes(mat).values():
        nt.nodes.remove(n)


def _new(nt, idname, role, location):
    n = nt.nodes.new(idname)
    n.name = n.label = PREFIX + role
    n[TAG] = role
    n.location = location
    return n


def _image(path):
    for im in bpy.data.images:
        if im.filepath and bpy.path.abspath(im.filepath) == path:
            return im
    return bpy.data.images.load(path, check_existing=True)


def sync(mat, context=None):
    """Makes mat's managed preview nodes show its opaline albedo map, or removes them when
    opaline is off, no map is known, or the material does not use nodes."""
    if mat is None or getattr(mat, "opaline", None) is None:
        return
    path = albedo_path(mat, context) if compat.uses_nodes(mat) else None
    if path is None:
        remove(mat)
        return
    nt = mat.node_tree
    have = managed_nodes(mat)
    if set(have) != set(_ROLES):
        remove(mat)
        xs = [n.location.x for n in nt.nodes] or [0.0]
        ys = [n.location.y for n in nt.nodes] or [0.0]
        x, y = max(xs) + 300.0, min(ys) - 300.0
        have = {"albedo": _new(nt, "ShaderNodeTexImage", "albedo", (x, y)),
                "bsdf": _new(nt, "ShaderNodeBsdfDiffuse", "bsdf", (x + 300.0, y)),
                "output": _new(nt, "ShaderNodeOutputMaterial", "output", (x + 500.0, y))}
        have["output"].target = 'EEVEE'
        nt.links.new(have["albedo"].outputs["Color"], have["bsdf"].inputs["Color"])
        nt.links.new(have["bsdf"].outputs[0], have["output"].inputs["Surface"])
    tex = have["albedo"]
    if tex.image is None or bpy.path.abspath(tex.image.filepath) != path:
        tex.image = _image(path)
    # The albedo map covers the material sample once; the renderer lays it by UV.
    tex.extension = 'REPEAT'
