/* tucker.c - see tucker.h. */
#include "tucker.h"

#include "preprocess.h"

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

op_status op_polyfit_chebyshev(const double *x, const double *y, int n, int nrhs, int degree,
                               double center, double scale, double *coef, op_error *err)
{
    int np = degree + 1, ldb = n > np ? n : np;
    double *a = malloc((size_t)n * (size_t)np * sizeof *a);
    double *b = calloc((size_t)ldb * (size_t)nrhs, sizeof *b);
    lapack_int *jpvt = calloc((size_t)np, sizeof *jpvt);
    if (!a || !b || !jpvt) {
        free(a);
        free(b);
        free(jpvt);
        return op_error_set(err, OP_ERR_NOMEM, "polynomial fit: out of memory");
    }
    /* Column p of the design matrix is T_p(t_i) (column-major). */
    for (int i = 0; i < n; i++) {
        double t = (x[i] - center) * scale, tm1 = 1.0, tp = t;
        a[i] = 1.0;
        if (np > 1)
            a[(size_t)n + i] = t;
        for (int p = 2; p < np; p++) {
            double next = 2.0 * t * tp - tm1;
            a[(size_t)p * n + i] = next;
            tm1 = tp;
            tp = next;
        }
    }
    for (int r = 0; r < nrhs; r++)
        memcpy(b + (size_t)r * ldb, y + (size_t)r * n, (size_t)n * sizeof *b);
    lapack_int rank = 0;
    lapack_int info = LAPACKE_dgelsy(LAPACK_COL_MAJOR, n, np, nrhs, a, n, b, ldb, jpvt, 1e-10,
                                     &rank);
    op_status st = OP_OK;
    if (info != 0) {
        st = op_error_set(err, OP_ERR_NUMERIC, "polynomial fit of degree %d to %d points failed "
                          "(LAPACK info %d)", degree, n, (int)info);
    } else {
        for (int r = 0; r < nrhs; r++)
            for (int p = 0; p < np; p++) {
                coef[(size_t)r * np + p] = b[(size_t)r * ldb + p];
                if (!isfinite(coef[(size_t)r * np + p]))
                    st = op_error_set(err, OP_ERR_NUMERIC, "polynomial fit: coefficient %d is "
                                      "not finite", p);
            }
    }
    free(a);
    free(b);
    free(jpvt);
    return st;
}

/* The cleaned per-entry mean over the channels. */
static void channel_mean(const float *const *ch, int nch, uint64_t count, float *mean)
{
    for (uint64_t i = 0; i < count; i++) {
        float s = 0.0f;
        for (int c = 0; c < nch; c++)
            s += op_prep_clean(ch[c][i]);
        mean[i] = s / (float)nch;
    }
}

/* Fits the colour polynomials of every row; res holds the mean's factors. */
static op_status fit_rows(const float *const *ch, int nch, op_tucker_result *res, op_error *err)
{
    int n = res->cols, T = res->terms, np = res->degree + 1;
    double *x = malloc((size_t)n * sizeof *x);
    double *y = malloc((size_t)n * (size_t)nch * sizeof *y);
    double *coef = malloc((size_t)np * (size_t)nch * sizeof *coef);
    op_status st = OP_OK;
    if (!x || !y || !coef)
        st = op_error_set(err, OP_ERR_NOMEM, "out of memory");
    op_progress *prog = op_progress_begin("tucker colour fit", (uint64_t)res->rows, NULL, NULL);
    for (int64_t r = 0; r < res->rows && st == OP_OK; r++) {
        const float *u = res->u + r * T;
        double lo = INFINITY, hi = -INFINITY;
        for (int j = 0; j < n; j++) {
            /* The same float arithmetic as the evaluation in op_method_tucker.c. */
            const float *v = res->v + (size_t)j * T;
            float dot = 0.0f;
            for (int t = 0; t < T; t++)
                dot += u[t] * v[t];
            x[j] = dot;
            lo = fmin(lo, x[j]);
            hi = fmax(hi, x[j]);
        }
        int s = res->shift ? (int)res->shift[r] : 0;
        float mx = res->max ? res->max[r] : 1.0f;
        for (int c = 0; c < nch; c++)
            for (int j = 0; j < n; j++) {
                int col = j + s < n ? j + s : j + s - n;
                y[(size_t)c * n + j] = mx > 0.0f ? op_prep_clean(ch[c][r * n + col]) / mx : 0.0;
            }
        double center = 0.5 * (lo + hi);
        double scale = hi - lo > 1e-30 * fmax(1.0, fabs(center)) ? 2.0 / (hi - lo) : 0.0;
        res->range[2 * r] = (float)center;
        res->range[2 * r + 1] = (float)scale;
        st = op_polyfit_chebyshev(x, y, n, nch, res->degree, (float)center, (float)scale, coef,
                                  err);
        if (st != OP_OK) {
            op_error_prefix(err, "row %lld: ", (long long)r);
            break;
        }
        for (int c = 0; c < nch; c++)
            for (int p = 0; p < np; p++)
                res->beta[((size_t)c * res->rows + r) * np + p] = (float)coef[(size_t)c * np + p];
        if ((r & 255) == 255)
            op_progress_advance(prog, 256);
    }
    op_progress_end(prog);
    free(x);
    free(y);
    free(coef);
    return st;
}

op_status op_tucker_factor(const float *const *channels, int nchannels, int64_t rows, int cols,
                           int terms, int degree, int shifted, const op_rsvd_options *opt,
                           op_tucker_result *res, op_error *err)
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
    float *mean = malloc(count * sizeof *mean);
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
    if (!mean || !mat || !res->u || !res->v || !res->range || !res->beta ||
        (shifted && (!res->shift || !res->max)))
        st = op_error_set(err, OP_ERR_NOMEM, "tucker: out of memory");
    if (st == OP_OK) {
        channel_mean(channels, nchannels, count, mean);
        if (shifted)
            op_prep_find_peaks(mean, rows, cols, res->shift, res->max);
        op_prep_apply(mean, rows, cols, res->shift, res->max, mat);
        free(mean);
        mean = NULL;
        op_progress *prog = op_progress_begin(
            "tucker factorization", op_rsvd_progress_units(rows, cols, terms, opt), NULL, NULL);
        st = op_rsvd(mat, rows, cols, terms, opt, res->u, res->v, NULL, prog, err);
        op_progress_end(prog);
    }
    free(mean);
    free(mat);
    if (st == OP_OK)
        st = fit_rows(channels, nchannels, res, err);
    if (st != OP_OK)
        op_tucker_free(res);
    return st;
}
