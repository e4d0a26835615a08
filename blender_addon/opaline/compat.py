"""The differences between the Blender versions the add-on supports (3.4 to 5.x), in one place.
Other modules ask these functions instead of testing bpy.app.version themselves."""

import math

import bpy

VERSION = tuple(bpy.app.version)


def uses_nodes(idblock):
    """Whether a material or world renders its node tree: always since Blender 5.0, which
    deprecated `use_nodes`; before, when `use_nodes` is set."""
    if getattr(idblock, "node_tree", None) is None:
        return False
    return VERSION >= (5, 0, 0) or bool(idblock.use_nodes)


def has_use_nodes_toggle():
    """Whether materials have a "Use Nodes" switch worth showing (before 5.0)."""
    return VERSION < (5, 0, 0)


def area_light_divisor(version=VERSION):
    """d in Cycles' radiance of an area light, power / (d x area): pi since Blender 4.0, 4
    before (version: a Blender version, the running one by default)."""
    return math.pi if tuple(version[:2]) >= (4, 0) else 4.0


def principled_transmission_input():
    """The name of the Principled BSDF's transmission input: "Transmission Weight" since
    Blender 4.0 (Principled v2), "Transmission" before."""
    return "Transmission Weight" if VERSION >= (4, 0, 0) else "Transmission"


def principled_emission_input():
    """The name of the Principled BSDF's emission colour input: "Emission Color" since Blender
    4.0 (Principled v2, whose Emission Strength defaults to 0), "Emission" before."""
    return "Emission Color" if VERSION >= (4, 0, 0) else "Emission"


def principled_f0(read):
    """The normal-incidence reflectance F0 of a Principled BSDF's dielectric layer, read(name)
    giving an input's value (None when the node has none): since Blender 4.0 (Principled v2)
    from 'IOR' scaled by 2 x 'Specular IOR Level' (0.5 leaves the IOR's own F0); before, from
    'Specular' s as F0 = 0.08 s."""
    if VERSION >= (4, 0, 0):
        ior = float(read("IOR") or 1.5)
        return ((ior - 1.0) / (ior + 1.0)) ** 2 * 2.0 * float(read("Specular IOR Level"))
    spec = read("Specular")
    return 0.08 * (0.5 if spec is None else float(spec))
