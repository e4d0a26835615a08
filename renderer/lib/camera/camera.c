/* camera.c - the perspective camera (see camera.h for its conventions). */
#include "camera/camera.h"

#include <math.h>
#include <string.h>

op_status op_camera_build(op_node *sensor, int full_width, int full_height, op_camera *cam,
                          op_error *err)
{
    memset(cam, 0, sizeof *cam);
    cam->full_width = full_width;
    cam->full_height = full_height;
    /* without fov, Mitsuba's default lens: 50 mm on the diagonal of a 36 x 24 mm film */
    double fov = 2.0 * atan(sqrt(36.0 * 36.0 + 24.0 * 24.0) / (2.0 * 50.0)) * 180.0 / M_PI;
    double near_clip = 0.01, far_clip = 10000.0;
    const char *axis = "diagonal";
    op_matrix4 to_world = op_matrix4_identity();
    if (sensor) {
        if (!sensor->type || strcmp(sensor->type, "perspective") != 0)
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <sensor type=\"%s\">: unsupported sensor "
                                "type (only \"perspective\")", sensor->file, sensor->line,
                                sensor->type ? sensor->type : "");
        sensor->used = 1;
        /* fovAxis says along what fov is measured (Mitsuba ignores it without fov) */
        const char *fov_axis;
        if (op_node_float(sensor, "fov", fov, &fov, err) ||
            op_node_string(sensor, "fovAxis", "x", &fov_axis, err) ||
            op_node_float(sensor, "nearClip", 0.01, &near_clip, err) ||
            op_node_float(sensor, "farClip", 10000.0, &far_clip, err) ||
            op_node_transform(sensor, "toWorld", &to_world, err))
            return err ? err->status : OP_ERR_INPUT;
        if (op_node_has(sensor, "fov"))
            axis = fov_axis;
        if (!(fov > 0.0 && fov < 180.0))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <sensor>: fov %g is not in (0, 180) "
                                "degrees", sensor->file, sensor->line, fov);
        if (!(near_clip > 0.0 && far_clip > near_clip))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <sensor>: need 0 < nearClip < farClip",
                                sensor->file, sensor->line);
        if (!op_matrix4_is_finite(&to_world))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <sensor>: toWorld is not finite",
                                sensor->file, sensor->line);
    }
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
    double w = full_width, h = full_height, t = tan(fov * 0.5 * M_PI / 180.0);
    double tx, ty;
    if (strcmp(axis, "x") == 0 || (strcmp(axis, "smaller") == 0 && w <= h) ||
        (strcmp(axis, "larger") == 0 && w >= h)) {
        tx = t;
        ty = t * h / w;
    } else if (strcmp(axis, "y") == 0 || strcmp(axis, "smaller") == 0 || strcmp(axis, "larger") == 0) {
        ty = t;
        tx = t * w / h;
    } else if (strcmp(axis, "diagonal") == 0) {
        double d = sqrt(w * w + h * h);
        tx = t * w / d;
        ty = t * h / d;
    } else {
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <sensor>: fovAxis \"%s\" is not x, y, "
                            "diagonal, smaller or larger", sensor->file, sensor->line, axis);
    }
    cam->tan_x = (float)tx;
    cam->tan_y = (float)ty;
    cam->near_clip = (float)near_clip;
    cam->far_clip = (float)far_clip;
    return OP_OK;
}

void op_camera_ray(const op_camera *cam, float fx, float fy, op_v3 *org, op_v3 *dir, float *tmin,
                   float *tmax)
{
    float sx = 2.0f * fx / (float)cam->full_width - 1.0f;  /* +1 at the right edge */
    float sy = 2.0f * fy / (float)cam->full_height - 1.0f; /* +1 at the bottom edge */
    /* +X is to the left and +Y up, so the right and bottom edges are -X and -Y. */
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
