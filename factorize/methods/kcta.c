/* kcta.c - see kcta.h. */
#include "kcta.h"

#include <cblas.h>
#include <float.h>
#include <lapacke.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define KMEANS_ITERS 25

op_kcta_options op_kcta_defaults(void)
{
    return (op_kcta_options){.clusters = 8, .km = 2, .terms = 4, .max_iters = 10, .tol = 1e-3,
                             .threads = 0, .sample_rows = 0, .svd = op_rsvd_defaults()};
}

void op_kcta_free(op_kcta_model *model)
{
    free(model->basis);
    free(model->idx);
    free(model->coef);
    model->basis = model->coef = NULL;
    model->idx = NULL;
}

void op_kcta_row(const op_kcta_model *md, int64_t i, float *out)
{
    const int n = md->cols, T = md->terms;
    memset(out, 0, (size_t)n * sizeof *out);
    for (int k = 0; k < md->km; k++) {
        const float *v = md->basis + (size_t)md->idx[i * md->km + k] * n * T;
        const float *y = md->coef + ((size_t)i * md->km + k) * T;
        cblas_sgemv(CblasRowMajor, CblasNoTrans, n, T, 1.0f, v, T, y, 1, 1.0f, out, 1);
    }
}

double op_kcta_error(const float *a, const op_kcta_model *md)
{
    float *row = malloc((size_t)md->cols * sizeof *row);
    if (!row)
        return INFINITY;
    double e = 0;
    for (int64_t i = 0; i < md->rows; i++) {
        op_kcta_row(md, i, row);
        const float *ai = a + i * md->cols;
        for (int j = 0; j < md->cols; j++) {
            double d = (double)ai[j] - row[j];
            e += d * d;
        }
    }
    free(row);
    return e;
}

/* ------------------------------------------------------------ small linear algebra */

/* Completes columns r .. T-1 of the cols x T row-major v (whose first r columns are
 * orthonormal) to an orthonormal set, from coordinate vectors (twice-applied Gram-Schmidt).
 * Needs T <= cols. */
static void complete_basis(float *v, int cols, int T, int r)
{
    double *x = malloc((size_t)cols * sizeof *x);
    if (!x)
        return; /* callers check orthonormality indirectly; never happens in practice */
    int next = 0;
    for (int t = r; t < T; t++) {
        for (; next < cols; next++) {
            for (int j = 0; j < cols; j++)
                x[j] = j == next;
            for (int pass = 0; pass < 2; pass++)
                for (int u = 0; u < t; u++) {
                    double d = 0;
                    for (int j = 0; j < cols; j++)
                        d += x[j] * v[(size_t)j * T + u];
                    for (int j = 0; j < cols; j++)
                        x[j] -= d * v[(size_t)j * T + u];
                }
            double nn = 0;
            for (int j = 0; j < cols; j++)
                nn += x[j] * x[j];
            if (nn > 0.25) {
                nn = sqrt(nn);
                for (int j = 0; j < cols; j++)
                    v[(size_t)j * T + t] = (float)(x[j] / nn);
                next++;
                break;
            }
        }
    }
    free(x);
}

/* v (cols x T) = an orthonormal basis whose leading columns span the top right singular
 * subspace of the m x cols matrix x (m may be 0). */
static op_status subspace_of(const float *x, int64_t m, int cols, int T, const op_rsvd_options *opt,
                             float *v, op_error *err)
{
    int r = (int)(m < T ? m : T);
    memset(v, 0, (size_t)cols * T * sizeof *v);
    if (r > 0) {
        float *us = malloc((size_t)m * r * sizeof *us), *vr = malloc((size_t)cols * r * sizeof *vr);
        if (!us || !vr) {
            free(us);
            free(vr);
            return op_error_set(err, OP_ERR_NOMEM, "kcta: out of memory");
        }
        op_status st = op_rsvd(x, m, cols, r, opt, us, vr, NULL, NULL, err);
        if (st == OP_OK)
            for (int j = 0; j < cols; j++)
                for (int t = 0; t < r; t++)
                    v[(size_t)j * T + t] = vr[(size_t)j * r + t];
        free(us);
        free(vr);
        if (st != OP_OK)
            return st;
    }
    complete_basis(v, cols, T, r);
    return OP_OK;
}

/* The Cholesky factor l (n x n, lower) of the symmetric n x n g, or 0 when g is not well
 * conditioned (a pivot below 1e-8 of the largest diagonal entry). */
static int gram_factor(const double *g, int n, double *l)
{
    memcpy(l, g, (size_t)n * n * sizeof *l);
    double dmax = 0;
    for (int i = 0; i < n; i++)
        dmax = fmax(dmax, g[(size_t)i * n + i]);
    if (!(dmax > 0))
        return 0;
    for (int j = 0; j < n; j++) {
        double d = l[(size_t)j * n + j];
        for (int k = 0; k < j; k++)
            d -= l[(size_t)j * n + k] * l[(size_t)j * n + k];
        if (!(d > 1e-8 * dmax))
            return 0;
        d = sqrt(d);
        l[(size_t)j * n + j] = d;
        for (int i = j + 1; i < n; i++) {
            double s = l[(size_t)i * n + j];
            for (int k = 0; k < j; k++)
                s -= l[(size_t)i * n + k] * l[(size_t)j * n + k];
            l[(size_t)i * n + j] = s / d;
        }
    }
    return 1;
}

/* y = (l l^T)^-1 b, l from gram_factor. */
static void gram_subst(const double *l, int n, const double *b, double *y)
{
    for (int i = 0; i < n; i++) {
        double s = b[i];
        for (int k = 0; k < i; k++)
            s -= l[(size_t)i * n + k] * y[k];
        y[i] = s / l[(size_t)i * n + i];
    }
    for (int i = n - 1; i >= 0; i--) {
        double s = y[i];
        for (int k = i + 1; k < n; k++)
            s -= l[(size_t)k * n + i] * y[k];
        y[i] = s / l[(size_t)i * n + i];
    }
}

/* Solves the symmetric positive semi-definite n x n system g y = b in the least-squares,
 * minimum-norm sense (Moore-Penrose): Cholesky when well conditioned, else an eigen
 * decomposition dropping eigenvalues below 1e-10 of the largest. work: 2 n^2 + 2 n doubles. */
static void gram_solve(const double *g, int n, const double *b, double *y, double *work)
{
    double *l = work, *w = work + (size_t)n * n;
    if (gram_factor(g, n, l)) {
        gram_subst(l, n, b, y);
        return;
    }
    memcpy(l, g, (size_t)n * n * sizeof *l);
    for (int i = 0; i < n; i++)
        y[i] = 0;
    double *ev = w, *wk = w + n;
    /* dsyev needs at least 3n - 1 doubles of workspace; n^2 + n is enough for every n >= 1. */
    if (LAPACKE_dsyev_work(LAPACK_ROW_MAJOR, 'V', 'U', n, l, n, ev, wk, n * n + n) != 0)
        return; /* leaves y = 0: a valid (if poor) coefficient set */
    double top = ev[n - 1];
    for (int k = 0; k < n; k++) {
        if (!(ev[k] > 1e-10 * top))
            continue;
        double d = 0;
        for (int i = 0; i < n; i++)
            d += l[(size_t)i * n + k] * b[i];
        d /= ev[k];
        for (int i = 0; i < n; i++)
            y[i] += d * l[(size_t)i * n + k];
    }
}

/* ------------------------------------------------------------ passes over the rows */

/* Rows per gemm of a clustering pass (their projections onto every cluster at once). */
#define SUB_ROWS 1024

typedef struct work {
    const float *a;
    int64_t rows;
    int n, C, K, T, CT;
    int threads;      /* op_parallel_for's count (<= 0: every core) */
    op_kcta_model *md;
    const op_rsvd_options *svd;
    float *vall;      /* n x CT: every basis side by side, the operand of the clustering gemm */
    float *vt;        /* C x T x n: every basis transposed, for the per-row loops */
    double *gram;     /* CT x CT: V_all^T V_all (only the diagonal blocks when K = 1) */
    double *chol;     /* K = 1: C x T x T, each cluster's block's gram_factor, */
    unsigned char *chol_ok; /* C: ... where it succeeded (else its rows use gram_solve) */
    double *rowerr;   /* rows: each row's squared error after the last pass */
    int64_t *mem_row; /* rows * K member lists, grouped by cluster */
    int *mem_slot;
    int64_t *mem_start; /* C + 1 */
    float *x;           /* a cluster's rows (residuals), x_rows x n, kept across refits */
    int64_t x_rows;
    /* A pass's sums, per stripe of rows (a task), reduced in stripe order: for every cluster
     * the T x n sum of r y^T over its members (r the row's residual, y the member's
     * coefficients) and the T x T sum of y y^T. */
    int nstripes;
    size_t acc_stride; /* values per cluster: T n + T T */
    float *acc;        /* nstripes x C x acc_stride (float sums within a stripe) */
    double *sum;       /* C x acc_stride: their total */
    double *scratch;   /* per thread: the Gram solver's doubles, a row's residual (n floats),
                          SUB_ROWS x CT floats of projections */
    size_t scratch_stride;
    int32_t *order;      /* K = 1, per thread: C + 1 cluster starts, then a block's rows by
                            cluster (SUB_ROWS) */
    size_t order_stride;
    int nthreads;
    int guard;         /* K_m > 1: a clustering pass keeps a row's previous clusters when
                          they capture more of it than the greedy search's (idx is valid) */
} work;

/* w->x with room for m rows of n, or NULL when out of memory. */
static float *rows_buffer(work *w, int64_t m)
{
    if (m > w->x_rows) {
        free(w->x);
        w->x = malloc((size_t)m * (size_t)w->n * sizeof *w->x);
        w->x_rows = w->x ? m : 0;
    }
    return w->x;
}

/* Refreshes vall, vt and gram from md->basis (after the bases changed). */
static void bases_changed(work *w)
{
    const int n = w->n, C = w->C, T = w->T, CT = w->CT;
    const float *b = w->md->basis;
    for (int c = 0; c < C; c++)
        for (int j = 0; j < n; j++)
            for (int t = 0; t < T; t++) {
                float v = b[((size_t)c * n + j) * T + t];
                w->vall[(size_t)j * CT + c * T + t] = v;
                w->vt[((size_t)c * T + t) * n + j] = v;
            }
    /* The Gram matrix of the bases, in double: the cross terms of Theorem 3. With K = 1 only
     * a cluster's own block is ever used. */
    for (int p = 0; p < CT; p++)
        for (int q = w->K == 1 ? p - p % T : 0; q < (w->K == 1 ? p - p % T + T : CT); q++) {
            double s = 0;
            const float *vp = w->vt + (size_t)p * n, *vq = w->vt + (size_t)q * n;
            for (int j = 0; j < n; j++)
                s += (double)vp[j] * vq[j];
            w->gram[(size_t)p * CT + q] = s;
        }
    if (w->K > 1)
        return;
    double g[4096];
    for (int c = 0; c < C; c++) {
        for (int t = 0; t < T; t++)
            for (int u = 0; u < T; u++)
                g[t * T + u] = w->gram[(size_t)(c * T + t) * CT + c * T + u];
        w->chol_ok[c] = (unsigned char)gram_factor(g, T, w->chol + (size_t)c * T * T);
    }
}

typedef struct pass_job {
    work *w;
    int assign; /* pick every row's clusters (the clustering stage), else keep them */
} pass_job;

/* Lanes of row_residual's sum: a fixed order, so every build variant gives the same bits. */
#define RES_LANES 16

/* sum_j x_j^2 in double, n values. */
OP_VECTOR_CLONES
static double sum_squares(const float *x, int64_t n)
{
    double lane[RES_LANES] = {0};
    int64_t j0 = 0;
    for (; j0 + RES_LANES <= n; j0 += RES_LANES)
        for (int k = 0; k < RES_LANES; k++)
            lane[k] += (double)x[j0 + k] * x[j0 + k];
    for (int k = 0; j0 + k < n; k++)
        lane[k] += (double)x[j0 + k] * x[j0 + k];
    double e = 0;
    for (int k = 0; k < RES_LANES; k++)
        e += lane[k];
    return e;
}

/* The end of a row's pass: its residual r = a - sum_{s < K} V_s y_s (vs[s]: T x n, the basis
 * transposed; y: K x T; n values), rc[s] (T x n) += y_s r^T; returns ||r||^2 in double. */
OP_VECTOR_CLONES
static double row_residual(const float *restrict a, const float *const *vs, const float *y,
                           float *const *rc, int K, int T, int n, float *restrict r)
{
    for (int s = 0; s < K; s++)
        for (int t = 0; t < T; t++) {
            const float *restrict v = vs[s] + (size_t)t * n;
            const float *restrict src = s == 0 && t == 0 ? a : r;
            float ys = y[s * T + t];
            for (int j = 0; j < n; j++)
                r[j] = src[j] - v[j] * ys;
        }
    for (int s = 0; s < K; s++)
        for (int t = 0; t < T; t++) {
            float *restrict o = rc[s] + (size_t)t * n, ys = y[s * T + t];
            for (int j = 0; j < n; j++)
                o[j] += ys * r[j];
        }
    return sum_squares(r, n);
}

/* The end of row i's pass from its stored clusters and coefficients: its residual r (n floats
 * of room), its squared error, and its terms of the sums for the bases' update in acc. */
static void row_end(work *w, int64_t i, float *acc, float *r)
{
    const int n = w->n, K = w->K, T = w->T;
    const op_kcta_model *md = w->md;
    const float *yf = md->coef + (size_t)i * K * T;
    if (K < 1 || K > 64)
        return; /* op_kcta_factor refuses these */
    /* Section 4.3's update needs M_c V_c = sum x y^T over the members, x = r + V_c y the
     * member's residual with the other clusters fixed (r is orthogonal to V_c): kept as the
     * sums of r y^T and y y^T. */
    const float *vs[64];
    float *rc[64];
    for (int s = 0; s < K; s++) {
        uint32_t c = md->idx[i * K + s];
        vs[s] = w->vt + (size_t)c * T * n;
        rc[s] = acc + (size_t)c * w->acc_stride;
    }
    w->rowerr[i] = row_residual(w->a + i * n, vs, yf, rc, K, T, n, r);
    for (int s = 0; s < K; s++) {
        float *gc = rc[s] + (size_t)T * n;
        for (int t = 0; t < T; t++)
            for (int u = 0; u < T; u++)
                gc[t * T + u] += yf[s * T + t] * yf[s * T + u];
    }
}

/* One row of a pass: its clusters (the greedy search of section 4.2 when assigning) and their
 * optimal coefficients (Theorem 4), stored in the model; then row_end unless defer (the caller
 * then calls it). p holds the row's projections onto every cluster (assigning) or room for
 * them (CT values). */
static void pass_row(work *w, int assign, int64_t i, float *p, double *sc, float *acc, int defer)
{
    const int n = w->n, C = w->C, K = w->K, T = w->T, CT = w->CT;
    op_kcta_model *md = w->md;
    const float *ai = w->a + i * n;
    double *y = sc, *b = y + 64, *gs = b + 64, *solve = gs + 4096;
    float *r = (float *)(solve + 2 * 4096 + 2 * 64);
    int sel[64];
    if (!assign) {
        for (int s = 0; s < K; s++) {
            sel[s] = (int)md->idx[i * K + s];
            cblas_sgemv(CblasRowMajor, CblasNoTrans, T, n, 1.0f, w->vt + (size_t)sel[s] * T * n,
                        n, ai, 1, 0.0f, p + sel[s] * T, 1);
        }
    }
    for (int k = 0; k < K; k++) {
        if (assign) {
            int best = -1;
            double bestscore = -1;
            for (int c = 0; c < C; c++) {
                int taken = 0;
                for (int s = 0; s < k; s++)
                    taken |= sel[s] == c;
                if (taken)
                    continue;
                double score = 0;
                for (int t = 0; t < T; t++) {
                    const double *g = w->gram + (size_t)(c * T + t) * CT;
                    double rr = p[c * T + t];
                    for (int s = 0; s < k; s++)
                        for (int u = 0; u < T; u++)
                            rr -= g[sel[s] * T + u] * y[s * T + u];
                    score += rr * rr;
                }
                if (score > bestscore) {
                    bestscore = score;
                    best = c;
                }
            }
            for (int c = 0; best < 0 && c < C; c++) { /* only if every score was NaN */
                int taken = 0;
                for (int s = 0; s < k; s++)
                    taken |= sel[s] == c;
                best = taken ? -1 : c;
            }
            sel[k] = best;
        } else if (k < K - 1) {
            continue; /* the clusters are known: one solve for all of them */
        }
        /* Theorem 4: the optimal projection onto all k + 1 selected clusters. */
        if (K == 1 && w->chol_ok[sel[0]]) { /* gram_solve's result, from the cached factor */
            for (int t = 0; t < T; t++)
                b[t] = p[sel[0] * T + t];
            gram_subst(w->chol + (size_t)sel[0] * T * T, T, b, y);
            continue;
        }
        int m = (k + 1) * T;
        for (int s = 0; s <= k; s++)
            for (int t = 0; t < T; t++) {
                b[s * T + t] = p[sel[s] * T + t];
                for (int s2 = 0; s2 <= k; s2++)
                    for (int u = 0; u < T; u++)
                        gs[(s * T + t) * m + s2 * T + u] =
                            w->gram[(size_t)(sel[s] * T + t) * CT + sel[s2] * T + u];
            }
        gram_solve(gs, m, b, y, solve);
    }
    if (assign && w->guard) {
        /* The greedy search is not optimal for K_m > 1: keep the previous clusters when their
         * optimal projection captures more (b^T y, the least-squares fit's energy). */
        int old[64], same = 1;
        double yo[64], bo[64] = {0}, go[4096];
        for (int s = 0; s < K; s++) {
            old[s] = (int)md->idx[i * K + s];
            int found = 0;
            for (int s2 = 0; s2 < K; s2++)
                found |= old[s] == sel[s2];
            same &= found;
        }
        if (!same) {
            const int m = K * T;
            for (int s = 0; s < K; s++)
                for (int t = 0; t < T; t++) {
                    bo[s * T + t] = p[old[s] * T + t];
                    for (int s2 = 0; s2 < K; s2++)
                        for (int u = 0; u < T; u++)
                            go[(s * T + t) * m + s2 * T + u] =
                                w->gram[(size_t)(old[s] * T + t) * CT + old[s2] * T + u];
                }
            gram_solve(go, m, bo, yo, solve);
            double en = 0, eo = 0;
            for (int q = 0; q < m; q++) {
                en += b[q] * y[q];
                eo += bo[q] * yo[q];
            }
            if (eo > en) {
                memcpy(sel, old, (size_t)K * sizeof *sel);
                memcpy(y, yo, (size_t)m * sizeof *y);
            }
        }
    }
    /* The stored (float) coefficients; then (now, or by the caller) what they leave. */
    for (int s = 0; s < K; s++) {
        md->idx[i * K + s] = (uint32_t)sel[s];
        for (int t = 0; t < T; t++)
            md->coef[((size_t)i * K + s) * T + t] = (float)y[s * T + t];
    }
    if (!defer)
        row_end(w, i, acc, r);
}

/* One stripe of rows (a task): blocks of SUB_ROWS rows, each projected onto every cluster by
 * one gemm when assigning. */
static void pass_task(void *user, int task, int thread)
{
    pass_job *j = user;
    work *w = j->w;
    const int n = w->n, CT = w->CT;
    int64_t r0 = w->rows * task / w->nstripes, r1 = w->rows * (task + 1) / w->nstripes;
    float *acc = w->acc + (size_t)task * w->C * w->acc_stride;
    double *sc = w->scratch + (size_t)thread * w->scratch_stride;
    float *r = (float *)(sc + 64 + 64 + 4096 + 2 * 4096 + 2 * 64);
    float *proj = (float *)(sc + 64 + 64 + 4096 + 2 * 4096 + 2 * 64 + (n + 1) / 2);
    memset(acc, 0, (size_t)w->C * w->acc_stride * sizeof *acc);
    for (int64_t i0 = r0; i0 < r1; i0 += SUB_ROWS) {
        int64_t nb = r1 - i0 < SUB_ROWS ? r1 - i0 : SUB_ROWS;
        if (j->assign) /* projections onto every cluster: the first term of (13) */
            cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, (int)nb, CT, n, 1.0f,
                        w->a + i0 * n, n, w->vall, CT, 0.0f, proj, CT);
        /* K_m = 1: the rows' ends grouped by cluster (in row order within one), so that a
         * cluster's basis and sums stay in cache; each sum gets its terms in the same order. */
        int group = w->K == 1;
        for (int64_t q = 0; q < nb; q++)
            pass_row(w, j->assign, i0 + q, j->assign ? proj + q * CT : proj, sc, acc, group);
        if (!group)
            continue;
        int32_t *start = w->order + (size_t)thread * w->order_stride, *order = start + w->C + 1;
        memset(start, 0, (size_t)(w->C + 1) * sizeof *start);
        for (int64_t q = 0; q < nb; q++)
            start[w->md->idx[i0 + q] + 1]++;
        for (int c = 0; c < w->C; c++)
            start[c + 1] += start[c];
        for (int64_t q = 0; q < nb; q++)
            order[start[w->md->idx[i0 + q]]++] = (int32_t)q;
        for (int64_t q = 0; q < nb; q++)
            row_end(w, i0 + order[q], acc, r);
    }
}

/* A pass over every row: assigning (the clustering stage) or with the clusters kept. Sets
 * idx, coef, rowerr, *total (the model's squared error, summed in row order) and the update
 * sums (reduced into stripe 0's). The result is the same for any thread count. */
static op_status pass(work *w, int assign, double *total, op_error *err)
{
    pass_job j = {w, assign};
    op_status st = op_parallel_for(w->threads, w->nstripes, pass_task, &j, NULL, err);
    if (st != OP_OK)
        return st;
    size_t len = (size_t)w->C * w->acc_stride;
    for (size_t q = 0; q < len; q++) {
        double v = 0;
        for (int s = 0; s < w->nstripes; s++)
            v += w->acc[s * len + q];
        w->sum[q] = v;
    }
    double e = 0;
    for (int64_t i = 0; i < w->rows; i++)
        e += w->rowerr[i];
    *total = e;
    return OP_OK;
}

typedef struct norm_job {
    const work *w;
    double part[16]; /* per stripe (work_begin makes at most 16) */
} norm_job;

static void norm_task(void *user, int task, int thread)
{
    norm_job *j = user;
    const work *w = j->w;
    int64_t r0 = w->rows * task / w->nstripes, r1 = w->rows * (task + 1) / w->nstripes;
    (void)thread;
    j->part[task] = sum_squares(w->a + r0 * w->n, (r1 - r0) * w->n);
}

/* sum_i ||a_i||^2, by stripes added in order (the same for any thread count). */
static double matrix_norm2(work *w)
{
    norm_job j = {.w = w};
    double e = 0;
    if (op_parallel_for(w->threads, w->nstripes, norm_task, &j, NULL, NULL) != OP_OK)
        return NAN; /* only for the log */
    for (int s = 0; s < w->nstripes; s++)
        e += j.part[s];
    return e;
}

/* Groups the (row, slot) pairs by cluster into the member lists. */
static void build_members(work *w)
{
    const int C = w->C, K = w->K;
    memset(w->mem_start, 0, (size_t)(C + 1) * sizeof *w->mem_start);
    for (int64_t q = 0; q < w->rows * K; q++)
        w->mem_start[w->md->idx[q] + 1]++;
    for (int c = 0; c < C; c++)
        w->mem_start[c + 1] += w->mem_start[c];
    int64_t *fill = malloc((size_t)C * sizeof *fill);
    if (!fill)
        return;
    memcpy(fill, w->mem_start, (size_t)C * sizeof *fill);
    for (int64_t i = 0; i < w->rows; i++)
        for (int s = 0; s < K; s++) {
            int c = (int)w->md->idx[i * K + s];
            w->mem_row[fill[c]] = i;
            w->mem_slot[fill[c]++] = s;
        }
    free(fill);
}

/* Section 4.3 as one step of subspace iteration per cluster, warm-started from its basis:
 * V_c <- orth(M_c V_c), M_c = X_c^T X_c the Gram matrix of the members' residuals with the
 * other clusters fixed, from the last pass's sums (M_c V_c = R_c^T + V_c G_c). For a PSD M
 * the step never lowers tr(V^T M V), the energy the basis captures, and repeated steps
 * converge to M_c's leading T-dimensional subspace, the rank-T truncated SVD of the paper.
 * Empty clusters keep their basis. */
static void update_bases(work *w)
{
    const int n = w->n, T = w->T;
    double *z = malloc((size_t)n * T * sizeof *z);
    if (!z)
        return; /* the bases stay: a valid (if unimproved) model */
    for (int c = 0; c < w->C; c++) {
        if (w->mem_start[c + 1] == w->mem_start[c])
            continue;
        const double *rc = w->sum + (size_t)c * w->acc_stride, *gc = rc + (size_t)T * n;
        float *v = w->md->basis + (size_t)c * n * T;
        for (int j = 0; j < n; j++)
            for (int t = 0; t < T; t++) {
                double s = rc[(size_t)t * n + j];
                for (int u = 0; u < T; u++)
                    s += (double)v[(size_t)j * T + u] * gc[u * T + t];
                z[(size_t)j * T + t] = s;
            }
        /* Gram-Schmidt, twice; a column that vanishes keeps the old direction instead. */
        int ok = 1;
        for (int t = 0; t < T && ok; t++) {
            for (int attempt = 0; attempt < 2; attempt++) {
                double before = 0;
                for (int j = 0; j < n; j++)
                    before += z[(size_t)j * T + t] * z[(size_t)j * T + t];
                for (int pass2 = 0; pass2 < 2; pass2++)
                    for (int u = 0; u < t; u++) {
                        double d = 0;
                        for (int j = 0; j < n; j++)
                            d += z[(size_t)j * T + u] * z[(size_t)j * T + t];
                        for (int j = 0; j < n; j++)
                            z[(size_t)j * T + t] -= d * z[(size_t)j * T + u];
                    }
                double nn = 0;
                for (int j = 0; j < n; j++)
                    nn += z[(size_t)j * T + t] * z[(size_t)j * T + t];
                if (before > 0 && nn > 1e-12 * before && nn > 0) {
                    nn = 1 / sqrt(nn);
                    for (int j = 0; j < n; j++)
                        z[(size_t)j * T + t] *= nn;
                    break;
                }
                if (attempt == 1) {
                    ok = 0;
                    break;
                }
                for (int j = 0; j < n; j++)
                    z[(size_t)j * T + t] = v[(size_t)j * T + t];
            }
        }
        if (!ok)
            continue; /* degenerate: the basis stays */
        for (size_t q = 0; q < (size_t)n * T; q++)
            v[q] = (float)z[q];
    }
    free(z);
}

/* Cluster c's members' residuals with the other clusters fixed, as rows of w->x (m rows, the
 * member lists' order), or NULL when out of memory. */
static float *gather_residuals(work *w, int c, int64_t *m_out)
{
    const int n = w->n, T = w->T, K = w->K;
    op_kcta_model *md = w->md;
    int64_t m0 = w->mem_start[c], m = w->mem_start[c + 1] - m0;
    float *x = rows_buffer(w, m ? m : 1);
    *m_out = m;
    for (int64_t q = 0; x && q < m; q++) {
        int64_t i = w->mem_row[m0 + q];
        float *xr = x + q * n;
        memcpy(xr, w->a + i * n, (size_t)n * sizeof *xr);
        for (int k = 0; k < K; k++) {
            if (k == w->mem_slot[m0 + q])
                continue;
            const float *v = md->basis + (size_t)md->idx[i * K + k] * n * T;
            cblas_sgemv(CblasRowMajor, CblasNoTrans, n, T, -1.0f, v, T,
                        md->coef + ((size_t)i * K + k) * T, 1, 1.0f, xr, 1);
        }
    }
    return x;
}

/* Section 4.3 done in full for one cluster: the rank-T truncated SVD of its members'
 * residuals (the other clusters fixed). For clusters whose membership a split changed. */
static op_status refit_cluster(work *w, int c, op_error *err)
{
    int64_t m;
    float *x = gather_residuals(w, c, &m);
    if (!x)
        return op_error_set(err, OP_ERR_NOMEM, "kcta: out of memory");
    if (m == 0)
        return OP_OK;
    return subspace_of(x, m, w->n, w->T, w->svd, w->md->basis + (size_t)c * w->n * w->T, err);
}

/* Section 4.2.3: the SVD of each cluster's coefficient block Y_c = U' S W^T (through the
 * eigen-decomposition of Y_c^T Y_c, T x T); V_c <- V_c W, Y_c <- Y_c W, which leaves every
 * reconstruction unchanged and orders each cluster's basis by energy. Returns the sum of the
 * clusters' core norms ||S||_F (Algorithm 1's convergence measure). */
static double postprocess(work *w)
{
    const int n = w->n, T = w->T, K = w->K;
    op_kcta_model *md = w->md;
    double *g = malloc((size_t)T * T * sizeof *g), *ev = malloc((size_t)T * sizeof *ev);
    float *vn = malloc((size_t)n * T * sizeof *vn);
    float *yn = malloc((size_t)T * sizeof *yn);
    double core = 0;
    if (!g || !ev || !vn || !yn)
        goto done;
    for (int c = 0; c < w->C; c++) {
        int64_t m0 = w->mem_start[c], m1 = w->mem_start[c + 1];
        if (m1 == m0)
            continue;
        memset(g, 0, (size_t)T * T * sizeof *g);
        for (int64_t q = m0; q < m1; q++) {
            const float *y = md->coef + ((size_t)w->mem_row[q] * K + w->mem_slot[q]) * T;
            for (int t = 0; t < T; t++)
                for (int u = 0; u < T; u++)
                    g[t * T + u] += (double)y[t] * y[u];
        }
        if (LAPACKE_dsyev(LAPACK_ROW_MAJOR, 'V', 'U', T, g, T, ev) != 0)
            continue; /* the rotation is optional: skip it */
        /* Columns of g are eigenvectors in ascending order; W = them in descending order,
         * each signed so that its V column's largest-magnitude entry is positive. */
        float *v = md->basis + (size_t)c * n * T;
        for (int t = 0; t < T; t++) {
            int src = T - 1 - t;
            core += fmax(ev[src], 0.0);
            float big = 0;
            for (int j = 0; j < n; j++) {
                double s = 0;
                for (int u = 0; u < T; u++)
                    s += (double)v[(size_t)j * T + u] * g[u * T + src];
                vn[(size_t)j * T + t] = (float)s;
                if (fabsf((float)s) > fabsf(big))
                    big = (float)s;
            }
            if (big < 0) {
                for (int j = 0; j < n; j++)
                    vn[(size_t)j * T + t] = -vn[(size_t)j * T + t];
                for (int u = 0; u < T; u++)
                    g[u * T + src] = -g[u * T + src];
            }
        }
        memcpy(v, vn, (size_t)n * T * sizeof *v);
        for (int64_t q = m0; q < m1; q++) {
            float *y = md->coef + ((size_t)w->mem_row[q] * K + w->mem_slot[q]) * T;
            for (int t = 0; t < T; t++) {
                double s = 0;
                for (int u = 0; u < T; u++)
                    s += (double)y[u] * g[u * T + (T - 1 - t)];
                yn[t] = (float)s;
            }
            memcpy(y, yn, (size_t)T * sizeof *y);
        }
    }
done:
    free(g);
    free(ev);
    free(vn);
    free(yn);
    return sqrt(core);
}

typedef struct ranked {
    double err;
    int64_t row;
} ranked;

/* Larger error first; ties by row, so the order is deterministic. */
static int by_error_desc(const void *pa, const void *pb)
{
    const ranked *a = pa, *b = pb;
    return a->err < b->err ? 1 : a->err > b->err ? -1 : (a->row > b->row) - (a->row < b->row);
}

/* Section 5.3: every empty cluster takes the worse half (by row error) of the members of the
 * cluster with the largest total error. The moved slots' coefficients become 0; the update
 * stage fits them; both clusters are flagged in touched. Returns the number of clusters
 * refilled. */
static int split_empty(work *w, unsigned char *touched)
{
    const int C = w->C, K = w->K, T = w->T;
    op_kcta_model *md = w->md;
    int splits = 0;
    for (int e = 0; e < C; e++) {
        if (w->mem_start[e + 1] > w->mem_start[e])
            continue;
        double worst = -1;
        int s = -1;
        for (int c = 0; c < C; c++) {
            int64_t cnt = 0;
            double tot = 0;
            for (int64_t q = 0; q < w->rows * K; q++)
                if ((int)md->idx[q] == c) {
                    cnt++;
                    tot += w->rowerr[q / K];
                }
            if (cnt >= 2 && tot > worst) {
                worst = tot;
                s = c;
            }
        }
        if (s < 0)
            break;
        int64_t cnt = 0;
        ranked *rows = malloc((size_t)w->rows * sizeof *rows);
        if (!rows)
            break;
        for (int64_t i = 0; i < w->rows; i++)
            for (int k = 0; k < K; k++)
                if ((int)md->idx[i * K + k] == s)
                    rows[cnt++] = (ranked){w->rowerr[i], i};
        qsort(rows, (size_t)cnt, sizeof *rows, by_error_desc);
        for (int64_t q = 0; q < cnt / 2; q++)
            for (int k = 0; k < K; k++)
                if ((int)md->idx[rows[q].row * K + k] == s) {
                    md->idx[rows[q].row * K + k] = (uint32_t)e;
                    memset(md->coef + ((size_t)rows[q].row * K + k) * T, 0,
                           (size_t)T * sizeof(float));
                }
        free(rows);
        touched[s] = touched[e] = 1;
        splits++;
        build_members(w);
    }
    return splits;
}

typedef struct init_job {
    work *w;
    const int *label;
    int64_t maxc;      /* rows of the largest cluster */
    op_rsvd_options svd; /* single-threaded */
    float *x;          /* per thread: maxc x n */
    op_status *st;     /* per cluster */
    op_error *errs;
} init_job;

/* Cluster `task`'s basis: the truncated SVD of its rows. */
static void init_task(void *user, int task, int thread)
{
    init_job *j = user;
    const work *w = j->w;
    const int n = w->n;
    float *x = j->x + (size_t)thread * (size_t)j->maxc * n;
    int64_t m = 0;
    for (int64_t i = 0; i < w->rows; i++)
        if (j->label[i] == task)
            memcpy(x + m++ * n, w->a + i * n, (size_t)n * sizeof *x);
    j->st[task] = subspace_of(x, m, n, w->T, &j->svd, w->md->basis + (size_t)task * n * w->T,
                              &j->errs[task]);
}

/* Section 5.1: k-means (k-means++ seeding from a fixed seed, Lloyd iterations) of the rows in
 * the space of the global leading right singular vectors, then one CTA step: the truncated SVD
 * of each cluster's rows gives its basis. */
static op_status initialize(work *w, op_error *err)
{
    const int n = w->n, C = w->C, T = w->T;
    int64_t rows = w->rows;
    int D = 2 * T > 8 ? 2 * T : 8;
    if (D > n)
        D = n;
    if (D > rows)
        D = (int)rows;
    float *z = malloc((size_t)rows * D * sizeof *z), *vg = malloc((size_t)n * D * sizeof *vg);
    double *cent = malloc((size_t)C * D * sizeof *cent), *dist = malloc((size_t)rows * sizeof *dist);
    int *label = malloc((size_t)rows * sizeof *label);
    int64_t *count = malloc((size_t)C * sizeof *count);
    float *x = NULL;
    op_status st = OP_OK;
    if (!z || !vg || !cent || !dist || !label || !count) {
        st = op_error_set(err, OP_ERR_NOMEM, "kcta: out of memory");
        goto done;
    }
    if ((st = op_rsvd(w->a, rows, n, D, w->svd, z, vg, NULL, NULL, err)) != OP_OK)
        goto done;
    uint64_t rng = 0x6b637461ull; /* "kcta" */
    /* k-means++: the first centre uniformly, the others with probability ~ distance^2. */
    int64_t first = (int64_t)(op_splitmix64(&rng) % (uint64_t)rows);
    for (int d = 0; d < D; d++)
        cent[d] = z[first * D + d];
    for (int64_t i = 0; i < rows; i++)
        dist[i] = INFINITY;
    for (int c = 1; c <= C; c++) {
        double total = 0;
        for (int64_t i = 0; i < rows; i++) {
            double s = 0;
            for (int d = 0; d < D; d++) {
                double e = z[i * D + d] - cent[(size_t)(c - 1) * D + d];
                s += e * e;
            }
            dist[i] = fmin(dist[i], s);
            total += dist[i];
        }
        if (c == C)
            break;
        double u = (double)(op_splitmix64(&rng) >> 11) * 0x1.0p-53 * total;
        int64_t pick = rows - 1;
        for (int64_t i = 0; i < rows; i++) {
            u -= dist[i];
            if (u < 0) {
                pick = i;
                break;
            }
        }
        for (int d = 0; d < D; d++)
            cent[(size_t)c * D + d] = z[pick * D + d];
    }
    for (int64_t i = 0; i < rows; i++)
        label[i] = -1;
    for (int it = 0; it < KMEANS_ITERS; it++) {
        int changed = 0;
        for (int64_t i = 0; i < rows; i++) {
            int best = 0;
            double bd = INFINITY;
            for (int c = 0; c < C; c++) {
                double s = 0;
                for (int d = 0; d < D; d++) {
                    double e = z[i * D + d] - cent[(size_t)c * D + d];
                    s += e * e;
                }
                if (s < bd) {
                    bd = s;
                    best = c;
                }
            }
            changed |= label[i] != best;
            label[i] = best;
        }
        if (!changed)
            break;
        memset(count, 0, (size_t)C * sizeof *count);
        for (int64_t i = 0; i < rows; i++)
            count[label[i]]++;
        for (int c = 0; c < C; c++) {
            if (!count[c])
                continue; /* an empty cluster keeps its centre */
            for (int d = 0; d < D; d++)
                cent[(size_t)c * D + d] = 0;
        }
        for (int64_t i = 0; i < rows; i++)
            for (int d = 0; d < D; d++)
                cent[(size_t)label[i] * D + d] += z[i * D + d] / (double)count[label[i]];
    }
    memset(count, 0, (size_t)C * sizeof *count);
    for (int64_t i = 0; i < rows; i++)
        count[label[i]]++;
    int64_t maxc = 1;
    for (int c = 0; c < C; c++)
        maxc = count[c] > maxc ? count[c] : maxc;
    /* The clusters' SVDs as parallel tasks, each on one thread (op_rsvd's result does not
     * depend on the thread count), the first failure in cluster order reported. */
    int nthreads = op_parallel_threads(w->threads);
    nthreads = nthreads > C ? C : nthreads;
    init_job j = {.w = w, .label = label, .maxc = maxc, .svd = *w->svd};
    j.svd.threads = 1;
    x = malloc((size_t)nthreads * (size_t)maxc * n * sizeof *x);
    j.x = x;
    j.st = malloc((size_t)C * sizeof *j.st);
    j.errs = calloc((size_t)C, sizeof *j.errs);
    if (!x || !j.st || !j.errs) {
        st = op_error_set(err, OP_ERR_NOMEM, "kcta: out of memory");
        free(j.st);
        free(j.errs);
        goto done;
    }
    st = op_parallel_for(nthreads, C, init_task, &j, NULL, err);
    for (int c = 0; c < C && st == OP_OK; c++)
        if ((st = j.st[c]) != OP_OK && err)
            *err = j.errs[c];
    free(j.st);
    free(j.errs);
done:
    free(x);
    free(z);
    free(vg);
    free(cent);
    free(dist);
    free(label);
    free(count);
    return st;
}

/* Sets up w for the rows x cols matrix a and the model md (whose arrays the caller owns):
 * stripes, scratch and the pass buffers. */
static op_status work_begin(work *w, const float *a, int64_t rows, int cols,
                            const op_kcta_options *opt, op_kcta_model *md, op_error *err)
{
    const int C = opt->clusters, K = opt->km, T = opt->terms;
    *w = (work){.a = a, .rows = rows, .n = cols, .C = C, .K = K, .T = T, .CT = C * T,
                .threads = opt->threads, .md = md, .svd = &opt->svd};
    /* Stripes: enough for the threads to share the rows, few enough that their sums stay
     * small; a function of the sizes only, so that the result is the same for any thread
     * count. */
    w->acc_stride = (size_t)T * cols + (size_t)T * T;
    int64_t stripes = ((int64_t)1 << 24) / ((int64_t)C * (int64_t)w->acc_stride);
    stripes = stripes < 1 ? 1 : stripes > 16 ? 16 : stripes;
    if (stripes > (rows + SUB_ROWS - 1) / SUB_ROWS)
        stripes = (rows + SUB_ROWS - 1) / SUB_ROWS;
    w->nstripes = (int)stripes;
    w->nthreads = op_parallel_threads(opt->threads);
    if (w->nthreads > w->nstripes)
        w->nthreads = w->nstripes;
    w->scratch_stride = 64 + 64 + 4096 + 2 * 4096 + 2 * 64 + ((size_t)cols + 1) / 2 +
                        ((size_t)SUB_ROWS * C * T + 1) / 2 + 8;
    size_t ni = (size_t)rows * K;
    w->vall = malloc((size_t)cols * C * T * sizeof *w->vall);
    w->vt = malloc((size_t)cols * C * T * sizeof *w->vt);
    w->gram = malloc((size_t)C * T * C * T * sizeof *w->gram);
    w->chol = malloc((size_t)C * T * T * sizeof *w->chol);
    w->order_stride = (size_t)C + 1 + SUB_ROWS;
    w->order = malloc((size_t)w->nthreads * w->order_stride * sizeof *w->order);
    w->chol_ok = malloc((size_t)C);
    w->rowerr = malloc((size_t)rows * sizeof *w->rowerr);
    w->mem_row = malloc(ni * sizeof *w->mem_row);
    w->mem_slot = malloc(ni * sizeof *w->mem_slot);
    w->mem_start = malloc((size_t)(C + 1) * sizeof *w->mem_start);
    w->acc = malloc((size_t)w->nstripes * C * w->acc_stride * sizeof *w->acc);
    w->sum = malloc((size_t)C * w->acc_stride * sizeof *w->sum);
    w->scratch = malloc((size_t)w->nthreads * w->scratch_stride * sizeof *w->scratch);
    if (!w->vall || !w->vt || !w->gram || !w->chol || !w->chol_ok || !w->order || !w->rowerr || !w->mem_row || !w->mem_slot ||
        !w->mem_start || !w->acc || !w->sum || !w->scratch)
        return op_error_set(err, OP_ERR_NOMEM, "kcta: out of memory for %lld rows",
                            (long long)rows);
    return OP_OK;
}

static void work_end(work *w)
{
    free(w->vall);
    free(w->vt);
    free(w->gram);
    free(w->chol);
    free(w->order);
    free(w->chol_ok);
    free(w->rowerr);
    free(w->mem_row);
    free(w->mem_slot);
    free(w->mem_start);
    free(w->acc);
    free(w->sum);
    free(w->scratch);
    free(w->x);
}

/* After a clustering pass: splits the empty clusters (section 5.3), gives each split cluster
 * and its donor the truncated SVD of its new members, then redoes the pass with the clusters
 * kept, so that coefficients, errors and update sums match the new clusters. */
static op_status settle(work *w, double *e, int *splits, unsigned char *touched, op_error *err)
{
    memset(touched, 0, (size_t)w->C);
    *splits = split_empty(w, touched);
    if (*splits == 0)
        return OP_OK;
    op_status st = OP_OK;
    for (int c = 0; c < w->C && st == OP_OK; c++)
        if (touched[c])
            st = refit_cluster(w, c, err);
    if (st != OP_OK)
        return st;
    bases_changed(w);
    if ((st = pass(w, 0, e, err)) == OP_OK)
        build_members(w);
    return st;
}

/* Algorithm 1 from the current bases: a clustering pass (history[0]), then up to max_iters
 * iterations of (update the bases, clustering pass), each recorded in the model's history; an
 * iteration that raises the error is undone and ends the loop, as does a relative decrease of
 * at most tol. Advances progress (may be NULL) and *reported by one per iteration done. */
static op_status iterate(work *w, int max_iters, double tol, op_progress *progress,
                         int *reported, op_error *err)
{
    op_kcta_model *md = w->md;
    const int C = w->C;
    size_t nb = (size_t)C * w->n * w->T, nc = (size_t)w->rows * w->K * w->T,
           ni = (size_t)w->rows * w->K;
    float *sb = malloc(nb * sizeof *sb), *sc = malloc(nc * sizeof *sc);
    uint32_t *si = malloc(ni * sizeof *si);
    unsigned char *touched = malloc((size_t)C);
    op_status st = OP_OK;
    double prev, t0 = op_monotonic_seconds();
    int splits;
    if (!sb || !sc || !si || !touched) {
        st = op_error_set(err, OP_ERR_NOMEM, "kcta: out of memory for %lld rows",
                          (long long)w->rows);
        goto done;
    }
    bases_changed(w);
    w->guard = 0;
    if ((st = pass(w, 1, &prev, err)) != OP_OK)
        goto done;
    w->guard = w->K > 1;
    build_members(w);
    if ((st = settle(w, &prev, &splits, touched, err)) != OP_OK)
        goto done;
    md->splits += splits;
    md->history[md->nhistory++] = prev;
    op_log(OP_LOG_DEBUG, "kcta, %lld rows: squared error %.9g, %d empty cluster(s) split "
           "(%.3f s)", (long long)w->rows, prev, splits, op_monotonic_seconds() - t0);
    for (int it = 0; it < max_iters && md->nhistory <= OP_KCTA_MAX_HISTORY; it++) {
        double t1 = op_monotonic_seconds();
        memcpy(sb, md->basis, nb * sizeof *sb);
        memcpy(sc, md->coef, nc * sizeof *sc);
        memcpy(si, md->idx, ni * sizeof *si);
        update_bases(w);
        bases_changed(w);
        double e;
        if ((st = pass(w, 1, &e, err)) != OP_OK)
            goto done;
        build_members(w);
        if ((st = settle(w, &e, &splits, touched, err)) != OP_OK)
            goto done;
        if (!isfinite(e)) {
            st = op_error_set(err, OP_ERR_NUMERIC, "kcta: iteration %d: error is not finite",
                              it + 1);
            goto done;
        }
        op_log(OP_LOG_DEBUG, "kcta iteration %d: squared error %.9g, %d empty cluster(s) split "
               "(%.3f s)", it + 1, e, splits, op_monotonic_seconds() - t1);
        if (progress)
            op_progress_advance(progress, 1);
        if (reported)
            (*reported)++;
        if (e > prev) {
            memcpy(md->basis, sb, nb * sizeof *sb);
            memcpy(md->coef, sc, nc * sizeof *sc);
            memcpy(md->idx, si, ni * sizeof *si);
            build_members(w);
            md->restored = 1;
            op_log(OP_LOG_DEBUG, "kcta: the error rose; restored iteration %d", it);
            break;
        }
        md->splits += splits;
        md->iterations = it + 1;
        md->history[md->nhistory++] = e;
        if (prev - e <= tol * prev)
            break;
        prev = e;
    }
done:
    free(sb);
    free(sc);
    free(si);
    free(touched);
    return st;
}

/* The sample stage's default size (kcta.h): max(SAMPLE_ROWS, SAMPLE_PER_CLUSTER * C) rows. */
#define SAMPLE_ROWS 16384
#define SAMPLE_PER_CLUSTER 256

op_status op_kcta_factor(const float *a, int64_t rows, int cols, const op_kcta_options *opt,
                         op_kcta_model *md, op_progress *progress, op_error *err)
{
    memset(md, 0, sizeof *md);
    const int C = opt->clusters, K = opt->km, T = opt->terms;
    if (rows < 1 || cols < 1)
        return op_error_set(err, OP_ERR_INPUT, "kcta: empty matrix");
    if (C < 1 || C > 65536 || (int64_t)C > rows)
        return op_error_set(err, OP_ERR_INPUT, "kcta: %d clusters, need 1 to min(65536, rows = "
                            "%lld)", C, (long long)rows);
    if (K < 1 || K > C || K > 64)
        return op_error_set(err, OP_ERR_INPUT, "kcta: K_m = %d, need 1 to min(64, C = %d)", K, C);
    if (T < 1 || T > cols || K * T > 64 || (int64_t)C * T > 4096)
        return op_error_set(err, OP_ERR_INPUT, "kcta: T = %d, need 1 to %d columns with K_m * T "
                            "<= 64 and C * T <= 4096", T, cols);
    if (opt->max_iters < 1 || opt->max_iters > OP_KCTA_MAX_HISTORY)
        return op_error_set(err, OP_ERR_INPUT, "kcta: %d iterations, need 1 to %d",
                            opt->max_iters, OP_KCTA_MAX_HISTORY);
    md->rows = rows;
    md->cols = cols;
    md->clusters = C;
    md->km = K;
    md->terms = T;
    size_t nb = (size_t)C * cols * T, nc = (size_t)rows * K * T, ni = (size_t)rows * K;
    md->basis = malloc(nb * sizeof *md->basis);
    md->coef = malloc(nc * sizeof *md->coef);
    md->idx = malloc(ni * sizeof *md->idx);
    work w = {0};
    op_status st = OP_OK;
    /* The passes' tasks call gemm themselves, and the other products are small (the clusters'
     * SVDs): OpenBLAS's own threads would only compete with the tasks or wait for work. */
    int blas = openblas_get_num_threads();
    openblas_set_num_threads(1);
    if (!md->basis || !md->coef || !md->idx) {
        st = op_error_set(err, OP_ERR_NOMEM, "kcta: out of memory for %lld rows", (long long)rows);
        goto done;
    }
    int64_t want = opt->sample_rows > 0 ? opt->sample_rows
                   : (int64_t)C * SAMPLE_PER_CLUSTER > SAMPLE_ROWS ? (int64_t)C * SAMPLE_PER_CLUSTER
                                                                   : SAMPLE_ROWS;
    int64_t S = rows / want;
    if (S >= 2) {
        /* The sample stage: initialization and iterations on every S-th row (a copy). */
        int64_t rs = (rows + S - 1) / S;
        float *as = malloc((size_t)rs * cols * sizeof *as);
        op_kcta_model ms = {.rows = rs, .cols = cols, .clusters = C, .km = K, .terms = T,
                            .basis = md->basis};
        ms.idx = malloc((size_t)rs * K * sizeof *ms.idx);
        ms.coef = malloc((size_t)rs * K * T * sizeof *ms.coef);
        work ws = {0};
        if (!as || !ms.idx || !ms.coef)
            st = op_error_set(err, OP_ERR_NOMEM, "kcta: out of memory for %lld rows",
                              (long long)rows);
        else {
            for (int64_t q = 0; q < rs; q++)
                memcpy(as + q * cols, a + q * S * cols, (size_t)cols * sizeof *as);
            st = work_begin(&ws, as, rs, cols, opt, &ms, err);
        }
        if (st == OP_OK)
            st = initialize(&ws, err);
        if (st == OP_OK)
            st = iterate(&ws, opt->max_iters, opt->tol, NULL, NULL, err);
        work_end(&ws);
        free(as);
        free(ms.idx);
        free(ms.coef);
        if (st != OP_OK)
            goto done;
        if ((st = work_begin(&w, a, rows, cols, opt, md, err)) != OP_OK)
            goto done;
    } else {
        if ((st = work_begin(&w, a, rows, cols, opt, md, err)) != OP_OK ||
            (st = initialize(&w, err)) != OP_OK)
            goto done;
    }
    md->norm2 = matrix_norm2(&w);
    op_progress_advance(progress, 1);
    int reported = 0; /* iterations whose progress unit was advanced */
    st = iterate(&w, opt->max_iters, opt->tol, progress, &reported, err);
    if (st != OP_OK)
        goto done;
    /* the iterations that convergence made unnecessary are done too */
    op_progress_advance(progress, (uint64_t)(opt->max_iters - reported));
    double core = postprocess(&w);
    op_log(OP_LOG_DEBUG, "kcta: core norm %.6g", core);
    /* Coefficients must be finite for the file; a basis is orthonormal by construction. */
    for (size_t q = 0; q < nc; q++)
        if (!isfinite(md->coef[q])) {
            st = op_error_set(err, OP_ERR_NUMERIC, "kcta: coefficient %zu is not finite", q);
            break;
        }
done:
    work_end(&w);
    openblas_set_num_threads(blas);
    if (st != OP_OK)
        op_kcta_free(md);
    return st;
}
