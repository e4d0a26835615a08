/* lookup.c - the exitance lookups over a translucent shape's pre-pass result (see lookup.h). */
#include "sss/lookup.h"

#include <limits.h>
#include <stdlib.h>
#include <string.h>

void op_sss_lookup_free(look_set *lk)
{
    free(lk->pos);
    free(lk->pts);
    free(lk->at);
    free(lk->runs);
    memset(lk, 0, sizeof *lk);
}

op_status op_sss_lookup_prepare(sss_shape *ss, op_error *err)
{
    const sss_grid *g = ss->rep ? &ss->look : &ss->interp;
    look_set *lk = &ss->lk;
    size_t n = 0, slots = g->occ.size, nruns = 0;
    for (int i = 0; ss->pts && i < ss->n; i++)
        n += !ss->rep || ss->rep[i];
    op_sss_lookup_free(lk);
    lk->pos = malloc((n ? n : 1) * sizeof *lk->pos);
    lk->pts = malloc((n ? n : 1) * sizeof *lk->pts);
    lk->at = malloc(2 * (slots ? slots : 1) * sizeof *lk->at);
    lk->runs = malloc(2 * 9 * (g->occ.count ? g->occ.count : 1) * sizeof *lk->runs);
    if (!lk->pos || !lk->pts || !lk->at || !lk->runs) {
        op_sss_lookup_free(lk);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for %d irradiance points", ss->n);
    }
    for (size_t k = 0; k < n; k++) {
        uint32_t i = g->items[k];
        const sss_point *q = &ss->pts[i];
        lk->pos[k] = q->p;
        lk->pts[k] = (look_pt){q->n.x, q->n.y, q->n.z, q->m,
                               ss->recv && ss->recv[i]};
    }
    for (size_t b = 0; b < slots; b++) {
        const int32_t *c = g->occ.tab + 3 * b;
        lk->at[2 * b] = (uint32_t)nruns;
        lk->at[2 * b + 1] = 0;
        if (c[0] == INT32_MIN)
            continue;
        for (int dz = -1; dz <= 1; dz++)
            for (int dy = -1; dy <= 1; dy++) {
                int row = 0; /* the row's points so far make a run */
                for (int dx = -1; dx <= 1; dx++) {
                    int32_t nc[3] = {c[0] + dx, c[1] + dy, c[2] + dz};
                    uint32_t k0, k1;
                    if (!grid_cell(g, nc, &k0, &k1))
                        continue;
                    if (row && lk->runs[2 * nruns - 1] == k0) {
                        lk->runs[2 * nruns - 1] = k1;
                        continue;
                    }
                    lk->runs[2 * nruns] = k0;
                    lk->runs[2 * nruns++ + 1] = k1;
                    lk->at[2 * b + 1]++;
                    row = 1;
                }
            }
    }
    return OP_OK;
}

/* A lookup's running sum (lookup_within): the exitance at p (normal n) from the points within
 * h (h2 = h^2). The points are screened by distance in batches, without data-dependent branches,
 * and those within h then summed in the order they came. */
enum { LOOK_BATCH = 64 };
/* The axes of the six entries of a symmetric 3 x 3 matrix: xx yy zz xy xz yz. */
static const int pair_a[6] = {0, 1, 2, 0, 0, 1}, pair_b[6] = {0, 1, 2, 1, 2, 2};
typedef struct look_sum {
    const sss_shape *ss;
    op_v3 p, n, m;
    float h2, wsum;
    int ok, nb;
    int linear;             /* the dipole's: also the moments of the local linear fit */
    float sd[3], sdd[6];    /* sum of w d and of w d d^T (pair_a, pair_b), d = x_j - p */
    float smd[3][3];        /* per channel: sum of w M d */
    float lo[3], hi[3];     /* per channel: the least and greatest M summed */
    uint32_t k[LOOK_BATCH]; /* the screened points */
    float w[LOOK_BATCH];    /* and their 1 - r^2/h^2 */
} look_sum;

/* Sums the screened points: weights 1 - r^2/h^2, or for the centred layout Franke and Little's
 * ((h - r) / r)^2 (each point's own value at its position, the material pixel's exitance at its
 * centre, smooth between); same-side normals only. */
static void look_flush(look_sum *ls)
{
    const sss_shape *ss = ls->ss;
    for (int b = 0; b < ls->nb; b++) {
        const look_pt *q = &ss->lk.pts[ls->k[b]];
        float w = ls->w[b];
        if (q->nx * ls->n.x + q->ny * ls->n.y + q->nz * ls->n.z <= 0.0f)
            continue;
        if (ss->centred) {
            float r = sqrtf(1.0f - w);
            w = (1.0f - r) / (r + 1e-4f);
            w *= w;
        } else if (ss->rep) { /* thinned receivers: the nearest count most (a narrower blur) */
            w *= w * w * w;
        }
        ls->ok &= q->recv;
        ls->wsum += w;
        ls->m = v3_add(ls->m, v3_scale(q->m, w));
        if (ls->linear) {
            op_v3 pj = ss->lk.pos[ls->k[b]];
            const float d[3] = {pj.x - ls->p.x, pj.y - ls->p.y, pj.z - ls->p.z};
            const float wd[3] = {w * d[0], w * d[1], w * d[2]}, mj[3] = {q->m.x, q->m.y, q->m.z};
            for (int a = 0; a < 3; a++)
                ls->sd[a] += wd[a];
            for (int a = 0; a < 6; a++)
                ls->sdd[a] += wd[pair_a[a]] * d[pair_b[a]];
            for (int c = 0; c < 3; c++) {
                for (int a = 0; a < 3; a++)
                    ls->smd[c][a] += mj[c] * wd[a];
                ls->lo[c] = fminf(ls->lo[c], mj[c]);
                ls->hi[c] = fmaxf(ls->hi[c], mj[c]);
            }
        }
    }
    ls->nb = 0;
}

/* The dipole's exitance at p from the moments of ls (wsum > 0): per channel, the value at p of
 * the weighted least-squares fit M(x) = M(p) + b . (x - p) over the points summed. Exact where
 * the exitance varies linearly (the weighted mean is off there by the gradient times the offset
 * of the points' weighted centroid from p: a few per cent in a profile's steep tail). b is
 * solved with a ridge of h^2 / 1000 (h the lookup radius), so that a direction the points do not
 * span (their plane's normal, a row of points) gets none; the value is clamped to the range of
 * the M summed, so that it never extrapolates past them (at an open edge). */
static op_v3 linear_fit(const look_sum *ls)
{
    double iw = 1.0 / ls->wsum, xm[3], C[6], ridge = 1e-3 * ls->h2;
    for (int a = 0; a < 3; a++)
        xm[a] = ls->sd[a] * iw;
    for (int a = 0; a < 6; a++)
        C[a] = ls->sdd[a] * iw - xm[pair_a[a]] * xm[pair_b[a]] + (a < 3 ? ridge : 0.0);
    /* the inverse of the symmetric C by its adjugate (C is positive definite: the ridge) */
    double A00 = C[1] * C[2] - C[5] * C[5], A01 = C[4] * C[5] - C[3] * C[2];
    double A02 = C[3] * C[5] - C[4] * C[1], A11 = C[0] * C[2] - C[4] * C[4];
    double A12 = C[3] * C[4] - C[0] * C[5], A22 = C[0] * C[1] - C[3] * C[3];
    double det = C[0] * A00 + C[3] * A01 + C[4] * A02, idet = det > 0.0 ? 1.0 / det : 0.0;
    const float mean[3] = {ls->m.x * (float)iw, ls->m.y * (float)iw, ls->m.z * (float)iw};
    float out[3];
    for (int c = 0; c < 3; c++) {
        double v = mean[c];
        double g[3], b[3];
        for (int a = 0; a < 3; a++)
            g[a] = ls->smd[c][a] * iw - xm[a] * mean[c];
        b[0] = (A00 * g[0] + A01 * g[1] + A02 * g[2]) * idet;
        b[1] = (A01 * g[0] + A11 * g[1] + A12 * g[2]) * idet;
        b[2] = (A02 * g[0] + A12 * g[1] + A22 * g[2]) * idet;
        v -= b[0] * xm[0] + b[1] * xm[1] + b[2] * xm[2];
        out[c] = (float)(v < ls->lo[c] ? ls->lo[c] : v > ls->hi[c] ? ls->hi[c] : v);
    }
    return v3(out[0], out[1], out[2]);
}

/* Screens the points [k0, k1) of the lookup's copy. */
static void look_scan(look_sum *ls, uint32_t k0, uint32_t k1)
{
    const op_v3 *pos = ls->ss->lk.pos;
    for (uint32_t k = k0; k < k1; k++) {
        op_v3 d = v3(pos[k].x - ls->p.x, pos[k].y - ls->p.y, pos[k].z - ls->p.z);
        float w = 1.0f - v3_dot(d, d) / ls->h2;
        ls->k[ls->nb] = k;
        ls->w[ls->nb] = w;
        ls->nb += w > 0.0f;
        if (ls->nb == LOOK_BATCH)
            look_flush(ls);
    }
}

/* The weighted mean of the exitance of the points within h of p (same-side normals) into *out
 * (0 where none), summed in the lookup grid's order (by cell, then index), *wsum the weights'
 * sum; returns 0 when one of them is not a receiver (*out is then meaningless). */
static int lookup_within(const sss_shape *ss, op_v3 p, op_v3 n, float h, op_v3 *out, float *wsum)
{
    const sss_grid *g = ss->rep ? &ss->look : &ss->interp;
    const look_set *lk = &ss->lk;
    look_sum ls; /* not zeroed whole: its batch is written before it is read */
    ls.ss = ss;
    ls.p = p;
    ls.n = n;
    ls.m = v3s(0.0f);
    ls.h2 = h * h;
    ls.wsum = 0.0f;
    ls.ok = 1;
    ls.nb = 0;
    ls.linear = ss->hier;
    if (ls.linear) {
        memset(ls.sd, 0, sizeof ls.sd);
        memset(ls.sdd, 0, sizeof ls.sdd);
        memset(ls.smd, 0, sizeof ls.smd);
        for (int ch = 0; ch < 3; ch++) {
            ls.lo[ch] = INFINITY;
            ls.hi[ch] = -INFINITY;
        }
    }
    int32_t c[3];
    cell_of(&g->cells, p, c);
    uint32_t b = g->occ.size ? cell_slot(&g->occ, c) : 0;
    if (h <= g->cells.cell && g->occ.size && g->occ.tab[3 * (size_t)b] != INT32_MIN) {
        /* the 3 x 3 x 3 cells around p's hold every point within h, in the grid's order */
        const uint32_t *run = lk->runs + 2 * (size_t)lk->at[2 * b];
        for (uint32_t r = 0; r < lk->at[2 * b + 1]; r++)
            look_scan(&ls, run[2 * r], run[2 * r + 1]);
    } else {
        int32_t lo[3], hi[3];
        cell_of(&g->cells, v3_sub(p, v3s(h)), lo);
        cell_of(&g->cells, v3_add(p, v3s(h)), hi);
        for (c[2] = lo[2]; c[2] <= hi[2]; c[2]++)
            for (c[1] = lo[1]; c[1] <= hi[1]; c[1]++)
                for (c[0] = lo[0]; c[0] <= hi[0]; c[0]++) {
                    uint32_t k0, k1;
                    if (grid_cell(g, c, &k0, &k1))
                        look_scan(&ls, k0, k1);
                }
    }
    look_flush(&ls);
    *wsum = ls.wsum;
    if (!(ls.wsum > 0.0f))
        *out = v3s(0.0f);
    else
        *out = ls.linear ? linear_fit(&ls) : v3_scale(ls.m, 1.0f / ls.wsum);
    return ls.ok;
}

int op_sss_shape_lookup(const sss_shape *ss, op_v3 p, op_v3 n, op_v3 *out)
{
    *out = v3s(0.0f);
    if (!ss->pts)
        return 0;
    float wsum;
    /* centred: the points of p's own material pixel (1.5 spacings: a pixel's (sub-)centres
     * and not its neighbours'), all within h where none is that close (a stretched map) */
    if (ss->centred && lookup_within(ss, p, n, 0.75f * ss->h, out, &wsum) && wsum > 0.0f)
        return 1;
    /* no point at all near p (outside a windowed shape's laid part): no exitance either */
    if (lookup_within(ss, p, n, ss->hr, out, &wsum) && wsum > 0.0f)
        return 1;
    *out = v3s(0.0f);
    return 0;
}
