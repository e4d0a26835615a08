/* volpath.c - the volumetric path tracer (see volpath.h). */
#include "integrator/volpath.h"

#include "integrator/path_parts.h"
#include "integrator/shadow.h"

/* The most path vertices (scattering events and bounces) one path may have: a guard against a
 * path trapped in a closed non-absorbing medium, where Russian roulette never stops it. */
#define OP_MAX_VERTICES 65536

/* A path vertex: a surface point (bsdf != NULL, it filled) or a scattering point in medium
 * `med` (bsdf NULL, p and the medium's phase function). */
typedef struct vertex {
    op_v3 p;
    const op_isect *it;
    const op_bsdf *bsdf;
    int med;
} vertex;

/* The scattering function of vertex v for wi -> wo (world, wi pointing back along the arriving
 * path), cosine included, and its sampling density *pdf. */
static op_v3 vertex_eval(const op_scene *s, const vertex *v, op_v3 wi, op_v3 wo, float *pdf)
{
    if (!v->bsdf) {
        *pdf = op_phase_eval(&s->media[v->med].phase, wi, wo);
        return v3s(*pdf);
    }
    op_v3 wi_l = op_frame_to_local(&v->it->frame, wi);
    op_v3 wo_l = op_frame_to_local(&v->it->frame, wo);
    /* light from below the geometric surface cannot arrive (guards shading-normal leaks) */
    if ((v3_dot(wo, v->it->ng) > 0.0f) != (wo_l.z > 0.0f)) {
        *pdf = 0.0f;
        return v3s(0.0f);
    }
    return v3_scale(op_bsdf_eval(v->bsdf, wi_l, wo_l, pdf), op_isect_shadowing(v->it, wo));
}

/* Next-event estimation at vertex v (path vertex `depth`, light arriving along -wi's
 * complement): one sample of every emitter but a constant environment (left to BSDF and phase
 * sampling, as the path tracer does), through media and index-matched boundaries, weighted by
 * the power heuristic against the vertex's own sampling. */
static op_v3 sample_direct(const op_scene *s, const vertex *v, op_v3 wi, int depth,
                           op_path_sampler *ps)
{
    op_v3 sum = v3s(0.0f);
    for (int k = 0; k < s->nemitters; k++) {
        const op_emitter *e = &s->emitters[k];
        if (env_bsdf_only(e, 1))
            continue;
        float u[3] = {0.0f, 0.0f, 0.0f};
        op_path_sample(ps, OP_DIM(depth, OP_DIM_LIGHT, k), op_emitter_sample_dims(e), u);
        op_light_sample ls;
        if (!op_emitter_sample(e, v->p, u[0], u[1], u[2], &ls))
            continue;
        float pdf;
        op_v3 f = vertex_eval(s, v, wi, ls.wi, &pdf);
        if (v3_is_black(f))
            continue;
        op_v3 org = v->p;
        int med = v->med;
        if (v->bsdf) {
            org = op_offset_origin(v->it->p, v->it->ng, ls.wi);
            med = op_medium_after(s, v->it, ls.wi, v->med);
        }
        op_v3 sd;
        float tmax = shadow_ray(v->p, org, ls.wi, ls.dist, &sd);
        const op_shadow_media media = {med, &ps->rng};
        op_v3 tr = op_shadow_transmittance(s, org, sd, tmax, &media);
        if (v3_is_black(tr))
            continue;
        float w = ls.pdf > 0.0f ? op_mis(ls.pdf, pdf) : 1.0f;
        sum = v3_add(sum, v3_scale(v3_mul(v3_mul(f, ls.value), tr), w));
    }
    return sum;
}

/* The path's throughput: beta (its contributions over the hero channel's densities) divided
 * by the densities of all channels relative to the hero's (r), averaged: one-sample MIS over
 * the channels' distance sampling strategies, for the whole path. */
static op_v3 throughput(op_v3 beta, op_v3 r)
{
    float avg = (r.x + r.y + r.z) / 3.0f;
    return avg > 0.0f && isfinite(avg) ? v3_scale(beta, 1.0f / avg) : v3s(0.0f);
}

op_v3 op_volpath_li(const op_scene *s, op_v3 org, op_v3 dir, float tmin, float tmax,
                    op_path_sampler *ps, float *alpha)
{
    const op_integrator *ig = &s->integrator;
    op_v3 L = v3s(0.0f), beta = v3s(1.0f), r = v3s(1.0f);
    float prev_pdf = 0.0f, dist = 0.0f; /* dist: the path's length since its last vertex */
    int prev_delta = 1, depth = 0, med = s->camera_medium, passes = 0;
    float uc;
    op_path_sample(ps, OP_DIM(0, OP_DIM_MEDIUM, 0xffff), 1, &uc);
    int hero = uc < 1.0f / 3.0f ? 0 : (uc < 2.0f / 3.0f ? 1 : 2);
    ray_walk w = walk_start(org, dir, tmin, tmax);
    *alpha = 0.0f;
    for (;;) {
        op_ray_hit hit;
        int found = walk_intersect(s, &w, &hit);
        vertex v = {v3s(0.0f), NULL, NULL, med};
        op_isect it;
        op_bsdf scratch;
        int scattered = 0;
        if (med >= 0) {
            float u, t;
            op_v3 f, pdf;
            op_path_sample(ps, OP_DIM(depth, OP_DIM_MEDIUM, passes), 1, &u);
            scattered = op_pmedium_sample_distance(&s->media[med], hero, w.org, w.dir,
                                                   found ? hit.t : w.tmax, u, &ps->rng, &t, &f,
                                                   &pdf);
            float ph = v3_get(pdf, hero);
            if (!(ph > 0.0f))
                break;
            beta = v3_mul(beta, v3_scale(f, 1.0f / ph));
            r = v3_mul(r, v3_scale(pdf, 1.0f / ph));
            if (v3_is_black(throughput(beta, r)) || (!scattered && !found))
                break; /* (an infinite medium's segment ends nowhere) */
            v.p = v3_add(w.org, v3_scale(w.dir, t));
        }
        if (!scattered && !found) {
            const op_emitter *e = s->env >= 0 ? &s->emitters[s->env] : NULL;
            if (e && !(depth == 0 && (ig->hide_emitters || e->camera_hidden))) {
                float mis = 1.0f;
                if (!prev_delta && !env_bsdf_only(e, 1))
                    mis = op_mis(prev_pdf, op_emitter_env_pdf(e, w.dir));
                L = v3_add(L, v3_scale(v3_mul(throughput(beta, r), op_emitter_env_le(e, w.dir)),
                                        mis));
            }
            break;
        }
        if (!scattered) {
            op_isect_from_hit(s, &hit, w.org, w.dir, &it);
            dist += hit.t;
            const op_shape_rec *sh = &s->shapes[it.shape];
            const op_emitter *e = sh->emitter >= 0 ? &s->emitters[sh->emitter] : NULL;
            if (e && !(depth == 0 && (ig->hide_emitters || e->camera_hidden))) {
                op_v3 nw, le = area_emission(sh, e, it.prim, v3_neg(w.dir), &nw);
                if (!v3_is_black(le)) {
                    float mis = 1.0f;
                    if (!prev_delta)
                        mis = op_mis(prev_pdf, op_emitter_area_pdf(e, nw, w.dir, dist));
                    L = v3_add(L, v3_scale(v3_mul(throughput(beta, r), le), mis));
                }
            }
            const op_bsdf *pb = shape_passable(s, it.shape);
            if (pb) {
                op_bsdf_passage pa = passage_at(pb, &it, w.dir);
                if (passage_passes(&pa, ps)) {
                    beta = v3_mul(beta, pa.pass);
                    med = op_medium_after(s, &it, w.dir, med);
                    passes++;
                    if (v3_is_black(beta) || !walk_past(&w, it.p, it.ng, hit.t))
                        break;
                    continue;
                }
                beta = v3_mul(beta, pa.hit);
            }
            v.p = it.p;
            v.it = &it;
            v.bsdf = op_bsdf_at(&s->bsdfs[sh->bsdf], it.u, it.v, &scratch);
        }
        *alpha = 1.0f;
        if ((ig->max_depth >= 0 && depth + 2 > ig->max_depth) || depth >= OP_MAX_VERTICES)
            break;
        op_v3 wi = v3_neg(w.dir), wo;
        if (!v.bsdf || !op_bsdf_is_smooth_only(v.bsdf))
            L = v3_add(L, v3_mul(throughput(beta, r), sample_direct(s, &v, wi, depth, ps)));
        float u[3] = {0.0f, 0.0f, 0.0f};
        if (!v.bsdf) {
            op_path_sample(ps, OP_DIM(depth, OP_DIM_BSDF, 0), 2, u);
            prev_pdf = op_phase_sample(&s->media[med].phase, wi, u[0], u[1], &wo);
            prev_delta = 0;
            w = walk_start(v.p, wo, 0.0f, INFINITY);
        } else {
            op_path_sample(ps, OP_DIM(depth, OP_DIM_BSDF, 0), bsdf_sample_dims(v.bsdf), u);
            op_bsdf_sample bs;
            op_v3 wi_l = op_frame_to_local(&v.it->frame, wi);
            if (!op_bsdf_sample_dir(v.bsdf, wi_l, u[0], u[1], u[2], &bs))
                break;
            wo = op_frame_to_world(&v.it->frame, bs.wo);
            if ((v3_dot(wo, v.it->ng) > 0.0f) != (bs.wo.z > 0.0f))
                break;
            beta = v3_mul(beta, v3_scale(bs.weight, op_isect_shadowing(v.it, wo)));
            prev_pdf = bs.pdf;
            prev_delta = bs.delta;
            med = op_medium_after(s, v.it, wo, med);
            w = walk_start(op_offset_origin(v.it->p, v.it->ng, wo), wo, 0.0f, INFINITY);
        }
        if (v3_is_black(beta) || !isfinite(v3_max(beta)))
            break;
        depth++;
        passes = 0;
        dist = 0.0f;
        if (depth >= ig->rr_depth) {
            /* on the throughput alone: never below 1, so a bright path is not cut short */
            float q = fminf(v3_max(throughput(beta, r)), 1.0f), ur;
            op_path_sample(ps, OP_DIM(depth, OP_DIM_RR, 0), 1, &ur);
            if (ur >= q)
                break;
            beta = v3_scale(beta, 1.0f / q);
        }
    }
    return L;
}
