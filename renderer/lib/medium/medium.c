/* medium.c - homogeneous and heterogeneous media (see medium.h). */
#include "medium/medium.h"

#include <math.h>

/* The most tentative collisions one tracking walk takes: a guard against a walk that never
 * ends (an unbounded medium whose hero channel is clear while another is not); past it the
 * segment counts as absorbed. */
#define OP_MAX_COLLISIONS (1 << 20)

void op_pmedium_free(op_pmedium *m)
{
    op_volume_free(m->extinction);
    op_volume_free(m->albedo);
    m->extinction = m->albedo = NULL;
}

/* exp(-s d) for one channel, with 0 * infinity taken as 0. */
static float tr1(float s, float d)
{
    return s > 0.0f ? expf(-s * d) : 1.0f;
}

static op_v3 homogeneous_tr(const op_pmedium *m, float d)
{
    return v3(tr1(m->sigma_t.x, d), tr1(m->sigma_t.y, d), tr1(m->sigma_t.z, d));
}

/* The part [*t0, *t1) of the segment [0, tmax) where the medium's extinction may be nonzero;
 * 0 when there is none. */
static int tracked_span(const op_pmedium *m, op_v3 org, op_v3 dir, float tmax, float *t0, float *t1)
{
    *t0 = 0.0f;
    *t1 = tmax;
    if (!(m->majorant > 0.0f))
        return 0;
    float a, b;
    if (op_volume_ray_span(m->extinction, org, dir, &a, &b)) {
        *t0 = fmaxf(a, 0.0f);
        *t1 = fminf(b, tmax);
    }
    return *t0 < *t1;
}

static op_v3 sigma_t_at(const op_pmedium *m, op_v3 p)
{
    op_v3 s = v3_scale(op_volume_eval(m->extinction, p), m->scale);
    return v3(fmaxf(s.x, 0.0f), fmaxf(s.y, 0.0f), fmaxf(s.z, 0.0f));
}

/* The majorant over a piece of the walk whose extinction grid values are at most bound: never
 * above the medium's own. */
static float local_majorant(const op_pmedium *m, float bound)
{
    if (!(m->scale >= 0.0f))
        return m->majorant;
    return fminf(m->majorant, fmaxf(m->scale * bound, 0.0f));
}

/* The bricks of a tracking walk along a segment: those of its tracked span whose majorant is
 * positive, in order (empty bricks skipped). */
typedef struct brick_walk {
    const op_pmedium *m;
    op_volume_walk walk;
    int live;
} brick_walk;

/* Starts the walk along org + t dir, t in [0, tmax). */
static void brick_walk_start(brick_walk *bw, const op_pmedium *m, op_v3 org, op_v3 dir, float tmax)
{
    float t0, t1;
    bw->m = m;
    bw->live = tracked_span(m, org, dir, tmax, &t0, &t1);
    if (bw->live)
        op_volume_walk_start(&bw->walk, m->extinction, org, dir, t0, t1);
}

/* The next brick: its piece [*a, *b) of the segment and its majorant *maj > 0; 0 at the end. */
static int brick_walk_next(brick_walk *bw, float *a, float *b, float *maj)
{
    float bound;
    while (bw->live) {
        if (!op_volume_walk_next(&bw->walk, a, b, &bound)) {
            bw->live = 0;
            break;
        }
        *maj = local_majorant(bw->m, bound);
        if (*maj > 0.0f)
            return 1;
    }
    return 0;
}

/* Ratio tracking: each tentative collision at the rate of the local majorant (restarting at
 * every brick) multiplies the estimate by the null fraction 1 - sigma_t / majorant of each
 * channel; Russian roulette once it is small. */
static op_v3 ratio_tracking(const op_pmedium *m, op_v3 org, op_v3 dir, float d, op_rng *rng)
{
    float a, b, maj;
    op_v3 T = v3s(1.0f);
    brick_walk bw;
    brick_walk_start(&bw, m, org, dir, d);
    int k = 0;
    while (brick_walk_next(&bw, &a, &b, &maj)) {
        float inv = 1.0f / maj, t = a;
        for (;;) {
            if (++k > OP_MAX_COLLISIONS)
                return v3s(0.0f);
            t -= log1pf(-op_rng_float(rng)) * inv;
            if (!(t < b))
                break;
            op_v3 st = sigma_t_at(m, v3_add(org, v3_scale(dir, t)));
            T = v3_mul(T, v3(fmaxf(1.0f - st.x * inv, 0.0f), fmaxf(1.0f - st.y * inv, 0.0f),
                             fmaxf(1.0f - st.z * inv, 0.0f)));
            float big = v3_max(T);
            if (big < 0.1f) {
                if (!(big > 0.0f) || op_rng_float(rng) < 0.5f)
                    return v3s(0.0f);
                T = v3_scale(T, 2.0f);
            }
        }
    }
    return T;
}

op_v3 op_pmedium_transmittance(const op_pmedium *m, op_v3 org, op_v3 dir, float d, op_rng *rng)
{
    if (!m->extinction)
        return homogeneous_tr(m, d);
    return ratio_tracking(m, org, dir, d, rng);
}

static int homogeneous_sample(const op_pmedium *m, int c, float tmax, float u, float *t, op_v3 *f,
                              op_v3 *pdf)
{
    float sc = v3_get(m->sigma_t, c);
    float d = sc > 0.0f ? -log1pf(-u) / sc : INFINITY;
    int scattered = d < tmax;
    *t = scattered ? d : tmax;
    op_v3 tr = homogeneous_tr(m, *t);
    *f = scattered ? v3_mul(m->sigma_s, tr) : tr;
    *pdf = scattered ? v3_mul(m->sigma_t, tr) : tr;
    return scattered;
}

/* Delta tracking against the local majorant (restarting at every brick) by channel c: a
 * tentative collision at x is real with probability sigma_t,c(x) / majorant, else null. The
 * majorant's exponential factors are the same for every channel and cancel, so per channel a
 * real collision weighs sigma_s (f) and sigma_t (pdf), a null one sigma_n = majorant - sigma_t
 * (both), all over channel c's. */
static int delta_tracking(const op_pmedium *m, int c, op_v3 org, op_v3 dir, float tmax, float u,
                          op_rng *rng, float *t, op_v3 *f, op_v3 *pdf)
{
    float a, b, maj;
    *t = tmax;
    *f = *pdf = v3s(1.0f);
    brick_walk bw;
    brick_walk_start(&bw, m, org, dir, tmax);
    int k = 0;
    while (brick_walk_next(&bw, &a, &b, &maj)) {
        float inv = 1.0f / maj, x = a;
        for (;;) {
            if (++k > OP_MAX_COLLISIONS) {
                *f = *pdf = v3s(0.0f);
                return 0;
            }
            x -= log1pf(-(k == 1 ? u : op_rng_float(rng))) * inv;
            if (!(x < b))
                break;
            op_v3 p = v3_add(org, v3_scale(dir, x));
            op_v3 st = sigma_t_at(m, p);
            float sc = v3_get(st, c);
            if (op_rng_float(rng) * maj < sc) {
                op_v3 al = op_volume_eval(m->albedo, p);
                *f = v3_mul(*f, v3_scale(v3_mul(st, al), 1.0f / sc));
                *pdf = v3_mul(*pdf, v3_scale(st, 1.0f / sc));
                *t = x;
                return 1;
            }
            op_v3 sn =
                v3(fmaxf(maj - st.x, 0.0f), fmaxf(maj - st.y, 0.0f), fmaxf(maj - st.z, 0.0f));
            op_v3 wn = v3_scale(sn, 1.0f / v3_get(sn, c));
            *f = v3_mul(*f, wn);
            *pdf = v3_mul(*pdf, wn);
        }
    }
    return 0;
}

int op_pmedium_sample_distance(const op_pmedium *m, int c, op_v3 org, op_v3 dir, float tmax,
                               float u, op_rng *rng, float *t, op_v3 *f, op_v3 *pdf)
{
    if (!m->extinction)
        return homogeneous_sample(m, c, tmax, u, t, f, pdf);
    return delta_tracking(m, c, org, dir, tmax, u, rng, t, f, pdf);
}
