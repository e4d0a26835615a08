/* tucker.h - the factorization of Kurt, Ozturk and Peers (2013), sections 4.2 and 4.3.
 *
 * The per-entry mean over the colour channels is preprocessed (section 4.1: each row shifted
 * so its maximum comes first, divided by it) and factored with T terms by the error-modelling
 * construction, each term the best rank-1 fit of the residual of the previous ones; for a 2-D
 * matrix that is the rank-T truncated SVD, computed by op_rsvd. Then for every row and channel
 * a polynomial of degree P maps the factored mean to that channel's (equally preprocessed)
 * values. Polynomials are series of Chebyshev polynomials in t, the row's range of factored
 * means mapped to [-1, 1]; they are fitted by one Householder QR of the design (never normal
 * equations on raw powers), which gives the least-squares fit of every degree up to P at once,
 * and each row and channel keeps the degree whose float32-stored coefficients are expected
 * closest to its data. A higher P therefore never makes the fit worse, and the coefficients stay
 * small enough for float32 storage (their cost is measured: op_polyfit_stats). */
#ifndef OP_FACTOR_TUCKER_H
#define OP_FACTOR_TUCKER_H

#include "opaline.h"
#include "preprocess.h"
#include "rsvd.h"

/* What the colour fits were like, accumulated over rows and channels. */
typedef struct op_polyfit_stats {
    double cond_max;   /* largest 1-norm condition number of a chosen fit's triangular factor */
    double coef_max;   /* largest |coefficient| */
    int degree_min;    /* the lowest degree any fit kept */
    uint64_t fits;
    double storage_sq; /* sum over entries of (float32-stored fit - double fit)^2 */
    double data_sq;    /* sum over entries of the fitted data^2 */
} op_polyfit_stats;

/* The factors, laid out as the file's sections (docs/formats.md). */
typedef struct op_tucker_result {
    int64_t rows;
    int cols, terms, degree, channels;
    uint32_t *shift;   /* rows, NULL when not shifted */
    float *max;        /* rows, NULL when not shifted */
    float *u;          /* rows x terms: f_j(x_i) g_j */
    float *v;          /* cols x terms: h_j(d) */
    float *range;      /* rows x 2: (center, scale), t = (mean^ - center) * scale in [-1, 1] */
    float *beta;       /* channels x rows x (degree + 1) Chebyshev coefficients */
    op_polyfit_stats fit;
    op_prep_counts values; /* the input's non-finite and negative values (first_nonfinite
                              not set: op_prep_scan finds it) */
} op_tucker_result;

/* Factors the channels (each rows x cols row-major float32; NULL-free array of `channels`); the
 * colour fits run on `threads` threads (<= 0: every core), with the same result for any count.
 * Non-finite and negative values count as 0 (res->values counts them). The mean over the
 * channels is made and preprocessed in the SVD's first pass (op_rsvd_fill), block by block. On
 * failure res holds nothing to free. */
op_status op_tucker_factor(const float *const *channels, int nchannels, int64_t rows, int cols,
                           int terms, int degree, int shifted, const op_rsvd_options *opt,
                           int threads, op_tucker_result *res, op_error *err);
void op_tucker_free(op_tucker_result *res);

/* A kept fit's float32 rounding moves it by at most this fraction of the data's largest value. */
#define OP_POLYFIT_STORAGE_TOL 1e-4

/* Least-squares fit of y (n values, nrhs right-hand sides each of stride n) by a Chebyshev
 * series of degree at most `degree` in t (n values, normally in [-1, 1]): coef (nrhs x
 * (degree + 1), zero above the degree kept). For each right-hand side the degree kept is the
 * one whose coefficients, stored as float32, are expected closest to y, among those whose
 * storage moves no value by more than OP_POLYFIT_STORAGE_TOL of y's largest; degrees that the
 * points cannot determine (fewer distinct t than coefficients) are never kept. stats (if not
 * NULL) accumulates the conditioning figures. */
op_status op_polyfit_chebyshev(const double *t, const double *y, int n, int nrhs, int degree,
                               double *coef, op_polyfit_stats *stats, op_error *err);
/* The Chebyshev series sum_p coef[p] T_p(t) (Clenshaw's recurrence). */
double op_chebyshev_eval(const double *coef, int degree, double t);

#endif
