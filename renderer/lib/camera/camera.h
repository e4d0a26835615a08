/* camera.h - Mitsuba's perspective sensor: camera space looks along +Z with +Y up and +X to the
 * LEFT in the image; fov in degrees along fovAxis; near/far clip; toWorld without scale. */
#ifndef OP_CAMERA_H
#define OP_CAMERA_H

#include "math/vec.h"
#include "scene/scene_desc.h"

typedef struct op_camera {
    op_v3 origin;
    op_v3 axis_x, axis_y, axis_z; /* camera-space axes in world space, unit length */
    float tan_x, tan_y;           /* half extents of the image plane at distance 1 */
    float near_clip, far_clip;
    int full_width, full_height;  /* the film's size (not the crop window) */
} op_camera;

/* Reads a <sensor type="perspective"> (sensor may be NULL: Mitsuba's defaults, fov 45 at the
 * origin looking along +Z) for a film of full_width x full_height. */
op_status op_camera_build(op_node *sensor, int full_width, int full_height, op_camera *cam,
                          op_error *err);

/* The primary ray through film position (fx, fy) in pixels of the full film (0,0 = top-left
 * corner of the top-left pixel). dir is unit length; the ray starts at the near plane distance
 * along it, *tmax is the far clip distance. */
void op_camera_ray(const op_camera *cam, float fx, float fy, op_v3 *org, op_v3 *dir, float *tmin,
                   float *tmax);

#endif
