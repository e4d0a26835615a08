/* rsvd.c - see rsvd.h. */
#include "rsvd.h"

#include <cblas.h>
#include <float.h>
#include <lapacke.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

op_rsvd_options op_rsvd_defaults(void)
{
    return (op_rsvd_options){.oversample = 10, .power_iters = 4, .power_tol = 1e-2, .seed = 1,
                             .precision = OP_SVD_SINGLE, .exact = 0, .threads = 0};
}

/* The squared Frobenius norm of n floats, accumulated in double. */
static double squared_norm(const float *a, size_t n)
{
    double sum = 0.0;
    for (size_t at = 0; at < n;) {
        blasint len = (blasint)(n - at < ((size_t)1 << 30) ? n - at : (size_t)1 << 30);
        sum += cblas_dsdot(len, a + at, 1, a + at, 1);
        at += (size_t)len;
    }
    return sum;
}

/* Whether power iterations may stop: the estimated squared rank-k error, ||A||^2 minus the
 * captured energy, fell by at most tol of itself since the previous iteration (so the error
 * itself changes by about tol / 2 or less), or by less than the rounding level of the energies
 * (resolution x ||A||^2: changes below it are rounding noise of the products, not progress), or
 * the error is itself at that level. */
static int converged(double captured_prev, double captured, double norm2, double tol,
                     double resolution)
{
    if (tol <= 0 || captured < 0 || captured_prev < 0)
        return 0;
    double residual = norm2 - captured;
    if (residual <= resolution * norm2)
        return 1;
    return captured - captured_prev <= fmax(tol * residual, resolution * norm2);
}

/* A standard normal deviate (Box-Muller). */
static double gaussian(uint64_t *state)
{
    double u1 = ((double)(op_splitmix64(state) >> 11) + 1.0) * 0x1.0p-53; /* (0, 1] */
    double u2 = (double)(op_splitmix64(state) >> 11) * 0x1.0p-53;
    return sqrt(-2.0 * log(u1)) * cos(6.283185307179586 * u2);
}

/* Rows per task of a pass over an in-memory matrix: about 1.5 MiB of it (a core's cache), fixed
 * by the shape alone so that the result does not depend on the thread count. */
static int64_t pass_rows(int64_t m, int64_t n)
{
    int64_t per = ((int64_t)3 << 19) / (n * (int64_t)sizeof(float));
    per = per < 16 ? 16 : per;
    while ((m + per - 1) / per > 1024) /* each task's part of A^T y is n x l */
        per *= 2;
    return per;
}

#define REAL float
#define FN(name) name##_single
#define RSVD_IS_DOUBLE 0
#define GEMM cblas_sgemm
#define GEQRF LAPACKE_sgeqrf
#define ORGQR LAPACKE_sorgqr
#define DOT cblas_dsdot
#define ENERGY_RESOLUTION (8 * FLT_EPSILON)
#include "rsvd_impl.h"

#define REAL double
#define FN(name) name##_double
#define RSVD_IS_DOUBLE 1
#define GEMM cblas_dgemm
#define GEQRF LAPACKE_dgeqrf
#define ORGQR LAPACKE_dorgqr
#define DOT cblas_ddot
#define ENERGY_RESOLUTION (64 * DBL_EPSILON)
#include "rsvd_impl.h"

/* Full SVD in double (gesdd), truncated to k. */
static op_status exact_svd(const float *a, int64_t m, int64_t n, int k, float *us, float *v,
                           double *s, op_error *err)
{
    int64_t mn = m < n ? m : n;
    double *A = malloc((size_t)m * (size_t)n * sizeof *A);
    double *U = malloc((size_t)m * (size_t)mn * sizeof *U);
    double *VT = malloc((size_t)mn * (size_t)n * sizeof *VT);
    double *S = malloc((size_t)mn * sizeof *S);
    op_status st = OP_OK;
    if (!A || !U || !VT || !S) {
        st = op_error_set(err, OP_ERR_NOMEM, "SVD: out of memory for a %lld x %lld matrix",
                          (long long)m, (long long)n);
        goto done;
    }
    for (size_t i = 0; i < (size_t)m * (size_t)n; i++)
        A[i] = a[i];
    lapack_int info = LAPACKE_dgesdd(LAPACK_ROW_MAJOR, 'S', (lapack_int)m, (lapack_int)n, A,
                                     (lapack_int)n, S, U, (lapack_int)mn, VT, (lapack_int)n);
    if (info != 0) {
        st = op_error_set(err, OP_ERR_NUMERIC, "SVD of a %lld x %lld matrix failed (LAPACK info "
                          "%d)", (long long)m, (long long)n, (int)info);
        goto done;
    }
    for (int64_t i = 0; i < m; i++)
        for (int t = 0; t < k; t++)
            us[i * k + t] = (float)(U[i * mn + t] * S[t]);
    for (int64_t j = 0; j < n; j++)
        for (int t = 0; t < k; t++)
            v[j * k + t] = (float)VT[t * n + j];
    if (s)
        for (int t = 0; t < k; t++)
            s[t] = S[t];
done:
    free(A);
    free(U);
    free(VT);
    free(S);
    return st;
}

/* Makes each pair's right vector's largest-magnitude entry positive; checks finiteness. */
static op_status fix_signs(int64_t m, int64_t n, int k, float *us, float *v, op_error *err)
{
    for (int t = 0; t < k; t++) {
        float big = 0.0f;
        for (int64_t j = 0; j < n; j++)
            if (fabsf(v[j * k + t]) > fabsf(big))
                big = v[j * k + t];
        if (big < 0.0f) {
            for (int64_t j = 0; j < n; j++)
                v[j * k + t] = -v[j * k + t];
            for (int64_t i = 0; i < m; i++)
                us[i * k + t] = -us[i * k + t];
        }
    }
    for (size_t i = 0; i < (size_t)m * (size_t)k; i++)
        if (!isfinite(us[i]))
            return op_error_set(err, OP_ERR_NUMERIC, "SVD: left factor entry %zu is not finite",
                                i);
    for (size_t i = 0; i < (size_t)n * (size_t)k; i++)
        if (!isfinite(v[i]))
            return op_error_set(err, OP_ERR_NUMERIC, "SVD: right factor entry %zu is not finite",
                                i);
    return OP_OK;
}

static int use_exact(int64_t m, int64_t n, int k, const op_rsvd_options *opt)
{
    int64_t mn = m < n ? m : n;
    return opt->exact || (int64_t)k + opt->oversample >= mn;
}

uint64_t op_rsvd_progress_units(int64_t m, int64_t n, int k, const op_rsvd_options *opt)
{
    return use_exact(m, n, k, opt) ? 1
                                   : (uint64_t)(1 + (opt->power_iters > 1 ? opt->power_iters : 1));
}

/* Fills a (m x n) through src in parallel blocks of rows, for the exact method. */
typedef struct fill_job {
    const op_row_source *src;
    float *a;
    int64_t m, n, per;
    op_status *status;
    op_error *errs;
} fill_job;

static void fill_task(void *user, int task, int thread)
{
    const fill_job *j = user;
    int64_t r0 = (int64_t)task * j->per, nb = j->m - r0 < j->per ? j->m - r0 : j->per;
    (void)thread;
    j->status[task] = j->src->fetch(j->src->user, r0, nb, j->a + r0 * j->n, &j->errs[task]);
}

static op_status fill_all(const op_row_source *src, float *a, int64_t m, int64_t n, int threads,
                          op_error *err)
{
    fill_job j = {src, a, m, n, pass_rows(m, n), NULL, NULL};
    int tasks = (int)((m + j.per - 1) / j.per);
    j.status = calloc((size_t)tasks, sizeof *j.status);
    j.errs = calloc((size_t)tasks, sizeof *j.errs);
    op_status st = !j.status || !j.errs ? op_error_set(err, OP_ERR_NOMEM, "out of memory")
                                        : op_parallel_for(threads, tasks, fill_task, &j, NULL,
                                                          err);
    for (int t = 0; st == OP_OK && t < tasks; t++)
        if (j.status[t] != OP_OK) {
            st = j.status[t];
            if (err)
                *err = j.errs[t];
        }
    free(j.status);
    free(j.errs);
    return st;
}

/* op_rsvd of a in memory; of rows when a is NULL; of a made by rows' first pass when fill. */
static op_status rsvd_any(const float *a, const op_row_source *rows, float *fill, int64_t m,
                          int64_t n, int k, const op_rsvd_options *opt, float *us, float *v,
                          double *s, op_progress *progress, op_error *err)
{
    op_rsvd_options def = op_rsvd_defaults();
    if (!opt)
        opt = &def;
    int64_t mn = m < n ? m : n;
    if (m < 1 || n < 1 || k < 1 || k > mn)
        return op_error_set(err, OP_ERR_INPUT, "SVD: rank %d is not in [1, %lld] for a %lld x %lld "
                            "matrix", k, (long long)mn, (long long)m, (long long)n);
    if (opt->oversample < 0 || opt->power_iters < 0 || !(opt->power_tol >= 0))
        return op_error_set(err, OP_ERR_INPUT, "SVD: negative oversampling or power iterations");
    if (m > INT32_MAX || n > INT32_MAX || m * n / n != m)
        return op_error_set(err, OP_ERR_INPUT, "SVD: %lld x %lld is too large for LAPACK",
                            (long long)m, (long long)n);
    if (rows && !fill && (use_exact(m, n, k, opt) || rows->block_rows < 1))
        return op_error_set(err, OP_ERR_INPUT, "SVD: a matrix read in blocks of rows needs the "
                            "randomized method (rank %d + oversampling %d < min(%lld, %lld), "
                            "no --exact-svd)", k, opt->oversample, (long long)m, (long long)n);
    op_status st = OP_OK;
    if (use_exact(m, n, k, opt)) {
        if (fill)
            st = fill_all(rows, fill, m, n, opt->threads, err);
        if (st == OP_OK)
            st = exact_svd(fill ? fill : a, m, n, k, us, v, s, err);
        op_progress_advance(progress, 1);
    } else {
        int l = k + opt->oversample, q = opt->power_iters > 1 ? opt->power_iters : 1;
        if (opt->precision == OP_SVD_DOUBLE) {
            source_double src = {a, fill, rows, opt->threads, NULL, NULL};
            st = randomized_double(&src, m, n, k, l, q, opt->power_tol, opt->seed, us, v, s,
                                   progress, err);
        } else {
            source_single src = {a, fill, rows, opt->threads, NULL, NULL};
            st = randomized_single(&src, m, n, k, l, q, opt->power_tol, opt->seed, us, v, s,
                                   progress, err);
        }
    }
    return st == OP_OK ? fix_signs(m, n, k, us, v, err) : st;
}

op_status op_rsvd(const float *a, int64_t m, int64_t n, int k, const op_rsvd_options *opt,
                  float *us, float *v, double *s, op_progress *progress, op_error *err)
{
    return rsvd_any(a, NULL, NULL, m, n, k, opt, us, v, s, progress, err);
}

op_status op_rsvd_rows(const op_row_source *src, int64_t m, int64_t n, int k,
                       const op_rsvd_options *opt, float *us, float *v, double *s,
                       op_progress *progress, op_error *err)
{
    return rsvd_any(NULL, src, NULL, m, n, k, opt, us, v, s, progress, err);
}

op_status op_rsvd_fill(const op_row_source *src, float *a, int64_t m, int64_t n, int k,
                       const op_rsvd_options *opt, float *us, float *v, double *s,
                       op_progress *progress, op_error *err)
{
    return rsvd_any(NULL, src, a, m, n, k, opt, us, v, s, progress, err);
}
