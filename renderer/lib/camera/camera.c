/* camera.c - Mitsuba's sensors (see camera.h for their conventions). */
#include "camera/camera.h"

#include "camera/meter.h"

#include <stdlib.h>
#include <string.h>

double op_camera_fov_from_focal_length(double mm, int width, int height)
{
    double diagonal = 2.0 * (sqrt(36.0 * 36.0 + 24.0 * 24.0) / (2.0 * mm)); /* tan at 1 */
    double aspect = (double)width / (double)height;
    double x = diagonal / sqrt(1.0 + 1.0 / (aspect * aspect));
    return 2.0 * atan(0.5 * x) * 180.0 / M_PI;
}

/* Mitsuba's focalLength: "<x>mm" or "<x>", x > 0 millimetres. */
static op_status parse_focal_length(const op_node *node, const char *s, double *mm,
                                    op_error *err)
{
    char buf[64];
    size_t n = strlen(s);
    if (n >= 2 && strcmp(s + n - 2, "mm") == 0)
        n -= 2;
    char *end = NULL;
    double v = NAN;
    if (n > 0 && n < sizeof buf) {
        memcpy(buf, s, n);
        buf[n] = '\0';
        v = strtod(buf, &end);
    }
    if (!end || *end != '\0' || !(v > 0.0) || !isfinite(v))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <%s>: focalLength \"%s\" is not a "
                            "positive length of the form <x>mm", node->file, node->line,
                            node->tag, s);
    *mm = v;
    return OP_OK;
}

/* The half extents (*tx, *ty) at distance 1 of a perspective image plane of w x h pixels whose
 * field of view is fov degrees along axis (x, y, diagonal, smaller or larger). */
static op_status fov_extents(const op_node *node, double fov, const char *axis, double w,
                             double h, double *tx, double *ty, op_error *err)
{
    double t = tan(fov * 0.5 * M_PI / 180.0);
    if (strcmp(axis, "x") == 0 || (strcmp(axis, "smaller") == 0 && w <= h) ||
        (strcmp(axis, "larger") == 0 && w >= h)) {
        *tx = t;
        *ty = t * h / w;
    } else if (strcmp(axis, "y") == 0 || strcmp(axis, "smaller") == 0 ||
               strcmp(axis, "larger") == 0) {
        *ty = t;
        *tx = t * w / h;
    } else if (strcmp(axis, "diagonal") == 0) {
        double d = sqrt(w * w + h * h);
        *tx = t * w / d;
        *ty = t * h / d;
    } else {
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <%s>: fovAxis \"%s\" is not x, y, "
                            "diagonal, smaller or larger", node->file, node->line, node->tag,
                            axis);
    }
    return OP_OK;
}

op_status op_camera_read_fov(op_node *node, int width, int height, double *tan_x, double *tan_y,
                             op_error *err)
{
    /* neither fov nor focalLength: Mitsuba's default lens, 50 mm (0.6 and 3 alike) */
    double fov = op_camera_fov_from_focal_length(50.0, width, height);
    const char *axis = "x", *focal = NULL;
    if (node) {
        GET_OR_FAIL(op_node_string(node, "focalLength", NULL, &focal, err));
        if (focal && op_node_has(node, "fov"))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <%s>: give either fov or "
                                "focalLength, not both", node->file, node->line, node->tag);
        if (focal) {
            double mm = 0.0;
            GET_OR_FAIL(parse_focal_length(node, focal, &mm, err));
            fov = op_camera_fov_from_focal_length(mm, width, height);
        } else {
            GET_OR_FAIL(op_node_float(node, "fov", fov, &fov, err));
        }
        const char *given_axis; /* read (so not reported unused) but only a fov's axis */
        GET_OR_FAIL(op_node_string(node, "fovAxis", "x", &given_axis, err));
        if (op_node_has(node, "fov"))
            axis = given_axis;
        if (!(fov > 0.0 && fov < 180.0))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <%s>: fov %g is not in (0, 180) "
                                "degrees", node->file, node->line, node->tag, fov);
    }
    return fov_extents(node, fov, axis, width, height, tan_x, tan_y, err);
}

static op_status read_clip(op_node *sensor, op_camera *cam, op_error *err)
{
    double near_clip = 0.01, far_clip = 10000.0;
    if (sensor) {
        GET_OR_FAIL(op_node_float(sensor, "nearClip", 0.01, &near_clip, err));
        GET_OR_FAIL(op_node_float(sensor, "farClip", 10000.0, &far_clip, err));
        if (!(near_clip > 0.0 && far_clip > near_clip))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <sensor>: need 0 < nearClip < farClip",
                                sensor->file, sensor->line);
    }
    cam->near_clip = (float)near_clip;
    cam->far_clip = (float)far_clip;
    return OP_OK;
}

/* The radiancemeter's placement by origin and direction (Mitsuba 3's alternative to toWorld). */
static op_status meter_placement(op_node *sensor, op_matrix4 *to_world, op_error *err)
{
    int has_o = op_node_has(sensor, "origin"), has_d = op_node_has(sensor, "direction");
    if (!has_o && !has_d)
        return OP_OK;
    if (has_o != has_d || op_node_has(sensor, "toWorld"))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <sensor type=\"radiancemeter\">: give "
                            "origin and direction together, or toWorld", sensor->file,
                            sensor->line);
    double o[3], d[3], zero[3] = {0, 0, 0}, z[3] = {0, 0, 1}, up[3] = {0, 1, 0}, t[3];
    GET_OR_FAIL(op_node_vec3(sensor, "origin", zero, o, err));
    GET_OR_FAIL(op_node_vec3(sensor, "direction", z, d, err));
    if (fabs(d[1]) > 0.9 * sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])) {
        up[0] = 1.0; /* any up vector not along the ray: the meter has no image axes */
        up[1] = 0.0;
    }
    for (int k = 0; k < 3; k++)
        t[k] = o[k] + d[k];
    if (!op_matrix4_lookat(o, t, up, to_world))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <sensor type=\"radiancemeter\">: zero or "
                            "non-finite direction", sensor->file, sensor->line);
    return OP_OK;
}

op_status op_camera_build(op_node *sensor, int full_width, int full_height, op_camera *cam,
                          op_error *err)
{
    memset(cam, 0, sizeof *cam);
    cam->full_width = full_width;
    cam->full_height = full_height;
    op_matrix4 to_world = op_matrix4_identity();
    const char *t = sensor && sensor->type ? sensor->type : "perspective";
    if (strcmp(t, "perspective") == 0)
        cam->type = OP_CAMERA_PERSPECTIVE;
    else if (strcmp(t, "thinlens") == 0)
        cam->type = OP_CAMERA_THINLENS;
    else if (strcmp(t, "orthographic") == 0)
        cam->type = OP_CAMERA_ORTHOGRAPHIC;
    else if (strcmp(t, "radiancemeter") == 0)
        cam->type = OP_CAMERA_RADIANCEMETER;
    else if (strcmp(t, "irradiancemeter") == 0)
        cam->type = OP_CAMERA_IRRADIANCEMETER;
    else
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <sensor type=\"%s\">: unsupported sensor "
                            "type (perspective, thinlens, orthographic, radiancemeter, "
                            "irradiancemeter)", sensor->file, sensor->line, t);
    if (sensor)
        sensor->used = 1;
    if (cam->type == OP_CAMERA_IRRADIANCEMETER) {
        /* placed by its shape, which the scene builder names */
        cam->shape = -1;
        if (op_node_has(sensor, "toWorld"))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <sensor type=\"irradiancemeter\">: "
                                "no toWorld (the meter lies on the shape it is a child of)",
                                sensor->file, sensor->line);
        cam->axis_x = v3(1.0f, 0.0f, 0.0f);
        cam->axis_y = v3(0.0f, 1.0f, 0.0f);
        cam->axis_z = v3(0.0f, 0.0f, 1.0f);
        cam->far_clip = INFINITY;
        return OP_OK;
    }
    if (cam->type == OP_CAMERA_PERSPECTIVE || cam->type == OP_CAMERA_THINLENS) {
        double tx, ty;
        GET_OR_FAIL(op_camera_read_fov(sensor, full_width, full_height, &tx, &ty, err));
        cam->tan_x = (float)tx;
        cam->tan_y = (float)ty;
    }
    if (cam->type != OP_CAMERA_RADIANCEMETER) {
        GET_OR_FAIL(read_clip(sensor, cam, err));
    } else {
        cam->near_clip = 1e-4f; /* Mitsuba's ray epsilon */
        cam->far_clip = INFINITY;
        GET_OR_FAIL(meter_placement(sensor, &to_world, err));
    }
    if (cam->type == OP_CAMERA_THINLENS) {
        double aperture, focus;
        if (!op_node_has(sensor, "apertureRadius"))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <sensor type=\"thinlens\"> needs an "
                                "apertureRadius", sensor->file, sensor->line);
        GET_OR_FAIL(op_node_float(sensor, "apertureRadius", 0.0, &aperture, err));
        GET_OR_FAIL(op_node_float(sensor, "focusDistance", cam->far_clip, &focus, err));
        if (!(aperture >= 0.0) || !isfinite(aperture) || !(focus > 0.0) || !isfinite(focus))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <sensor type=\"thinlens\">: need "
                                "apertureRadius >= 0 and focusDistance > 0, both finite",
                                sensor->file, sensor->line);
        cam->aperture = (float)aperture;
        cam->focus = (float)focus;
    }
    if (sensor && !(cam->type == OP_CAMERA_RADIANCEMETER && op_node_has(sensor, "origin")))
        GET_OR_FAIL(op_node_transform(sensor, "toWorld", &to_world, err));
    if (!op_matrix4_is_finite(&to_world))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <sensor>: toWorld is not finite",
                            sensor->file, sensor->line);
    double o[3] = {0, 0, 0}, ex[3] = {1, 0, 0}, ey[3] = {0, 1, 0}, ez[3] = {0, 0, 1};
    op_matrix4_point(&to_world, o, o);
    op_matrix4_vector(&to_world, ex, ex);
    op_matrix4_vector(&to_world, ey, ey);
    op_matrix4_vector(&to_world, ez, ez);
    cam->origin = v3_from_d(o);
    if (!v3_unit_from_d(ex, &cam->axis_x) || !v3_unit_from_d(ey, &cam->axis_y) ||
        !v3_unit_from_d(ez, &cam->axis_z))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <sensor>: toWorld is degenerate",
                            sensor ? sensor->file : "?", sensor ? sensor->line : 0);
    if (cam->type == OP_CAMERA_ORTHOGRAPHIC) {
        cam->half_x = (float)sqrt(ex[0] * ex[0] + ex[1] * ex[1] + ex[2] * ex[2]);
        cam->half_y = (float)(sqrt(ey[0] * ey[0] + ey[1] * ey[1] + ey[2] * ey[2]) * full_height /
                              full_width);
    }
    return OP_OK;
}

int op_camera_lens_dims(const op_camera *cam)
{
    return cam->type == OP_CAMERA_THINLENS || cam->type == OP_CAMERA_IRRADIANCEMETER ? 2 : 0;
}

float op_camera_weight(const op_camera *cam)
{
    return cam->type == OP_CAMERA_IRRADIANCEMETER ? OP_METER_WEIGHT : 1.0f;
}

int op_camera_unfiltered(const op_camera *cam)
{
    return cam->type == OP_CAMERA_IRRADIANCEMETER;
}

/* Shirley and Chiu's concentric map of [0, 1)^2 onto the unit disk. */
static void concentric_disk(float u, float v, float *x, float *y)
{
    float a = 2.0f * u - 1.0f, b = 2.0f * v - 1.0f, r, phi;
    if (a == 0.0f && b == 0.0f) {
        *x = *y = 0.0f;
        return;
    }
    if (fabsf(a) > fabsf(b)) {
        r = a;
        phi = (OP_PI / 4.0f) * (b / a);
    } else {
        r = b;
        phi = (OP_PI / 2.0f) - (OP_PI / 4.0f) * (a / b);
    }
    *x = r * cosf(phi);
    *y = r * sinf(phi);
}

void op_camera_ray_lens(const op_camera *cam, float fx, float fy, float lens_u, float lens_v,
                        op_v3 *org, op_v3 *dir, float *tmin, float *tmax)
{
    float sx = 2.0f * fx / (float)cam->full_width - 1.0f;  /* +1 at the right edge */
    float sy = 2.0f * fy / (float)cam->full_height - 1.0f; /* +1 at the bottom edge */
    switch (cam->type) {
    case OP_CAMERA_IRRADIANCEMETER:
        op_meter_ray(cam->surface, cam->surface_rectangle, fx / (float)cam->full_width,
                     fy / (float)cam->full_height, lens_u, lens_v, org, dir, tmin);
        *tmax = cam->far_clip;
        return;
    case OP_CAMERA_RADIANCEMETER:
        *org = cam->origin;
        *dir = cam->axis_z;
        *tmin = cam->near_clip;
        *tmax = cam->far_clip;
        return;
    case OP_CAMERA_ORTHOGRAPHIC:
        /* +X is to the left and +Y up, so the right and bottom edges are -X and -Y. */
        *org = v3_add(cam->origin, v3_add(v3_scale(cam->axis_x, -sx * cam->half_x),
                                          v3_scale(cam->axis_y, -sy * cam->half_y)));
        *dir = cam->axis_z;
        *tmin = cam->near_clip;
        *tmax = cam->far_clip;
        return;
    case OP_CAMERA_THINLENS: {
        float ax, ay;
        concentric_disk(lens_u, lens_v, &ax, &ay);
        op_v3 focus_p = v3(-sx * cam->tan_x * cam->focus, -sy * cam->tan_y * cam->focus,
                           cam->focus);
        op_v3 a = v3(ax * cam->aperture, ay * cam->aperture, 0.0f);
        op_v3 local = v3_norm(v3_sub(focus_p, a));
        *org = v3_add(cam->origin, v3_add(v3_scale(cam->axis_x, a.x), v3_scale(cam->axis_y, a.y)));
        *dir = v3_norm(v3_add(v3_add(v3_scale(cam->axis_x, local.x),
                                     v3_scale(cam->axis_y, local.y)),
                              v3_scale(cam->axis_z, local.z)));
        *tmin = cam->near_clip / local.z;
        *tmax = cam->far_clip / local.z;
        return;
    }
    case OP_CAMERA_PERSPECTIVE:
        break;
    }
    op_v3 local = v3(-sx * cam->tan_x, -sy * cam->tan_y, 1.0f);
    float len = v3_len(local);
    op_v3 d = v3_add(v3_add(v3_scale(cam->axis_x, local.x), v3_scale(cam->axis_y, local.y)),
                     cam->axis_z);
    *dir = v3_norm(d);
    *org = cam->origin;
    /* The clip planes are z = const in camera space. */
    *tmin = cam->near_clip * len;
    *tmax = cam->far_clip * len;
}

void op_camera_ray(const op_camera *cam, float fx, float fy, op_v3 *org, op_v3 *dir, float *tmin,
                   float *tmax)
{
    op_camera_ray_lens(cam, fx, fy, 0.5f, 0.5f, org, dir, tmin, tmax);
}
