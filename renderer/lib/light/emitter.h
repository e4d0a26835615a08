/* emitter.h - light sources: point, spot (Mitsuba's linear falloff in angle from beamWidth to
 * cutoffAngle, times an optional texture projected across the cone), area (on a shape, emitting from its front side), directional, constant,
 * envmap (a lat-long OpenEXR/PNG image in Mitsuba's orientation: +y up), sky (Mitsuba's
 * Hosek-Wilkie sky, light/sky.h, tabulated into an envmap when built) and collimated
 * (Mitsuba's beam: power along one ray, a delta in position and direction, so that no surface
 * point can sample it nor any path hit it: it lights nothing a path tracer sees, as in
 * Mitsuba, where only particle tracing shows it). */
#ifndef OP_EMITTER_H
#define OP_EMITTER_H

#include "opaline.h"
#include "math/vec.h"
#include "scene/scene_desc.h"
#include "geometry/shape.h"
#include "opaline_image.h"
#include "bsdf/texture.h"

typedef enum op_emitter_type {
    OP_EM_POINT,
    OP_EM_SPOT,
    OP_EM_AREA,
    OP_EM_DIRECTIONAL,
    OP_EM_CONSTANT,
    OP_EM_ENVMAP,
    OP_EM_COLLIMATED,
    OP_EM_PROJECTOR
} op_emitter_type;

typedef struct op_emitter {
    op_emitter_type type;
    op_v3 pos;              /* point, spot, collimated, projector */
    op_v3 value;            /* intensity (point, spot), radiance (area, constant), irradiance
                               (directional), scale (envmap), power (collimated), pi scale
                               irradiance (projector) */
    op_frame frame;         /* spot, projector: the unit axes of toWorld (s = +X, t = +Y,
                               n = +Z, the beam's or the view's axis); envmap: world-to-map
                               rotation rows */
    float tan_x, tan_y;     /* projector: half extents of its image plane at distance 1;
                               spot: tan_x = tan(cutoff), the texture's half extent there */
    op_texture tex;         /* spot: the projected texture; projector: the irradiance's; type
                               OP_TEX_NONE when there is none (a constant irradiance is in
                               value) */
    float cos_cutoff, cos_beam, cutoff, beam;
    const op_trimesh *mesh; /* area: the shape's mesh (owned by the scene) */
    int shape;              /* area: the shape's index */
    int camera_hidden;      /* area, constant, envmap, sky: visibleToCamera=false, its
                               emission is not seen by the camera segment of a path (before
                               any bounce) */
    op_v3 dir;              /* directional, collimated: the direction the light travels */
    op_image env;           /* envmap */
    op_frame env_to_world;  /* envmap: columns of the map-to-world rotation (toWorld's) */
    int env_row_corners;    /* envmap: rows lie at v = y / (height - 1) (Mitsuba 3), not at
                               pixel centres (y + 0.5) / height (Mitsuba 0.6) */
    float *env_cell;        /* envmap: each pixel cell's sampling weight (env_build_distribution) */
    float *env_row_cdf;     /* envmap: height + 1 entries, the rows' cumulative weight */
    float *env_col_cdf;     /* envmap: height rows of width + 1, each row's cumulative weight */
    double env_weight;      /* envmap: the sum of all cell weights */
} op_emitter;

typedef struct op_light_sample {
    op_v3 wi;     /* unit, from the shading point toward the light */
    float dist;   /* distance to the light, INFINITY for directional/environment */
    op_v3 value;  /* incident radiance divided by the sampling density (solid angle or delta) */
    float pdf;    /* solid-angle density, 0 for delta lights */
} op_light_sample;

/* Builds an emitter node; for an area emitter, mesh/shape are its shape's. An envmap's file is
 * found by op_node_resolve; one of more than max_pixels pixels is refused. A spot's or a
 * projector's texture reads its image through textures, which must outlive e. */
op_status op_emitter_build(op_node *node, const op_trimesh *mesh, int shape,
                           op_tex_cache *textures, long long max_pixels, op_emitter *e,
                           op_error *err);
/* 1 when op_emitter_build renders <emitter type="type">, else 0. */
int op_emitter_type_known(const char *type);
void op_emitter_free(op_emitter *e);
int op_emitter_is_env(const op_emitter *e);

/* How many of op_emitter_sample's u1, u2, u3 the emitter reads (in that order): 0 for point,
 * spot, directional, collimated and projector lights, 2 for constant and envmap, 3 for area. */
int op_emitter_sample_dims(const op_emitter *e);
/* Samples a direction from p toward the emitter; returns 0 when it contributes nothing. */
int op_emitter_sample(const op_emitter *e, op_v3 p, float u1, float u2, float u3,
                      op_light_sample *s);
/* Radiance leaving an area emitter at a point with geometric normal n toward direction w. */
op_v3 op_emitter_area_le(const op_emitter *e, op_v3 n, op_v3 w);
/* Solid-angle density with which op_emitter_sample picks the area emitter point at distance
 * dist along dir from the shading point (n the light's geometric normal). */
float op_emitter_area_pdf(const op_emitter *e, op_v3 n, op_v3 dir, float dist);
/* Radiance arriving from an environment emitter along -dir (dir points away from the scene). */
op_v3 op_emitter_env_le(const op_emitter *e, op_v3 dir);
/* Solid-angle density with which op_emitter_sample picks direction dir (pointing away from the
 * scene) of an environment emitter: uniform over the sphere for `constant`; for `envmap`
 * piecewise constant over the map's pixels in (u, v), proportional to luminance * sin(theta)
 * of the pixel's centre row, divided by the lat-long Jacobian 2 pi^2 sin(theta) of dir. */
float op_emitter_env_pdf(const op_emitter *e, op_v3 dir);

#endif
