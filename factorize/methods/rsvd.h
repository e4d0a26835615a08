/* rsvd.h - truncated singular value decompositions of a dense float32 matrix.
 *
 * The randomized method is Halko, Martinsson and Tropp (2011), algorithms 4.4 and 5.1, as
 * subspace iteration on A^T A: a Gaussian test matrix Omega with oversampling (l = k + p
 * columns), W = A^T A Omega, then Z = orth(W) (LAPACK geqrf/orgqr), Y = A Z, W = A^T Y for each
 * power iteration, and A ~ Y Z^T: the SVD of Y by its QR and gesdd of the l x l R in double.
 * Every power iteration is one pass over A: each block of rows gives its part of Y and of A^T Y
 * while it is in cache (in-memory blocks of fixed size are parallel tasks, merged in order, so
 * the result does not depend on the thread count). Power iterations stop early once the rank-k
 * error has converged: its estimate is ||A||_F^2 (measured in the first pass) minus the top-k
 * eigenvalues of Z^T A^T A Z, the squared Ritz values of A on span(Z). Products use
 * OpenBLAS's gemm. The result is deterministic for a given seed, and every singular pair's sign
 * is fixed so that the entry of largest magnitude of its right singular vector is positive. */
#ifndef OP_FACTOR_RSVD_H
#define OP_FACTOR_RSVD_H

#include "opaline.h"

typedef enum op_svd_precision { OP_SVD_SINGLE, OP_SVD_DOUBLE } op_svd_precision;

typedef struct op_rsvd_options {
    int oversample;   /* extra test vectors p (default 10) */
    int power_iters;  /* at most this many power iterations q (default 4; 0 acts as 1) */
    double power_tol; /* stop iterating (from the third iteration on: earlier stops cost
                         accuracy that shows in the svd method's error on the chessboards)
                         once the squared rank-k error estimate improves by at
                         most this fraction of itself (default 1e-2: the error itself by
                         about 0.5 %) or by less than the rounding level of the energies
                         (8 FLT_EPSILON ||A||^2 in single precision, 64 DBL_EPSILON in
                         double); 0: always q iterations */
    uint64_t seed;    /* test-matrix seed (default 1) */
    op_svd_precision precision; /* arithmetic of the randomized stages (default single) */
    int exact;        /* nonzero: full LAPACK SVD (gesdd in double) instead */
    int threads;      /* threads of the passes over an in-memory matrix (<= 0: all cores; the
                         streamed and exact methods use OpenBLAS's own) */
} op_rsvd_options;

/* The defaults above. */
op_rsvd_options op_rsvd_defaults(void);

/* Rank-k truncated SVD of the row-major m x n matrix a: us (m x k, row-major) holds the left
 * singular vectors times the singular values, v (n x k, row-major) the right singular vectors,
 * s (k values, may be NULL) the singular values in decreasing order. Needs 1 <= k <= min(m, n).
 * When k + oversample >= min(m, n) the exact method is used. Fails with OP_ERR_NOMEM, or with
 * OP_ERR_NUMERIC (naming the stage) when LAPACK fails or a result is not finite. */
op_status op_rsvd(const float *a, int64_t m, int64_t n, int k, const op_rsvd_options *opt,
                  float *us, float *v, double *s, op_progress *progress, op_error *err);

/* A matrix read in blocks of rows, for one larger than memory: fetch writes rows [r0, r0 +
 * count) of the row-major m x n matrix to dst (count x n floats), or fails setting err. */
typedef struct op_row_source {
    op_status (*fetch)(void *user, int64_t r0, int64_t count, float *dst, op_error *err);
    void *user;
    int64_t block_rows; /* rows per fetch, >= 1 */
} op_row_source;

/* op_rsvd of a matrix read through src: the randomized method, every product with A a pass
 * over its blocks in order (memory: one block, plus the m x (k + p) and n x (k + p) bases).
 * The same factors as op_rsvd within rounding (A^T Y's sums are split by blocks). The exact
 * method is refused (OP_ERR_INPUT); so is k + oversample >= min(m, n), which needs it. */
op_status op_rsvd_rows(const op_row_source *src, int64_t m, int64_t n, int k,
                       const op_rsvd_options *opt, float *us, float *v, double *s,
                       op_progress *progress, op_error *err);

/* op_rsvd of a matrix made while it is factored: the first pass has src->fetch write rows
 * [r0, r0 + count) to a + r0 * n (from several threads at once, for disjoint ranges; the block
 * sizes are op_rsvd's, src->block_rows is not used), later passes read a, which holds the whole
 * matrix afterwards. The same factors as op_rsvd of that matrix, bit for bit; a failing fetch
 * fails the call with the error of the failing block of lowest rows. */
op_status op_rsvd_fill(const op_row_source *src, float *a, int64_t m, int64_t n, int k,
                       const op_rsvd_options *opt, float *us, float *v, double *s,
                       op_progress *progress, op_error *err);

/* Units of progress op_rsvd reports for these arguments. */
uint64_t op_rsvd_progress_units(int64_t m, int64_t n, int k, const op_rsvd_options *opt);

#endif
