/* isect.h - a surface point found by a ray, and where a ray leaving it starts. What the path
 * tracer (integrator.c) and the subsurface pre-pass (sss/prepass.c) share about surfaces. */
#ifndef OP_ISECT_H
#define OP_ISECT_H

#include "scene/render_scene.h"

/* A surface point found by a ray. */
typedef struct op_isect {
    op_v3 p;
    op_v3 ng;      /* unit geometric normal, on the side of the mesh's shading normal */
    op_v3 ns;      /* unit shading normal: the mesh's, tilted by a bumpmap or normalmap */
    float u, v;    /* texture coordinates (0 when the mesh has none) */
    int shape, prim;
    op_frame frame;/* shading frame around ns */
} op_isect;

/* Fills it from a hit of the ray org + t dir (the frame tilted as the shape's bsdf says,
 * bsdf/bump.h). */
void op_isect_from_hit(const op_scene *scene, const op_ray_hit *hit, op_v3 org, op_v3 dir,
                       op_isect *it);
/* A ray origin just off the surface at p on the side that direction w leaves toward. */
op_v3 op_offset_origin(op_v3 p, op_v3 ng, op_v3 w);

#endif
