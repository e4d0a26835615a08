"""Blender's colour management -> the film's view transform (docs/scene-format.md, "View
transform"): the PNG that opaline-render writes from the export goes through the same
OpenColorIO display, view, look, exposure and gamma as Blender's F12 image and saved renders.

- `ocio_config()`: the config Blender reads: $OCIO when it names a file, else Blender's own.
- `film_view(scene, warn)`: the <film> parameters, as (kind, name, value).
"""

import os


def ocio_config():
    """The OpenColorIO config file Blender uses (absolute), "" when none is found."""
    env = os.environ.get("OCIO", "")
    if env and os.path.isfile(env):
        return os.path.abspath(env)
    import bpy
    path = os.path.join(bpy.utils.system_resource('DATAFILES'), "colormanagement",
                        "config.ocio")
    return os.path.abspath(path) if os.path.isfile(path) else ""


def view_params(config, display, view, look, exposure, gamma):
    """The <film> parameters of a view transform; the look "None" and the defaults are left
    out."""
    params = [("string", "viewConfig", config), ("string", "viewDisplay", display),
              ("string", "viewTransform", view)]
    if look and look != "None":
        params.append(("string", "viewLook", look))
    if exposure != 0.0:
        params.append(("float", "viewExposure", exposure))
    if gamma != 1.0:
        params.append(("float", "viewGamma", gamma))
    return params


def film_view(scene, warn):
    """The view transform of scene's colour management as <film> parameters (none when
    Blender's config is not found)."""
    vs, ds = scene.view_settings, scene.display_settings
    config = ocio_config()
    if not config:
        warn("Blender's OpenColorIO config was not found: PNG outputs are plain sRGB, without "
             "the %s view transform" % vs.view_transform)
        return []
    if vs.use_curve_mapping:
        warn("Color Management > Curves is not exported: PNG outputs are without it")
    if getattr(vs, "use_white_balance", False):
        warn("Color Management > White Balance is not exported: PNG outputs are without it")
    # Blender raises a gamma of 0 to FLT_EPSILON, as the renderer needs it above 0
    return view_params(config, ds.display_device, vs.view_transform, vs.look, vs.exposure,
                       max(vs.gamma, 1.1920929e-07))
