/* camera.h - Mitsuba's sensors: perspective, thinlens, orthographic and radiancemeter. Camera
 * space looks along +Z with +Y up and +X to the LEFT in the image; toWorld places it (without
 * scale, except for the orthographic sensor, whose toWorld scale sets the extent of its sensor
 * plane [-1, 1] x [-h/w, h/w]); near/far clip distances along the ray's axis. */
#ifndef OP_CAMERA_H
#define OP_CAMERA_H

#include "math/vec.h"
#include "scene/scene_desc.h"

typedef enum op_camera_type {
    OP_CAMERA_PERSPECTIVE,
    OP_CAMERA_THINLENS,     /* perspective through a disk aperture focused at a distance */
    OP_CAMERA_ORTHOGRAPHIC, /* parallel rays along +Z from a plane */
    OP_CAMERA_RADIANCEMETER /* one ray from the origin along +Z, the same for every pixel */
} op_camera_type;

typedef struct op_camera {
    op_camera_type type;
    op_v3 origin;
    op_v3 axis_x, axis_y, axis_z; /* camera-space axes in world space, unit length */
    float tan_x, tan_y;           /* perspective, thinlens: half extents of the image plane at
                                     distance 1; 0 for the others */
    float half_x, half_y;         /* orthographic: half extents of the sensor plane in world
                                     units along axis_x and axis_y */
    float aperture, focus;        /* thinlens: aperture radius and focus distance */
    float near_clip, far_clip;
    int full_width, full_height;  /* the film's size (not the crop window) */
} op_camera;

/* Reads a <sensor> (sensor may be NULL: Mitsuba's defaults, a perspective sensor of fov 45 at
 * the origin looking along +Z) for a film of full_width x full_height. */
op_status op_camera_build(op_node *sensor, int full_width, int full_height, op_camera *cam,
                          op_error *err);

/* The field of view along x, in degrees, of a film of width x height pixels seen through a lens
 * of focal length mm millimetres in 35 mm film equivalent: the 36 x 24 mm film's diagonal
 * field of view spans the image's diagonal (Mitsuba's focalLength). */
double op_camera_fov_from_focal_length(double mm, int width, int height);

/* The half extents at distance 1 (*tan_x, *tan_y) of an image plane of width x height pixels
 * that node's fov (along fovAxis) or focalLength gives; without either (or node NULL),
 * Mitsuba's default: focalLength 50 mm.
 * The perspective and thin-lens sensors' and the projector emitter's. */
op_status op_camera_read_fov(op_node *node, int width, int height, double *tan_x, double *tan_y,
                             op_error *err);

/* How many numbers op_camera_ray_lens reads from (lens_u, lens_v): 2 for a thin lens, else 0. */
int op_camera_lens_dims(const op_camera *cam);

/* The primary ray through film position (fx, fy) in pixels of the full film (0,0 = top-left
 * corner of the top-left pixel), through the aperture point that (lens_u, lens_v) in [0, 1)^2
 * picks (a thin lens's disk, by the concentric map; unused by the others). dir is unit length;
 * the ray starts at the near plane along it, *tmax is at the far plane. */
void op_camera_ray_lens(const op_camera *cam, float fx, float fy, float lens_u, float lens_v,
                        op_v3 *org, op_v3 *dir, float *tmin, float *tmax);

/* The ray through film position (fx, fy) and the centre of the aperture: what the camera sees
 * there in focus (op_camera_ray_lens at lens position (0.5, 0.5)). */
void op_camera_ray(const op_camera *cam, float fx, float fy, op_v3 *org, op_v3 *dir, float *tmin,
                   float *tmax);

#endif
