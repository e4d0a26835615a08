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

/* The energy A holds on the top k directions of span(Z), Z (n x l) orthonormal, from W = A^T A Z:
 * the sum of the k largest eigenvalues of Z^T W = (A Z)^T (A Z) (symmetrized), the squared Ritz
 * values. gram (l x l) and eig (l) are scratch. Returns -1 if LAPACK fails (never converged). */
static double FN(top_energy)(const REAL *z, const REAL *w, int64_t n, int l, int k, double *gram,
                             double *eig)
{
    for (int i = 0; i < l; i++)
        for (int j = 0; j <= i; j++)
            gram[(size_t)j * l + i] =
                0.5 * (DOT((blasint)n, z + (size_t)i * n, 1, w + (size_t)j * n, 1) +
                       DOT((blasint)n, z + (size_t)j * n, 1, w + (size_t)i * n, 1));
    if (LAPACKE_dsyev(LAPACK_COL_MAJOR, 'N', 'L', l, gram, l, eig) != 0)
        return -1.0;
    double e = 0.0;
    for (int i = l - k; i < l; i++) /* ascending order */
        e += eig[i];
    return e;
}

/* The matrix A of a randomized SVD: in memory (A, row-major m x n floats), made by its first
 * pass (fill: rows->fetch writes the rows there, in parallel tasks; then it is A), or read
 * through rows in blocks of rows->block_rows (into fblk, then blk in this precision). */
typedef struct FN(source) {
    const float *A;
    float *fill;
    const op_row_source *rows;
    int threads;
    float *fblk;
    REAL *blk;
} FN(source);

/* One pass over an in-memory (or filled) A in fixed blocks of rows, one op_parallel_for task
 * each: y = A z for the block's rows, and the block's part of A^T y, merged in task order. */
typedef struct FN(pass_job) {
    FN(source) *a;
    int64_t m, n, per;
    int l;
    const REAL *z;
    REAL *y, *parts, *dblk; /* dblk: one block per thread (double precision only) */
    double *norms;          /* per task ||block||^2, or NULL */
    op_status *status;      /* per task */
    op_error *errs;         /* per task */
} FN(pass_job);

static void FN(pass_task)(void *user, int task, int thread)
{
    const FN(pass_job) *j = user;
    int64_t n = j->n, r0 = (int64_t)task * j->per, nb = j->m - r0 < j->per ? j->m - r0 : j->per;
    const float *src;
    if (j->a->fill) {
        src = j->a->fill + r0 * n;
        j->status[task] = j->a->rows->fetch(j->a->rows->user, r0, nb, j->a->fill + r0 * n,
                                            &j->errs[task]);
        if (j->status[task] != OP_OK)
            return;
    } else {
        src = j->a->A + r0 * n;
    }
    if (j->norms)
        j->norms[task] = squared_norm(src, (size_t)nb * (size_t)n);
#if RSVD_IS_DOUBLE
    REAL *blk = j->dblk + (size_t)thread * (size_t)j->per * (size_t)n;
    for (size_t i = 0; i < (size_t)nb * (size_t)n; i++)
        blk[i] = src[i];
#else
    const REAL *blk = src;
    (void)thread;
#endif
    GEMM(CblasColMajor, CblasTrans, CblasNoTrans, (blasint)nb, j->l, (blasint)n, 1, blk,
         (blasint)n, j->z, (blasint)n, 0, j->y + r0, (blasint)j->m);
    GEMM(CblasColMajor, CblasNoTrans, CblasNoTrans, (blasint)n, j->l, (blasint)nb, 1, blk,
         (blasint)n, j->y + r0, (blasint)j->m, 0, j->parts + (size_t)task * (size_t)n * j->l,
         (blasint)n);
}

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

/* One pass over A: y = A z (y column-major m x l, z column-major n x l) and w = A^T y (n x l),
 * each block of rows used for both while it is in cache; with norm2, also ||A||^2. A filled
 * source is in memory afterwards. */
static op_status FN(pass)(FN(source) *a, int64_t m, int64_t n, int l, const REAL *z, REAL *y,
                          REAL *w, double *norm2, op_error *err)
{
    if (norm2)
        *norm2 = 0.0;
    if (!a->A && !a->fill) { /* streamed: blocks in order, OpenBLAS's threads in each product */
        for (int64_t b = 0, r0, nb; b * a->rows->block_rows < m; b++) {
            op_status st = FN(block)(a, m, n, b, &r0, &nb, err);
            if (st != OP_OK)
                return st;
            if (norm2)
                *norm2 += squared_norm(a->fblk, (size_t)nb * (size_t)n);
            GEMM(CblasColMajor, CblasTrans, CblasNoTrans, (blasint)nb, (blasint)l, (blasint)n, 1,
                 a->blk, (blasint)n, z, (blasint)n, 0, y + r0, (blasint)m);
            GEMM(CblasColMajor, CblasNoTrans, CblasNoTrans, (blasint)n, (blasint)l, (blasint)nb,
                 1, a->blk, (blasint)n, y + r0, (blasint)m, b ? 1 : 0, w, (blasint)n);
        }
        return OP_OK;
    }
    FN(pass_job) j = {.a = a, .m = m, .n = n, .per = pass_rows(m, n), .l = l, .z = z, .y = y};
    int tasks = (int)((m + j.per - 1) / j.per);
    int threads = op_parallel_threads(a->threads);
    threads = threads < tasks ? threads : tasks;
    j.parts = malloc((size_t)tasks * (size_t)n * (size_t)l * sizeof *j.parts);
    j.norms = norm2 ? calloc((size_t)tasks, sizeof *j.norms) : NULL;
    j.status = calloc((size_t)tasks, sizeof *j.status);
    j.errs = calloc((size_t)tasks, sizeof *j.errs);
    double *sum = calloc((size_t)n * (size_t)l, sizeof *sum);
#if RSVD_IS_DOUBLE
    j.dblk = malloc((size_t)threads * (size_t)j.per * (size_t)n * sizeof *j.dblk);
#endif
    op_status st = OP_OK;
    if (!j.parts || (norm2 && !j.norms) || !j.status || !j.errs || !sum ||
        (RSVD_IS_DOUBLE && !j.dblk))
        st = op_error_set(err, OP_ERR_NOMEM, "randomized SVD: out of memory for %d blocks of "
                          "%lld rows", tasks, (long long)j.per);
    if (st == OP_OK) {
        /* the tasks' products single-threaded, on the pool's threads only: the tasks are the
         * parallelism (OpenBLAS's idle threads would spin beside them), and OpenBLAS's own
         * threads do not flush denormals as the pool's do, so the result would depend on
         * whether a product ran on them */
        int blas_threads = openblas_get_num_threads();
        openblas_set_num_threads(1);
        st = op_parallel_for(threads, tasks, FN(pass_task), &j, NULL, err);
        openblas_set_num_threads(blas_threads);
    }
    for (int t = 0; st == OP_OK && t < tasks; t++)
        if (j.status[t] != OP_OK) { /* the first failing block's error */
            st = j.status[t];
            if (err)
                *err = j.errs[t];
        }
    if (st == OP_OK) {
        size_t nl = (size_t)n * (size_t)l;
        for (int t = 0; t < tasks; t++) {
            const REAL *p = j.parts + (size_t)t * nl;
            for (size_t i = 0; i < nl; i++)
                sum[i] += p[i];
            if (norm2)
                *norm2 += j.norms[t];
        }
        for (size_t i = 0; i < nl; i++)
            w[i] = (REAL)sum[i];
        if (a->fill) {
            a->A = a->fill;
            a->fill = NULL;
        }
    }
    free(j.parts);
    free(j.norms);
    free(j.status);
    free(j.errs);
    free(j.dblk);
    free(sum);
    return st;
}

/* Randomized rank-k SVD with l >= k test vectors and at most q >= 1 power iterations, fewer
 * when the rank-k error has converged to tol (see converged()); see op_rsvd. Each iteration is
 * one pass over A (A^T A z); the first also makes a filled A and measures ||A||^2. */
static op_status FN(randomized)(FN(source) *A, int64_t m, int64_t n, int k, int l, int q,
                                double tol, uint64_t seed, float *us, float *v, double *s,
                                op_progress *progress, op_error *err)
{
    double norm2 = 0.0;
    op_status st = OP_OK;
    REAL *acopy = NULL;
    if (!A->A && !A->fill) {
        int64_t per = A->rows->block_rows < m ? A->rows->block_rows : m;
        A->fblk = malloc((size_t)per * (size_t)n * sizeof *A->fblk);
#if RSVD_IS_DOUBLE
        A->blk = acopy = malloc((size_t)per * (size_t)n * sizeof *acopy);
#else
        A->blk = A->fblk;
#endif
        if (!A->fblk || !A->blk) {
            free(A->fblk);
            free(acopy);
            return op_error_set(err, OP_ERR_NOMEM, "randomized SVD: out of memory for a block of "
                                "%lld rows", (long long)per);
        }
    }
    /* Row-major m x n A is column-major n x m A^T (leading dimension n). */
    REAL *y = malloc((size_t)m * (size_t)l * sizeof *y);
    REAL *z = malloc((size_t)n * (size_t)l * sizeof *z);
    REAL *w = malloc((size_t)n * (size_t)l * sizeof *w);
    REAL *tau = malloc((size_t)l * sizeof *tau);
    REAL *mk = malloc((size_t)l * (size_t)k * sizeof *mk);
    REAL *wk = malloc((size_t)l * (size_t)k * sizeof *wk);
    double *small = malloc((3 * (size_t)l * (size_t)l + (size_t)l) * sizeof *small);
    REAL *usr = NULL, *vr = NULL;
#if RSVD_IS_DOUBLE
    usr = malloc((size_t)m * (size_t)k * sizeof *usr);
    vr = malloc((size_t)n * (size_t)k * sizeof *vr);
#endif
    if (!y || !z || !w || !tau || !mk || !wk || !small || (RSVD_IS_DOUBLE && (!usr || !vr))) {
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
    /* W = A^T A Omega; then while the estimate of the rank-k error still improves (at most q
     * times): Z = orth(W), Y = A Z, W = A^T Y. The result is A ~ Y Z^T. */
    if ((st = FN(pass)(A, m, n, l, z, y, w, tol > 0 ? &norm2 : NULL, err)) != OP_OK)
        goto done;
    op_progress_advance(progress, 1);
    double captured_prev = 0.0;
    int it = 1;
    for (;; it++) {
        REAL *swap = z;
        z = w;
        w = swap;
        if ((st = FN(orthonormalize)(z, n, l, tau, NULL, err)) != OP_OK)
            goto done;
        if ((st = FN(pass)(A, m, n, l, z, y, w, NULL, err)) != OP_OK)
            goto done;
        op_progress_advance(progress, 1);
        if (it >= q)
            break;
        double captured = FN(top_energy)(z, w, n, l, k, xt, sv);
        if (it > 2 && converged(captured_prev, captured, norm2, tol, ENERGY_RESOLUTION)) {
            op_progress_advance(progress, (uint64_t)(q - it));
            break;
        }
        captured_prev = captured;
    }
    op_log(OP_LOG_DEBUG, "randomized SVD of %lld x %lld to rank %d: %d power iteration(s), "
           "%d passes", (long long)m, (long long)n, k, it, it + 1);
    /* Y = Qy R (m x l), and R = Wr S X^T (l x l, in double), so
     * A ~ Y Z^T = (Qy Wr) S (Z X)^T. */
    if ((st = FN(orthonormalize)(y, m, l, tau, r, err)) != OP_OK)
        goto done;
    lapack_int info = LAPACKE_dgesdd(LAPACK_COL_MAJOR, 'A', l, l, r, l, sv, wr, l, xt, l);
    if (info != 0) {
        st = op_error_set(err, OP_ERR_NUMERIC, "randomized SVD: SVD of the %d x %d projection "
                          "failed (LAPACK info %d)", l, l, (int)info);
        goto done;
    }
    /* mk[j][t] = Wr(j, t) s_t; wk[j][t] = X(j, t) with X(j, t) = xt[t + j l]. */
    for (int j = 0; j < l; j++)
        for (int t = 0; t < k; t++) {
            mk[(size_t)j * k + t] = (REAL)(wr[j + (size_t)t * l] * sv[t]);
            wk[(size_t)j * k + t] = (REAL)xt[t + (size_t)j * l];
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
    free(A->fblk);
    A->fblk = NULL;
    free(y);
    free(z);
    free(w);
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
