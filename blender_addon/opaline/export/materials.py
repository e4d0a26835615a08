"""Blender materials -> opaline BSDFs, subsurface and mesh emitters.

Node mapping (the closest of opaline's Mitsuba-style BSDFs; see docs/blender-addon.md):
- Diffuse BSDF                -> diffuse (reflectance = Color, or its Image Texture)
- Glass BSDF                  -> dielectric (intIOR = IOR), or when rough roughdielectric
                                 (alpha = Roughness^2, Cycles' squaring; GGX, or Beckmann
                                 for Blender's Beckmann distribution)
- Principled BSDF             -> transmission >= 0.5: as the Glass BSDF (Blender < 4.0 also
                                 roughens refraction by Transmission Roughness t: roughness
                                 1 - (1 - r)(1 - t));
                                 otherwise Mitsuba 3's principled (Burley's BSDF, which
                                 Cycles' follows: baseColor, metallic, roughness, each a
                                 number or its Image Texture, GGX alpha = r^2; eta from
                                 the specular F0), or diffuse without specular and metal;
                                 Emission colour x Emission Strength > 0: also an area
                                 emitter on the shape (as the Emission shader);
                                 Alpha < 1 or linked to an Image Texture: inside a mask
                                 (opacity = Alpha)
- Emission                    -> an area emitter on the shape (radiance = Color * Strength;
                                 Cycles' emission strength is radiance) over a black diffuse
- anything else / no nodes    -> diffuse with the material's viewport colour (with a warning)
- no material                 -> diffuse 0.8 (Cycles' default surface)
A material with opaline subsurface gets, beside its <subsurface>, the surface reflection of
sheen_for (from its Principled BSDF, or the "Surface sheen" setting): dielectric or a GGX
roughdielectric.
Reflective BSDFs are wrapped in `twosided`, as Cycles shades both sides of a surface.
A Diffuse Color / Base Color (and a Principled Roughness, Metallic, Alpha) linked to an Image
Texture node exports a bitmap texture (textures.py); other linked inputs are not followed: the
default value is used and a warning names the socket.
"""

import math
import os

from . import textures as textures_mod
from .xml_writer import Element
from .. import chooser, compat, presets
from ..errors import OpalineError

DEFAULT_GREY = (0.8, 0.8, 0.8)


def _rgb(v):
    return (float(v[0]), float(v[1]), float(v[2]))


def _input(node, names, warn, label):
    """The default value of the first existing input among `names`."""
    for n in names:
        s = node.inputs.get(n)
        if s is not None:
            if s.is_linked:
                warn("%s: input '%s' is linked; its texture is not exported, the default "
                     "value is used" % (label, n))
            return s.default_value
    return None


def _linked_texture(b, param, sock, warn, label, textures):
    """Adds to element b, as `param`, the Image Texture linked to socket sock when textures (a
    TextureWriter) is given and one is; True when it did. A linked socket it does not export is
    warned (the caller writes its default value)."""
    if sock.is_linked and textures is not None:
        tex = textures_mod.texture_for(sock, param, textures, warn, label)
        if tex is not None:
            b.add(tex)
            return True
    elif sock.is_linked:
        warn("%s: input '%s' is linked; its texture is not exported, the default value is "
             "used" % (label, sock.name))
    return False


def _reflectance(b, param, node, names, warn, label, textures):
    """Adds reflectance `param` to bsdf element b: the Image Texture linked to the first
    existing input of `names` when textures (a TextureWriter) is given, else its colour."""
    s = next((node.inputs.get(n) for n in names if node.inputs.get(n) is not None), None)
    if s is not None and not _linked_texture(b, param, s, warn, label, textures):
        b.rgb(param, _rgb(s.default_value))


def _surface_node(mat):
    if not compat.uses_nodes(mat):
        return None
    out = None
    for n in mat.node_tree.nodes:
        if n.bl_idname == "ShaderNodeOutputMaterial" and n.is_active_output:
            out = n
            if n.target in ('ALL', 'CYCLES'):
                break
    if out is None:
        return None
    sock = out.inputs.get("Surface")
    if sock is None or not sock.is_linked:
        return None
    node = sock.links[0].from_node
    # Pass through reroutes.
    while node.bl_idname == "NodeReroute" and node.inputs[0].is_linked:
        node = node.inputs[0].links[0].from_node
    return node


def principled_f0(node, warn, label):
    """Normal-incidence reflectance F0 of a Principled BSDF's dielectric layer
    (compat.principled_f0)."""
    return compat.principled_f0(lambda name: _input(node, [name], warn, label))


def ior_from_f0(f0):
    """The index of refraction whose normal-incidence Fresnel reflectance is f0."""
    s = math.sqrt(min(max(f0, 0.0), 0.999))
    return (1.0 + s) / (1.0 - s)


def microfacet_alpha(roughness):
    """GGX alpha of a Blender roughness r: r^2, as Cycles squares every microfacet roughness."""
    r = min(max(float(roughness), 0.0), 1.0)
    return r * r


SMOOTH_ALPHA = 1e-4  # below it a microfacet BSDF is written as its smooth form
MAX_ETA = 9.99  # indices of refraction lie in (0, 10)


def _distribution(node):
    """The Mitsuba microfacet distribution of a Glass or Principled node: beckmann for
    Beckmann, else ggx (GGX and Multiscatter GGX); None for Sharp (Blender < 4.0's Glass)."""
    d = getattr(node, "distribution", "GGX")
    if d == 'SHARP':
        return None
    return "beckmann" if d == 'BECKMANN' else "ggx"


def _clamped_ior(ior, warn, label):
    """ior within what opaline's BSDFs take ((1, 10)), warned when it was larger."""
    if ior > MAX_ETA:
        warn("%s: the index of refraction %.4g is rendered as %g (the largest opaline's BSDFs "
             "take)" % (label, ior, MAX_ETA))
    return min(max(ior, 1.0001), MAX_ETA)


def _dielectric(ior, alpha, distribution, warn, label):
    if distribution is None or alpha < SMOOTH_ALPHA:
        b = Element("bsdf", {"type": "dielectric"})
    else:
        b = Element("bsdf", {"type": "roughdielectric"})
        b.string("distribution", distribution)
        b.float("alpha", alpha)
    b.float("intIOR", _clamped_ior(ior, warn, label))
    b.float("extIOR", 1.0)
    return b


def _principled(node, f0, warn, label, textures):
    """Mitsuba 3's `principled` (Burley's Disney BSDF, which Cycles' Principled BSDF follows)
    for an opaque Principled BSDF: baseColor, metallic and roughness (each a number or its
    Image Texture; the BSDF squares roughness into GGX alpha = r^2, as Cycles does, and a metal's
    Fresnel rises from Base Color at normal incidence to 1 at grazing, Schlick's), and eta from
    the specular F0."""
    b = Element("bsdf", {"type": "principled"})
    _reflectance(b, "baseColor", node, ["Base Color"], warn, label, textures)
    _weight(b, "metallic", node, "Metallic", warn, label, textures)
    _weight(b, "roughness", node, "Roughness", warn, label, textures)
    b.float("eta", _clamped_ior(ior_from_f0(f0), warn, label))
    return b


def _weight(b, param, node, name, warn, label, textures):
    """Adds the value of input `name` as float `param` of b, or the Image Texture linked to it
    (read as stored: a grey map in Non-Color) when textures (a TextureWriter) is given."""
    s = node.inputs.get(name)
    if not _linked_texture(b, param, s, warn, label, textures):
        b.float(param, min(max(float(s.default_value), 0.0), 1.0))


def _warn_normal(node, warn, label):
    """Warns when the node's Normal input is linked (a normal or bump map), which is not
    exported."""
    s = node.inputs.get("Normal")
    if s is not None and s.is_linked:
        warn("%s: input 'Normal' is linked (a normal or bump map); it is not exported, the "
             "surface is rendered with the mesh's own normals" % label)


def _alpha_mask(b, node, warn, label, textures):
    """b, or a `mask` around it when the Principled BSDF's Alpha is below 1 or linked to an
    Image Texture's Color (a grey cut-out map; Cycles mixes in a transparent BSDF of weight
    1 - Alpha, which is the mask's opacity = Alpha)."""
    s = node.inputs.get("Alpha")
    if s is None:
        return b
    m = Element("bsdf", {"type": "mask"})
    if s.is_linked and textures is not None:
        tex = textures_mod.texture_for(s, "opacity", textures, warn, label)
        if tex is None:
            return b
        m.add(tex)
    else:
        if s.is_linked:
            warn("%s: input 'Alpha' is linked; its texture is not exported, the default value "
                 "is used" % label)
        a = min(max(float(s.default_value), 0.0), 1.0)
        if a >= 1.0:
            return b
        m.float("opacity", a)
    m.add(b)
    return m


def _principled_emitter(node, warn, label):
    """The area emitter of a Principled BSDF's emission (radiance = Emission colour x Emission
    Strength, as for the Emission shader), or None when it is black."""
    col = _input(node, [compat.principled_emission_input()], warn, label)
    strength = _input(node, ["Emission Strength"], warn, label)
    if col is None:
        return None
    k = 1.0 if strength is None else float(strength)
    rad = tuple(k * c for c in _rgb(col))
    if max(rad) <= 0.0:
        return None
    e = Element("emitter", {"type": "area"})
    e.rgb("radiance", rad)
    return e


def _twosided(b):
    t = Element("bsdf", {"type": "twosided"})
    t.add(b)
    return t


def bsdf_for(mat, warn, textures=None):
    """(bsdf Element, emitter Element or None) for Blender material `mat` (may be None).
    textures: a textures.TextureWriter, to export Image Texture nodes (None: colours only)."""
    if mat is None:
        b = Element("bsdf", {"type": "diffuse"})
        b.rgb("reflectance", DEFAULT_GREY)
        return _twosided(b), None
    label = "material %s" % mat.name
    node = _surface_node(mat)
    kind = node.bl_idname if node is not None else None
    if kind == "ShaderNodeBsdfDiffuse":
        b = Element("bsdf", {"type": "diffuse"})
        _reflectance(b, "reflectance", node, ["Color"], warn, label, textures)
        return _twosided(b), None
    if kind == "ShaderNodeBsdfGlass":
        ior = float(_input(node, ["IOR"], warn, label))
        rough = float(_input(node, ["Roughness"], warn, label))
        return _dielectric(ior, microfacet_alpha(rough), _distribution(node), warn, label), None
    if kind == "ShaderNodeBsdfPrincipled":
        trans = float(_input(node, [compat.principled_transmission_input()], warn, label) or
                      0.0)
        ior = float(_input(node, ["IOR"], warn, label) or 1.45)
        f0 = principled_f0(node, warn, label)
        emitter = _principled_emitter(node, warn, label)
        if trans >= 0.5:
            rough = float(_input(node, ["Roughness"], warn, label))
            # Principled v1 (Blender < 4.0) roughens refraction further by its own input
            t_rough = node.inputs.get("Transmission Roughness")
            if t_rough is not None:
                rough = 1.0 - (1.0 - rough) * (1.0 - float(_input(
                    node, ["Transmission Roughness"], warn, label)))
            return _dielectric(ior, microfacet_alpha(rough), _distribution(node), warn,
                               label), emitter
        metal = node.inputs.get("Metallic")
        if f0 <= 8e-6 and not metal.is_linked and metal.default_value <= 0.0:
            b = Element("bsdf", {"type": "diffuse"})
            _reflectance(b, "reflectance", node, ["Base Color"], warn, label, textures)
            return _alpha_mask(_twosided(b), node, warn, label, textures), emitter
        _warn_normal(node, warn, label)
        b = _twosided(_principled(node, f0, warn, label, textures))
        return _alpha_mask(b, node, warn, label, textures), emitter
    if kind == "ShaderNodeEmission":
        col = _rgb(_input(node, ["Color"], warn, label))
        strength = float(_input(node, ["Strength"], warn, label))
        e = Element("emitter", {"type": "area"})
        e.rgb("radiance", tuple(strength * c for c in col))
        b = Element("bsdf", {"type": "diffuse"})
        b.rgb("reflectance", (0.0, 0.0, 0.0))
        return b, e
    if kind is not None:
        warn("%s: shader node '%s' is not mapped; exported as diffuse with its viewport colour"
             % (label, node.bl_idname))
    b = Element("bsdf", {"type": "diffuse"})
    b.rgb("reflectance", _rgb(mat.diffuse_color))
    return _twosided(b), None


def subsurface_for(mat, find_preset, renderer_finds, xml_dir, warn, prepass=None,
                   material_ref=None):
    """The <subsurface> element of a material with opaline subsurface enabled, else None.

    find_preset(name) -> presets.Preset or None; renderer_finds(preset) -> whether
    opaline-render finds that preset by its name (else the .opm path is written);
    prepass: (irrSamples, maxPoints; 0: none written) of the scene's render settings, or None
    for the renderer's defaults; material_ref(opm_path) -> the value that names a material file in the
    XML (default: the absolute path; collecting exports give a path relative to the XML).
    intIOR is written for the dipole only: measured Rd contains the boundary, and the renderer
    reads no IOR for it."""
    if mat is None:
        return None
    s = getattr(mat, "opaline", None)
    if s is None or not s.enabled:
        return None
    label = "material %s" % mat.name
    if s.kind == 'PRESET':
        if not s.preset:
            raise OpalineError("%s: opaline subsurface is enabled but no preset is chosen"
                               % label)
        p = find_preset(s.preset)
        if p is None:
            raise OpalineError("%s: %s" % (label, chooser.missing_message(s.preset)))
        typ = p.method
        if material_ref is not None:
            value = material_ref(p.opm)
        else:
            value = p.name if renderer_finds(p) else p.opm
    elif s.kind == 'DIPOLE':
        typ = "dipole"
        value = s.dipole_material
    else:
        import bpy
        path = bpy.path.abspath(s.filepath) if s.filepath else ""
        if not path or not os.path.isfile(path):
            raise OpalineError("%s: opaline material file '%s' does not exist" % (label, path))
        typ = s.file_method
        if typ == 'AUTO':
            typ = _method_of_file(path)
        value = material_ref(path) if material_ref is not None else os.path.abspath(path)
    e = Element("subsurface", {"type": typ})
    e.string("material", value)
    e.float("sceneUnitsPerMetre", s.scale)
    if typ == "dipole":
        e.float("intIOR", s.ior)
    if prepass is not None:
        e.integer("irrSamples", prepass[0])
        if prepass[1] > 0:  # 0: the renderer's default (--limit sss-max-points)
            e.integer("maxPoints", prepass[1])
    return e


def sheen_for(mat, warn):
    """The <bsdf> giving the surface reflection of a translucent material (beside its
    <subsurface>; docs/subsurface-rendering.md), or None: from the Principled BSDF (IOR from its
    F0, alpha = Roughness^2) or from the opaline settings (sheen 'ON'); a dielectric when smooth
    (alpha below 0.001), else a GGX roughdielectric."""
    s = mat.opaline
    if s.sheen == 'OFF':
        return None
    if s.sheen == 'ON':
        ior, rough = s.sheen_ior, s.sheen_roughness
    else:
        node = _surface_node(mat)
        if node is None or node.bl_idname != "ShaderNodeBsdfPrincipled":
            return None
        label = "material %s" % mat.name
        f0 = principled_f0(node, warn, label)
        if f0 <= 8e-6:
            return None
        ior = ior_from_f0(f0)
        rough = float(_input(node, ["Roughness"], warn, label))
    alpha = rough * rough
    if alpha < 1e-3:
        b = Element("bsdf", {"type": "dielectric"})
    else:
        b = Element("bsdf", {"type": "roughdielectric"})
        b.string("distribution", "ggx")
        b.float("alpha", min(alpha, 1.0))
    b.float("intIOR", _clamped_ior(ior, warn, "material %s" % mat.name))
    b.float("extIOR", 1.0)
    return b


def _method_of_file(path):
    return presets.method_of(path)
