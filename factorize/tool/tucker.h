/* tucker.h - the factorization of Kurt, Ozturk and Peers (2013), sections 4.2 and 4.3.
 *
 * The per-entry mean over the colour channels is preprocessed (section 4.1: each row shifted
 * so its maximum comes first, divided by it) and factored with T terms by the error-modelling
 * construction, each term the best rank-1 fit of the residual of the previous ones; for a 2-D
 * matrix that is the rank-T truncated SVD, computed by op_rsvd. Then for every row and channel
 * a polynomial of degree P maps the factored mean to that channel's (equally preprocessed)
 * values. Polynomials are fitted by least squares in a Chebyshev basis on the row's range of
 * factored means mapped to [-1, 1], by complete orthogonal factorization (LAPACK gelsy), never
 * by normal equations on raw powers, so that P up to 10 and beyond stays accurate. */
#ifndef OP_FACTOR_TUCKER_H
#define OP_FACTOR_TUCKER_H

#include "opaline.h"
#include "rsvd.h"

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
} op_tucker_result;

/* Factors the channels (each rows x cols row-major float32; NULL-free array of `channels`).
 * Non-finite and negative values count as 0. On failure res holds nothing to free. */
op_status op_tucker_factor(const float *const *channels, int nchannels, int64_t rows, int cols,
                           int terms, int degree, int shifted, const op_rsvd_options *opt,
                           op_tucker_result *res, op_error *err);
void op_tucker_free(op_tucker_result *res);

/* Least-squares fit of y (n values, nrhs right-hand sides each of stride n) by a Chebyshev
 * series of `degree` in t = (x - center) * scale: coef (nrhs x (degree + 1)). Rank-deficient
 * data (fewer distinct x than coefficients) gets the minimum-norm solution. */
op_status op_polyfit_chebyshev(const double *x, const double *y, int n, int nrhs, int degree,
                               double center, double scale, double *coef, op_error *err);
/* The Chebyshev series sum_p coef[p] T_p(t) (Clenshaw's recurrence). */
double op_chebyshev_eval(const double *coef, int degree, double t);

#endif
