"""Blender camera + render settings -> opaline <sensor> (with its film, its view transform
(colour.py), and its sampler).

Pure functions first (tested without bpy):
- `render_size(res_x, res_y, percentage)`: the output resolution Blender renders.
- `perspective_fov(...)`: the field of view in degrees and the axis it spans, from the lens,
  the sensor size and the sensor fit, exactly as Blender frames the image (see
  docs/blender-addon.md, "Camera").
"""

import math


def render_size(res_x, res_y, percentage):
    """(width, height) in pixels of a Blender render at `percentage` percent."""
    w = max(1, int(res_x * percentage / 100))
    h = max(1, int(res_y * percentage / 100))
    return w, h


def fit_axis(sensor_fit, width, height, aspect_x=1.0, aspect_y=1.0):
    """'x' or 'y': the image axis that the sensor size spans."""
    if sensor_fit == 'HORIZONTAL':
        return 'x'
    if sensor_fit == 'VERTICAL':
        return 'y'
    return 'x' if width * aspect_x >= height * aspect_y else 'y'


def perspective_fov(lens_mm, sensor_width_mm, sensor_height_mm, sensor_fit, width, height,
                    aspect_x=1.0, aspect_y=1.0):
    """(fov_degrees, axis): Blender's full angle of view along `axis`.

    AUTO fits sensor_width to the larger image side; HORIZONTAL fits sensor_width to x;
    VERTICAL fits sensor_height to y. fov = 2 atan(sensor / (2 lens))."""
    axis = fit_axis(sensor_fit, width, height, aspect_x, aspect_y)
    sensor = sensor_height_mm if sensor_fit == 'VERTICAL' else sensor_width_mm
    return math.degrees(2.0 * math.atan(0.5 * sensor / lens_mm)), axis


def fov_other_axis(fov_deg, axis, width, height, aspect_x=1.0, aspect_y=1.0):
    """The angle of view along the other image axis (for tests and documentation)."""
    t = math.tan(math.radians(fov_deg) * 0.5)
    wx, wy = width * aspect_x, height * aspect_y
    if axis == 'x':
        return math.degrees(2.0 * math.atan(t * wy / wx))
    return math.degrees(2.0 * math.atan(t * wx / wy))


def max_depth_from_bounces(max_bounces):
    """opaline's path length limit for Cycles' `max_bounces` (0 = direct light only = path
    length 2: camera -> surface -> light)."""
    return int(max_bounces) + 2


def export_camera(scene, cam_obj, matrix, samples, warn):
    """The <sensor> element for camera object `cam_obj` at world matrix `matrix` (rows)."""
    from .xml_writer import Element, transform_lookat
    r = scene.render
    width, height = render_size(r.resolution_x, r.resolution_y, r.resolution_percentage)
    cam = cam_obj.data
    loc = (matrix[0][3], matrix[1][3], matrix[2][3])
    fwd = tuple(-matrix[i][2] for i in range(3))
    n = math.sqrt(sum(c * c for c in fwd)) or 1.0
    fwd = tuple(c / n for c in fwd)
    up = tuple(matrix[i][1] for i in range(3))
    nu = math.sqrt(sum(c * c for c in up)) or 1.0
    up = tuple(c / nu for c in up)
    target = tuple(loc[i] + fwd[i] for i in range(3))
    if cam.type != 'PERSP':
        from ..errors import OpalineError
        raise OpalineError("camera %s: %s cameras are not supported by opaline-render (only "
                           "perspective)" % (cam_obj.name, cam.type.lower()))
    fov, axis = perspective_fov(cam.lens, cam.sensor_width, cam.sensor_height,
                                cam.sensor_fit, width, height,
                                r.pixel_aspect_x, r.pixel_aspect_y)
    s = Element("sensor", {"type": "perspective"}, comment="camera %s: %.6g mm lens" %
                (cam_obj.name, cam.lens))
    s.float("fov", fov)
    s.string("fovAxis", axis)
    s.float("nearClip", cam.clip_start)
    s.float("farClip", cam.clip_end)
    s.add(transform_lookat("toWorld", loc, target, up))
    if abs(cam.shift_x) > 1e-6 or abs(cam.shift_y) > 1e-6:
        warn("camera %s: lens shift is not supported and was ignored" % cam_obj.name)
    if r.pixel_aspect_x != r.pixel_aspect_y:
        warn("non-square pixel aspect is not supported; the image will be stretched")
    if getattr(cam, "dof", None) is not None and cam.dof.use_dof:
        warn("camera %s: depth of field is not exported" % cam_obj.name)
    # Cycles samples with low-discrepancy (scrambled Sobol) numbers; so does opaline's sobol
    sm = s.add(Element("sampler", {"type": "sobol"}))
    sm.integer("sampleCount", samples)
    f = s.add(Element("film", {"type": "hdrfilm"}))
    f.integer("width", width)
    f.integer("height", height)
    from .colour import film_view
    for kind, name, value in film_view(scene, warn):
        getattr(f, kind)(name, value)
    return s
