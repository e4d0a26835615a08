/* nmf.c - see nmf.h. */
#include "nmf.h"

#include "preprocess.h"

#include <cblas.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define RESIDUAL_BLOCK 2048

op_nmf_options op_nmf_defaults(void)
{
    return (op_nmf_options){.rank = 10, .max_iter = 200, .tol = 1e-4, .svd = op_rsvd_defaults()};
}

typedef struct radius {
    int d2, col;
} radius;

static int by_radius(const void *pa, const void *pb)
{
    const radius *a = pa, *b = pb;
    return a->d2 != b->d2 ? (a->d2 > b->d2) - (a->d2 < b->d2) : (a->col > b->col) - (a->col < b->col);
}

void op_nmf_homogeneous(const float *rd, int64_t rows, int kernel, double e, float *profile,
                        float *scale)
{
    int n = kernel * kernel, h = kernel / 2;
    double *acc = calloc((size_t)n, sizeof *acc);
    radius *order = malloc((size_t)n * sizeof *order);
    for (int j = 0; j < n; j++)
        profile[j] = 0.0f;
    for (int64_t i = 0; i < rows; i++) {
        double s = 0;
        for (int j = 0; j < n; j++)
            s += op_prep_clean(rd[i * n + j]);
        scale[i] = (float)(e == 1.0 ? s : pow(s, e));
        if (acc && s > 0)
            for (int j = 0; j < n; j++)
                acc[j] += op_prep_clean(rd[i * n + j]) / s;
    }
    if (!acc || !order) {
        free(acc);
        free(order);
        return; /* out of memory: an all-zero profile, which reconstructs to 0 */
    }
    for (int j = 0; j < n; j++) {
        int dy = j / kernel - h, dx = j % kernel - h;
        order[j] = (radius){dx * dx + dy * dy, j};
    }
    qsort(order, (size_t)n, sizeof *order, by_radius);
    double total = 0;
    for (int g0 = 0; g0 < n;) {
        int g1 = g0;
        double s = 0;
        while (g1 < n && order[g1].d2 == order[g0].d2)
            s += acc[order[g1++].col];
        for (int g = g0; g < g1; g++)
            acc[order[g].col] = s / (g1 - g0);
        total += s;
        g0 = g1;
    }
    if (total > 0)
        for (int j = 0; j < n; j++)
            profile[j] = (float)(e == 1.0 ? acc[j] / total : pow(acc[j] / total, e));
    free(acc);
    free(order);
}

void op_nmf_remainder(const float *rd, int64_t rows, int cols, const float *profile,
                      const float *scale, float *q)
{
    for (int64_t i = 0; i < rows; i++)
        for (int j = 0; j < cols; j++) {
            double d = (double)scale[i] * profile[j];
            double v = d > 0 ? op_prep_clean(rd[i * cols + j]) / d : 0.0;
            q[i * cols + j] = (float)fmin(v, 1e30);
        }
}

/* ||q - w h^T||_F^2 in double, by row blocks (scratch: RESIDUAL_BLOCK x cols floats). */
static double objective(const float *q, int64_t rows, int cols, int T, const float *w,
                        const float *h, float *scratch)
{
    double f = 0;
    for (int64_t i0 = 0; i0 < rows; i0 += RESIDUAL_BLOCK) {
        int nb = (int)(rows - i0 < RESIDUAL_BLOCK ? rows - i0 : RESIDUAL_BLOCK);
        cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasTrans, nb, cols, T, 1.0f, w + i0 * T, T,
                    h, T, 0.0f, scratch, cols);
        const float *qb = q + i0 * cols;
        for (size_t k = 0; k < (size_t)nb * cols; k++) {
            double d = (double)qb[k] - scratch[k];
            f += d * d;
        }
    }
    return f;
}

/* One HALS sweep over the columns of x (m x T), given p = Q-side product (m x T) and the Gram
 * matrix g (T x T) of the other factor: x_k <- max(0, x_k + (p_k - x g_k) / g_kk). */
static void hals_sweep(float *x, int64_t m, int T, const float *p, const double *g)
{
    for (int k = 0; k < T; k++) {
        double gkk = g[k * T + k];
        if (!(gkk > 0))
            continue;
        for (int64_t i = 0; i < m; i++) {
            float *xi = x + i * T;
            double s = p[i * T + k];
            for (int t = 0; t < T; t++)
                s -= (double)xi[t] * g[t * T + k];
            double v = xi[k] + s / gkk;
            xi[k] = v > 0 ? (float)v : 0.0f;
        }
    }
}

/* g = x^T x (T x T, double) for x m x T. */
static void gram(const float *x, int64_t m, int T, double *g)
{
    memset(g, 0, (size_t)T * T * sizeof *g);
    for (int64_t i = 0; i < m; i++)
        for (int t = 0; t < T; t++)
            for (int u = t; u < T; u++)
                g[t * T + u] += (double)x[i * T + t] * x[i * T + u];
    for (int t = 0; t < T; t++)
        for (int u = 0; u < t; u++)
            g[t * T + u] = g[u * T + t];
}

/* NNDSVD: each singular pair's dominant sign part (Boutsidis and Gallopoulos 2008). */
static void nndsvd(int64_t rows, int cols, int T, const float *us, const float *v,
                   const double *s, float *w, float *h)
{
    for (int t = 0; t < T; t++) {
        double pu = 0, nu = 0, pv = 0, nv = 0;
        if (!(s[t] > 0)) {
            for (int64_t i = 0; i < rows; i++)
                w[i * T + t] = 0.0f;
            for (int j = 0; j < cols; j++)
                h[(size_t)j * T + t] = 0.0f;
            continue;
        }
        for (int64_t i = 0; i < rows; i++) {
            double x = us[i * T + t] / s[t];
            pu += x > 0 ? x * x : 0;
            nu += x < 0 ? x * x : 0;
        }
        for (int j = 0; j < cols; j++) {
            double y = v[(size_t)j * T + t];
            pv += y > 0 ? y * y : 0;
            nv += y < 0 ? y * y : 0;
        }
        pu = sqrt(pu), nu = sqrt(nu), pv = sqrt(pv), nv = sqrt(nv);
        int pos = pu * pv >= nu * nv;
        double nx = pos ? pu : nu, ny = pos ? pv : nv, sigma = pos ? pu * pv : nu * nv;
        double f = sqrt(s[t] * sigma);
        for (int64_t i = 0; i < rows; i++) {
            double x = us[i * T + t] / s[t] * (pos ? 1 : -1);
            w[i * T + t] = x > 0 && nx > 0 ? (float)(f * x / nx) : 0.0f;
        }
        for (int j = 0; j < cols; j++) {
            double y = v[(size_t)j * T + t] * (pos ? 1 : -1);
            h[(size_t)j * T + t] = y > 0 && ny > 0 ? (float)(f * y / ny) : 0.0f;
        }
    }
}

op_status op_nmf_hals(const float *q, int64_t rows, int cols, const op_nmf_options *opt,
                      float *w, float *h, op_nmf_stats *stats, op_progress *progress,
                      op_error *err)
{
    const int T = opt->rank;
    int64_t mn = rows < cols ? rows : cols;
    memset(stats, 0, sizeof *stats);
    if (T < 1 || T > mn || T > 4096)
        return op_error_set(err, OP_ERR_INPUT, "nmf: rank %d is not in [1, %lld]", T,
                            (long long)(mn < 4096 ? mn : 4096));
    if (opt->max_iter < 0 || !(opt->tol >= 0))
        return op_error_set(err, OP_ERR_INPUT, "nmf: bad stopping rule");
    float *us = malloc((size_t)rows * T * sizeof *us), *v = malloc((size_t)cols * T * sizeof *v);
    float *p = malloc((size_t)(rows > cols ? rows : cols) * T * sizeof *p);
    int64_t sb = rows < RESIDUAL_BLOCK ? rows : RESIDUAL_BLOCK;
    float *scratch = malloc((size_t)sb * cols * sizeof *scratch);
    double *s = malloc((size_t)T * sizeof *s), *g = malloc((size_t)T * T * sizeof *g);
    op_status st = OP_OK;
    if (!us || !v || !p || !scratch || !s || !g) {
        st = op_error_set(err, OP_ERR_NOMEM, "nmf: out of memory");
        goto done;
    }
    double norm = 0;
    for (size_t k = 0; k < (size_t)rows * cols; k++)
        norm += (double)q[k] * q[k];
    stats->norm = norm;
    if ((st = op_rsvd(q, rows, cols, T, &opt->svd, us, v, s, NULL, err)) != OP_OK)
        goto done;
    nndsvd(rows, cols, T, us, v, s, w, h);
    double f = objective(q, rows, cols, T, w, h, scratch);
    stats->initial = f;
    int it = 0, converged = f <= 1e-12 * norm;
    while (!converged && it < opt->max_iter) {
        /* W: P = Q H, G = H^T H; then H: P = Q^T W, G = W^T W. */
        cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, (int)rows, T, cols, 1.0f, q, cols,
                    h, T, 0.0f, p, T);
        gram(h, cols, T, g);
        hals_sweep(w, rows, T, p, g);
        cblas_sgemm(CblasRowMajor, CblasTrans, CblasNoTrans, cols, T, (int)rows, 1.0f, q, cols,
                    w, T, 0.0f, p, T);
        gram(w, rows, T, g);
        hals_sweep(h, cols, T, p, g);
        double fn = objective(q, rows, cols, T, w, h, scratch);
        it++;
        op_progress_advance(progress, 1);
        if (!isfinite(fn)) {
            st = op_error_set(err, OP_ERR_NUMERIC, "nmf: iteration %d: objective not finite", it);
            goto done;
        }
        converged = fabs(f - fn) <= opt->tol * f || fn <= 1e-12 * norm;
        f = fn;
    }
    op_progress_advance(progress, (uint64_t)(opt->max_iter - it));
    stats->iterations = it;
    stats->converged = converged;
    stats->objective = f;
    for (size_t k = 0; k < (size_t)rows * T; k++)
        if (!isfinite(w[k]))
            st = op_error_set(err, OP_ERR_NUMERIC, "nmf: W value %zu is not finite", k);
    for (size_t k = 0; k < (size_t)cols * T; k++)
        if (!isfinite(h[k]))
            st = op_error_set(err, OP_ERR_NUMERIC, "nmf: H value %zu is not finite", k);
done:
    free(us);
    free(v);
    free(p);
    free(scratch);
    free(s);
    free(g);
    return st;
}
