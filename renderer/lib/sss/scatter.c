/* scatter.c - a measured material's exitance, pair by pair (see scatter.h). */
#include "sss/scatter.h"

#include <stdlib.h>
#include <string.h>

/* Four floats: a kernel value's three channels (and a zero), an accumulator's. GCC and clang
 * both have the vector extension; each lane's arithmetic is what the scalar code would do. */
typedef float v4f __attribute__((vector_size(16)));

/* The points as the scatter reads them: as arrays, in the order of the gather grid's items (by
 * cell, then by index; sss/grid.h). */
struct gather_set {
    float *x, *y, *z, *nx, *ny, *nz;
    float *a;         /* centred: the point's area over the pixel's */
    int32_t *rj;      /* its index among the computed receivers, or -1 */
};

/* The scatter's accumulators (one per chunk of sources) take at most about MAX_ACC_BYTES
 * beyond one chunk: fewer chunks for shapes of many points (fixed by the point count, so the
 * summation order does not depend on which points are receivers). */
enum { POINTS_PER_CHUNK = 256, MAX_CHUNKS = 16 };
#define MAX_ACC_BYTES (256.0 * 1024 * 1024)

/* One thread's room: the source's kernel rows, and its candidates and receivers. */
typedef struct scratch {
    float *rows;  /* per channel a K x K row, as op_material_eval_row writes it */
    v4f *row4;    /* the rows interleaved, with a border of one zero pixel: (K + 2)^2 */
    size_t cap;   /* candidates the arrays below hold */
    float *u, *v; /* a candidate's offset in kernel pixels (centred: its kernel column) */
    int32_t *in;  /* 1: in the source's kernel window */
    int32_t *rj;  /* its receiver index, or -1 */
    float *a;     /* centred: its area over the pixel's */
    int32_t *rec; /* the source's receivers */
    v4f *val;     /* and their kernel values */
} scratch;

typedef struct scatter_job {
    sss_shape *ss;
    int chunk;    /* sources per chunk */
    v4f *acc;     /* per chunk, one accumulator per computed receiver */
    scratch *tmp; /* per thread */
    atomic_int *cancel;
    op_progress *prog;
    atomic_int nomem;
} scatter_job;

/* A source's tangents in material pixels per world unit. */
static void source_frame(const sss_shape *ss, const sss_point *s, op_v3 *gu, op_v3 *gv)
{
    *gu = ss->centred ? s->gu : v3_scale(s->tu, 1.0f / ss->px);
    *gv = ss->centred ? s->gv : v3_scale(s->tv, 1.0f / ss->py);
}

/* Narrows [*first, *last] (whole numbers) to the cx with |b + (cx + 1/2) d| <= w; 0 when none
 * is left. */
static int row_interval(double b, double d, double w, double *first, double *last)
{
    if (d == 0.0)
        return fabs(b) <= w;
    double lo = (-w - b) / d - 0.5, hi = (w - b) / d - 0.5;
    if (d < 0.0) {
        double t = lo;
        lo = hi;
        hi = t;
    }
    *first = fmax(*first, ceil(lo));
    *last = fmin(*last, floor(hi));
    return *first <= *last;
}

int op_sss_gather_cells(const sss_shape *ss, const sss_point *s,
                        int32_t cells[OP_SSS_GATHER_CELLS][3])
{
    const sss_cells *g = &ss->gather.cells;
    op_v3 gu, gv;
    source_frame(ss, s, &gu, &gv);
    float r = ss->radius, w = (float)(ss->kernel / 2) + 1.0f + 0.01f;
    int32_t lo[3], hi[3];
    for (int a = 0; a < 3; a++) {
        float e = ss->radius;
        if (ss->centred)
            e = fminf(((float)(ss->kernel / 2) + 1.0f) * (fabsf(v3_get(s->tu, a)) * ss->px +
                                                         fabsf(v3_get(s->tv, a)) * ss->py) +
                          fabsf(v3_get(s->n, a)) * ss->radius,
                      ss->radius);
        float o = v3_get(g->origin, a), x = v3_get(s->p, a);
        lo[a] = 2 * (int32_t)floorf((x - e - o) / r);
        hi[a] = 2 * (int32_t)floorf((x + e - o) / r) + 1;
    }
    /* a cell's extent along gu and gv: its centre's offset -/+ half its side times the L1
     * norm. A cell meets the window where its centre's offsets u, v lie within w + su and
     * w + sv; along a row (x) u and v are linear in cx, so the cells of a row that meet it are
     * an interval, solved for in double (the 0.01 pixel in w covers single precision's
     * rounding of the points' offsets). */
    double cell = g->cell, wu = (double)w + 0.5 * cell * (fabs(gu.x) + fabs(gu.y) + fabs(gu.z)),
           wv = (double)w + 0.5 * cell * (fabs(gv.x) + fabs(gv.y) + fabs(gv.z));
    int n = 0;
    for (int32_t cz = lo[2]; cz <= hi[2]; cz++)
        for (int32_t cy = lo[1]; cy <= hi[1]; cy++) {
            /* (mx, my, mz): the row's line at x = the grid's origin (cx = -1/2), from s */
            double my = (double)g->origin.y + (cy + 0.5) * cell - s->p.y,
                   mz = (double)g->origin.z + (cz + 0.5) * cell - s->p.z,
                   mx = (double)g->origin.x - s->p.x;
            double first = lo[0], last = hi[0];
            if (!row_interval(mx * gu.x + my * gu.y + mz * gu.z, cell * gu.x, wu, &first, &last) ||
                !row_interval(mx * gv.x + my * gv.y + mz * gv.z, cell * gv.x, wv, &first, &last))
                continue;
            for (int32_t cx = (int32_t)first; cx <= (int32_t)last && n < OP_SSS_GATHER_CELLS; cx++) {
                cells[n][0] = cx;
                cells[n][1] = cy;
                cells[n++][2] = cz;
            }
        }
    return n;
}

void op_sss_gather_free(sss_shape *ss)
{
    struct gather_set *gs = ss->gset;
    if (!gs)
        return;
    free(gs->x);
    free(gs->y);
    free(gs->z);
    free(gs->nx);
    free(gs->ny);
    free(gs->nz);
    free(gs->a);
    free(gs->rj);
    free(gs);
    ss->gset = NULL;
}

op_status op_sss_gather_build(sss_shape *ss, op_error *err)
{
    op_sss_gather_free(ss);
    struct gather_set *gs = calloc(1, sizeof *gs);
    size_t n = (size_t)ss->n, m = n ? n : 1;
    int ok = (ss->gset = gs) != NULL;
    if (ok) {
        gs->x = malloc(m * sizeof *gs->x);
        gs->y = malloc(m * sizeof *gs->y);
        gs->z = malloc(m * sizeof *gs->z);
        gs->nx = malloc(m * sizeof *gs->nx);
        gs->ny = malloc(m * sizeof *gs->ny);
        gs->nz = malloc(m * sizeof *gs->nz);
        gs->a = malloc(m * sizeof *gs->a);
        gs->rj = malloc(m * sizeof *gs->rj);
        ok = gs->x && gs->y && gs->z && gs->nx && gs->ny && gs->nz && gs->a && gs->rj;
    }
    if (!ok) {
        op_sss_gather_free(ss);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for %d irradiance points", ss->n);
    }
    for (size_t k = 0; k < n; k++) {
        uint32_t j = ss->gather.items[k];
        const sss_point *q = &ss->pts[j];
        gs->x[k] = q->p.x;
        gs->y[k] = q->p.y;
        gs->z[k] = q->p.z;
        gs->nx[k] = q->n.x;
        gs->ny[k] = q->n.y;
        gs->nz[k] = q->n.z;
        gs->a[k] = q->a / ss->a_pix;
        gs->rj[k] = ss->rmap[j];
    }
    return OP_OK;
}

/* The points [*first, *last) of scatter chunk `chunk`: those whose index in the whole layout
 * lies in [chunk size, (chunk + 1) size), so that a receiver's sum runs in the same order
 * whichever points are laid or are sources. */
static void chunk_range(const sss_shape *ss, int chunk, int size, int *first, int *last)
{
    long long lo = (long long)chunk * size, hi = lo + size;
    if (hi > ss->nfull)
        hi = ss->nfull;
    int b[2];
    for (int e = 0; e < 2; e++) {
        long long want = e ? hi : lo;
        int l = 0, h = ss->n; /* the first point whose index is at least want */
        while (l < h) {
            int mid = l + (h - l) / 2;
            if (point_index(ss, mid) < want)
                l = mid + 1;
            else
                h = mid;
        }
        b[e] = l;
    }
    *first = b[0];
    *last = b[1];
}

/* Makes t hold n candidates; 0 when out of memory. */
static int scratch_reserve(scratch *t, size_t n)
{
    if (n <= t->cap)
        return 1;
    size_t cap = t->cap ? t->cap : 1024;
    while (cap < n)
        cap *= 2;
    void *q;
    /* an array of t reallocated to cap entries, kept as it was when out of memory */
#define GROW(p) ((q = realloc((p), cap * sizeof *(p))) != NULL && ((p) = q, 1))
    int ok = GROW(t->u) && GROW(t->v) && GROW(t->in) && GROW(t->rj) && GROW(t->a) &&
             GROW(t->rec);
#undef GROW
    v4f *val = ok ? aligned_alloc(sizeof(v4f), cap * sizeof *val) : NULL; /* realloc does not
                                                                            keep alignment */
    if (!val)
        return 0;
    free(t->val);
    t->val = val;
    t->cap = cap;
    return 1;
}

/* The sum of the n values of row: eight partial sums (by index mod 8), then those in double. */
static double row_sum(const float *row, int n)
{
    float part[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    int k = 0;
    for (; k + 8 <= n; k += 8)
        for (int j = 0; j < 8; j++)
            part[j] += row[k + j];
    for (; k < n; k++)
        part[k & 7] += row[k];
    double sum = 0.0;
    for (int j = 0; j < 8; j++)
        sum += part[j];
    return sum;
}

/* Evaluates the kernel rows of the source s into t (rows and row4) and their sums (total). */
static void source_rows(const sss_shape *ss, const sss_point *s, scratch *t, double total[3])
{
    int K = ss->kernel, P = K + 2;
    for (int c = 0; c < ss->channels; c++)
        op_material_eval_row(ss->desc->material, c, (int)s->fx, (int)s->fy,
                             t->rows + (size_t)c * K * K);
    const float *rr = t->rows, *rg = ss->channels == 3 ? rr + K * K : rr,
                *rb = ss->channels == 3 ? rr + 2 * K * K : rr;
    total[0] = row_sum(rr, K * K);
    total[1] = row_sum(rg, K * K);
    total[2] = row_sum(rb, K * K);
    for (int y = 0; y < K; y++)
        for (int x = 0; x < K; x++) {
            int k = y * K + x;
            t->row4[(y + 1) * P + x + 1] = (v4f){rr[k], rg[k], rb[k], 0.0f};
        }
}

/* The candidates k0 <= k < k1 of a source at p with normal n and tangents gu, gv (in kernel
 * pixels per unit): their offsets along gu, gv (u, v) and whether they lie in the window
 * [-lim, lim)^2 on the source's side (in). */
OP_VECTOR_CLONES
static void window_test(const struct gather_set *restrict gs, uint32_t k0, uint32_t k1,
                        const float p[3], const float n[3], const float gu[3], const float gv[3],
                        float lim, float *restrict u, float *restrict v, int32_t *restrict in)
{
    for (uint32_t k = k0; k < k1; k++) {
        float c = n[0] * gs->nx[k] + n[1] * gs->ny[k] + n[2] * gs->nz[k];
        float dx = gs->x[k] - p[0], dy = gs->y[k] - p[1], dz = gs->z[k] - p[2];
        float a = dx * gu[0] + dy * gu[1] + dz * gu[2];
        float b = dx * gv[0] + dy * gv[1] + dz * gv[2];
        u[k - k0] = a;
        v[k - k0] = b;
        in[k - k0] = (c > 0.0f) & (a >= -lim) & (a < lim) & (b >= -lim) & (b < lim);
    }
}

/* The centred layout's candidates k0 <= k < k1 of a source at p with normal n, tangents gu, gv,
 * and position in its pixel fr (fractions plus 1024): their kernel column in the bordered
 * rows (u, as a float) and whether they count (in): on the source's side, within reach2 of it
 * (a windowed shape's reach, window_build), at a whole-pixel offset inside the kernel. */
OP_VECTOR_CLONES
static void centred_test(const struct gather_set *restrict gs, uint32_t k0, uint32_t k1,
                         const float p[3], const float n[3], const float gu[3], const float gv[3],
                         const float fr[2], float reach2, int half, float *restrict u,
                         int32_t *restrict in)
{
    int P = 2 * half + 3;
    for (uint32_t k = k0; k < k1; k++) {
        float c = gs->nx[k] * n[0] + gs->ny[k] * n[1] + gs->nz[k] * n[2];
        float dx = gs->x[k] - p[0], dy = gs->y[k] - p[1], dz = gs->z[k] - p[2];
        float d2 = dx * dx + dy * dy + dz * dz;
        float ux = dx * gu[0] + dy * gu[1] + dz * gu[2];
        float uy = dx * gv[0] + dy * gv[1] + dz * gv[2];
        int ok = (c > 0.0f) & (d2 <= reach2) & (fabsf(ux) < 512.0f) & (fabsf(uy) < 512.0f);
        /* a pixel index is (int)(v + 1024) - 1024 for |v| < 1024, without floorf's cost */
        int ox = ok ? (int)(fr[0] + ux) - 1024 : 0, oy = ok ? (int)(fr[1] + uy) - 1024 : 0;
        ok &= (ox >= -half) & (ox <= half) & (oy >= -half) & (oy <= half);
        u[k - k0] = (float)((oy + half + 1) * P + (ox + half + 1));
        in[k - k0] = ok;
    }
}

/* Keeps, in place, those of the m candidates of t from `at` on (one run of cells, its first
 * point k0) that are in, with their receiver index (and centred, area; else offset v); returns
 * the list's new length. */
static size_t keep_in(const struct gather_set *gs, int centred, uint32_t k0, scratch *t,
                      size_t at, size_t m)
{
    size_t to = at;
    if (centred)
        for (size_t q = 0; q < m; q++) {
            t->u[to] = t->u[at + q];
            t->rj[to] = gs->rj[k0 + q];
            t->a[to] = gs->a[k0 + q];
            to += (size_t)t->in[at + q];
        }
    else
        for (size_t q = 0; q < m; q++) {
            t->u[to] = t->u[at + q];
            t->v[to] = t->v[at + q];
            t->rj[to] = gs->rj[k0 + q];
            to += (size_t)t->in[at + q];
        }
    return to;
}

/* Lists the candidates of source s that lie in its kernel window, in the order of
 * op_sss_gather_cells (within a cell, ascending point index), into t; returns their count, or
 * -1 when out of memory. */
static long gather_in(const sss_shape *ss, const sss_point *s, scratch *t)
{
    const struct gather_set *gs = ss->gset;
    const sss_grid *g = &ss->gather;
    int32_t cells[OP_SSS_GATHER_CELLS][3];
    int ncells = op_sss_gather_cells(ss, s, cells);
    /* runs of listed cells along one row (x) whose points are contiguous */
    uint32_t lo[OP_SSS_GATHER_CELLS], hi[OP_SSS_GATHER_CELLS];
    int nruns = 0, row = -1; /* row: the listed cell that began the last run */
    size_t total = 0;
    for (int ci = 0; ci < ncells; ci++) {
        uint32_t k0, k1;
        if (!grid_cell(g, cells[ci], &k0, &k1))
            continue;
        total += k1 - k0;
        if (nruns > 0 && cells[row][1] == cells[ci][1] && cells[row][2] == cells[ci][2] &&
            hi[nruns - 1] == k0) {
            hi[nruns - 1] = k1;
        } else {
            row = ci;
            lo[nruns] = k0;
            hi[nruns++] = k1;
        }
    }
    if (!scratch_reserve(t, total))
        return -1;
    op_v3 gu, gv;
    source_frame(ss, s, &gu, &gv);
    float p[3] = {s->p.x, s->p.y, s->p.z}, n[3] = {s->n.x, s->n.y, s->n.z};
    float fu[3] = {gu.x, gu.y, gu.z}, fv[3] = {gv.x, gv.y, gv.z};
    int half = ss->kernel / 2;
    /* centred: offsets from the source's position inside its pixel (fractions in [0, 1)) */
    float fr[2] = {s->fx - floorf(s->fx) + 1024.0f, s->fy - floorf(s->fy) + 1024.0f};
    size_t m = 0;
    for (int ci = 0; ci < nruns; ci++) {
        if (ss->centred)
            centred_test(gs, lo[ci], hi[ci], p, n, fu, fv, fr, 3.0f * ss->radius * ss->radius,
                         half, t->u + m, t->in + m);
        else
            window_test(gs, lo[ci], hi[ci], p, n, fu, fv, (float)half + 1.0f, t->u + m,
                        t->v + m, t->in + m);
        m = keep_in(gs, ss->centred, lo[ci], t, m, hi[ci] - lo[ci]);
    }
    return (long)m;
}

/* The kernel value at candidate q of t: bilinear between the four kernel offsets around its
 * offset (u, v) in the bordered rows of side P, the border's zeros standing for the offsets
 * outside the kernel. */
static inline v4f bilinear(const scratch *t, long q, int P)
{
    float du = t->u[q], dv = t->v[q];
    int ox = (int)du, oy = (int)dv;
    ox -= (float)ox > du; /* floor */
    oy -= (float)oy > dv;
    float tx = du - (float)ox, ty = dv - (float)oy;
    float wx0 = 1.0f - tx, wy0 = 1.0f - ty;
    int half = (P - 3) / 2;
    const v4f *r = t->row4 + (oy + half + 1) * P + (ox + half + 1);
    v4f val = (wx0 * wy0) * r[0];
    val += (tx * wy0) * r[1];
    val += (wx0 * ty) * r[P];
    val += (tx * ty) * r[P + 1];
    return val;
}

/* Appends candidate q of t, of kernel value val, to the source's receivers when it is one;
 * returns their new count. */
static inline size_t keep_receiver(scratch *t, long q, v4f val, size_t nrec)
{
    t->rec[nrec] = t->rj[q];
    t->val[nrec] = val;
    return nrec + (t->rj[q] >= 0);
}

/* A source's normalization: its row's sum `want` over what its receivers got, clamped to
 * [lo, 2]. */
static float norm_gain(double want, double got, double lo)
{
    double q = got > 0.0 ? want / got : 1.0;
    return (float)(q < lo ? lo : q > 2.0 ? 2.0 : q);
}

/* Scatters the irradiance of one chunk of source points into that chunk's own accumulator:
 * acc[j] += E_i,c g_i,c Rd_c(pixel(i), offset(i -> j)) over the receivers j in i's footprint,
 * where g_i,c (clamped to [1/2, 2]) makes the receivers of i get exactly the row's sum (the
 * albedo of i's pixel) times A_pixel / A_i: each source hands on exactly its energy whatever
 * the local arrangement of the points (see docs/subsurface-rendering.md). The centred layout's
 * pair value is the kernel at the whole-pixel offset from the source's pixel to the receiver's
 * (sss/measured_points.h), each receiver weighted by its area in the normalization, each source's
 * energy E_i A_i g_i / A_pixel; receivers lie within sqrt(3) gather radii of their source (in
 * the kernel's window they are within one radius in its tangent plane; the bound holds the pairs
 * a curved surface may add, and is what a windowed shape's window assumes). Chunks are fixed
 * ranges of points, summed in order afterwards, so the result does not depend on the thread
 * count. */
static void scatter_task(void *user, int task, int thread)
{
    scatter_job *job = user;
    const sss_shape *ss = job->ss;
    scratch *t = &job->tmp[thread];
    int first, last;
    chunk_range(ss, task, job->chunk, &first, &last);
    v4f *acc = job->acc + (size_t)task * (size_t)ss->nrecv;
    int P = ss->kernel + 2;
    float expect = ss->centred ? 1.0f : ss->a_pix / ss->a_i; /* receivers per kernel pixel */
    /* points sparser than the kernel's pixels: a receiver's value stands for the kernel over
     * its whole area (its own centre value over an area of many pixels would multiply the
     * source's energy by that area), so the source's share is not bounded below */
    double lo = expect < 1.0f ? 0.0 : 0.5;
    int i;
    for (i = first; i < last; i++) {
        if ((i & 63) == 0 && job->cancel && atomic_load(job->cancel))
            break; /* the pass returns OP_ERR_CANCELLED; this chunk's sum is dropped */
        const sss_point *s = &ss->pts[i];
        if (v3_is_black(s->e)) /* also every point that is not a source */
            continue;
        double total[3];
        source_rows(ss, s, t, total);
        long m = gather_in(ss, s, t);
        if (m < 0) { /* this source's light is lost, reported by the pass */
            atomic_store(&job->nomem, 1);
            continue;
        }
        size_t nrec = 0;
        op_v3 e;
        if (ss->centred) {
            v4f got = {0, 0, 0, 0};
            for (long q = 0; q < m; q++) {
                int col = (int)t->u[q];
                got += t->row4[col] * t->a[q];
                t->rec[nrec] = t->rj[q];
                t->val[nrec] = t->row4[col];
                nrec += t->rj[q] >= 0;
            }
            float k = s->a / ss->a_pix;
            e = v3(s->e.x * (norm_gain(total[0], got[0], 0.5) * k),
                   s->e.y * (norm_gain(total[1], got[1], 0.5) * k),
                   s->e.z * (norm_gain(total[2], got[2], 0.5) * k));
        } else {
            /* four partial sums (by q mod 4) keep the adds apart */
            v4f p0 = {0, 0, 0, 0}, p1 = p0, p2 = p0, p3 = p0;
            long q = 0;
            for (; q + 4 <= m; q += 4) {
                v4f v0 = bilinear(t, q, P), v1 = bilinear(t, q + 1, P),
                    v2 = bilinear(t, q + 2, P), v3 = bilinear(t, q + 3, P);
                p0 += v0;
                p1 += v1;
                p2 += v2;
                p3 += v3;
                nrec = keep_receiver(t, q, v0, nrec);
                nrec = keep_receiver(t, q + 1, v1, nrec);
                nrec = keep_receiver(t, q + 2, v2, nrec);
                nrec = keep_receiver(t, q + 3, v3, nrec);
            }
            for (; q < m; q++) {
                v4f v0 = bilinear(t, q, P);
                p0 += v0;
                nrec = keep_receiver(t, q, v0, nrec);
            }
            v4f part[4] = {p0, p1, p2, p3};
            v4f got = (part[0] + part[1]) + (part[2] + part[3]);
            e = v3(s->e.x * norm_gain(total[0] * expect, got[0], lo),
                   s->e.y * norm_gain(total[1] * expect, got[1], lo),
                   s->e.z * norm_gain(total[2] * expect, got[2], lo));
        }
        v4f e4 = {e.x, e.y, e.z, 0.0f};
        for (size_t k = 0; k < nrec; k++)
            acc[t->rec[k]] += e4 * t->val[k];
    }
    op_progress_advance(job->prog, (uint64_t)(i - first));
}

static void scratch_free(scratch *t)
{
    free(t->rows);
    free(t->row4);
    free(t->u);
    free(t->v);
    free(t->in);
    free(t->rj);
    free(t->a);
    free(t->rec);
    free(t->val);
}

op_status op_sss_scatter(sss_shape *ss, int threads, atomic_int *cancel, op_progress *prog,
                         op_error *err)
{
    scatter_job job = {.ss = ss, .cancel = cancel, .prog = prog};
    atomic_init(&job.nomem, 0);
    int K = ss->kernel, P = K + 2, nt = op_parallel_threads(threads);
    /* the chunks are fixed ranges of the whole layout, whatever the camera needs, so a
     * receiver's sum runs in the same order as in the full computation (chunk_range) */
    int nf = ss->nfull, nchunks = (nf + POINTS_PER_CHUNK - 1) / POINTS_PER_CHUNK;
    int most = (int)fmin(MAX_CHUNKS, fmax(1.0, MAX_ACC_BYTES / ((double)sizeof(v4f) * nf)));
    if (nchunks > most)
        nchunks = most;
    job.chunk = (nf + nchunks - 1) / nchunks;
    nchunks = (nf + job.chunk - 1) / job.chunk;
    size_t nacc = (size_t)nchunks * (size_t)ss->nrecv;
    job.tmp = calloc((size_t)nt, sizeof *job.tmp);
    job.acc = aligned_alloc(sizeof(v4f), (nacc ? nacc : 1) * sizeof *job.acc);
    int ok = job.tmp && job.acc;
    for (int i = 0; ok && i < nt; i++) {
        scratch *t = &job.tmp[i];
        t->rows = malloc((size_t)ss->channels * K * K * sizeof *t->rows);
        t->row4 = aligned_alloc(sizeof(v4f), (size_t)P * P * sizeof *t->row4);
        ok = t->rows && t->row4;
        if (ok)
            memset(t->row4, 0, (size_t)P * P * sizeof *t->row4); /* the border stays zero */
    }
    op_status st = OP_OK;
    if (!ok)
        st = op_error_set(err, OP_ERR_NOMEM, "out of memory for the subsurface pass");
    if (st == OP_OK) {
        memset(job.acc, 0, nacc * sizeof *job.acc);
        st = op_parallel_for(threads, nchunks, scatter_task, &job, cancel, err);
    }
    if (st == OP_OK && atomic_load(&job.nomem))
        st = op_error_set(err, OP_ERR_NOMEM, "out of memory in the subsurface pass");
    if (st == OP_OK) {
        float k = ss->centred ? 1.0f : ss->a_i / ss->a_pix;
        for (int j = 0; j < ss->n; j++) {
            int rj = ss->rmap[j];
            if (rj < 0)
                continue;
            double m[3] = {0, 0, 0};
            for (int ch = 0; ch < nchunks; ch++)
                for (int q = 0; q < 3; q++)
                    m[q] += job.acc[(size_t)ch * ss->nrecv + (size_t)rj][q];
            ss->pts[j].m = v3((float)m[0] * k, (float)m[1] * k, (float)m[2] * k);
        }
    }
    for (int i = 0; job.tmp && i < nt; i++)
        scratch_free(&job.tmp[i]);
    free(job.tmp);
    free(job.acc);
    return st;
}
