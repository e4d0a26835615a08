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
    return (op_kcta_options){.clusters = 8, .km = 2, .terms = 4, .max_iters = 10, .tol = 1e-4,
                             .svd = op_rsvd_defaults()};
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

/* Solves the symmetric positive semi-definite n x n system g y = b in the least-squares,
 * minimum-norm sense (Moore-Penrose): Cholesky when well conditioned, else an eigen
 * decomposition dropping eigenvalues below 1e-10 of the largest. work: 2 n^2 + 2 n doubles. */
static void gram_solve(const double *g, int n, const double *b, double *y, double *work)
{
    double *l = work, *w = work + (size_t)n * n;
    memcpy(l, g, (size_t)n * n * sizeof *l);
    double dmax = 0;
    for (int i = 0; i < n; i++)
        dmax = fmax(dmax, g[(size_t)i * n + i]);
    int ok = dmax > 0;
    for (int j = 0; j < n && ok; j++) {
        double d = l[(size_t)j * n + j];
        for (int k = 0; k < j; k++)
            d -= l[(size_t)j * n + k] * l[(size_t)j * n + k];
        if (!(d > 1e-8 * dmax)) {
            ok = 0;
            break;
        }
        d = sqrt(d);
        l[(size_t)j * n + j] = d;
        for (int i = j + 1; i < n; i++) {
            double s = l[(size_t)i * n + j];
            for (int k = 0; k < j; k++)
                s -= l[(size_t)i * n + k] * l[(size_t)j * n + k];
            l[(size_t)i * n + j] = s / d;
        }
    }
    if (ok) {
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

/* ------------------------------------------------------------ the stages */

typedef struct work {
    const float *a;
    int64_t rows;
    int n, C, K, T, CT;
    op_kcta_model *md;
    const op_rsvd_options *svd;
    float *vall;    /* n x CT */
    double *gram;   /* CT x CT */
    float *proj;    /* block x CT */
    double *rowerr; /* rows */
    int64_t *mem_row; /* rows * K member lists, grouped by cluster */
    int *mem_slot;
    int64_t *mem_start; /* C + 1 */
    float *x;           /* a cluster's rows (residuals), x_rows x n, kept across iterations */
    int64_t x_rows;     /* so that its pages are faulted in once, not at every iteration */
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

#define PROJ_BLOCK 4096

/* The clustering stage: greedy search with optimal projection for every row. Fills idx, coef
 * and rowerr (the squared error of every row, computed in the reduced space). */
static void clustering_stage(work *w)
{
    const int n = w->n, C = w->C, K = w->K, T = w->T, CT = w->CT;
    op_kcta_model *md = w->md;
    for (int c = 0; c < C; c++)
        for (int j = 0; j < n; j++)
            for (int t = 0; t < T; t++)
                w->vall[(size_t)j * CT + c * T + t] = md->basis[((size_t)c * n + j) * T + t];
    /* The Gram matrix of all cluster bases, in double: the cross terms of Theorem 3. */
    for (int p = 0; p < CT; p++)
        for (int q = p; q < CT; q++) {
            double s = 0;
            for (int j = 0; j < n; j++)
                s += (double)w->vall[(size_t)j * CT + p] * w->vall[(size_t)j * CT + q];
            w->gram[(size_t)p * CT + q] = w->gram[(size_t)q * CT + p] = s;
        }
    int KT = K * T;
    double y[4096], b[4096], gs[4096], scratch[2 * 4096 + 2 * 64 + 64];
    int sel[64];
    for (int64_t i0 = 0; i0 < w->rows; i0 += PROJ_BLOCK) {
        int64_t nb = w->rows - i0 < PROJ_BLOCK ? w->rows - i0 : PROJ_BLOCK;
        /* Projections of the rows onto every cluster: the first term of (13). */
        cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, (int)nb, CT, n, 1.0f,
                    w->a + i0 * n, n, w->vall, CT, 0.0f, w->proj, CT);
        for (int64_t ii = 0; ii < nb; ii++) {
            int64_t i = i0 + ii;
            const float *p = w->proj + ii * CT;
            for (int k = 0; k < K; k++) {
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
                        double r = p[c * T + t];
                        for (int s = 0; s < k; s++)
                            for (int u = 0; u < T; u++)
                                r -= g[sel[s] * T + u] * y[s * T + u];
                        score += r * r;
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
                /* Theorem 4: the optimal projection onto all k + 1 selected clusters. */
                int m = (k + 1) * T;
                for (int s = 0; s <= k; s++)
                    for (int t = 0; t < T; t++) {
                        b[s * T + t] = p[sel[s] * T + t];
                        for (int s2 = 0; s2 <= k; s2++)
                            for (int u = 0; u < T; u++)
                                gs[(s * T + t) * m + s2 * T + u] =
                                    w->gram[(size_t)(sel[s] * T + t) * CT + sel[s2] * T + u];
                    }
                gram_solve(gs, m, b, y, scratch);
            }
            const float *ai = w->a + i * n;
            double e = 0, yb = 0, ygy = 0;
            for (int j = 0; j < n; j++)
                e += (double)ai[j] * ai[j];
            for (int q = 0; q < KT; q++) {
                yb += y[q] * b[q];
                double s = 0;
                for (int q2 = 0; q2 < KT; q2++)
                    s += gs[q * KT + q2] * y[q2];
                ygy += y[q] * s;
            }
            w->rowerr[i] = fmax(0.0, e - 2 * yb + ygy);
            for (int s = 0; s < K; s++) {
                md->idx[i * K + s] = (uint32_t)sel[s];
                for (int t = 0; t < T; t++)
                    md->coef[((size_t)i * K + s) * T + t] = (float)y[s * T + t];
            }
        }
    }
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
 * stage fits them. Returns the number of clusters refilled. */
static int split_empty(work *w)
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
        splits++;
        build_members(w);
    }
    return splits;
}

/* Section 4.3: each cluster in turn, on its members only, gets the rank-T truncated SVD of
 * their residuals with the other clusters fixed; the new basis replaces the old one only when
 * it captures at least as much of the residuals. Members' coefficients become the projection
 * of their residuals. The total error never increases. */
static op_status update_stage(work *w, op_error *err)
{
    const int n = w->n, T = w->T, K = w->K;
    op_kcta_model *md = w->md;
    op_status st = OP_OK;
    int64_t maxm = 0;
    for (int c = 0; c < w->C; c++)
        if (w->mem_start[c + 1] - w->mem_start[c] > maxm)
            maxm = w->mem_start[c + 1] - w->mem_start[c];
    float *x = rows_buffer(w, maxm ? maxm : 1);
    float *ynew = malloc((size_t)(maxm ? maxm : 1) * T * sizeof *ynew);
    float *yold = malloc((size_t)(maxm ? maxm : 1) * T * sizeof *yold);
    float *vnew = malloc((size_t)n * T * sizeof *vnew);
    if (!x || !ynew || !yold || !vnew) {
        st = op_error_set(err, OP_ERR_NOMEM, "kcta: out of memory");
        goto done;
    }
    for (int c = 0; c < w->C && st == OP_OK; c++) {
        int64_t m0 = w->mem_start[c], m = w->mem_start[c + 1] - m0;
        if (m == 0)
            continue;
        for (int64_t q = 0; q < m; q++) {
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
        float *vold = md->basis + (size_t)c * n * T;
        st = subspace_of(x, m, n, T, w->svd, vnew, err);
        if (st != OP_OK)
            break;
        cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, (int)m, T, n, 1.0f, x, n, vnew, T,
                    0.0f, ynew, T);
        cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, (int)m, T, n, 1.0f, x, n, vold, T,
                    0.0f, yold, T);
        double enew = 0, eold = 0;
        for (int64_t q = 0; q < m * T; q++) {
            enew += (double)ynew[q] * ynew[q];
            eold += (double)yold[q] * yold[q];
        }
        const float *ych = yold;
        if (enew >= eold) {
            memcpy(vold, vnew, (size_t)n * T * sizeof *vold);
            ych = ynew;
        }
        for (int64_t q = 0; q < m; q++)
            memcpy(md->coef + ((size_t)w->mem_row[m0 + q] * K + w->mem_slot[m0 + q]) * T,
                   ych + q * T, (size_t)T * sizeof(float));
    }
done:
    free(ynew);
    free(yold);
    free(vnew);
    return st;
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
    x = rows_buffer(w, maxc);
    if (!x) {
        st = op_error_set(err, OP_ERR_NOMEM, "kcta: out of memory");
        goto done;
    }
    for (int c = 0; c < C && st == OP_OK; c++) {
        int64_t m = 0;
        for (int64_t i = 0; i < rows; i++)
            if (label[i] == c)
                memcpy(x + m++ * n, w->a + i * n, (size_t)n * sizeof *x);
        st = subspace_of(x, m, n, T, w->svd, w->md->basis + (size_t)c * n * T, err);
    }
done:
    free(z);
    free(vg);
    free(cent);
    free(dist);
    free(label);
    free(count);
    return st;
}

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
    float *sb = malloc(nb * sizeof *sb), *sc = malloc(nc * sizeof *sc);
    uint32_t *si = malloc(ni * sizeof *si);
    work w = {a, rows, cols, C, K, T, C * T, md, &opt->svd, NULL, NULL, NULL, NULL, NULL, NULL,
              NULL, NULL, 0};
    int64_t pb = rows < PROJ_BLOCK ? rows : PROJ_BLOCK;
    w.vall = malloc((size_t)cols * C * T * sizeof *w.vall);
    w.gram = malloc((size_t)C * T * C * T * sizeof *w.gram);
    w.proj = malloc((size_t)pb * C * T * sizeof *w.proj);
    w.rowerr = malloc((size_t)rows * sizeof *w.rowerr);
    w.mem_row = malloc(ni * sizeof *w.mem_row);
    w.mem_slot = malloc(ni * sizeof *w.mem_slot);
    w.mem_start = malloc((size_t)(C + 1) * sizeof *w.mem_start);
    op_status st = OP_OK;
    if (!md->basis || !md->coef || !md->idx || !sb || !sc || !si || !w.vall || !w.gram ||
        !w.proj || !w.rowerr || !w.mem_row || !w.mem_slot || !w.mem_start) {
        st = op_error_set(err, OP_ERR_NOMEM, "kcta: out of memory for %lld rows", (long long)rows);
        goto done;
    }
    if ((st = initialize(&w, err)) != OP_OK)
        goto done;
    op_progress_advance(progress, 1);
    double prev = INFINITY;
    int reported = 0; /* iterations whose progress unit was advanced */
    for (int it = 0; it < opt->max_iters; it++) {
        if (it > 0) {
            memcpy(sb, md->basis, nb * sizeof *sb);
            memcpy(sc, md->coef, nc * sizeof *sc);
            memcpy(si, md->idx, ni * sizeof *si);
        }
        clustering_stage(&w);
        build_members(&w);
        double core = postprocess(&w);
        int splits = split_empty(&w);
        if ((st = update_stage(&w, err)) != OP_OK)
            goto done;
        double e = op_kcta_error(a, md);
        if (!isfinite(e)) {
            st = op_error_set(err, OP_ERR_NUMERIC, "kcta: iteration %d: error is not finite",
                              it + 1);
            goto done;
        }
        op_log(OP_LOG_DEBUG, "kcta iteration %d: squared error %.9g, core norm %.6g, %d empty "
               "cluster(s) split", it + 1, e, core, splits);
        op_progress_advance(progress, 1);
        reported++;
        if (e > prev) {
            memcpy(md->basis, sb, nb * sizeof *sb);
            memcpy(md->coef, sc, nc * sizeof *sc);
            memcpy(md->idx, si, ni * sizeof *si);
            md->restored = 1;
            op_log(OP_LOG_DEBUG, "kcta: the error rose; restored iteration %d", it);
            break;
        }
        md->splits += splits;
        md->iterations = it + 1;
        md->history[md->nhistory++] = e;
        if (isfinite(prev) && prev - e <= opt->tol * prev)
            break;
        prev = e;
    }
    /* the iterations that convergence made unnecessary are done too */
    op_progress_advance(progress, (uint64_t)(opt->max_iters - reported));
    /* Coefficients must be finite for the file; a basis is orthonormal by construction. */
    for (size_t q = 0; q < nc; q++)
        if (!isfinite(md->coef[q])) {
            st = op_error_set(err, OP_ERR_NUMERIC, "kcta: coefficient %zu is not finite", q);
            break;
        }
done:
    free(sb);
    free(sc);
    free(si);
    free(w.vall);
    free(w.gram);
    free(w.proj);
    free(w.rowerr);
    free(w.mem_row);
    free(w.mem_slot);
    free(w.mem_start);
    free(w.x);
    if (st != OP_OK)
        op_kcta_free(md);
    return st;
}
