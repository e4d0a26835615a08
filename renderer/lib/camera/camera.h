/* camera.h - Mitsuba's sensors: perspective, thinlens, orthographic, radiancemeter and
 * irradiancemeter (on a shape's surface: camera/meter.h). Camera
 * space looks along +Z with +Y up and +X to the LEFT in the image; toWorld places it (without
 * scale, except for the orthographic sensor, whose toWorld scale sets the extent of its sensor
 * plane [-1, 1] x [-h/w, h/w]); near/far clip distances along the ray's axis. */
#ifndef OP_CAMERA_H
#define OP_CAMERA_H

#include "math/vec.h"
#include "geometry/shape.h"
#include "scene/scene_desc.h"

typedef enum op_camera_type {
    OP_CAMERA_PERSPECTIVE,
    OP_CAMERA_THINLENS,     /* perspective through a disk aperture focused at a distance */
    OP_CAMERA_ORTHOGRAPHIC, /* parallel rays along +Z from a plane */
    OP_CAMERA_RADIANCEMETER, /* one ray from the origin along +Z, the same for every pixel */
    OP_CAMERA_IRRADIANCEMETER /* rays from a shape's surface (camera/meter.h) */
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
    int shape;                    /* irradiancemeter: the index of the shape it is a child of */
    const op_trimesh *surface;    /* irradiancemeter: that shape's world-space mesh (the
                                     scene's), set once the scene's shapes are built */
    int surface_rectangle;        /* irradiancemeter: the shape is a rectangle (camera/meter.h) */
} op_camera;

/* Reads a <sensor> (an irradiancemeter's is the child of its shape, whose index the scene
 * builder sets with its surface; sensor may be NULL: Mitsuba's defaults, a perspective sensor of fov 45 at
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

/* How many numbers op_camera_ray_lens reads from (lens_u, lens_v): 2 for a thin lens and an
 * irradiancemeter (its direction), else 0. */
int op_camera_lens_dims(const op_camera *cam);

/* The primary ray through film position (fx, fy) in pixels of the full film (0,0 = top-left
 * corner of the top-left pixel), through the aperture point that (lens_u, lens_v) in [0, 1)^2
 * picks (a thin lens's disk, by the concentric map; an irradiancemeter's direction; unused by
 * the others). dir is unit length; the ray starts at the near plane along it, *tmax is at the
 * far plane. An irradiancemeter's ray starts at the surface point that (fx / full_width,
 * fy / full_height) picks. */
void op_camera_ray_lens(const op_camera *cam, float fx, float fy, float lens_u, float lens_v,
                        op_v3 *org, op_v3 *dir, float *tmin, float *tmax);

/* The ray through film position (fx, fy) and the centre of the aperture: what the camera sees
 * there in focus (op_camera_ray_lens at lens position (0.5, 0.5)). */
void op_camera_ray(const op_camera *cam, float fx, float fy, op_v3 *org, op_v3 *dir, float *tmin,
                   float *tmax);

/* The factor on a primary ray's radiance that makes the sensor's measurement: the
 * irradiancemeter's OP_METER_WEIGHT, 1 for the others. */
float op_camera_weight(const op_camera *cam);

/* Whether the sensor's pixels are measurements over parts of a domain of samples rather than
 * images through a reconstruction filter (the irradiancemeter: a pixel is the mean over its part
 * of the unit square of surface samples, the film's filter does not apply). */
int op_camera_unfiltered(const op_camera *cam);

#endif
