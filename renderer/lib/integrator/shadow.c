/* shadow.c - shadow rays through passable surfaces and media (see shadow.h). */
#include "integrator/shadow.h"

#include "integrator/path_parts.h"

int op_medium_after(const op_scene *s, const op_isect *it, op_v3 w, int cur)
{
    const op_shape_rec *sh = &s->shapes[it->shape];
    if (sh->interior < 0 && sh->exterior < 0)
        return cur;
    return v3_dot(w, it->ng) < 0.0f ? sh->interior : sh->exterior;
}

op_v3 op_shadow_transmittance(const op_scene *s, op_v3 org, op_v3 dir, float tmax,
                              const op_shadow_media *media)
{
    int med = media ? media->med : -1;
    if (!s->has_passable) { /* the first surface met ends it: a medium cannot change */
        if (op_accel_occluded(s->accel, org, dir, 0.0f, tmax))
            return v3s(0.0f);
        return med >= 0 ? op_pmedium_transmittance(&s->media[med], org, dir, tmax, media->rng)
                        : v3s(1.0f);
    }
    op_v3 T = v3s(1.0f);
    op_v3 end = v3_add(org, v3_scale(dir, isinf(tmax) ? 0.0f : tmax));
    ray_walk w = walk_start(org, dir, 0.0f, tmax);
    for (;;) {
        op_ray_hit hit;
        int found = walk_intersect(s, &w, &hit);
        if (med >= 0)
            T = v3_mul(T, op_pmedium_transmittance(&s->media[med], w.org, w.dir,
                                                   found ? hit.t : w.tmax, media->rng));
        if (!found || v3_is_black(T))
            return T;
        const op_bsdf *pb = shape_passable(s, hit.shape);
        if (!pb)
            return v3s(0.0f);
        op_isect it;
        op_isect_from_hit(s, &hit, w.org, w.dir, &it);
        T = v3_mul(T, passage_at(pb, &it, w.dir).through);
        if (v3_is_black(T))
            return T;
        if (media)
            med = op_medium_after(s, &it, w.dir, med);
        if (!walk_past(&w, it.p, it.ng, hit.t))
            return v3s(0.0f);
        if (!isinf(tmax)) {
            /* aimed again at the fixed end from the origin moved off the surface: along the old
             * direction the ray would pass beside the end, and meet the light before it */
            op_v3 d = v3_sub(end, w.org);
            float len = v3_len(d);
            if (!(len > 0.0f) || v3_dot(d, w.dir) <= 0.0f)
                return T;
            w.dir = v3_scale(d, 1.0f / len);
            w.tmax = len;
        }
    }
}
