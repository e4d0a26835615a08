/* kcta.h - K-clustered tensor approximation (Tsai and Shih 2012) of a row-major matrix.
 *
 * For a 2-D matrix A (rows x cols) clustered along the rows, a cluster c's tensor
 * approximation is a rank-T subspace: an orthonormal basis V_c (cols x T) whose core is
 * absorbed into the rows' coefficients. Every row i mixes exactly K_m distinct clusters:
 *     a_i ~ sum_{k < K_m} V_{idx[i][k]} coef[i][k]          (coef[i][k]: T values)
 * The algorithm alternates (paper, Algorithm 1):
 *  - the clustering stage (section 4.2): for every row, a greedy search picks its K_m clusters
 *    one at a time, each maximizing the norm of the projection of the row's residual onto the
 *    cluster subspace (Theorems 1 and 3), computed in the reduced space from A V_all (one gemm
 *    per block of rows) and the Gram matrix V_all^T V_all; after every pick the coefficients
 *    of all picked clusters are the optimal projection (Theorem 4: a Gram system, solved by a
 *    pseudo-inverse); for K_m > 1, where the greedy search is not optimal, a row keeps its
 *    previous clusters when they capture more of it. The same pass computes each row's
 *    residual r and its exact squared error, and sums per cluster r y^T and y y^T (y the
 *    member's coefficients); empty clusters are then split (section 5.3);
 *  - the update stage (section 4.3): each cluster's basis V_c becomes orth(M_c V_c), M_c the
 *    Gram matrix of its members' residuals with the other clusters fixed, from those sums
 *    (M_c V_c = sum r y^T + V_c sum y y^T): one step of subspace iteration towards the rank-T
 *    truncated SVD of the paper, warm-started from the current basis, so that an iteration
 *    reads the matrix once. A split cluster and its donor get the truncated SVD in full.
 * Every iteration is thus one pass over the rows. The post-processing SVD of each cluster's
 * coefficient block (section 4.2.3), which rotates basis and coefficients without changing
 * the approximation, is done once at the end.
 * Initialization (section 5.1): k-means (k-means++ seeding, fixed seed) of the rows in the
 * space of the global leading right singular vectors, then one CTA step (per-cluster truncated
 * SVD). On a large matrix (at least twice sample_rows rows) the initialization and a first run
 * of the iterations use every S-th row only (S = rows / sample_rows), and the iterations on the
 * whole matrix start from their bases. When an iteration ends with a larger total error than
 * the previous one, the previous iteration is restored and the iteration stops (section 5.3),
 * so the error never increases.
 * The result is the same for any thread count: the passes split the rows into stripes fixed
 * by the sizes alone and add the stripes' sums in order; the initial per-cluster SVDs are
 * parallel tasks, each single-threaded. OpenBLAS runs single-threaded during the fit.
 * With K_m = 1 this is CTA: hard clustering with a rank-T subspace per cluster. */
#ifndef OP_FACTOR_KCTA_H
#define OP_FACTOR_KCTA_H

#include "opaline.h"
#include "rsvd.h"

typedef struct op_kcta_options {
    int clusters;   /* C >= 1 */
    int km;         /* K_m, 1 <= K_m <= C */
    int terms;      /* T, rank of each cluster, 1 <= T <= cols */
    int max_iters;  /* iterations of the two stages, 1 to OP_KCTA_MAX_HISTORY (the sample
                       stage, when there is one, runs as many again on the sample) */
    double tol;     /* stop once an iteration lowers the error by at most this fraction */
    int threads;    /* threads of the passes over the rows (<= 0: every core); the result
                       is the same for any count */
    int64_t sample_rows; /* rows of the sample stage (0: max(16384, 256 C)) */
    op_rsvd_options svd; /* for the truncated SVDs */
} op_kcta_options;

/* C = 8, K_m = 2, T = 4, 10 iterations, tol 1e-3, every core, the default sample,
 * op_rsvd_defaults(). */
op_kcta_options op_kcta_defaults(void);

#define OP_KCTA_MAX_HISTORY 256

typedef struct op_kcta_model {
    int64_t rows;
    int cols, clusters, km, terms;
    float *basis;     /* clusters x cols x terms, each block row-major (like svd's V) */
    uint32_t *idx;    /* rows x km cluster indices, distinct within a row */
    float *coef;      /* rows x km x terms */
    int iterations;   /* iterations accepted (a restored one does not count) */
    int restored;     /* 1 when the last iteration raised the error and was undone */
    int splits;       /* empty clusters refilled by splitting */
    /* Total squared error sum_i ||a_i - a^_i||^2 on the whole matrix: [0] after the first
     * clustering stage (from the initial bases), then after every accepted iteration
     * (nhistory = iterations + 1); non-increasing, the last one the model's. */
    double history[OP_KCTA_MAX_HISTORY + 1];
    int nhistory;
    double norm2;     /* sum_i ||a_i||^2 of the whole matrix, in double */
} op_kcta_model;

/* Factors the row-major rows x cols matrix a (finite values). Fails with OP_ERR_INPUT for
 * parameters out of range (naming them), OP_ERR_NOMEM, or OP_ERR_NUMERIC. On failure model
 * holds nothing to free. On success it has advanced progress by 1 + opt->max_iters units (the
 * initialization, then one per iteration, those that convergence skipped included). */
op_status op_kcta_factor(const float *a, int64_t rows, int cols, const op_kcta_options *opt,
                         op_kcta_model *model, op_progress *progress, op_error *err);
void op_kcta_free(op_kcta_model *model);

/* sum_i ||a_i - a^_i||^2 of the model on a, in double. */
double op_kcta_error(const float *a, const op_kcta_model *model);
/* The reconstruction of row i into out (cols values). */
void op_kcta_row(const op_kcta_model *model, int64_t i, float *out);

#endif
