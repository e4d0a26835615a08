/* tucker.c - see tucker.h. */
#include "tucker.h"

#include "preprocess.h"

#include <cblas.h>
#include <float.h>
#include <lapacke.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

void op_tucker_free(op_tucker_result *res)
{
    free(res->shift);
    free(res->max);
    free(res->u);
    free(res->v);
    free(res->range);
    free(res->beta);
    memset(res, 0, sizeof *res);
}

double op_chebyshev_eval(const double *coef, int degree, double t)
{
    double b1 = 0, b2 = 0;
    for (int p = degree; p >= 1; p--) {
        double b0 = 2.0 * t * b1 - b2 + coef[p];
        b2 = b1;
        b1 = b0;
    }
    return t * b1 - b2 + coef[0];
}

/* The float32 rounding of coefficients c[0..d] and Clenshaw's float recurrence over them can
 * move a value by at most about this much for |t| <= 1 (|T_p(t)| <= 1). */
static double storage_error_bound(const double *c, int d)
{
    double rounding = 0, sum = 0;
    for (int p = 0; p <= d; p++) {
        rounding += fabs(c[p] - (double)(float)c[p]);
        sum += fabs(c[p]);
    }
    return rounding + 2.0 * (d + 1) * (double)FLT_EPSILON * sum;
}

enum { SUM_LANES = 8 };

/* max |v[i]| of n finite values: on the bits of |v| (non-negative doubles order as their
 * bits), in lanes, so that it vectorizes. */
static double abs_max(const double *v, int n)
{
    int64_t m[SUM_LANES] = {0};
    int i = 0;
    for (; i + SUM_LANES <= n; i += SUM_LANES)
        for (int k = 0; k < SUM_LANES; k++) {
            int64_t b;
            memcpy(&b, &v[i + k], sizeof b);
            b &= INT64_MAX;
            m[k] = b > m[k] ? b : m[k];
        }
    for (int k = 0; i + k < n; k++) {
        int64_t b;
        memcpy(&b, &v[i + k], sizeof b);
        b &= INT64_MAX;
        m[k] = b > m[k] ? b : m[k];
    }
    for (int k = 1; k < SUM_LANES; k++)
        m[0] = m[k] > m[0] ? m[k] : m[0];
    double r;
    memcpy(&r, &m[0], sizeof r);
    return r;
}

/* The sum of v[i]^2 over n values, in lanes summed in a fixed order (it vectorizes). */
static double sum_squares(const double *v, int n)
{
    double s[SUM_LANES] = {0};
    int i = 0;
    for (; i + SUM_LANES <= n; i += SUM_LANES)
        for (int k = 0; k < SUM_LANES; k++)
            s[k] += v[i + k] * v[i + k];
    for (int k = 0; i + k < n; k++)
        s[k] += v[i + k] * v[i + k];
    double r = 0;
    for (int k = 0; k < SUM_LANES; k++)
        r += s[k];
    return r;
}

/* Scratch of op_polyfit_chebyshev for n points, nrhs right-hand sides and np coefficients, in
 * doubles: the design, the right-hand sides, tau, the tails, one fit, LAPACK's workspace (at
 * least 64 columns a block; the _work calls skip LAPACKE's NaN scan of the inputs, which cost as
 * much as the factorization: the inputs are finite). */
static size_t polyfit_scratch(int n, int nrhs, int np)
{
    return (size_t)n * (size_t)np + (size_t)n * (size_t)nrhs + (size_t)np + (size_t)n + 1 +
           (size_t)np + 64 * ((size_t)np + (size_t)nrhs);
}

/* op_polyfit_chebyshev with scratch (polyfit_scratch doubles). */
static op_status polyfit(const double *t, const double *y, int n, int nrhs, int degree,
                         double *coef, op_polyfit_stats *stats, double *scratch, op_error *err)
{
    int np = degree + 1, kmax = np < n ? np : n;
    double *a = scratch, *b = a + (size_t)n * np, *tau = b + (size_t)n * nrhs, *tail = tau + np;
    double *c = tail + n + 1, *work = c + np;
    lapack_int lwork = 64 * (np + nrhs);
    op_status st = OP_OK;
    /* Column p of the design matrix is T_p(t_i) (column-major). */
    for (int i = 0; i < n; i++) {
        double tm1 = 1.0, tp = t[i];
        a[i] = 1.0;
        if (np > 1)
            a[(size_t)n + i] = tp;
        for (int p = 2; p < np; p++) {
            double next = 2.0 * t[i] * tp - tm1;
            a[(size_t)p * n + i] = next;
            tm1 = tp;
            tp = next;
        }
    }
    memcpy(b, y, (size_t)n * (size_t)nrhs * sizeof *b);
    /* A = QR without pivoting: the least-squares fit of degree d < np is the back-substitution
     * of R's leading (d + 1) x (d + 1) block against the first d + 1 entries of Q^T y, so one
     * factorization gives every degree up to P. */
    lapack_int info = LAPACKE_dgeqrf_work(LAPACK_COL_MAJOR, n, np, a, n, tau, work, lwork);
    if (info == 0)
        info = LAPACKE_dormqr_work(LAPACK_COL_MAJOR, 'L', 'T', n, nrhs, kmax, a, n, tau, b, n,
                                   work, lwork);
    if (info != 0) {
        st = op_error_set(err, OP_ERR_NUMERIC, "polynomial fit of degree %d to %d points failed "
                          "(LAPACK info %d)", degree, n, (int)info);
        goto done;
    }
    /* Degrees whose new column is (numerically) in the span of the lower ones add nothing: the
     * points have fewer distinct values than coefficients. */
    double rmax = 0;
    for (int k = 0; k < kmax; k++)
        rmax = fmax(rmax, fabs(a[(size_t)k * n + k]));
    int dmax = 0;
    while (dmax + 1 < kmax && fabs(a[(size_t)(dmax + 1) * n + dmax + 1]) > 1e-12 * rmax)
        dmax++;
    for (int r = 0; r < nrhs; r++) {
        const double *g = b + (size_t)r * n;
        double ymax = abs_max(y + (size_t)r * n, n);
        /* tail[k] = the squared residual of the degree k - 1 fit (k <= kmax): the sum of g^2
         * from kmax on in lanes, then the few below one by one */
        tail[kmax] = sum_squares(g + kmax, n - kmax);
        for (int k = kmax - 1; k >= 0; k--)
            tail[k] = tail[k + 1] + g[k] * g[k];
        /* Of the fits of degree 0..dmax whose float32 storage moves no value by more than
         * OP_POLYFIT_STORAGE_TOL of the data's largest, the one expected closest to the data:
         * its residual plus that rounding. The candidates only grow with P, so the error never
         * does; the storage bound keeps the coefficients of the order of the data. */
        double best = INFINITY;
        int best_d = 0;
        double *out = coef + (size_t)r * np;
        for (int d = 0; d <= dmax; d++) {
            for (int k = d; k >= 0; k--) {
                double s = g[k];
                for (int j = k + 1; j <= d; j++)
                    s -= a[(size_t)j * n + k] * c[j];
                c[k] = s / a[(size_t)k * n + k];
            }
            double e = storage_error_bound(c, d);
            double est = tail[d + 1] + (double)n * e * e;
            int ok = d == 0 || e <= OP_POLYFIT_STORAGE_TOL * ymax;
            for (int k = 0; k <= d; k++)
                ok &= isfinite(c[k]);
            if (ok && est < best) {
                best = est;
                best_d = d;
                for (int k = 0; k < np; k++)
                    out[k] = k <= d ? c[k] : 0.0;
            }
        }
        if (!isfinite(best)) {
            st = op_error_set(err, OP_ERR_NUMERIC, "polynomial fit: no finite coefficients");
            goto done;
        }
        if (stats) {
            double cmax = 0;
            for (int k = 0; k <= best_d; k++)
                cmax = fmax(cmax, fabs(out[k]));
            double rcond = 0;
            if (LAPACKE_dtrcon(LAPACK_COL_MAJOR, '1', 'U', 'N', best_d + 1, a, n, &rcond) != 0)
                rcond = 0;
            stats->coef_max = fmax(stats->coef_max, cmax);
            stats->cond_max = fmax(stats->cond_max, rcond > 0 ? 1.0 / rcond : INFINITY);
            stats->degree_min = stats->fits ? (best_d < stats->degree_min ? best_d
                                                                          : stats->degree_min)
                                            : best_d;
            stats->fits++;
        }
    }
done:
    return st;
}

op_status op_polyfit_chebyshev(const double *t, const double *y, int n, int nrhs, int degree,
                               double *coef, op_polyfit_stats *stats, op_error *err)
{
    double *scratch = malloc(polyfit_scratch(n, nrhs, degree + 1) * sizeof *scratch);
    op_status st = scratch ? polyfit(t, y, n, nrhs, degree, coef, stats, scratch, err)
                           : op_error_set(err, OP_ERR_NOMEM, "polynomial fit: out of memory");
    free(scratch);
    return st;
}

/* The rows of the preprocessed per-entry mean over the channels, for op_rsvd_fill: the mean of
 * the cleaned values, shifted and normalized (when shift is not NULL), counting the values as
 * op_prep_scan does. */
typedef struct mean_source {
    const float *const *ch;
    int nch, cols;
    uint32_t *shift;
    float *max;
    _Atomic uint64_t nonfinite, negative;
} mean_source;

OP_VECTOR_CLONES
static op_status mean_fetch(void *user, int64_t r0, int64_t count, float *dst, op_error *err)
{
    mean_source *m = user;
    int n = m->cols;
    float *mean = malloc((size_t)n * sizeof *mean);
    if (!mean)
        return op_error_set(err, OP_ERR_NOMEM, "tucker: out of memory");
    uint64_t nonfinite = 0, negative = 0;
    for (int64_t r = r0; r < r0 + count; r++) {
        for (int j = 0; j < n; j++)
            mean[j] = 0.0f;
        for (int c = 0; c < m->nch; c++) {
            const float *in = m->ch[c] + r * n;
            uint32_t bad = 0, neg = 0;
            for (int j = 0; j < n; j++) { /* op_prep_scan's counts, on the bits */
                uint32_t bits;
                memcpy(&bits, &in[j], sizeof bits);
                bad += op_prep_is_nonfinite(bits);
                neg += op_prep_is_negative(bits);
                mean[j] += op_prep_clean_pool(in[j]);
            }
            nonfinite += bad;
            negative += neg;
        }
        for (int j = 0; j < n; j++)
            mean[j] /= (float)m->nch;
        if (m->shift)
            op_prep_find_peaks(mean, 1, n, m->shift + r, m->max + r);
        op_prep_apply(mean, 1, n, m->shift ? m->shift + r : NULL, m->max ? m->max + r : NULL,
                      dst + (r - r0) * n);
    }
    atomic_fetch_add(&m->nonfinite, nonfinite);
    atomic_fetch_add(&m->negative, negative);
    free(mean);
    return OP_OK;
}

/* The int32 whose order is v's (finite v; -0 below +0). */
static inline int32_t order_key(float v)
{
    int32_t b;
    memcpy(&b, &v, sizeof b);
    return b ^ ((b >> 31) & INT32_MAX);
}

/* The smallest and largest of n >= 1 finite floats, on their order keys in lanes (integer
 * selects vectorize; floating compares, which may trap, do not). */
static void float_range(const float *v, int n, float *lo, float *hi)
{
    int32_t mn[SUM_LANES], mx[SUM_LANES];
    for (int k = 0; k < SUM_LANES; k++)
        mn[k] = mx[k] = order_key(v[0]);
    int i = 0;
    for (; i + SUM_LANES <= n; i += SUM_LANES)
        for (int k = 0; k < SUM_LANES; k++) {
            int32_t b = order_key(v[i + k]);
            mn[k] = b < mn[k] ? b : mn[k];
            mx[k] = b > mx[k] ? b : mx[k];
        }
    for (int k = 0; i + k < n; k++) {
        int32_t b = order_key(v[i + k]);
        mn[k] = b < mn[k] ? b : mn[k];
        mx[k] = b > mx[k] ? b : mx[k];
    }
    for (int k = 1; k < SUM_LANES; k++) {
        mn[0] = mn[k] < mn[0] ? mn[k] : mn[0];
        mx[0] = mx[k] > mx[0] ? mx[k] : mx[0];
    }
    mn[0] ^= (mn[0] >> 31) & INT32_MAX; /* the key is its own inverse */
    mx[0] ^= (mx[0] >> 31) & INT32_MAX;
    memcpy(lo, &mn[0], sizeof *lo);
    memcpy(hi, &mx[0], sizeof *hi);
}

/* Rows per task of the colour fits: fixed, so that the merged figures do not depend on the
 * thread count. */
enum { FIT_ROWS_PER_TASK = 256, FIT_LANES = 8 };

typedef struct fit_job {
    const float *const *ch;
    int nch;
    op_tucker_result *res;
    const float *vt;         /* res->v transposed (terms x cols) */
    op_polyfit_stats *parts; /* per task */
    op_status *status;       /* per task */
    op_error *errs;          /* per task */
    op_progress *prog;
} fit_job;

/* Fits the colour polynomials of one block of rows (one op_parallel_for task): each row's and
 * channel's coefficients go to res, its figures to the task's part. */
OP_VECTOR_CLONES
static void fit_task(void *user, int task, int thread)
{
    const fit_job *j = user;
    const float *const *ch = j->ch;
    int nch = j->nch;
    op_tucker_result *res = j->res;
    op_polyfit_stats *fit = &j->parts[task];
    op_error *err = &j->errs[task];
    int n = res->cols, T = res->terms, np = res->degree + 1;
    int64_t r0 = (int64_t)task * FIT_ROWS_PER_TASK;
    int64_t r1 = r0 + FIT_ROWS_PER_TASK < res->rows ? r0 + FIT_ROWS_PER_TASK : res->rows;
    (void)thread;
    double *t = malloc((size_t)n * sizeof *t);
    float *tf = malloc((size_t)n * sizeof *tf);
    double *y = malloc((size_t)n * (size_t)nch * sizeof *y);
    double *coef = malloc((size_t)np * (size_t)nch * sizeof *coef);
    /* Clenshaw's partial sums across the columns, float and double (vectorized loops) */
    float *fb = malloc(2 * (size_t)n * sizeof *fb);
    double *db = malloc(2 * (size_t)n * sizeof *db);
    double *scratch = malloc(polyfit_scratch(n, nch, np) * sizeof *scratch);
    op_status st = OP_OK;
    if (!t || !tf || !y || !coef || !fb || !db || !scratch)
        st = op_error_set(err, OP_ERR_NOMEM, "out of memory");
    for (int64_t r = r0; r < r1 && st == OP_OK; r++) {
        const float *u = res->u + r * T;
        /* The same float arithmetic as the evaluation in libopaline/method_tucker.c: each dot
         * product summed in order of k, vectorized across the columns. */
        for (int jj = 0; jj < n; jj++)
            tf[jj] = 0.0f;
        for (int k = 0; k < T; k++) {
            const float *v = j->vt + (size_t)k * n, uk = u[k];
            for (int jj = 0; jj < n; jj++)
                tf[jj] += uk * v[jj];
        }
        float lo, hi;
        float_range(tf, n, &lo, &hi);
        double mid = 0.5 * ((double)lo + (double)hi);
        float center = (float)mid;
        /* a range at float rounding level is no range: the row is constant in t (t = 0) */
        double span = (double)hi - lo;
        float scale = span > 64.0 * FLT_EPSILON * fmax(fabs(lo), fabs(hi)) && span > 1e-30
                          ? (float)(2.0 / span)
                          : 0.0f;
        res->range[2 * r] = center;
        res->range[2 * r + 1] = scale;
        for (int jj = 0; jj < n; jj++) {
            tf[jj] = (tf[jj] - center) * scale; /* as the evaluator computes it */
            t[jj] = tf[jj];
        }
        int s = res->shift ? (int)res->shift[r] : 0;
        float mx = res->max ? res->max[r] : 1.0f;
        for (int c = 0; c < nch; c++) {
            double *yc = y + (size_t)c * n;
            const float *in = ch[c] + r * n;
            if (!(mx > 0.0f)) {
                for (int jj = 0; jj < n; jj++)
                    yc[jj] = 0.0;
                continue;
            }
            for (int jj = 0; jj < n - s; jj++)
                yc[jj] = op_prep_clean_pool(in[jj + s]) / mx;
            for (int jj = n - s; jj < n; jj++)
                yc[jj] = op_prep_clean_pool(in[jj + s - n]) / mx;
        }
        st = polyfit(t, y, n, nch, res->degree, coef, fit, scratch, err);
        if (st != OP_OK) {
            op_error_prefix(err, "row %lld: ", (long long)r);
            break;
        }
        for (int c = 0; c < nch; c++) {
            float *beta = res->beta + ((size_t)c * res->rows + r) * np;
            const double *cd = coef + (size_t)c * np;
            for (int p = 0; p < np; p++)
                beta[p] = (float)cd[p];
            /* The stored (float32) series in the evaluator's float arithmetic
             * (libopaline/method_tucker.c) against op_chebyshev_eval's double one, at every
             * column: Clenshaw's recurrences as loops over the columns. */
            float *f1 = fb, *f2 = fb + n;
            double *d1 = db, *d2 = db + n;
            for (int jj = 0; jj < n; jj++) {
                f1[jj] = f2[jj] = 0.0f;
                d1[jj] = d2[jj] = 0.0;
            }
            for (int p = res->degree; p >= 1; p--) {
                const float bp = beta[p];
                const double cp = cd[p];
                for (int jj = 0; jj < n; jj++) {
                    float f0 = 2.0f * tf[jj] * f1[jj] - f2[jj] + bp;
                    f2[jj] = f1[jj];
                    f1[jj] = f0;
                    double d0 = 2.0 * t[jj] * d1[jj] - d2[jj] + cp;
                    d2[jj] = d1[jj];
                    d1[jj] = d0;
                }
            }
            /* in FIT_LANES lanes, summed in a fixed order, so that it vectorizes */
            double ss[FIT_LANES] = {0}, ds[FIT_LANES] = {0};
            const double *yc = y + (size_t)c * n;
            int j0 = 0;
            for (; j0 + FIT_LANES <= n; j0 += FIT_LANES)
                for (int k = 0; k < FIT_LANES; k++) {
                    int jj = j0 + k;
                    double d = (double)(tf[jj] * f1[jj] - f2[jj] + beta[0]) -
                               (t[jj] * d1[jj] - d2[jj] + cd[0]);
                    ss[k] += d * d;
                    ds[k] += yc[jj] * yc[jj];
                }
            for (int jj = j0; jj < n; jj++) {
                double d = (double)(tf[jj] * f1[jj] - f2[jj] + beta[0]) -
                           (t[jj] * d1[jj] - d2[jj] + cd[0]);
                ss[jj - j0] += d * d;
                ds[jj - j0] += yc[jj] * yc[jj];
            }
            for (int k = 0; k < FIT_LANES; k++) {
                fit->storage_sq += ss[k];
                fit->data_sq += ds[k];
            }
        }
    }
    j->status[task] = st;
    op_progress_advance(j->prog, (uint64_t)(r1 - r0));
    free(t);
    free(tf);
    free(y);
    free(coef);
    free(fb);
    free(db);
    free(scratch);
}

/* Fits the colour polynomials of every row, in parallel; res holds the mean's factors. Also
 * measures what storing the coefficients as float32 costs (res->fit). */
static op_status fit_rows(const float *const *ch, int nch, int threads, op_tucker_result *res,
                          op_error *err)
{
    int64_t ntasks = (res->rows + FIT_ROWS_PER_TASK - 1) / FIT_ROWS_PER_TASK;
    if (ntasks > (1 << 30))
        return op_error_set(err, OP_ERR_INPUT, "tucker: %lld rows: too many",
                            (long long)res->rows);
    int tasks = (int)ntasks;
    float *vt = malloc((size_t)res->cols * (size_t)res->terms * sizeof *vt + 1);
    for (int jj = 0; vt && jj < res->cols; jj++)
        for (int k = 0; k < res->terms; k++)
            vt[(size_t)k * res->cols + jj] = res->v[(size_t)jj * res->terms + k];
    fit_job j = {ch, nch, res, vt, calloc((size_t)tasks + 1, sizeof *j.parts),
                 calloc((size_t)tasks + 1, sizeof *j.status),
                 calloc((size_t)tasks + 1, sizeof *j.errs), NULL};
    memset(&res->fit, 0, sizeof res->fit);
    op_status st = OP_OK;
    if (!vt || !j.parts || !j.status || !j.errs)
        st = op_error_set(err, OP_ERR_NOMEM, "out of memory");
    j.prog = op_progress_begin("tucker colour fit", (uint64_t)res->rows, NULL, NULL);
    if (st == OP_OK) {
        /* LAPACK's small QRs single-threaded in each task: the tasks are the parallelism */
        int blas_threads = openblas_get_num_threads();
        openblas_set_num_threads(1);
        st = op_parallel_for(threads, tasks, fit_task, &j, NULL, err);
        openblas_set_num_threads(blas_threads);
    }
    op_progress_end(j.prog);
    /* Merged in task order: the first failing row's error, the figures of all. */
    for (int t = 0; st == OP_OK && t < tasks; t++)
        if (j.status[t] != OP_OK) {
            st = j.status[t];
            if (err)
                *err = j.errs[t];
        }
    op_polyfit_stats *f = &res->fit;
    for (int t = 0; st == OP_OK && t < tasks; t++) {
        const op_polyfit_stats *p = &j.parts[t];
        f->cond_max = fmax(f->cond_max, p->cond_max);
        f->coef_max = fmax(f->coef_max, p->coef_max);
        if (p->fits)
            f->degree_min = f->fits && f->degree_min < p->degree_min ? f->degree_min
                                                                     : p->degree_min;
        f->fits += p->fits;
        f->storage_sq += p->storage_sq;
        f->data_sq += p->data_sq;
    }
    free(vt);
    free(j.parts);
    free(j.status);
    free(j.errs);
    return st;
}

op_status op_tucker_factor(const float *const *channels, int nchannels, int64_t rows, int cols,
                           int terms, int degree, int shifted, const op_rsvd_options *opt,
                           int threads, op_tucker_result *res, op_error *err)
{
    memset(res, 0, sizeof *res);
    if (degree < 0 || degree > 20)
        return op_error_set(err, OP_ERR_INPUT, "tucker: degree %d is not in [0, 20]", degree);
    res->rows = rows;
    res->cols = cols;
    res->terms = terms;
    res->degree = degree;
    res->channels = nchannels;
    uint64_t count = (uint64_t)rows * (uint64_t)cols, np = (uint64_t)degree + 1;
    float *mat = malloc(count * sizeof *mat);
    res->u = malloc((uint64_t)rows * (uint64_t)terms * sizeof *res->u);
    res->v = malloc((uint64_t)cols * (uint64_t)terms * sizeof *res->v);
    res->range = malloc((uint64_t)rows * 2 * sizeof *res->range);
    res->beta = malloc((uint64_t)nchannels * (uint64_t)rows * np * sizeof *res->beta);
    if (shifted) {
        res->shift = malloc((uint64_t)rows * sizeof *res->shift);
        res->max = malloc((uint64_t)rows * sizeof *res->max);
    }
    op_status st = OP_OK;
    if (!mat || !res->u || !res->v || !res->range || !res->beta ||
        (shifted && (!res->shift || !res->max)))
        st = op_error_set(err, OP_ERR_NOMEM, "tucker: out of memory");
    if (st == OP_OK) {
        /* the mean made and preprocessed block by block in the SVD's first pass */
        mean_source src = {.ch = channels, .nch = nchannels, .cols = cols, .shift = res->shift,
                           .max = res->max};
        atomic_init(&src.nonfinite, 0);
        atomic_init(&src.negative, 0);
        op_row_source rs = {mean_fetch, &src, 1};
        op_rsvd_options o = opt ? *opt : op_rsvd_defaults();
        o.threads = threads;
        op_progress *prog = op_progress_begin(
            "tucker factorization", op_rsvd_progress_units(rows, cols, terms, &o), NULL, NULL);
        st = op_rsvd_fill(&rs, mat, rows, cols, terms, &o, res->u, res->v, NULL, prog, err);
        op_progress_end(prog);
        res->values.nonfinite = atomic_load(&src.nonfinite);
        res->values.negative = atomic_load(&src.negative);
    }
    (void)count;
    free(mat);
    if (st == OP_OK)
        st = fit_rows(channels, nchannels, threads, res, err);
    if (st != OP_OK)
        op_tucker_free(res);
    return st;
}
