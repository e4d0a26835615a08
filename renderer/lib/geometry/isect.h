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
    op_v3 n0;      /* with a shadowing term: the untilted shading normal */
    float shadow_a2; /* the term's roughness alpha^2 (0: no term) */
} op_isect;

/* The shadowing term of a tilted shading normal (Estevez et al. 2019, as Mitsuba 3's bumpmap and
 * normalmap apply it by default) for direction w (world, unit) leaving the surface: a Smith
 * masking of a GGX surface whose alpha^2 = min(tan^2(tilt) / 8, 1), in the untilted frame. It
 * multiplies every value of the wrapped BSDF toward w (light samples and sampled directions);
 * 1 where no term applies. */
static inline float op_isect_shadowing(const op_isect *it, op_v3 w)
{
    if (!(it->shadow_a2 > 0.0f))
        return 1.0f;
    float c = v3_dot(it->n0, w), c2 = c * c;
    if (!(c2 > 0.0f))
        return 0.0f;
    float t2 = (1.0f - c2) / c2;
    return 2.0f / (1.0f + sqrtf(1.0f + it->shadow_a2 * t2));
}

/* Fills it from a hit of the ray org + t dir (the frame tilted as the shape's bsdf says,
 * bsdf/bump.h). */
void op_isect_from_hit(const op_scene *scene, const op_ray_hit *hit, op_v3 org, op_v3 dir,
                       op_isect *it);
/* A ray origin just off the surface at p on the side that direction w leaves toward. */
op_v3 op_offset_origin(op_v3 p, op_v3 ng, op_v3 w);

#endif
