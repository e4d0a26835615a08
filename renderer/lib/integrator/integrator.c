/* integrator.c - path tracing, Mitsuba's direct lighting, debug views, irradiance (see
 * integrator.h). */
#include "integrator/integrator.h"

#include <string.h>

#include "camera/sampler.h"
#include "integrator/path_parts.h"
#include "integrator/shadow.h"
#include "integrator/volpath.h"

/* The white Lambertian used for irradiance estimates. */
static const op_bsdf white_bsdf = {.type = OP_BSDF_DIFFUSE, .reflectance = {1.0f, 1.0f, 1.0f}};

/* Next-event estimation at path vertex `depth`: n_light samples of every emitter (scenes have
 * few emitters, and sampling each avoids the noise of choosing between a strong and a weak one),
 * averaged, each weighted by the power heuristic against n_bsdf BSDF samples (Veach's
 * multi-sample MIS; the path tracer takes 1 and 1). Emitter k's samples use dimension key
 * OP_DIM(depth, OP_DIM_LIGHT, k). */
static op_v3 sample_direct(const op_scene *s, const op_isect *it, const op_bsdf *bsdf, op_v3 wi_l,
                           int n_light, int n_bsdf, int depth, op_path_sampler *ps)
{
    op_v3 sum = v3s(0.0f);
    for (int jk = 0; jk < n_light * s->nemitters; jk++) {
        int k = jk % s->nemitters;
        const op_emitter *e = &s->emitters[k];
        if (env_bsdf_only(e, n_bsdf))
            continue;
        float u[3] = {0.0f, 0.0f, 0.0f};
        op_path_sample_k(ps, OP_DIM(depth, OP_DIM_LIGHT, k), (uint32_t)(jk / s->nemitters),
                         (uint32_t)n_light, op_emitter_sample_dims(e), u);
        op_light_sample ls;
        if (!op_emitter_sample(e, it->p, u[0], u[1], u[2], &ls))
            continue;
        op_v3 wo_l = op_frame_to_local(&it->frame, ls.wi);
        /* light from below the geometric surface cannot arrive (guards shading-normal leaks) */
        if ((v3_dot(ls.wi, it->ng) > 0.0f) != (wo_l.z > 0.0f))
            continue;
        float bsdf_pdf;
        op_v3 f = v3_scale(op_bsdf_eval(bsdf, wi_l, wo_l, &bsdf_pdf),
                           op_isect_shadowing(it, ls.wi));
        if (v3_is_black(f))
            continue;
        op_v3 org = op_offset_origin(it->p, it->ng, ls.wi);
        op_v3 sd;
        float tmax = shadow_ray(it->p, org, ls.wi, ls.dist, &sd);
        op_v3 tr = op_shadow_transmittance(s, org, sd, tmax, NULL);
        if (v3_is_black(tr))
            continue;
        float w = ls.pdf > 0.0f ? op_mis((float)n_light * ls.pdf, (float)n_bsdf * bsdf_pdf) : 1.0f;
        sum = v3_add(sum, v3_scale(v3_mul(v3_mul(f, ls.value), tr), w));
    }
    return n_light == 1 ? sum : v3_scale(sum, 1.0f / (float)n_light);
}

/* What a path meets at it, coming from direction wi_world (pointing away from the surface).
 * *m gets pi times the radiance the surface itself sends towards wi_world: at a translucent
 * shape with the pre-pass's exitance M, on the lit side (black seen from behind), M itself
 * without a surface bsdf (the Rd holds both crossings of the boundary,
 * docs/subsurface-rendering.md) and M t(cos) exit_norm through one; black elsewhere. Returns
 * the BSDF to shade with: NULL where the path ends (a translucent shape with exitance and no
 * surface bsdf), the boundary's reflection lobe (with exitance and a surface bsdf), a
 * translucent shape's stand-in without exitance there (built in *proxy: diffuse of its mean
 * albedo, under a plastic interface where it has a surface bsdf), else the shape's own BSDF. */
static const op_bsdf *surface_at(const op_trace_ctx *ctx, const op_isect *it, op_v3 wi_world,
                                 op_bsdf *proxy, op_v3 *m)
{
    const op_scene *s = ctx->scene;
    const op_shape_rec *sh = &s->shapes[it->shape];
    *m = v3s(0.0f);
    if (sh->sss < 0)
        return op_bsdf_at(&s->bsdfs[sh->bsdf], it->u, it->v, proxy);
    const op_sss_desc *d = &s->sss[sh->sss];
    if (ctx->sss && op_sss_lookup(ctx->sss, sh->sss, it->p, it->ns, m)) {
        if (v3_dot(wi_world, it->ng) <= 0.0f)
            *m = v3s(0.0f);
        else if (d->has_boundary)
            *m = v3_scale(v3_mul(*m, op_bsdf_through_at(&d->through, v3_dot(wi_world, it->ns))),
                          d->through.exit_norm);
        return d->has_boundary ? &d->sheen : NULL;
    }
    if (d->has_boundary) {
        op_bsdf_sheen_standin(&d->sheen, d->albedo_mean, proxy);
        return proxy;
    }
    op_bsdf_default(proxy);
    proxy->reflectance = d->albedo_mean;
    return proxy;
}

/* The path-tracing loop. With start != NULL the path begins at that surface with bsdf
 * start_bsdf seen from direction wi (world, pointing away from the surface). A ray that passes
 * through a passable surface goes on in the same direction without counting a bounce; dist_acc
 * keeps the length of the straight segment since the last bounce for the emitters' MIS. */
static op_v3 trace(const op_trace_ctx *ctx, op_v3 org, op_v3 dir, float tmin, float tmax,
                   const op_isect *start, const op_bsdf *start_bsdf, op_path_sampler *ps,
                   float *alpha)
{
    const op_scene *s = ctx->scene;
    const op_integrator *ig = &s->integrator;
    int max_depth = ig->type == OP_INT_DIRECT ? 2 : ig->max_depth;
    op_v3 L = v3s(0.0f), beta = v3s(1.0f);
    float prev_pdf = 0.0f;
    int prev_delta = 1, depth = 0, at_start = start != NULL;
    ray_walk w = walk_start(org, dir, tmin, tmax);
    if (alpha)
        *alpha = 0.0f;
    op_isect it;
    op_bsdf proxy; /* a translucent shape's diffuse stand-in during the irradiance pass */
    for (;;) {
        const op_bsdf *bsdf;
        op_v3 wi_world;
        if (at_start) {
            at_start = 0;
            it = *start;
            bsdf = start_bsdf;
            wi_world = it.ns;
        } else {
            op_ray_hit hit;
            op_v3 d = w.dir;
            if (!walk_intersect(s, &w, &hit)) {
                const op_emitter *e = s->env >= 0 ? &s->emitters[s->env] : NULL;
                if (e && !(depth == 0 && !start && (ig->hide_emitters || e->camera_hidden))) {
                    op_v3 le = op_emitter_env_le(e, d);
                    float mis = 1.0f;
                    if (!prev_delta && !env_bsdf_only(e, 1))
                        mis = op_mis(prev_pdf, op_emitter_env_pdf(e, d));
                    L = v3_add(L, v3_scale(v3_mul(beta, le), mis));
                }
                break;
            }
            op_isect_from_hit(s, &hit, w.org, d, &it);
            wi_world = v3_neg(d);
            const op_shape_rec *sh = &s->shapes[it.shape];
            const op_emitter *e = sh->emitter >= 0 ? &s->emitters[sh->emitter] : NULL;
            if (e && !(depth == 0 && !start && (ig->hide_emitters || e->camera_hidden))) {
                op_v3 nw, le = area_emission(sh, e, it.prim, wi_world, &nw);
                if (!v3_is_black(le)) {
                    float mis = 1.0f;
                    if (!prev_delta)
                        mis = op_mis(prev_pdf, op_emitter_area_pdf(e, nw, d, w.dist + hit.t));
                    L = v3_add(L, v3_scale(v3_mul(beta, le), mis));
                }
            }
            const op_bsdf *pb = shape_passable(s, it.shape);
            if (pb) {
                op_bsdf_passage pa = passage_at(pb, &it, d);
                if (passage_passes(&pa, ps)) {
                    beta = v3_mul(beta, pa.pass);
                    if (v3_is_black(beta) || !walk_past(&w, it.p, it.ng, hit.t))
                        break;
                    continue;
                }
                beta = v3_mul(beta, pa.hit);
            }
            if (alpha)
                *alpha = 1.0f;
            if (max_depth >= 0 && depth + 2 > max_depth)
                break;
            op_v3 m;
            bsdf = surface_at(ctx, &it, wi_world, &proxy, &m);
            if (!bsdf || !v3_is_black(m))
                L = v3_add(L, v3_scale(v3_mul(beta, m), OP_INV_PI));
            if (!bsdf)
                break;
        }
        op_v3 wi_l = op_frame_to_local(&it.frame, wi_world);
        if (!op_bsdf_is_smooth_only(bsdf))
            L = v3_add(L, v3_mul(beta, sample_direct(s, &it, bsdf, wi_l, 1, 1, depth, ps)));
        float u[3] = {0.0f, 0.0f, 0.0f};
        op_path_sample(ps, OP_DIM(depth, OP_DIM_BSDF, 0), bsdf_sample_dims(bsdf), u);
        op_bsdf_sample bs;
        if (!op_bsdf_sample_dir(bsdf, wi_l, u[0], u[1], u[2], &bs))
            break;
        op_v3 wo = op_frame_to_world(&it.frame, bs.wo);
        if ((v3_dot(wo, it.ng) > 0.0f) != (bs.wo.z > 0.0f))
            break;
        beta = v3_mul(beta, v3_scale(bs.weight, op_isect_shadowing(&it, wo)));
        if (v3_is_black(beta) || !isfinite(v3_max(beta)))
            break;
        prev_pdf = bs.pdf;
        prev_delta = bs.delta;
        depth++;
        if (depth >= ig->rr_depth) {
            float q = fminf(v3_max(beta), 0.95f);
            float ur;
            op_path_sample(ps, OP_DIM(depth, OP_DIM_RR, 0), 1, &ur);
            if (ur >= q)
                break;
            beta = v3_scale(beta, 1.0f / q);
        }
        w = walk_start(op_offset_origin(it.p, it.ng, wo), wo, 0.0f, INFINITY);
    }
    return L;
}

/* Emission that a BSDF sample (direction dir from it, density pdf, delta or not) finds: the
 * first area emitter's front or the environment, through passable surfaces as the path tracer
 * passes them, weighted by the power heuristic of n_bsdf such samples against n_light samples of
 * the emitter found (weight 1 for delta samples). */
static op_v3 bsdf_sample_emission(const op_scene *s, const op_isect *it, op_v3 dir, float pdf,
                                  int delta, int n_light, int n_bsdf, op_path_sampler *ps)
{
    op_v3 L = v3s(0.0f), T = v3s(1.0f);
    ray_walk w = walk_start(op_offset_origin(it->p, it->ng, dir), dir, 0.0f, INFINITY);
    for (;;) {
        op_ray_hit hit;
        if (!walk_intersect(s, &w, &hit)) {
            if (s->env >= 0) {
                const op_emitter *e = &s->emitters[s->env];
                float mis = delta || env_bsdf_only(e, n_bsdf)
                                ? 1.0f
                                : op_mis((float)n_bsdf * pdf,
                                         (float)n_light * op_emitter_env_pdf(e, dir));
                L = v3_add(L, v3_scale(v3_mul(T, op_emitter_env_le(e, dir)), mis));
            }
            return L;
        }
        const op_shape_rec *sh = &s->shapes[hit.shape];
        if (sh->emitter >= 0) {
            const op_emitter *e = &s->emitters[sh->emitter];
            op_v3 nw, le = area_emission(sh, e, hit.prim, v3_neg(dir), &nw);
            if (!v3_is_black(le)) {
                float mis = delta ? 1.0f
                                  : op_mis((float)n_bsdf * pdf,
                                           (float)n_light *
                                               op_emitter_area_pdf(e, nw, dir, w.dist + hit.t));
                L = v3_add(L, v3_scale(v3_mul(T, le), mis));
            }
        }
        const op_bsdf *pb = shape_passable(s, hit.shape);
        if (!pb)
            return L;
        op_bsdf_passage pa = passage_at_hit(s, pb, &hit, w.org, dir);
        if (!passage_passes(&pa, ps))
            return L;
        T = v3_mul(T, pa.pass);
        if (v3_is_black(T))
            return L;
        op_v3 p = v3_add(w.org, v3_scale(dir, hit.t));
        if (!walk_past(&w, p, v3_norm(hit.ng), hit.t))
            return L;
    }
}

/* Mitsuba's `direct` integrator: emission seen along the camera ray (through passable surfaces),
 * then at the surface found emitterSamples samples of every emitter and bsdfSamples BSDF samples
 * combined by multiple importance sampling; no indirect light. A translucent shape shows its
 * pre-pass's exitance (or, without one, acts as a diffuse surface of its mean albedo). */
static op_v3 direct(const op_trace_ctx *ctx, op_v3 org, op_v3 dir, float tmin, float tmax,
                    op_path_sampler *ps, float *alpha)
{
    const op_scene *s = ctx->scene;
    const op_integrator *ig = &s->integrator;
    op_v3 L = v3s(0.0f), beta = v3s(1.0f);
    op_isect it;
    *alpha = 0.0f;
    ray_walk w = walk_start(org, dir, tmin, tmax);
    for (;;) {
        op_ray_hit hit;
        if (!walk_intersect(s, &w, &hit)) {
            if (s->env >= 0 && !ig->hide_emitters && !s->emitters[s->env].camera_hidden)
                L = v3_add(L, v3_mul(beta, op_emitter_env_le(&s->emitters[s->env], dir)));
            return L;
        }
        op_isect_from_hit(s, &hit, w.org, dir, &it);
        const op_shape_rec *sh = &s->shapes[it.shape];
        if (sh->emitter >= 0 && !ig->hide_emitters && !s->emitters[sh->emitter].camera_hidden) {
            op_v3 nw;
            L = v3_add(L, v3_mul(beta, area_emission(sh, &s->emitters[sh->emitter], it.prim,
                                                     v3_neg(dir), &nw)));
        }
        const op_bsdf *pb = shape_passable(s, it.shape);
        if (pb) {
            op_bsdf_passage pa = passage_at(pb, &it, dir);
            if (passage_passes(&pa, ps)) {
                beta = v3_mul(beta, pa.pass);
                if (v3_is_black(beta) || !walk_past(&w, it.p, it.ng, hit.t))
                    return L;
                continue;
            }
            beta = v3_mul(beta, pa.hit);
        }
        break;
    }
    *alpha = 1.0f;
    op_bsdf proxy;
    op_v3 m;
    const op_bsdf *bsdf = surface_at(ctx, &it, v3_neg(dir), &proxy, &m);
    if (!bsdf)
        return v3_add(L, v3_scale(v3_mul(beta, m), OP_INV_PI));
    if (!v3_is_black(m))
        L = v3_add(L, v3_scale(v3_mul(beta, m), OP_INV_PI));
    int nl = ig->emitter_samples, nb = ig->bsdf_samples;
    op_v3 wi_l = op_frame_to_local(&it.frame, v3_neg(dir));
    if (nl > 0 && !op_bsdf_is_smooth_only(bsdf))
        L = v3_add(L, v3_mul(beta, sample_direct(s, &it, bsdf, wi_l, nl, nb, 0, ps)));
    op_v3 sum = v3s(0.0f);
    for (int k = 0; k < nb; k++) {
        float u[3] = {0.0f, 0.0f, 0.0f};
        op_path_sample_k(ps, OP_DIM(0, OP_DIM_BSDF, 0), (uint32_t)k, (uint32_t)nb,
                         bsdf_sample_dims(bsdf), u);
        op_bsdf_sample bs;
        if (!op_bsdf_sample_dir(bsdf, wi_l, u[0], u[1], u[2], &bs))
            continue;
        op_v3 wo = op_frame_to_world(&it.frame, bs.wo);
        if ((v3_dot(wo, it.ng) > 0.0f) != (bs.wo.z > 0.0f) || v3_is_black(bs.weight))
            continue;
        op_v3 le = bsdf_sample_emission(s, &it, wo, bs.pdf, bs.delta, nl, nb, ps);
        sum = v3_add(sum, v3_mul(v3_scale(bs.weight, op_isect_shadowing(&it, wo)), le));
    }
    if (nb > 0)
        L = v3_add(L, v3_mul(beta, v3_scale(sum, 1.0f / (float)nb)));
    return L;
}

/* The debug views; passable surfaces are seen through as by the path tracer (stochastically
 * where partly opaque). */
static op_v3 debug_view(const op_trace_ctx *ctx, op_v3 org, op_v3 dir, float tmin, float tmax,
                        op_path_sampler *ps, float *alpha)
{
    const op_scene *s = ctx->scene;
    op_ray_hit hit;
    op_isect it;
    *alpha = 0.0f;
    ray_walk w = walk_start(org, dir, tmin, tmax);
    for (;;) {
        if (!walk_intersect(s, &w, &hit))
            return v3s(0.0f);
        op_isect_from_hit(s, &hit, w.org, dir, &it);
        const op_bsdf *pb = shape_passable(s, it.shape);
        if (!pb)
            break;
        op_bsdf_passage pa = passage_at(pb, &it, dir);
        if (!passage_passes(&pa, ps))
            break;
        if (!walk_past(&w, it.p, it.ng, hit.t))
            return v3s(0.0f);
    }
    *alpha = 1.0f;
    const op_shape_rec *sh = &s->shapes[it.shape];
    switch (s->integrator.type) {
    case OP_INT_NORMALS:
        return it.ns;
    case OP_INT_UV:
        return v3(it.u, it.v, 0.0f);
    default:
        if (sh->sss >= 0)
            return s->sss[sh->sss].albedo_mean;
        return op_bsdf_albedo(op_bsdf_at(&s->bsdfs[sh->bsdf], it.u, it.v, &(op_bsdf){0}));
    }
}

op_v3 op_li(const op_trace_ctx *ctx, op_v3 org, op_v3 dir, float tmin, float tmax,
            op_path_sampler *ps, float *alpha)
{
    op_integrator_type t = ctx->scene->integrator.type;
    if (t == OP_INT_NORMALS || t == OP_INT_UV || t == OP_INT_ALBEDO)
        return debug_view(ctx, org, dir, tmin, tmax, ps, alpha);
    if (t == OP_INT_DIRECT)
        return direct(ctx, org, dir, tmin, tmax, ps, alpha);
    if (ctx->scene->integrator.volumetric && ctx->scene->nmedia > 0)
        return op_volpath_li(ctx->scene, org, dir, tmin, tmax, ps, alpha);
    return trace(ctx, org, dir, tmin, tmax, NULL, NULL, ps, alpha);
}

void op_camera_sss_hits(const op_scene *s, op_v3 org, op_v3 dir, float tmin, float tmax,
                        int max_bounces, op_rng *rng, op_sss_cam_fn hit_fn, void *user)
{
    const op_integrator *ig = &s->integrator;
    int max_depth = ig->type == OP_INT_DIRECT ? 2 : ig->max_depth;
    float len = 0.0f;
    ray_walk w = walk_start(org, dir, tmin, tmax);
    for (int depth = 0;;) {
        op_ray_hit hit;
        op_isect it;
        if (!walk_intersect(s, &w, &hit))
            return;
        op_isect_from_hit(s, &hit, w.org, w.dir, &it);
        len += hit.t;
        const op_shape_rec *sh = &s->shapes[it.shape];
        const op_bsdf *pb = shape_passable(s, it.shape);
        if (pb && passage_at(pb, &it, w.dir).stop < 1.0f) {
            if (!walk_past(&w, it.p, it.ng, hit.t))
                return;
            continue;
        }
        if (max_depth >= 0 && depth + 2 > max_depth)
            return;
        const op_bsdf *bsdf;
        if (sh->sss < 0) {
            bsdf = &s->bsdfs[sh->bsdf];
        } else {
            /* the path tracer goes on with the sheen's reflection where the exitance is known,
             * which the hit makes it */
            const op_sss_desc *d = &s->sss[sh->sss];
            if (!hit_fn(user, &it, len, fabsf(v3_dot(w.dir, it.ng))) || !d->has_boundary)
                return;
            bsdf = &d->sheen;
        }
        if (!op_bsdf_is_smooth_only(bsdf) || depth >= max_bounces)
            return;
        op_v3 wi_l = op_frame_to_local(&it.frame, v3_neg(w.dir));
        float u1 = op_rng_float(rng), u2 = op_rng_float(rng), u3 = op_rng_float(rng);
        op_bsdf_sample bs;
        if (!op_bsdf_sample_dir(bsdf, wi_l, u1, u2, u3, &bs))
            return;
        op_v3 wo = op_frame_to_world(&it.frame, bs.wo);
        if ((v3_dot(wo, it.ng) > 0.0f) != (bs.wo.z > 0.0f))
            return;
        depth++;
        w = walk_start(op_offset_origin(it.p, it.ng, wo), wo, 0.0f, INFINITY);
    }
}

op_v3 op_irradiance(const op_scene *scene, int sss, op_v3 p, op_v3 ng, op_v3 ns, op_rng *rng)
{
    op_bsdf through = white_bsdf;
    if (sss >= 0 && scene->sss[sss].has_boundary) {
        through.type = OP_BSDF_THROUGH;
        through.through = &scene->sss[sss].through;
    }
    const op_trace_ctx ctx = {scene, NULL};
    op_isect it;
    memset(&it, 0, sizeof it);
    it.p = p;
    it.ng = ng;
    it.ns = ns;
    it.frame = op_frame_from_normal(ns);
    it.shape = -1;
    op_path_sampler ps = op_path_sampler_from_rng(*rng);
    op_v3 L = trace(&ctx, p, ns, 0.0f, INFINITY, &it, &through, &ps, NULL);
    *rng = ps.rng;
    return v3_scale(L, OP_PI);
}

const op_sss_transport op_path_transport = {op_irradiance, op_camera_sss_hits};
