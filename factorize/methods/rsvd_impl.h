/* rsvd_impl.h - the randomized stages of rsvd.c in one precision. Included by rsvd.c only,
 * once per precision, with REAL, FN(name), RSVD_IS_DOUBLE, GEMM, GEQRF, ORGQR, DOT (a dot
 * product of REALs accumulated in double) and
 * ENERGY_RESOLUTION (the relative rounding level of energies computed from products in REAL)
 * defined;
 * it undefines them at its end, ready for the next precision. */

/* Replaces the columns of the column-major rows x cols matrix y by an orthonormal basis Q of
 * their span (Householder QR; rank-deficient input still yields orthonormal columns). If r is
 * not NULL it receives the cols x cols upper triangular R (column-major) with y = Q R. */
static op_status FN(orthonormalize)(REAL *y, int64_t rows, int cols, REAL *tau, double *r,
                                    op_error *err)
{
    lapack_int info = GEQRF(LAPACK_COL_MAJOR, (lapack_int)rows, cols, y, (lapack_int)rows, tau);
    if (info == 0 && r)
        for (int j = 0; j < cols; j++)
            for (int i = 0; i < cols; i++)
                r[i + (size_t)j * cols] = i <= j ? (double)y[i + (size_t)j * rows] : 0.0;
    if (info == 0)
        info = ORGQR(LAPACK_COL_MAJOR, (lapack_int)rows, cols, cols, y, (lapack_int)rows, tau);
    if (info != 0)
        return op_error_set(err, OP_ERR_NUMERIC, "randomized SVD: QR of a %lld x %d basis "
                            "failed (LAPACK info %d)", (long long)rows, cols, (int)info);
    return OP_OK;
}

/* The energy the top k directions of the n x l matrix z hold: the sum of the k largest
 * eigenvalues of z^T z (the squared Ritz values of A on the subspace z = A^T Y came from).
 * gram (l x l) and eig (l) are scratch. Returns -1 if LAPACK fails (never converged). */
static double FN(top_energy)(const REAL *z, int64_t n, int l, int k, double *gram, double *eig)
{
    for (int i = 0; i < l; i++)
        for (int j = 0; j <= i; j++)
            gram[(size_t)j * l + i] = DOT((blasint)n, z + (size_t)i * n, 1, z + (size_t)j * n, 1);
    if (LAPACKE_dsyev(LAPACK_COL_MAJOR, 'N', 'L', l, gram, l, eig) != 0)
        return -1.0;
    double e = 0.0;
    for (int i = l - k; i < l; i++) /* ascending order */
        e += eig[i];
    return e;
}

/* The matrix A of a randomized SVD: in memory (A, row-major m x n) or read through rows in
 * blocks of rows->block_rows (into fblk, then blk in this precision). */
typedef struct FN(source) {
    const REAL *A;
    const op_row_source *rows;
    float *fblk;
    REAL *blk;
    double norm2; /* accumulated by the first FN(times) of a streamed matrix */
} FN(source);

/* Block b of a streamed A, in this precision: *nb rows from row *r0. */
static op_status FN(block)(FN(source) *a, int64_t m, int64_t n, int64_t b, int64_t *r0,
                           int64_t *nb, op_error *err)
{
    int64_t per = a->rows->block_rows;
    *r0 = b * per;
    *nb = m - *r0 < per ? m - *r0 : per;
    op_status st = a->rows->fetch(a->rows->user, *r0, *nb, a->fblk, err);
#if RSVD_IS_DOUBLE
    for (size_t i = 0; st == OP_OK && i < (size_t)*nb * (size_t)n; i++)
        a->blk[i] = a->fblk[i];
#else
    (void)n;
#endif
    return st;
}

/* y = A z (y column-major m x l, z column-major n x l); with norm2, also sums ||A||^2. */
static op_status FN(times)(FN(source) *a, int64_t m, int64_t n, int l, const REAL *z, REAL *y,
                           int norm2, op_error *err)
{
    if (!a->rows) {
        GEMM(CblasColMajor, CblasTrans, CblasNoTrans, (blasint)m, (blasint)l, (blasint)n, 1,
             a->A, (blasint)n, z, (blasint)n, 0, y, (blasint)m);
        return OP_OK;
    }
    for (int64_t b = 0, r0, nb; b * a->rows->block_rows < m; b++) {
        op_status st = FN(block)(a, m, n, b, &r0, &nb, err);
        if (st != OP_OK)
            return st;
        if (norm2)
            a->norm2 += squared_norm(a->fblk, (size_t)nb * (size_t)n);
        GEMM(CblasColMajor, CblasTrans, CblasNoTrans, (blasint)nb, (blasint)l, (blasint)n, 1,
             a->blk, (blasint)n, z, (blasint)n, 0, y + r0, (blasint)m);
    }
    return OP_OK;
}

/* z = A^T y (z column-major n x l, y column-major m x l). */
static op_status FN(trans_times)(FN(source) *a, int64_t m, int64_t n, int l, const REAL *y,
                                 REAL *z, op_error *err)
{
    if (!a->rows) {
        GEMM(CblasColMajor, CblasNoTrans, CblasNoTrans, (blasint)n, (blasint)l, (blasint)m, 1,
             a->A, (blasint)n, y, (blasint)m, 0, z, (blasint)n);
        return OP_OK;
    }
    for (int64_t b = 0, r0, nb; b * a->rows->block_rows < m; b++) {
        op_status st = FN(block)(a, m, n, b, &r0, &nb, err);
        if (st != OP_OK)
            return st;
        GEMM(CblasColMajor, CblasNoTrans, CblasNoTrans, (blasint)n, (blasint)l, (blasint)nb, 1,
             a->blk, (blasint)n, y + r0, (blasint)m, b ? 1 : 0, z, (blasint)n);
    }
    return OP_OK;
}

/* Randomized rank-k SVD with l >= k test vectors and at most q power iterations, fewer when
 * the rank-k error has converged to tol (see converged()); see op_rsvd. */
static op_status FN(randomized)(const float *a, const op_row_source *rows, int64_t m, int64_t n,
                                int k, int l, int q, double tol, uint64_t seed, float *us,
                                float *v, double *s, op_progress *progress, op_error *err)
{
    double norm2 = tol > 0 && !rows ? squared_norm(a, (size_t)m * (size_t)n) : 0.0;
    op_status st = OP_OK;
    FN(source) A = {NULL, rows, NULL, NULL, 0.0};
    REAL *acopy = NULL;
    if (rows) {
        int64_t per = rows->block_rows < m ? rows->block_rows : m;
        A.fblk = malloc((size_t)per * (size_t)n * sizeof *A.fblk);
#if RSVD_IS_DOUBLE
        A.blk = acopy = malloc((size_t)per * (size_t)n * sizeof *acopy);
#else
        A.blk = A.fblk;
#endif
        if (!A.fblk || !A.blk) {
            free(A.fblk);
            free(acopy);
            return op_error_set(err, OP_ERR_NOMEM, "randomized SVD: out of memory for a block of "
                                "%lld rows", (long long)per);
        }
    } else {
#if RSVD_IS_DOUBLE
        acopy = malloc((size_t)m * (size_t)n * sizeof *acopy);
        if (!acopy)
            return op_error_set(err, OP_ERR_NOMEM, "randomized SVD: out of memory for a %lld x "
                                "%lld double matrix", (long long)m, (long long)n);
        for (size_t i = 0; i < (size_t)m * (size_t)n; i++)
            acopy[i] = a[i];
        A.A = acopy;
#else
        A.A = a;
#endif
    }
    /* Row-major m x n A is column-major n x m A^T (leading dimension n). */
    REAL *y = malloc((size_t)m * (size_t)l * sizeof *y);
    REAL *z = malloc((size_t)n * (size_t)l * sizeof *z);
    REAL *tau = malloc((size_t)l * sizeof *tau);
    REAL *mk = malloc((size_t)l * (size_t)k * sizeof *mk);
    REAL *wk = malloc((size_t)l * (size_t)k * sizeof *wk);
    double *small = malloc((3 * (size_t)l * (size_t)l + (size_t)l) * sizeof *small);
    REAL *usr = NULL, *vr = NULL;
#if RSVD_IS_DOUBLE
    usr = malloc((size_t)m * (size_t)k * sizeof *usr);
    vr = malloc((size_t)n * (size_t)k * sizeof *vr);
#endif
    if (!y || !z || !tau || !mk || !wk || !small || (RSVD_IS_DOUBLE && (!usr || !vr))) {
        st = op_error_set(err, OP_ERR_NOMEM, "randomized SVD: out of memory");
        goto done;
    }
    /* l x l scratch: r (R, then overwritten by dgesdd), wr (its left singular vectors), xt
     * (its right ones, transposed; also the Gram matrix of top_energy), and l values sv. */
    double *r = small, *wr = r + (size_t)l * l, *xt = wr + (size_t)l * l;
    double *sv = xt + (size_t)l * l;
    uint64_t rng = seed;
    for (size_t i = 0; i < (size_t)n * (size_t)l; i++)
        z[i] = (REAL)gaussian(&rng);
    /* Y = orth(A Omega); then Z = A^T Y, which is B^T for the current Y, and while the
     * estimate of the rank-k error still improves, Z = orth(Z), Y = orth(A Z) and again. */
    if ((st = FN(times)(&A, m, n, l, z, y, rows && tol > 0, err)) != OP_OK)
        goto done;
    if (rows)
        norm2 = A.norm2;
    op_progress_advance(progress, 1);
    if ((st = FN(orthonormalize)(y, m, l, tau, NULL, err)) != OP_OK)
        goto done;
    double captured_prev = 0.0;
    for (int it = 0;; it++) {
        if ((st = FN(trans_times)(&A, m, n, l, y, z, err)) != OP_OK)
            goto done;
        op_progress_advance(progress, 1);
        if (it == q)
            break;
        double captured = FN(top_energy)(z, n, l, k, xt, sv);
        if (it > 0 && converged(captured_prev, captured, norm2, tol, ENERGY_RESOLUTION)) {
            op_progress_advance(progress, (uint64_t)(2 * (q - it)));
            break;
        }
        captured_prev = captured;
        if ((st = FN(orthonormalize)(z, n, l, tau, NULL, err)) != OP_OK)
            goto done;
        if ((st = FN(times)(&A, m, n, l, z, y, 0, err)) != OP_OK)
            goto done;
        op_progress_advance(progress, 1);
        if ((st = FN(orthonormalize)(y, m, l, tau, NULL, err)) != OP_OK)
            goto done;
    }
    /* B^T = Z = A^T Y (n x l) = Qz R, and R = Wr S X^T (l x l, in double), so
     * A ~ Y B = (Y X) S (Qz Wr)^T. */
    if ((st = FN(orthonormalize)(z, n, l, tau, r, err)) != OP_OK)
        goto done;
    lapack_int info = LAPACKE_dgesdd(LAPACK_COL_MAJOR, 'A', l, l, r, l, sv, wr, l, xt, l);
    if (info != 0) {
        st = op_error_set(err, OP_ERR_NUMERIC, "randomized SVD: SVD of the %d x %d projection "
                          "failed (LAPACK info %d)", l, l, (int)info);
        goto done;
    }
    /* mk[j][t] = X(j, t) s_t with X(j, t) = xt[t + j l]; wk[j][t] = Wr(j, t). */
    for (int j = 0; j < l; j++)
        for (int t = 0; t < k; t++) {
            mk[(size_t)j * k + t] = (REAL)(xt[t + (size_t)j * l] * sv[t]);
            wk[(size_t)j * k + t] = (REAL)wr[j + (size_t)t * l];
        }
#if RSVD_IS_DOUBLE
    GEMM(CblasRowMajor, CblasTrans, CblasNoTrans, (blasint)m, k, l, 1, y, (blasint)m, mk, k, 0,
         usr, k);
    GEMM(CblasRowMajor, CblasTrans, CblasNoTrans, (blasint)n, k, l, 1, z, (blasint)n, wk, k, 0,
         vr, k);
    for (size_t i = 0; i < (size_t)m * (size_t)k; i++)
        us[i] = (float)usr[i];
    for (size_t i = 0; i < (size_t)n * (size_t)k; i++)
        v[i] = (float)vr[i];
#else
    GEMM(CblasRowMajor, CblasTrans, CblasNoTrans, (blasint)m, k, l, 1, y, (blasint)m, mk, k, 0,
         us, k);
    GEMM(CblasRowMajor, CblasTrans, CblasNoTrans, (blasint)n, k, l, 1, z, (blasint)n, wk, k, 0,
         v, k);
#endif
    if (s)
        for (int t = 0; t < k; t++)
            s[t] = sv[t];
done:
    free(acopy); /* streamed in double: the block */
    free(A.fblk);
    free(y);
    free(z);
    free(tau);
    free(mk);
    free(wk);
    free(small);
    free(usr);
    free(vr);
    return st;
}

#undef REAL
#undef FN
#undef RSVD_IS_DOUBLE
#undef GEMM
#undef GEQRF
#undef ORGQR
#undef DOT
#undef ENERGY_RESOLUTION
