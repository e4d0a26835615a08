/* test_factor_svd.c - the randomized truncated SVD against a full LAPACK SVD (Eckart-Young),
 * and the svd method end to end under numerical stress: zero and constant rows, noise, a huge
 * dynamic range, NaN and infinity, rank deficiency, T above the rank, K = 1, one pixel, and
 * single against double precision. Every case ends in a clear error or a finite, correct
 * material. */
#include "factor_test_util.h"

#include "rsvd.h"

#include <lapacke.h>

/* splitmix64-based standard normal deviates, deterministic. */
static double normal(uint64_t *s)
{
    uint64_t z[2];
    for (int i = 0; i < 2; i++)
        z[i] = op_splitmix64(s);
    double u1 = ((double)(z[0] >> 11) + 1.0) * 0x1.0p-53, u2 = (double)(z[1] >> 11) * 0x1.0p-53;
    return sqrt(-2.0 * log(u1)) * cos(6.283185307179586 * u2);
}

/* ||A - US V^T||_F in double. */
static double residual(const float *a, int m, int n, int k, const float *us, const float *v)
{
    double s = 0;
    for (int i = 0; i < m; i++)
        for (int j = 0; j < n; j++) {
            double x = a[(size_t)i * n + j];
            for (int t = 0; t < k; t++)
                x -= (double)us[(size_t)i * k + t] * v[(size_t)j * k + t];
            s += x * x;
        }
    return sqrt(s);
}

/* The optimal rank-k error: the norm of the trailing singular values (full dgesdd). */
static double optimal_error(const float *a, int m, int n, int k)
{
    double *d = malloc((size_t)m * n * sizeof *d), *s = malloc((size_t)n * sizeof *s);
    for (size_t i = 0; i < (size_t)m * n; i++)
        d[i] = a[i];
    assert_int_equal(LAPACKE_dgesdd(LAPACK_ROW_MAJOR, 'N', m, n, d, n, s, NULL, m, NULL, n), 0);
    double e = 0;
    for (int i = k; i < (m < n ? m : n); i++)
        e += s[i] * s[i];
    free(d);
    free(s);
    return sqrt(e);
}

/* Kernel-like rows (Gaussians of varying width and centre, as in real data) plus noise. */
static float *kernel_matrix(int m, int side, double noise)
{
    int n = side * side;
    float *a = malloc((size_t)m * n * sizeof *a);
    uint64_t rng = 42;
    for (int i = 0; i < m; i++) {
        double w = 1.0 + 3.0 * (0.5 + 0.5 * sin(i * 0.37)), amp = 1.0 + 0.5 * cos(i * 0.11);
        double cx = side / 2 + 1.5 * sin(i * 0.05), cy = side / 2 + 1.5 * cos(i * 0.07);
        for (int j = 0; j < n; j++) {
            double dx = j % side - cx, dy = j / side - cy;
            a[(size_t)i * n + j] =
                (float)(amp * exp(-(dx * dx + dy * dy) / (2 * w * w)) + noise * normal(&rng));
        }
    }
    return a;
}

static float *gaussian_matrix(int m, int n)
{
    float *a = malloc((size_t)m * n * sizeof *a);
    uint64_t rng = 7;
    for (size_t i = 0; i < (size_t)m * n; i++)
        a[i] = (float)normal(&rng);
    return a;
}

/* The rank-k error of op_rsvd with power_tol (negative: the default) against the optimum;
 * asserts it is within 1 % and the singular values decrease. Returns the error. */
static double check_eckart_young_tol(const float *a, int m, int n, int k, op_svd_precision prec,
                                     double power_tol)
{
    float *us = malloc((size_t)m * k * sizeof *us), *v = malloc((size_t)n * k * sizeof *v);
    double s[64];
    op_rsvd_options opt = op_rsvd_defaults();
    opt.precision = prec;
    if (power_tol >= 0)
        opt.power_tol = power_tol;
    op_error err = {0};
    OP_ASSERT_OK(op_rsvd(a, m, n, k, &opt, us, v, s, NULL, &err), err);
    double got = residual(a, m, n, k, us, v), best = optimal_error(a, m, n, k);
    print_message("  %d x %d rank %d (%s, power_tol %g): error %.9g, optimal %.9g, ratio %.6f\n",
                  m, n, k, prec == OP_SVD_DOUBLE ? "double" : "single", opt.power_tol, got, best,
                  got / best);
    assert_true(got <= 1.01 * best);
    for (int t = 1; t < k; t++)
        assert_true(s[t] <= s[t - 1]);
    free(us);
    free(v);
    return got;
}

static void check_eckart_young(const float *a, int m, int n, int k, op_svd_precision prec)
{
    check_eckart_young_tol(a, m, n, k, prec, -1);
}

static void eckart_young_kernel_rows(void **state)
{
    float *a = kernel_matrix(3000, 15, 1e-3);
    check_eckart_young(a, 3000, 225, 10, OP_SVD_SINGLE);
    check_eckart_young(a, 3000, 225, 10, OP_SVD_DOUBLE);
    check_eckart_young(a, 3000, 225, 3, OP_SVD_SINGLE);
    /* A decaying spectrum converges before the 4 power iterations: the adaptive stop ends
     * earlier (a different, equally good result) than always iterating. */
    double adaptive = check_eckart_young_tol(a, 3000, 225, 10, OP_SVD_SINGLE, -1);
    double fixed = check_eckart_young_tol(a, 3000, 225, 10, OP_SVD_SINGLE, 0);
    assert_true(adaptive != fixed);
    assert_true(adaptive <= 1.001 * fixed);
    free(a);
    /* At rank 40 the error is a few millionths of ||A||^2, so the energies'
     * improvement falls below what float products resolve and turns into rounding noise: the
     * adaptive stop must still end early (a result other than 4 iterations') and stay optimal.
     * (Without the resolution floor it runs all 4 iterations here.) */
    a = kernel_matrix(3000, 15, 1e-6);
    adaptive = check_eckart_young_tol(a, 3000, 225, 40, OP_SVD_SINGLE, -1);
    fixed = check_eckart_young_tol(a, 3000, 225, 40, OP_SVD_SINGLE, 0);
    assert_true(adaptive != fixed);
    assert_true(adaptive <= 1.001 * fixed);
    free(a);
}

static void eckart_young_flat_spectrum(void **state)
{
    /* Pure noise: the hardest case for a randomized method. */
    float *a = gaussian_matrix(1500, 200);
    check_eckart_young(a, 1500, 200, 10, OP_SVD_SINGLE);
    check_eckart_young(a, 1500, 200, 10, OP_SVD_DOUBLE);
    check_eckart_young_tol(a, 1500, 200, 10, OP_SVD_SINGLE, 0);
    free(a);
}

static void rsvd_deterministic_and_exact_when_small(void **state)
{
    float *a = kernel_matrix(500, 5, 1e-2);
    int m = 500, n = 25, k = 4;
    float *u1 = malloc((size_t)m * k * 4), *v1 = malloc((size_t)n * k * 4);
    float *u2 = malloc((size_t)m * k * 4), *v2 = malloc((size_t)n * k * 4);
    op_rsvd_options opt = op_rsvd_defaults();
    opt.oversample = 5;
    op_error err = {0};
    OP_ASSERT_OK(op_rsvd(a, m, n, k, &opt, u1, v1, NULL, NULL, &err), err);
    OP_ASSERT_OK(op_rsvd(a, m, n, k, &opt, u2, v2, NULL, NULL, &err), err);
    assert_memory_equal(u1, u2, (size_t)m * k * 4);
    assert_memory_equal(v1, v2, (size_t)n * k * 4);
    /* The sign convention: each right vector's largest-magnitude entry is positive. */
    for (int t = 0; t < k; t++) {
        float big = 0;
        for (int j = 0; j < n; j++)
            if (fabsf(v1[j * k + t]) > fabsf(big))
                big = v1[j * k + t];
        assert_true(big > 0);
    }
    /* Rank above min(m, n) is refused; k = min(m, n) is exact. */
    assert_int_equal(op_rsvd(a, m, n, n + 1, &opt, u1, v1, NULL, NULL, &err), OP_ERR_INPUT);
    float *ue = malloc((size_t)m * n * 4), *ve = malloc((size_t)n * n * 4);
    OP_ASSERT_OK(op_rsvd(a, m, n, n, &opt, ue, ve, NULL, NULL, &err), err);
    double norm = 0;
    for (size_t i = 0; i < (size_t)m * n; i++)
        norm += (double)a[i] * a[i];
    assert_true(residual(a, m, n, n, ue, ve) < 1e-5 * sqrt(norm));
    free(ue);
    free(ve);
    free(u1);
    free(v1);
    free(u2);
    free(v2);
    free(a);
}

/* ------------------------------------------------------------ the method end to end */

static void svd_end_to_end(void **state)
{
    ds_spec d = ds_chess(16, 12, 7, 0);
    char *in = ds_write(&d);
    char out[1024], report[1024], png[1024], errtext[8192];
    snprintf(out, sizeof out, "%s", op_test_tmp_path("svd.opm"));
    snprintf(report, sizeof report, "%s", op_test_tmp_path("svd.json"));
    snprintf(png, sizeof png, "%s", op_test_tmp_path("svd.png"));
    const char *args[] = {"--method", "svd", "-T", "6", "--report", report, "--albedo-png", png,
                          "--name", "Chess test", NULL};
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, args), 0);
    double rel = ds_compare(&d, out, NULL);
    print_message("  svd T=6 relative RMSE %.3g\n", rel);
    assert_true(rel < 0.02);
    check_eval_paths(out);
    op_material *m = open_valid(out);
    const op_material_info *info = op_material_get_info(m);
    assert_int_equal(info->method, OP_METHOD_SVD);
    assert_int_equal(info->terms, 6);
    assert_int_equal(info->shifted, 1);
    assert_true(info->log_a == 100.0 && info->log_b == 1.0);
    assert_string_equal(info->name, "Chess test");
    assert_non_null(op_material_section(m, "ALBEDO", NULL));
    op_material_close(m);
    check_file_contains(report, "\"method\": \"svd\"");
    check_file_contains(report, "\"relative_rmse\": ");
    check_file_contains(report, "\"compression_ratio\": ");
    check_file_contains(report, "\"peak_memory_bytes\": ");
    check_image_size(png, 16, 12);

    /* Unshifted, and other A and B. */
    const char *args2[] = {"--method", "svd", "-T", "6", "--no-shift", "--log-a", "0.01",
                           "--log-b", "0.5", NULL};
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, args2), 0);
    rel = ds_compare(&d, out, NULL);
    print_message("  svd T=6 unshifted A=0.01 B=0.5 relative RMSE %.3g\n", rel);
    assert_true(rel < 0.05);
    check_eval_paths(out);
    free(in);
    free(d.v);
}

/* Preprocessing and evaluation run on threads in fixed row blocks: the material file and the
 * reported errors are the same for any -t (the dataset spans several blocks). */
static void same_result_for_any_thread_count(void **state)
{
    ds_spec d = ds_chess(120, 90, 7, 0);
    char *in = ds_write(&d);
    char out[2][1024], report[2][1024], errtext[8192];
    const char *threads[2] = {"1", "3"};
    for (int i = 0; i < 2; i++) {
        snprintf(out[i], sizeof out[i], "%s", op_test_tmp_path(i ? "t3.opm" : "t1.opm"));
        snprintf(report[i], sizeof report[i], "%s", op_test_tmp_path(i ? "t3.json" : "t1.json"));
        const char *args[] = {"--method", "svd", "-T", "4", "-t", threads[i], "--report",
                              report[i], NULL};
        assert_int_equal(run_factor(in, out[i], errtext, sizeof errtext, args), 0);
    }
    size_t n0, n1;
    char *a = slurp_bytes(out[0], &n0), *b = slurp_bytes(out[1], &n1);
    assert_int_equal(n0, n1);
    assert_memory_equal(a, b, n0);
    free(a);
    free(b);
    a = slurp(report[0]);
    b = slurp(report[1]);
    const char *keys[] = {"\"rmse\": ", "\"max_error\": ", "\"psnr\": "};
    for (int k = 0; k < 3; k++) {
        const char *x = strstr(a, keys[k]), *y = strstr(b, keys[k]);
        assert_non_null(x);
        assert_non_null(y);
        assert_int_equal(strcspn(x, ","), strcspn(y, ","));
        assert_memory_equal(x, y, strcspn(x, ","));
    }
    free(a);
    free(b);
    free(in);
    free(d.v);
}

/* op_rsvd_rows: a matrix read in blocks of rows (any block size, one row to more than all)
 * gives op_rsvd's factors within rounding, in both precisions. */
typedef struct block_reader {
    const float *a;
    int n;
    int64_t fetched; /* rows handed out */
} block_reader;

static op_status fetch_block(void *user, int64_t r0, int64_t count, float *dst, op_error *err)
{
    block_reader *b = user;
    (void)err;
    memcpy(dst, b->a + r0 * b->n, (size_t)count * (size_t)b->n * sizeof *dst);
    b->fetched += count;
    return OP_OK;
}

static void streamed_rsvd_matches(void **state)
{
    const int m = 300, n = 49, k = 6;
    float *a = kernel_matrix(m, 7, 1e-3);
    float *us0 = malloc((size_t)m * k * sizeof *us0), *v0 = malloc((size_t)n * k * sizeof *v0);
    float *us1 = malloc((size_t)m * k * sizeof *us1), *v1 = malloc((size_t)n * k * sizeof *v1);
    const int64_t blocks[] = {1, 7, 64, 1000};
    for (int prec = 0; prec < 2; prec++) {
        op_rsvd_options opt = op_rsvd_defaults();
        opt.precision = prec ? OP_SVD_DOUBLE : OP_SVD_SINGLE;
        op_error err = {0};
        OP_ASSERT_OK(op_rsvd(a, m, n, k, &opt, us0, v0, NULL, NULL, &err), err);
        double scale = 0;
        for (int i = 0; i < m * k; i++)
            scale = fmax(scale, fabs(us0[i]));
        for (size_t b = 0; b < sizeof blocks / sizeof blocks[0]; b++) {
            block_reader r = {a, n, 0};
            op_row_source src = {fetch_block, &r, blocks[b]};
            OP_ASSERT_OK(op_rsvd_rows(&src, m, n, k, &opt, us1, v1, NULL, NULL, &err), err);
            double du = 0, dv = 0;
            for (int i = 0; i < m * k; i++)
                du = fmax(du, fabs(us1[i] - us0[i]));
            for (int i = 0; i < n * k; i++)
                dv = fmax(dv, fabs(v1[i] - v0[i]));
            if (du > 1e-4 * scale || dv > 1e-4)
                fail_msg("block %lld, %s: factors differ by %.3g (left, of %.3g) and %.3g (right)",
                         (long long)blocks[b], prec ? "double" : "single", du, scale, dv);
            assert_true(r.fetched >= 2 * m && r.fetched % m == 0); /* whole passes only */
        }
    }
    /* the exact method cannot stream: refused, not silently read whole */
    op_rsvd_options ex = op_rsvd_defaults();
    ex.exact = 1;
    block_reader r = {a, n, 0};
    op_row_source src = {fetch_block, &r, 10};
    op_error err = {0};
    assert_int_equal(op_rsvd_rows(&src, m, n, k, &ex, us1, v1, NULL, NULL, &err), OP_ERR_INPUT);
    free(a);
    free(us0);
    free(v0);
    free(us1);
    free(v1);
}

/* `factor --block-rows N` (a dataset forced to stream in tiny blocks) writes the in-memory
 * run's material within rounding: the same shifts and maxima, every value within 1e-4 of the
 * largest, the same relative error within 1e-3 of itself + 1e-6 (the data here is nearly of
 * rank 5: its error, 3e-5, changes by rounding-level amounts). */
static void streamed_factor_matches(void **state)
{
    ds_spec d = ds_chess(40, 30, 7, 0.1);
    char *in = ds_write(&d);
    char out[3][1024], errtext[8192];
    const char *blocks[3] = {"0", "7", "5000"};
    double rel[3], maxabs[3];
    for (int i = 0; i < 3; i++) {
        char name[32];
        snprintf(name, sizeof name, "stream%d.opm", i);
        snprintf(out[i], sizeof out[i], "%s", op_test_tmp_path(name));
        const char *args[] = {"--method", "svd", "-T", "5", "--block-rows", blocks[i], NULL};
        assert_int_equal(run_factor(in, out[i], errtext, sizeof errtext, args), 0);
        if (i)
            assert_non_null(strstr(errtext, "never whole in memory"));
        rel[i] = ds_compare(&d, out[i], &maxabs[i]);
    }
    op_material *m0 = open_valid(out[0]);
    for (int i = 1; i < 3; i++) {
        if (!(fabs(rel[i] - rel[0]) <= 1e-3 * rel[0] + 1e-6))
            fail_msg("--block-rows %s: relative error %.9g, in memory %.9g", blocks[i], rel[i],
                     rel[0]);
        op_material *m1 = open_valid(out[i]);
        const char *tags[] = {"SHIFT.R", "MAX.R", "SHIFT.B", "MAX.B"};
        for (int t = 0; t < 4; t++) {
            uint64_t n0, n1;
            const void *x = op_material_section(m0, tags[t], &n0);
            const void *y = op_material_section(m1, tags[t], &n1);
            assert_non_null(x);
            assert_non_null(y);
            assert_int_equal(n0, n1);
            assert_memory_equal(x, y, n0);
        }
        /* the reconstruction (a trailing singular vector alone may turn within its
         * near-degenerate subspace) */
        float r0[49], r1[49];
        double big = 0, diff = 0;
        for (int c = 0; c < 3; c++)
            for (int y = 0; y < 30; y++)
                for (int x = 0; x < 40; x++) {
                    op_material_eval_row(m0, c, x, y, r0);
                    op_material_eval_row(m1, c, x, y, r1);
                    for (int q = 0; q < 49; q++) {
                        big = fmax(big, r0[q]);
                        diff = fmax(diff, fabs(r0[q] - r1[q]));
                    }
                }
        if (diff > 1e-4 * big)
            fail_msg("--block-rows %s: the material differs by %.3g (largest value %.3g)",
                     blocks[i], diff, big);
        op_material_close(m1);
    }
    op_material_close(m0);
    const char *bad[] = {"--method", "tucker", "--block-rows", "7", NULL};
    assert_int_equal(run_factor(in, out[2], errtext, sizeof errtext, bad), 2);
    assert_non_null(strstr(errtext, "--block-rows applies to --method svd only"));
    free(in);
    free(d.v);
}

static void bad_arguments(void **state)
{
    ds_spec d = ds_chess(4, 4, 3, 0);
    char *in = ds_write(&d);
    char errtext[8192], out[1024], other[1024];
    snprintf(out, sizeof out, "%s", op_test_tmp_path("bad.opm"));
    snprintf(other, sizeof other, "%s", op_test_tmp_path("x.opm"));
    const char *cases[][6] = {
        {"--method", "dipole", NULL},
        {"--method", "svd", "-T", "0", NULL},
        {"--method", "svd", "-T", "2.5", NULL},
        {"--method", "svd", "--log-a", "0", NULL},
        {"--method", "svd", "--log-b", "-1", NULL},
        {"--method", "svd", "--frobnicate", NULL},
        {"-T", "3", NULL},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        assert_int_equal(run_factor(in, out, errtext, sizeof errtext, cases[i]), 2);
    /* A factored material is not a dataset; a missing file is an input error. */
    const char *ok[] = {"--method", "svd", "-T", "2", NULL};
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, ok), 0);
    assert_int_equal(run_factor(out, other, errtext, sizeof errtext, ok), 2);
    assert_non_null(strstr(errtext, "not a dataset"));
    assert_int_equal(run_factor("/nonexistent/ds.opm", out, errtext, sizeof errtext, ok), 2);
    free(in);
    free(d.v);
}

/* Extreme --log-a/--log-b: a transform that loses the data (values underflowing, infinite, or
 * past what the reconstruction can hold) is refused naming both options; a poor but faithful one
 * is accepted and its error reported. */
static void log_transform_extremes(void **state)
{
    ds_spec d = ds_chess(12, 12, 5, 0.3);
    char *in = ds_write(&d);
    char errtext[8192], out[1024];
    snprintf(out, sizeof out, "%s", op_test_tmp_path("logx.opm"));
    const char *refused[][2] = {{"1e30", "1"}, {"1e-30", "1"}, {"100", "1e30"}};
    for (size_t i = 0; i < sizeof refused / sizeof refused[0]; i++) {
        const char *args[] = {"--method", "svd", "-T", "3", "--log-a", refused[i][0], "--log-b",
                              refused[i][1], NULL};
        assert_int_equal(run_factor(in, out, errtext, sizeof errtext, args), 2);
        assert_non_null(strstr(errtext, "loses channel"));
        assert_non_null(strstr(errtext, "--log-a"));
    }
    /* B = 1e-30 is faithful here: no value is 0, so ln(R/A + B) stays finite */
    const char *accepted[][2] = {{"1e-3", "1"}, {"1e6", "1"}, {"1", "1e-6"}, {"100", "1e-30"}};
    for (size_t i = 0; i < sizeof accepted / sizeof accepted[0]; i++) {
        const char *args[] = {"--method", "svd", "-T", "3", "--log-a", accepted[i][0], "--log-b",
                              accepted[i][1], NULL};
        assert_int_equal(run_factor(in, out, errtext, sizeof errtext, args), 0);
        double rel = ds_compare(&d, out, NULL);
        print_message("  A=%s B=%s: relative RMSE %.4g\n", accepted[i][0], accepted[i][1], rel);
        assert_true(rel < 0.5);
    }
    free(in);
    free(d.v);
}

static void zero_and_constant_rows(void **state)
{
    ds_spec d = ds_chess(8, 8, 5, 0);
    for (int c = 0; c < 3; c++)
        for (int64_t r = 0; r < 64; r++)
            for (int j = 0; j < 25; j++) {
                if (r % 4 == 0)
                    *ds_at(&d, c, r, j) = 0.0f;
                else if (r % 4 == 1)
                    *ds_at(&d, c, r, j) = 0.01f;
            }
    char *in = ds_write(&d);
    char errtext[8192], out[1024];
    snprintf(out, sizeof out, "%s", op_test_tmp_path("zc.opm"));
    const char *args[] = {"--method", "svd", "-T", "4", NULL};
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, args), 0);
    double rel = ds_compare(&d, out, NULL);
    print_message("  zero and constant rows: relative RMSE %.3g\n", rel);
    assert_true(rel < 0.02);
    op_material *m;
    op_error err = {0};
    OP_ASSERT_OK(op_material_open(out, &m, &err), err);
    for (int j = 0; j < 25; j++)
        assert_true(op_material_eval(m, 1, 4, 0, j % 5 - 2, j / 5 - 2) == 0.0f); /* row 4 */
    op_material_close(m);
    free(in);
    free(d.v);
}

static void negative_noise(void **state)
{
    ds_spec clean = ds_chess(8, 8, 5, 0), d = ds_chess(8, 8, 5, 0);
    uint64_t rng = 3;
    int negatives = 0;
    for (size_t i = 0; i < (size_t)3 * 64 * 25; i++) {
        d.v[i] += (float)(2e-3 * normal(&rng));
        negatives += d.v[i] < 0;
    }
    assert_true(negatives > 0);
    char *in = ds_write(&d);
    char errtext[8192], out[1024], report[1024];
    snprintf(out, sizeof out, "%s", op_test_tmp_path("neg.opm"));
    snprintf(report, sizeof report, "%s", op_test_tmp_path("neg.json"));
    const char *args[] = {"--method", "svd", "-T", "5", "--report", report, NULL};
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, args), 0);
    /* Compared with the signal under the noise: the truncation filters the noise. */
    double se = 0, sr = 0;
    for (size_t i = 0; i < (size_t)3 * 64 * 25; i++) {
        se += (double)(d.v[i] - clean.v[i]) * (d.v[i] - clean.v[i]);
        sr += (double)clean.v[i] * clean.v[i];
    }
    double rel = ds_compare(&clean, out, NULL), noise = sqrt(se / sr);
    print_message("  negative noise (%d values): relative RMSE to the clean signal %.3g (the "
                  "noisy data's %.3g)\n", negatives, rel, noise);
    assert_true(rel < noise);
    char expect[64];
    snprintf(expect, sizeof expect, "\"negative_values\": %d,", negatives);
    check_file_contains(report, expect);
    const char *raw[] = {"--method", "raw", NULL};
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, raw), 0);
    assert_true(ds_compare(&d, out, NULL) < 0.01); /* only the negatives were clamped */
    free(in);
    free(d.v);
    free(clean.v);
}

static void huge_dynamic_range(void **state)
{
    /* Rows of one shape scaled from 1e-12 to 1e3: shifting and normalizing makes them one
     * rank-1 matrix, so every row, however dim, is reproduced to float precision. */
    ds_spec d = ds_new(8, 8, 5, 1);
    for (int64_t r = 0; r < 64; r++) {
        double scale = pow(10.0, -12.0 + 15.0 * (double)r / 63.0);
        for (int j = 0; j < 25; j++)
            *ds_at(&d, 0, r, j) = (float)(scale * ds_profile(&d, j, 1.5));
    }
    char *in = ds_write(&d);
    char errtext[8192], out[1024];
    snprintf(out, sizeof out, "%s", op_test_tmp_path("dyn.opm"));
    const char *args[] = {"--method", "svd", "-T", "1", NULL};
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, args), 0);
    op_material *m;
    op_error err = {0};
    OP_ASSERT_OK(op_material_open(out, &m, &err), err);
    float row[25];
    for (int64_t r = 0; r < 64; r++) {
        op_material_eval_row(m, 0, (int)(r % 8), (int)(r / 8), row);
        for (int j = 0; j < 25; j++) {
            double ref = *ds_at(&d, 0, r, j);
            if (fabs(row[j] - ref) > 1e-4 * ref + 1e-30)
                fail_msg("row %lld column %d: %g for %g", (long long)r, j, (double)row[j], ref);
        }
    }
    op_material_close(m);
    free(in);
    free(d.v);
}

static void nan_and_inf(void **state)
{
    ds_spec d = ds_chess(8, 8, 5, 0);
    *ds_at(&d, 1, 5, 7) = NAN;
    *ds_at(&d, 2, 9, 3) = INFINITY;
    char *in = ds_write(&d);
    char errtext[8192], out[1024], report[1024];
    snprintf(out, sizeof out, "%s", op_test_tmp_path("nan.opm"));
    snprintf(report, sizeof report, "%s", op_test_tmp_path("nan.json"));
    const char *args[] = {"--method", "svd", "-T", "3", "--report", report, NULL};
    const char *san[] = {"--method", "svd", "-T", "3", "--report", report, "--sanitize", NULL};
    check_nonfinite_handled(&d, in, out, report, args, san);
    /* Infinity alone is named as such. */
    *ds_at(&d, 1, 5, 7) = 0.0f;
    free(in);
    in = ds_write(&d);
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, args), 2);
    assert_non_null(strstr(errtext, "RD.B"));
    assert_non_null(strstr(errtext, "row 9, column 3"));
    assert_non_null(strstr(errtext, "infinite"));
    free(in);
    free(d.v);
}

static void rank_deficient_and_t_above_rank(void **state)
{
    /* Rank 2 in every channel. A large A makes ln(R/A + B) linear to ~1e-8, so the log
     * transform keeps the rank and T = 5 > 2 must reproduce the data. */
    ds_spec d = ds_new(10, 10, 5, 3);
    for (int c = 0; c < 3; c++)
        for (int64_t r = 0; r < 100; r++)
            for (int j = 0; j < 25; j++)
                *ds_at(&d, c, r, j) = (float)((1 + r % 7) * ds_profile(&d, j, 1.0 + c * 0.2) +
                                              (1 + r % 3) * 0.3 * ds_profile(&d, j, 2.5));
    char *in = ds_write(&d);
    char errtext[8192], out[1024];
    snprintf(out, sizeof out, "%s", op_test_tmp_path("rank.opm"));
    const char *args[] = {"--method", "svd", "-T", "5", "--no-shift", "--log-a", "1e6", NULL};
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, args), 0);
    double rel = ds_compare(&d, out, NULL);
    print_message("  rank 2, T=5: relative RMSE %.3g\n", rel);
    assert_true(rel < 1e-4);
    /* T above min(rows, columns) = 25 is lowered to 25, with a warning; exact. */
    const char *big[] = {"--method", "svd", "-T", "40", "--no-shift", NULL};
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, big), 0);
    assert_non_null(strstr(errtext, "-T 40 exceeds"));
    rel = ds_compare(&d, out, NULL);
    print_message("  T=40 > 25 columns: relative RMSE %.3g\n", rel);
    assert_true(rel < 1e-5);
    free(in);
    free(d.v);
}

static void kernel_one_and_single_pixel(void **state)
{
    char errtext[8192], out[1024];
    snprintf(out, sizeof out, "%s", op_test_tmp_path("k1.opm"));
    const char *args[] = {"--method", "svd", "-T", "10", NULL};
    /* K = 1: one column, so each shifted, normalized row is 1 and the result exact. */
    ds_spec d = ds_new(6, 5, 1, 3);
    for (size_t i = 0; i < (size_t)3 * 30; i++)
        d.v[i] = (float)(0.01 * (1 + i % 11));
    char *in = ds_write(&d);
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, args), 0);
    assert_true(ds_compare(&d, out, NULL) < 1e-6);
    check_eval_paths(out);
    free(in);
    free(d.v);
    /* W = H = 1: one row. */
    d = ds_new(1, 1, 9, 3);
    for (int c = 0; c < 3; c++)
        for (int j = 0; j < 81; j++)
            *ds_at(&d, c, 0, j) = (float)(0.1 * (c + 1) * ds_profile(&d, j, 2.0));
    in = ds_write(&d);
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, args), 0);
    assert_true(ds_compare(&d, out, NULL) < 1e-6);
    check_eval_paths(out);
    const char *tk[] = {"--method", "tucker", "-T", "3", "-P", "4", NULL};
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, tk), 0);
    assert_true(ds_compare(&d, out, NULL) < 1e-3);
    free(in);
    free(d.v);
}

static void single_and_double_precision(void **state)
{
    /* 576 x 81, large enough for the randomized path, with kernel widths varying smoothly so
     * that the rank-4 truncation error dominates float rounding. */
    ds_spec d = ds_new(24, 24, 9, 3);
    for (int c = 0; c < 3; c++)
        for (int64_t r = 0; r < 576; r++)
            for (int j = 0; j < 81; j++)
                *ds_at(&d, c, r, j) = (float)(0.05 * ds_profile(&d, j, 0.7 + (double)(r % 24) / 8.0 +
                                                                      0.3 * sin((double)r / 24.0 + c)));
    char *in = ds_write(&d);
    char errtext[8192], out[1024];
    snprintf(out, sizeof out, "%s", op_test_tmp_path("prec.opm"));
    double rel[3];
    const char *modes[3][2] = {{"--precision", "single"}, {"--precision", "double"},
                               {"--exact-svd", NULL}};
    for (int i = 0; i < 3; i++) {
        const char *args[] = {"--method", "svd", "-T", "4", modes[i][0], modes[i][1], NULL};
        assert_int_equal(run_factor(in, out, errtext, sizeof errtext, args), 0);
        rel[i] = ds_compare(&d, out, NULL);
    }
    print_message("  relative RMSE single %.6g, double %.6g, exact %.6g\n", rel[0], rel[1],
                  rel[2]);
    assert_true(rel[2] > 1e-4); /* the truncation matters */
    assert_true(fabs(rel[0] - rel[2]) <= 0.01 * rel[2]);
    assert_true(fabs(rel[1] - rel[2]) <= 0.01 * rel[2]);
    free(in);
    free(d.v);
}

/* On a small dataset: the raw method reproduces
 * the dataset exactly; the svd method's error does not grow with T (beyond float noise) while
 * its file grows; and each channel's stored factors are within 1 % of the best rank-T
 * approximation (Eckart-Young) of the matrix the method factors, built here independently:
 * every row circularly shifted to start at its maximum, divided by it, then ln(v / 100 + 1). */
static void method_errors_on_a_dataset(void **state)
{
    ds_spec d = ds_chess(24, 20, 7, 0.1);
    int rows = d.w * d.h, cols = d.k * d.k;
    char *in = ds_write(&d);
    char out[1024], errtext[8192];
    snprintf(out, sizeof out, "%s", op_test_tmp_path("quick.opm"));
    const char *raw[] = {"--method", "raw", NULL};
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, raw), 0);
    double max_abs = -1, rel = ds_compare(&d, out, &max_abs);
    assert_true(rel == 0.0 && max_abs == 0.0);
    float *mat = malloc((size_t)rows * cols * sizeof *mat);
    double prev = INFINITY;
    uint64_t prev_size = 0;
    for (int T = 1; T <= 8; T++) {
        char t[8];
        snprintf(t, sizeof t, "%d", T);
        const char *args[] = {"--method", "svd", "-T", t, NULL};
        assert_int_equal(run_factor(in, out, errtext, sizeof errtext, args), 0);
        rel = ds_compare(&d, out, NULL);
        op_material *m = open_valid(out);
        uint64_t size = op_material_file_size(m);
        print_message("  svd T=%d: relative RMSE %.6g, %llu bytes\n", T, rel,
                      (unsigned long long)size);
        assert_true(rel <= prev * 1.0001);
        assert_true(size > prev_size);
        prev = rel;
        prev_size = size;
        for (int c = 0; c < 3; c++) {
            for (int r = 0; r < rows; r++) {
                const float *src = ds_at(&d, c, r, 0);
                int top = 0;
                for (int j = 1; j < cols; j++)
                    top = src[j] > src[top] ? j : top;
                for (int j = 0; j < cols; j++)
                    mat[(size_t)r * cols + j] =
                        (float)log((double)src[(j + top) % cols] / src[top] / 100.0 + 1.0);
            }
            char tu[8], tv[8];
            snprintf(tu, sizeof tu, "U.%c", "RGB"[c]);
            snprintf(tv, sizeof tv, "V.%c", "RGB"[c]);
            const float *u = op_material_section(m, tu, NULL), *v = op_material_section(m, tv, NULL);
            assert_non_null(u);
            assert_non_null(v);
            double got = residual(mat, rows, cols, T, u, v), best = optimal_error(mat, rows, cols, T);
            double norm = optimal_error(mat, rows, cols, 0);
            if (c == 0)
                print_message("    channel R: log-domain error %.6g, optimum %.6g (ratio %.5f)\n",
                              got, best, got / best);
            /* plus 1e-6 of ||M||: float32 rounding, which is all that is left at T = 7 and 8 */
            assert_true(got <= 1.01 * best + 1e-6 * norm);
        }
        op_material_close(m);
    }
    free(mat);
    free(in);
    free(d.v);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(eckart_young_kernel_rows),
        cmocka_unit_test(eckart_young_flat_spectrum),
        cmocka_unit_test(rsvd_deterministic_and_exact_when_small),
        cmocka_unit_test(svd_end_to_end),
        cmocka_unit_test(method_errors_on_a_dataset),
        cmocka_unit_test(same_result_for_any_thread_count),
        cmocka_unit_test(streamed_rsvd_matches),
        cmocka_unit_test(streamed_factor_matches),
        cmocka_unit_test(bad_arguments),
        cmocka_unit_test(log_transform_extremes),
        cmocka_unit_test(zero_and_constant_rows),
        cmocka_unit_test(negative_noise),
        cmocka_unit_test(huge_dynamic_range),
        cmocka_unit_test(nan_and_inf),
        cmocka_unit_test(rank_deficient_and_t_above_rank),
        cmocka_unit_test(kernel_one_and_single_pixel),
        cmocka_unit_test(single_and_double_precision),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
