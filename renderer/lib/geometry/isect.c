/* isect.c - surface points from ray hits (see isect.h). */
#include "geometry/isect.h"

/* The derivatives of the surface position along its texture coordinates on the triangle with
 * corners a, b, c (world space) of texture coordinates ta, tb, tc: arbitrary tangents of the
 * geometric normal ng where the coordinates are degenerate, as Mitsuba 0.6 picks them. */
static void uv_tangents(op_v3 a, op_v3 b, op_v3 c, const float *ta, const float *tb,
                        const float *tc, op_v3 ng, op_v3 *dpdu, op_v3 *dpdv)
{
    float du1 = tb[0] - ta[0], dv1 = tb[1] - ta[1], du2 = tc[0] - ta[0], dv2 = tc[1] - ta[1];
    float det = du1 * dv2 - dv1 * du2;
    if (det == 0.0f || !isfinite(1.0f / det)) {
        op_frame f = op_frame_from_normal(ng);
        *dpdu = f.s;
        *dpdv = f.t;
        return;
    }
    op_v3 e1 = v3_sub(b, a), e2 = v3_sub(c, a);
    float inv = 1.0f / det;
    *dpdu = v3_scale(v3_sub(v3_scale(e1, dv2), v3_scale(e2, dv1)), inv);
    *dpdv = v3_scale(v3_sub(v3_scale(e2, du1), v3_scale(e1, du2)), inv);
}

void op_isect_from_hit(const op_scene *scene, const op_ray_hit *hit, op_v3 org, op_v3 dir,
                       op_isect *it)
{
    const op_shape_rec *sh = &scene->shapes[hit->shape];
    const op_trimesh *m = &sh->mesh;
    const uint32_t *idx = m->idx + 3 * (size_t)hit->prim;
    op_v3 a, b, c;
    op_trimesh_tri(m, hit->prim, &a, &b, &c);
    if (sh->instanced) {
        /* the corners in world space, and the winding they had as a world-space copy */
        a = op_place_point(&sh->place, a);
        b = op_place_point(&sh->place, b);
        c = op_place_point(&sh->place, c);
        if (sh->place.swap) {
            op_v3 t = b;
            b = c;
            c = t;
        }
    }
    float b0 = 1.0f - hit->b1 - hit->b2;
    float w1 = hit->b1, w2 = hit->b2; /* weights of corners b and c */
    if (sh->instanced && sh->place.swap) {
        w1 = hit->b2;
        w2 = hit->b1;
    }
    it->shape = hit->shape;
    it->prim = hit->prim;
    /* the barycentric point is more accurate than org + t dir far from the origin */
    it->p = v3_add(v3_add(v3_scale(a, b0), v3_scale(b, w1)), v3_scale(c, w2));
    (void)org;
    it->ng = v3_norm(v3_cross(v3_sub(b, a), v3_sub(c, a)));
    if (m->nrm) {
        const float *n = m->nrm;
        op_v3 n0 = v3(n[3 * idx[0]], n[3 * idx[0] + 1], n[3 * idx[0] + 2]);
        op_v3 n1 = v3(n[3 * idx[1]], n[3 * idx[1] + 1], n[3 * idx[1] + 2]);
        op_v3 n2 = v3(n[3 * idx[2]], n[3 * idx[2] + 1], n[3 * idx[2] + 2]);
        if (sh->instanced) {
            float sg = sh->place.flip ? -1.0f : 1.0f;
            n0 = v3_scale(v3_norm(op_place_normal(&sh->place, n0)), sg);
            n1 = v3_scale(v3_norm(op_place_normal(&sh->place, n1)), sg);
            n2 = v3_scale(v3_norm(op_place_normal(&sh->place, n2)), sg);
        }
        op_v3 ns = v3_norm(v3_add(v3_add(v3_scale(n0, b0), v3_scale(n1, hit->b1)),
                                  v3_scale(n2, hit->b2)));
        it->ns = v3_len(ns) > 0.0f ? ns : it->ng;
        if (v3_dot(it->ng, it->ns) < 0.0f)
            it->ng = v3_neg(it->ng);
    } else {
        it->ns = it->ng;
    }
    if (m->uv) {
        const float *t = m->uv;
        it->u = t[2 * idx[0]] * b0 + t[2 * idx[1]] * hit->b1 + t[2 * idx[2]] * hit->b2;
        it->v = t[2 * idx[0] + 1] * b0 + t[2 * idx[1] + 1] * hit->b1 + t[2 * idx[2] + 1] * hit->b2;
    } else {
        it->u = w1; /* as Embree reports them for a world-space copy */
        it->v = w2;
    }
    it->frame = op_frame_from_normal(it->ns);
    it->n0 = it->ns;
    it->shadow_a2 = 0.0f;
    const op_bsdf *bsdf = &scene->bsdfs[sh->bsdf];
    const op_bump *bump = &bsdf->bump;
    if (sh->sss < 0 && (bump->type != OP_BUMP_NONE || op_bsdf_is_anisotropic(bsdf))) {
        /* the frame whose s follows dp/du, and the tilt of a bumpmap or normalmap in it
         * (without texture coordinates the parameterization is barycentric, as in Mitsuba 3:
         * (u, v) the weights of corners b and c) */
        op_v3 dpdu = v3_sub(b, a), dpdv = v3_sub(c, a);
        if (m->uv) {
            const float *t = m->uv;
            int kb = sh->instanced && sh->place.swap ? 2 : 1; /* the corner b came from */
            uv_tangents(a, b, c, t + 2 * idx[0], t + 2 * idx[kb], t + 2 * idx[3 - kb], it->ng,
                        &dpdu, &dpdv);
        }
        op_frame sh_frame = op_frame_from_tangent(it->ns, dpdu);
        it->frame = bump->type == OP_BUMP_NONE
                        ? sh_frame
                        : op_bump_frame(bump, &sh_frame, it->ng, dpdu, dpdv, it->u, it->v,
                                        v3_neg(dir));
        if (bump->shadowing) {
            float ct = fminf(fabsf(v3_dot(it->frame.n, it->ns)), 1.0f);
            it->shadow_a2 = ct > 0.0f ? fminf(0.125f * (1.0f - ct * ct) / (ct * ct), 1.0f) : 1.0f;
        }
        it->ns = it->frame.n;
    }
}

op_v3 op_offset_origin(op_v3 p, op_v3 ng, op_v3 w)
{
    float mag = fmaxf(fabsf(p.x), fmaxf(fabsf(p.y), fabsf(p.z)));
    float eps = 1e-4f * fmaxf(1.0f, mag);
    return v3_add(p, v3_scale(ng, v3_dot(ng, w) >= 0.0f ? eps : -eps));
}
