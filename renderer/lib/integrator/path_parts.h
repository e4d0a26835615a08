/* path_parts.h - what the path tracers (integrator.c, volpath.c) share about surfaces along a
 * ray: passable surfaces (masks, thin dielectrics) passed through, area emission, and how many
 * numbers a BSDF sample draws. */
#ifndef OP_PATH_PARTS_H
#define OP_PATH_PARTS_H

#include <math.h>

#include "camera/sampler.h"
#include "geometry/isect.h"

/* The most passable surfaces one ray segment may pass through before it counts as absorbed
 * (guards against rays trapped in coincident cut-out surfaces). */
#define OP_MAX_PASSES 256

/* The BSDF of shape i when rays can pass it (op_bsdf_passable: a mask, a thin dielectric),
 * else NULL (translucent shapes are never passable). */
static inline const op_bsdf *shape_passable(const op_scene *s, int i)
{
    const op_shape_rec *sh = &s->shapes[i];
    if (sh->sss >= 0 || !op_bsdf_passable(&s->bsdfs[sh->bsdf]))
        return NULL;
    return &s->bsdfs[sh->bsdf];
}

/* The passage of passable surface b at it for a ray along dir. */
static inline op_bsdf_passage passage_at(const op_bsdf *b, const op_isect *it, op_v3 dir)
{
    return op_bsdf_passage_at(b, it->u, it->v, v3_dot(dir, it->ns));
}

/* The passage of passable surface b where the ray org + t dir met it (hit). */
static inline op_bsdf_passage passage_at_hit(const op_scene *s, const op_bsdf *b,
                                             const op_ray_hit *hit, op_v3 org, op_v3 dir)
{
    if (!op_bsdf_passage_varies(b))
        return op_bsdf_passage_at(b, 0.0f, 0.0f, 1.0f);
    op_isect it;
    op_isect_from_hit(s, hit, org, dir, &it);
    return passage_at(b, &it, dir);
}

/* Whether a ray passes a surface of passage pa: always for stop 0, never for 1, else with
 * probability 1 - stop drawn from the path's own stream (so the image does not depend on
 * threads). */
static inline int passage_passes(const op_bsdf_passage *pa, op_path_sampler *ps)
{
    if (pa->stop <= 0.0f)
        return 1;
    if (pa->stop >= 1.0f)
        return 0;
    return op_path_random(ps) >= pa->stop;
}

/* A ray walked through passable surfaces: the segment org + t dir, t in (tmin, tmax); dist is
 * the length walked before org, passes the surfaces passed so far. */
typedef struct ray_walk {
    op_v3 org, dir;
    float tmin, tmax, dist;
    int passes;
} ray_walk;

static inline ray_walk walk_start(op_v3 org, op_v3 dir, float tmin, float tmax)
{
    return (ray_walk){org, dir, tmin, tmax, 0.0f, 0};
}

static inline int walk_intersect(const op_scene *s, const ray_walk *w, op_ray_hit *hit)
{
    return op_accel_intersect(s->accel, w->org, w->dir, w->tmin, w->tmax, hit);
}

/* Moves the walk past the surface it hit at p (geometric normal ng) at distance t, in the same
 * direction. Returns 0, the walk over, once more than OP_MAX_PASSES surfaces were passed. */
static inline int walk_past(ray_walk *w, op_v3 p, op_v3 ng, float t)
{
    if (++w->passes > OP_MAX_PASSES)
        return 0;
    w->dist += t;
    w->org = op_offset_origin(p, ng, w->dir);
    w->tmin = 0.0f;
    if (!isinf(w->tmax))
        w->tmax -= t;
    return 1;
}

/* The radiance area emitter e of shape sh emits from the front (winding) side of triangle prim
 * towards wo; *nw gets the triangle's unnormalized winding normal. */
static inline op_v3 area_emission(const op_shape_rec *sh, const op_emitter *e, int prim,
                                  op_v3 wo, op_v3 *nw)
{
    op_v3 a, b, c;
    op_trimesh_tri(&sh->mesh, prim, &a, &b, &c);
    *nw = v3_cross(v3_sub(b, a), v3_sub(c, a));
    return op_emitter_area_le(e, *nw, wo);
}

/* The shadow ray from org (p offset off its surface) to the light sample at distance dist from
 * p along w: its direction *dir and its length, stopped short of the light's own surface by
 * 1e-4 of the length or what op_offset_origin would move an origin there, whichever is more
 * (infinite for a light at infinity). It is aimed from org at the sampled point itself: a ray
 * along w from org, parallel to p's, would meet the light's surface before or after it. */
static inline float shadow_ray(op_v3 p, op_v3 org, op_v3 w, float dist, op_v3 *dir)
{
    *dir = w;
    if (isinf(dist))
        return INFINITY;
    op_v3 q = v3_add(p, v3_scale(w, dist)), d = v3_sub(q, org);
    float len = v3_len(d);
    if (!(len > 0.0f))
        return 0.0f;
    *dir = v3_scale(d, 1.0f / len);
    float mag = fmaxf(1.0f, fmaxf(fabsf(q.x), fmaxf(fabsf(q.y), fabsf(q.z))));
    return fmaxf(len - fmaxf(1e-4f * len, 1e-4f * mag), 0.0f);
}

/* How many of op_bsdf_sample_dir's u1, u2, u3 a path should draw for bsdf: the lobe choice u3
 * only where there is a choice (any type not listed here gets all three). */
static inline int bsdf_sample_dims(const op_bsdf *b)
{
    return b->type == OP_BSDF_DIFFUSE || b->type == OP_BSDF_CONDUCTOR ||
                   b->type == OP_BSDF_THROUGH || b->type == OP_BSDF_SHEEN ||
                   b->type == OP_BSDF_ROUGHCONDUCTOR || b->type == OP_BSDF_ROUGHDIFFUSE
               ? 2
               : 3;
}

/* Whether emitter e is left to BSDF sampling alone where n_bsdf BSDF samples are taken: a
 * constant environment. For a constant radiance the BSDF's own distribution is the better
 * strategy (a cosine-weighted sample of a diffuse surface under open sky has no variance),
 * while its uniform sphere samples would waste half their shadow rays below the surface and
 * add variance even under the power heuristic. BSDF samples that reach it weigh 1. */
static inline int env_bsdf_only(const op_emitter *e, int n_bsdf)
{
    return e->type == OP_EM_CONSTANT && n_bsdf > 0;
}

#endif
