/* nmf.h - the baseline of Peers et al. 2006 (as Kurt, Ozturk and Peers 2013 describe it): each
 * row of Rd is divided by a homogeneous approximation of the material, and the non-negative
 * remainder is factored by non-negative matrix factorization.
 *
 * Homogeneous approximation, per channel: the radial profile p(|d|) of the whole dataset (the
 * mean over rows of each row divided by its sum, averaged over the columns of equal
 * dx^2 + dy^2, normalized to sum 1), scaled to the row's albedo s_i (its sum):
 *     H[i][j] = s_i p_j,   Q[i][j] = Rd[i][j] / H[i][j]   (0 where H is 0)
 * (Optionally H^e, 0 <= e <= 1, in place of H: see op_nmf_homogeneous.)
 * Q >= 0 is factored as W H^T (rows x T and cols x T, both >= 0) by HALS (hierarchical
 * alternating least squares, Cichocki and Phan 2009) from an NNDSVD start (Boutsidis and
 * Gallopoulos 2008, built on the deterministic op_rsvd), until the relative change of the
 * objective ||Q - W H^T||_F^2 between two iterations is below tol, or max_iter iterations.
 * The reconstruction Rd^ = s_i p_j (W[i] . H[j]) is non-negative by construction. */
#ifndef OP_FACTOR_NMF_H
#define OP_FACTOR_NMF_H

#include "opaline.h"
#include "rsvd.h"

typedef struct op_nmf_options {
    int rank;        /* T >= 1, <= min(rows, cols) */
    int max_iter;    /* default 200 */
    double tol;      /* default 1e-4 */
    op_rsvd_options svd;
} op_nmf_options;

/* rank 10, max_iter 200, tol 1e-4, op_rsvd_defaults(). */
op_nmf_options op_nmf_defaults(void);

typedef struct op_nmf_stats {
    int iterations;
    int converged;        /* 1 when the tolerance stopped it, 0 when max_iter did */
    double objective;     /* final ||Q - W H^T||_F^2 */
    double initial;       /* the NNDSVD start's objective */
    double norm;          /* ||Q||_F^2 */
} op_nmf_stats;

/* The homogeneous approximation of one channel rd (rows x K*K, row-major; non-finite and
 * negative values count as 0), raised to the power e in [0, 1]: profile = p^e (K*K values
 * >= 0; p sums to 1, or is all 0 when rd is) and scale = s^e (rows values >= 0, s the row
 * sums). e = 1 is Peers et al.'s division; smaller e weights the NMF objective more towards
 * absolute error in Rd (e = 0 factors Rd itself). */
void op_nmf_homogeneous(const float *rd, int64_t rows, int kernel, double e, float *profile,
                        float *scale);

/* q = the remainder of rd after division by the homogeneous approximation (rows x cols). */
void op_nmf_remainder(const float *rd, int64_t rows, int cols, const float *profile,
                      const float *scale, float *q);

/* Factors the non-negative rows x cols matrix q: w (rows x rank) and h (cols x rank), both
 * row-major, non-negative and finite. Fails with OP_ERR_INPUT for a bad rank, OP_ERR_NOMEM or
 * OP_ERR_NUMERIC. */
op_status op_nmf_hals(const float *q, int64_t rows, int cols, const op_nmf_options *opt,
                      float *w, float *h, op_nmf_stats *stats, op_progress *progress,
                      op_error *err);

#endif
