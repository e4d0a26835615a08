/* test_factor_kcta.c - K-clustered tensor approximation: with K_m = 1 it is CTA (hard
 * clustering, the optimal truncated SVD per cluster), the error never increases across
 * iterations, the result is the same for any thread count (sample stage or not), data made of
 * known cluster subspaces is recovered, empty clusters are refilled, and the method works end to
 * end through `opaline-factor factor --method kcta`. */
#include "factor_test_util.h"

#include "kcta.h"

#include <lapacke.h>

/* Rows of varied Gaussian kernels (side x side columns), like shifted real data, with noise. */
static float *kernel_rows(int rows, int side, double noise)
{
    int n = side * side;
    float *a = malloc((size_t)rows * n * sizeof *a);
    uint64_t rng = 5;
    for (int i = 0; i < rows; i++) {
        double w = 0.8 + 2.5 * ds_uniform(&rng), amp = 0.5 + ds_uniform(&rng);
        double cx = side / 2 + ds_uniform(&rng) - 0.5, cy = side / 2 + ds_uniform(&rng) - 0.5;
        for (int j = 0; j < n; j++) {
            double dx = j % side - cx, dy = j / side - cy;
            a[(size_t)i * n + j] = (float)(amp * exp(-(dx * dx + dy * dy) / (2 * w * w)) +
                                           noise * (ds_uniform(&rng) - 0.5));
        }
    }
    return a;
}

/* The optimal rank-T error ||X - X_T||_F^2 of the listed rows of a (full dgesdd). */
static double optimal_sq_error(const float *a, int n, const int64_t *rows, int m, int T)
{
    if (m == 0)
        return 0;
    double *d = malloc((size_t)m * n * sizeof *d), *s = malloc((size_t)n * sizeof *s);
    for (int q = 0; q < m; q++)
        for (int j = 0; j < n; j++)
            d[(size_t)q * n + j] = a[(size_t)rows[q] * n + j];
    int mn = m < n ? m : n;
    assert_int_equal(LAPACKE_dgesdd(LAPACK_ROW_MAJOR, 'N', m, n, d, n, s, NULL, m, NULL, n), 0);
    double e = 0;
    for (int i = T; i < mn; i++)
        e += s[i] * s[i];
    free(d);
    free(s);
    return e;
}

/* sum_i ||a_i - sum_k V_{idx[i][k]} coef[i][k]||^2 of the model on the rows x cols matrix a,
 * from the model's arrays as kcta.h documents them: the test's own measure, independent of
 * op_kcta_error and op_kcta_row of the module under test. */
static double model_sq_error(const float *a, const op_kcta_model *md)
{
    int n = md->cols, T = md->terms, km = md->km;
    double e = 0;
    for (int64_t i = 0; i < md->rows; i++)
        for (int j = 0; j < n; j++) {
            double v = 0;
            for (int k = 0; k < km; k++) {
                uint32_t c = md->idx[i * km + k];
                assert_true(c < (uint32_t)md->clusters);
                const float *basis = md->basis + (size_t)c * n * T;
                const float *coef = md->coef + ((size_t)i * km + k) * T;
                for (int t = 0; t < T; t++)
                    v += (double)basis[j * T + t] * coef[t];
            }
            double d = a[i * n + j] - v;
            e += d * d;
        }
    return e;
}

static void km1_is_cta(void **state)
{
    const int rows = 600, side = 7, n = 49, T = 3;
    float *a = kernel_rows(rows, side, 1e-3);
    op_kcta_options opt = op_kcta_defaults();
    opt.clusters = 4;
    opt.km = 1;
    opt.terms = T;
    opt.svd.exact = 1;
    op_kcta_model md;
    op_error err = {0};
    OP_ASSERT_OK(op_kcta_factor(a, rows, n, &opt, &md, NULL, &err), err);
    /* Every cluster's basis is orthonormal and optimal for its members, every row's
     * coefficients are its projection: the model's error is the sum of the clusters' optimal
     * truncation errors. */
    int64_t *members = malloc((size_t)rows * sizeof *members);
    double total = 0;
    for (int c = 0; c < 4; c++) {
        const float *v = md.basis + (size_t)c * n * T;
        for (int t = 0; t < T; t++)
            for (int u = 0; u < T; u++) {
                double d = 0;
                for (int j = 0; j < n; j++)
                    d += (double)v[j * T + t] * v[j * T + u];
                assert_true(fabs(d - (t == u)) < 1e-4);
            }
        int m = 0;
        for (int i = 0; i < rows; i++)
            if ((int)md.idx[i] == c) {
                members[m++] = i;
                for (int t = 0; t < T; t++) {
                    double p = 0;
                    for (int j = 0; j < n; j++)
                        p += (double)a[(size_t)i * n + j] * v[j * T + t];
                    assert_true(fabs(p - md.coef[(size_t)i * T + t]) < 1e-4 * (1 + fabs(p)));
                }
            }
        total += optimal_sq_error(a, n, members, m, T);
    }
    double got = model_sq_error(a, &md);
    /* the module's own measure agrees with the test's */
    assert_true(fabs(op_kcta_error(a, &md) - got) <= 1e-6 * got + 1e-12);
    print_message("  K_m = 1: error %.6g, sum of the clusters' optimal errors %.6g\n", got, total);
    assert_true(fabs(got - total) <= 1e-3 * total + 1e-9);
    /* Hard clustering beats one global subspace of the same rank. */
    int64_t *all = malloc((size_t)rows * sizeof *all);
    for (int i = 0; i < rows; i++)
        all[i] = i;
    double global = optimal_sq_error(a, n, all, rows, T);
    assert_true(got < global);
    op_kcta_free(&md);

    /* One cluster with K_m = 1 is the truncated SVD. */
    opt.clusters = 1;
    OP_ASSERT_OK(op_kcta_factor(a, rows, n, &opt, &md, NULL, &err), err);
    got = model_sq_error(a, &md);
    print_message("  C = 1: error %.6g, truncated SVD %.6g\n", got, global);
    assert_true(fabs(got - global) <= 1e-4 * global);
    op_kcta_free(&md);
    free(all);
    free(members);
    free(a);
}

static void error_never_increases(void **state)
{
    const int rows = 800, n = 49;
    float *a = kernel_rows(rows, 7, 2e-2);
    for (int km = 1; km <= 3; km++) {
        op_kcta_options opt = op_kcta_defaults();
        opt.clusters = 6;
        opt.km = km;
        opt.terms = 2;
        opt.max_iters = 15;
        opt.tol = 0;
        op_kcta_model md;
        op_error err = {0};
        OP_ASSERT_OK(op_kcta_factor(a, rows, n, &opt, &md, NULL, &err), err);
        print_message("  K_m = %d: %d iterations%s, error %.6g -> %.6g\n", km, md.iterations,
                      md.restored ? " (then one restored)" : "", md.history[0],
                      md.history[md.nhistory - 1]);
        assert_int_equal(md.nhistory, md.iterations + 1);
        for (int i = 1; i < md.nhistory; i++)
            assert_true(md.history[i] <= md.history[i - 1]);
        /* the reported history ends at the model's true error */
        assert_true(fabs(model_sq_error(a, &md) - md.history[md.nhistory - 1]) <=
                    1e-6 * md.history[0]);
        /* Every row mixes K_m distinct clusters. */
        for (int i = 0; i < rows; i++)
            for (int k = 0; k < km; k++) {
                assert_true(md.idx[i * km + k] < 6u);
                for (int k2 = 0; k2 < k; k2++)
                    assert_true(md.idx[i * km + k] != md.idx[i * km + k2]);
            }
        op_kcta_free(&md);
    }
    free(a);
}

/* The passes split the rows into stripes fixed by the sizes alone: 1 and 3 threads give the
 * same bytes, with and without the sample stage, for K_m = 1 and 2; the history is
 * non-increasing and ends at the model's true error in both stages' cases. */
static void same_for_any_thread_count(void **state)
{
    const int rows = 5000, n = 49;
    float *a = kernel_rows(rows, 7, 2e-2);
    for (int km = 1; km <= 2; km++)
        for (int sample = 0; sample <= 1; sample++) {
            op_kcta_options opt = op_kcta_defaults();
            opt.clusters = 6;
            opt.km = km;
            opt.terms = 2;
            opt.sample_rows = sample ? 1000 : 0; /* every 5th row first */
            op_kcta_model m1, m3;
            op_error err = {0};
            opt.threads = 1;
            OP_ASSERT_OK(op_kcta_factor(a, rows, n, &opt, &m1, NULL, &err), err);
            opt.threads = 3;
            OP_ASSERT_OK(op_kcta_factor(a, rows, n, &opt, &m3, NULL, &err), err);
            print_message("  K_m = %d, %s sample: %d iterations, error %.6g -> %.6g\n", km,
                          sample ? "with a" : "no", m1.iterations, m1.history[0],
                          m1.history[m1.nhistory - 1]);
            assert_int_equal(m1.nhistory, m3.nhistory);
            assert_memory_equal(m1.history, m3.history, (size_t)m1.nhistory * sizeof(double));
            assert_memory_equal(m1.basis, m3.basis, (size_t)6 * n * 2 * sizeof(float));
            assert_memory_equal(m1.idx, m3.idx, (size_t)rows * km * sizeof(uint32_t));
            assert_memory_equal(m1.coef, m3.coef, (size_t)rows * km * 2 * sizeof(float));
            for (int i = 1; i < m1.nhistory; i++)
                assert_true(m1.history[i] <= m1.history[i - 1]);
            assert_true(fabs(model_sq_error(a, &m1) - m1.history[m1.nhistory - 1]) <=
                        1e-6 * m1.history[0]);
            op_kcta_free(&m1);
            op_kcta_free(&m3);
        }
    free(a);
}

/* Rows that are non-negative mixtures of exactly two of four 2-D subspaces: cluster c's basis
 * vector t covers the columns j with j % 8 == 2c + t (disjoint, non-negative). Each row has a
 * primary cluster (coefficients in [1, 2]) and a secondary one (coefficients in [0.1, 0.4]),
 * so that hard clustering finds the primary clusters and only the mixing of a second cluster
 * per row reproduces the rest. */
static float *mixture_rows(int rows, int n, uint64_t seed)
{
    float *a = calloc((size_t)rows * n, sizeof *a);
    uint64_t rng = seed;
    for (int i = 0; i < rows; i++) {
        int c1 = (int)(ds_uniform(&rng) * 4), c2 = (c1 + 1 + (int)(ds_uniform(&rng) * 3)) % 4;
        double y[4] = {1 + ds_uniform(&rng), 1 + ds_uniform(&rng), 0.1 + 0.3 * ds_uniform(&rng),
                       0.1 + 0.3 * ds_uniform(&rng)};
        for (int j = 0; j < n; j++) {
            int c = (j % 8) / 2, t = j % 2;
            double v = 1.0 + 0.3 * (j % 3);
            a[(size_t)i * n + j] = (float)(c == c1 ? y[t] * v : c == c2 ? y[2 + t] * v : 0.0);
        }
    }
    return a;
}

static void recovers_known_subspaces(void **state)
{
    const int rows = 500, n = 36;
    float *a = mixture_rows(rows, n, 11);
    op_kcta_options opt = op_kcta_defaults();
    opt.clusters = 4;
    opt.km = 2;
    opt.terms = 2;
    opt.max_iters = 30;
    op_kcta_model md;
    op_error err = {0};
    OP_ASSERT_OK(op_kcta_factor(a, rows, n, &opt, &md, NULL, &err), err);
    double norm = 0;
    for (size_t i = 0; i < (size_t)rows * n; i++)
        norm += (double)a[i] * a[i];
    double rel = sqrt(model_sq_error(a, &md) / norm);
    /* Hard clustering (CTA) with the same clusters cannot do it. */
    op_kcta_model one;
    opt.km = 1;
    OP_ASSERT_OK(op_kcta_factor(a, rows, n, &opt, &one, NULL, &err), err);
    double rel1 = sqrt(model_sq_error(a, &one) / norm);
    print_message("  4 subspaces, K_m = 2: relative error %.3g after %d iterations (K_m = 1: "
                  "%.3g)\n", rel, md.iterations, rel1);
    assert_true(rel < 1e-3);
    assert_true(rel1 > 1e-2);
    op_kcta_free(&md);
    op_kcta_free(&one);
    free(a);
}

static void empty_clusters_are_split(void **state)
{
    /* Two distinct rows repeated: k-means can fill at most two of five clusters. */
    const int rows = 60, n = 9;
    float *a = malloc((size_t)rows * n * sizeof *a);
    for (int i = 0; i < rows; i++)
        for (int j = 0; j < n; j++)
            a[i * n + j] = (float)(i % 2 ? 1.0 + j : 9.0 - j) * (float)(1.0 + 0.01 * i);
    op_kcta_options opt = op_kcta_defaults();
    opt.clusters = 5;
    opt.km = 1;
    opt.terms = 1;
    op_kcta_model md;
    op_error err = {0};
    OP_ASSERT_OK(op_kcta_factor(a, rows, n, &opt, &md, NULL, &err), err);
    int used[5] = {0};
    for (int i = 0; i < rows; i++)
        used[md.idx[i]]++;
    print_message("  %d split(s); members per cluster %d %d %d %d %d\n", md.splits, used[0],
                  used[1], used[2], used[3], used[4]);
    assert_true(md.splits > 0);
    for (int c = 0; c < 5; c++)
        assert_true(used[c] > 0);
    assert_true(model_sq_error(a, &md) < 1e-6 * rows * n);
    op_kcta_free(&md);
    free(a);
}

static void end_to_end(void **state)
{
    ds_spec d = ds_chess(16, 12, 7, 0.1);
    char *in = ds_write(&d);
    char out[1024], report[1024], png[1024], errtext[8192];
    snprintf(out, sizeof out, "%s", op_test_tmp_path("kcta.opm"));
    snprintf(report, sizeof report, "%s", op_test_tmp_path("kcta.json"));
    snprintf(png, sizeof png, "%s", op_test_tmp_path("kcta.png"));
    const char *args[] = {"--method", "kcta", "-C", "4", "--km", "2", "-T", "2", "--iters", "8",
                          "--report", report, "--albedo-png", png, NULL};
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, args), 0);
    double rel = ds_compare(&d, out, NULL);
    print_message("  kcta C=4 K_m=2 T=2: relative RMSE %.3g\n", rel);
    assert_true(rel < 0.02);
    check_eval_paths(out);
    op_material *m = open_valid(out);
    const op_material_info *info = op_material_get_info(m);
    assert_int_equal(info->method, OP_METHOD_KCTA);
    assert_int_equal(info->terms, 2);
    assert_int_equal(info->clusters, 4);
    assert_int_equal(info->shifted, 1);
    uint64_t bytes = 0;
    const uint32_t *par = op_material_section(m, "KCTA", &bytes);
    assert_non_null(par);
    assert_int_equal(par[0], 2);
    assert_int_equal(par[1], 2);
    assert_non_null(op_material_section(m, "KIDX.G", &bytes));
    assert_int_equal(bytes, 16 * 12 * 2 * 2);
    assert_non_null(op_material_section(m, "ALBEDO", NULL));
    op_material_close(m);
    check_file_contains(report, "\"method\": \"kcta\"");
    check_image_size(png, 16, 12);

    /* K_m = 1 and unshifted. */
    const char *a2[] = {"--method", "kcta", "-C", "3", "--km", "1", "-T", "3", "--no-shift",
                        NULL};
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, a2), 0);
    rel = ds_compare(&d, out, NULL);
    print_message("  kcta C=3 K_m=1 T=3 unshifted: relative RMSE %.3g\n", rel);
    assert_true(rel < 0.05);
    check_eval_paths(out);
    free(in);
    free(d.v);

    /* Known subspaces through the whole pipeline (unshifted, so the subspaces survive). */
    ds_spec k = ds_new(25, 20, 7, 1);
    float *mix = mixture_rows(500, 49, 3);
    memcpy(k.v, mix, (size_t)500 * 49 * sizeof *mix);
    free(mix);
    in = ds_write(&k);
    const char *a3[] = {"--method", "kcta", "-C", "4", "--km", "2", "-T", "2", "--iters", "30",
                        "--no-shift", NULL};
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, a3), 0);
    rel = ds_compare(&k, out, NULL);
    print_message("  known subspaces end to end: relative RMSE %.3g\n", rel);
    assert_true(rel < 1e-3);
    free(in);
    free(k.v);
}

static void bad_arguments(void **state)
{
    ds_spec d = ds_chess(4, 4, 3, 0.1);
    char *in = ds_write(&d);
    char errtext[8192], out[1024];
    snprintf(out, sizeof out, "%s", op_test_tmp_path("bad.opm"));
    const char *cases[][10] = {
        {"--method", "kcta", "-C", "0", NULL},
        {"--method", "kcta", "-C", "2", "--km", "3", NULL},
        {"--method", "kcta", "--km", "1.5", NULL},
        {"--method", "svd", "-C", "4", NULL},
        {"--method", "tucker", "--iters", "4", NULL},
        {"--method", "kcta", "-C", "8", "--km", "8", "-T", "9", NULL}, /* K_m * T > 64 */
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        assert_int_equal(run_factor(in, out, errtext, sizeof errtext, cases[i]), 2);
    /* More clusters than rows: lowered, with a warning. */
    const char *many[] = {"--method", "kcta", "-C", "40", "--km", "1", "-T", "1", NULL};
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, many), 0);
    assert_non_null(strstr(errtext, "-C 40 exceeds"));
    assert_true(ds_compare(&d, out, NULL) < 0.05);
    free(in);
    free(d.v);
}

/* kcta counts the values in its own preprocessing pass (counts_values): a non-finite one is
 * still named (channel, row, column), nothing is written, and --sanitize replaces them. */
static void nan_and_inf(void **state)
{
    ds_spec d = ds_chess(8, 8, 5, 0);
    *ds_at(&d, 1, 5, 7) = NAN;
    *ds_at(&d, 2, 9, 3) = INFINITY;
    char *in = ds_write(&d);
    char out[1024], report[1024];
    snprintf(out, sizeof out, "%s", op_test_tmp_path("kcta-nan.opm"));
    snprintf(report, sizeof report, "%s", op_test_tmp_path("kcta-nan.json"));
    const char *args[] = {"--method", "kcta", "-C", "3", "--km", "1", "-T", "2", "--report",
                          report, NULL};
    const char *san[] = {"--method", "kcta", "-C", "3", "--km", "1", "-T", "2", "--report",
                         report, "--sanitize", NULL};
    check_nonfinite_handled(&d, in, out, report, args, san);
    free(in);
    free(d.v);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(km1_is_cta),
        cmocka_unit_test(error_never_increases),
        cmocka_unit_test(same_for_any_thread_count),
        cmocka_unit_test(recovers_known_subspaces),
        cmocka_unit_test(empty_clusters_are_split),
        cmocka_unit_test(end_to_end),
        cmocka_unit_test(bad_arguments),
        cmocka_unit_test(nan_and_inf),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
