/* test_factor_nmf.c - the NMF baseline (Peers et al. 2006): the homogeneous approximation,
 * HALS on exactly non-negative low-rank data, the stopping rule, determinism, and the method
 * end to end through `opaline-factor factor --method nmf`. */
#include "factor_test_util.h"

#include "nmf.h"

static void homogeneous_profile(void **state)
{
    ds_spec d = ds_new(6, 5, 7, 1);
    uint64_t rng = 1;
    for (int64_t r = 0; r < 30; r++)
        for (int j = 0; j < 49; j++)
            *ds_at(&d, 0, r, j) = (float)((1 + r % 4) * ds_profile(&d, j, 1.0 + 0.05 * r) *
                                          (0.9 + 0.2 * ds_uniform(&rng)));
    float prof[49], scale[30];
    op_nmf_homogeneous(d.v, 30, 7, 1.0, prof, scale);
    double sum = 0;
    for (int j = 0; j < 49; j++) {
        sum += prof[j];
        assert_true(prof[j] >= 0);
        /* Radially symmetric: equal for equal dx^2 + dy^2 (the mirror and the transpose). */
        int dy = j / 7 - 3, dx = j % 7 - 3;
        assert_float_equal(prof[j], prof[(dx + 3) * 7 + (dy + 3)], 1e-7);
        assert_float_equal(prof[j], prof[(-dy + 3) * 7 + (-dx + 3)], 1e-7);
    }
    assert_float_equal(sum, 1.0, 1e-5);
    for (int64_t r = 0; r < 30; r++) {
        double s = 0;
        for (int j = 0; j < 49; j++)
            s += *ds_at(&d, 0, r, j);
        assert_float_equal(scale[r], s, 1e-5 * s);
    }
    free(d.v);
}

static void hals_on_exact_nonnegative_data(void **state)
{
    const int rows = 300, cols = 40, T = 3;
    float *q = malloc((size_t)rows * cols * sizeof *q);
    uint64_t rng = 9;
    double w0[300][3], h0[40][3];
    for (int i = 0; i < rows; i++)
        for (int t = 0; t < T; t++)
            w0[i][t] = ds_uniform(&rng) < 0.3 ? 0 : ds_uniform(&rng);
    for (int j = 0; j < cols; j++)
        for (int t = 0; t < T; t++)
            h0[j][t] = ds_uniform(&rng) < 0.3 ? 0 : ds_uniform(&rng);
    for (int i = 0; i < rows; i++)
        for (int j = 0; j < cols; j++)
            q[i * cols + j] = (float)(w0[i][0] * h0[j][0] + w0[i][1] * h0[j][1] +
                                      w0[i][2] * h0[j][2]);
    op_nmf_options opt = op_nmf_defaults();
    opt.rank = T;
    opt.max_iter = 500;
    opt.tol = 1e-7;
    float *w = malloc((size_t)rows * T * sizeof *w), *h = malloc((size_t)cols * T * sizeof *h);
    float *w2 = malloc((size_t)rows * T * sizeof *w2), *h2 = malloc((size_t)cols * T * sizeof *h2);
    op_nmf_stats st;
    op_error err = {0};
    OP_ASSERT_OK(op_nmf_hals(q, rows, cols, &opt, w, h, &st, NULL, &err), err);
    print_message("  rank 3: %d iterations, relative error %.3g (NNDSVD start %.3g)\n",
                  st.iterations, sqrt(st.objective / st.norm), sqrt(st.initial / st.norm));
    assert_true(st.objective <= st.initial);
    assert_true(sqrt(st.objective / st.norm) < 1e-2);
    for (int k = 0; k < rows * T; k++)
        assert_true(w[k] >= 0 && isfinite(w[k]));
    for (int k = 0; k < cols * T; k++)
        assert_true(h[k] >= 0 && isfinite(h[k]));
    /* Deterministic. */
    OP_ASSERT_OK(op_nmf_hals(q, rows, cols, &opt, w2, h2, &st, NULL, &err), err);
    assert_memory_equal(w, w2, (size_t)rows * T * sizeof *w);
    assert_memory_equal(h, h2, (size_t)cols * T * sizeof *h);
    /* The stopping rule: a loose tolerance stops early, max_iter caps. */
    op_nmf_stats loose;
    opt.tol = 1e-2;
    OP_ASSERT_OK(op_nmf_hals(q, rows, cols, &opt, w2, h2, &loose, NULL, &err), err);
    assert_true(loose.converged && loose.iterations <= st.iterations);
    opt.tol = 0;
    opt.max_iter = 3;
    OP_ASSERT_OK(op_nmf_hals(q, rows, cols, &opt, w2, h2, &loose, NULL, &err), err);
    assert_int_equal(loose.iterations, 3);
    assert_false(loose.converged);
    opt.rank = 41;
    assert_int_equal(op_nmf_hals(q, rows, cols, &opt, w2, h2, &loose, NULL, &err), OP_ERR_INPUT);
    free(q);
    free(w);
    free(h);
    free(w2);
    free(h2);
}

static void end_to_end(void **state)
{
    /* A homogeneous material (every row the same radial profile times its albedo) has a
     * constant remainder: rank 1 is exact. */
    ds_spec d = ds_new(10, 8, 7, 3);
    for (int c = 0; c < 3; c++)
        for (int64_t r = 0; r < 80; r++)
            for (int j = 0; j < 49; j++)
                *ds_at(&d, c, r, j) = (float)((0.01 + 0.001 * (r % 13)) * (c + 1) *
                                              ds_profile(&d, j, 1.2 + 0.3 * c));
    char *in = ds_write(&d);
    char out[1024], report[1024], png[1024], errtext[8192];
    snprintf(out, sizeof out, "%s", op_test_tmp_path("nmf.opm"));
    snprintf(report, sizeof report, "%s", op_test_tmp_path("nmf.json"));
    snprintf(png, sizeof png, "%s", op_test_tmp_path("nmf.png"));
    const char *a1[] = {"--method", "nmf", "-T", "1", "--report", report, "--albedo-png", png,
                        NULL};
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, a1), 0);
    double rel = ds_compare(&d, out, NULL);
    print_message("  homogeneous material, T=1: relative RMSE %.3g\n", rel);
    assert_true(rel < 1e-5);
    check_eval_paths(out);
    op_material *m = open_valid(out);
    assert_int_equal(op_material_get_info(m)->method, OP_METHOD_NMF);
    assert_int_equal(op_material_get_info(m)->shifted, 0);
    assert_non_null(op_material_section(m, "PROF.G", NULL));
    assert_non_null(op_material_section(m, "ALBEDO", NULL));
    op_material_close(m);
    check_file_contains(report, "\"method\": \"nmf\"");
    free(in);
    free(d.v);

    /* A two-material checkerboard: more terms fit better; every exponent works. */
    d = ds_new(12, 12, 7, 3);
    for (int c = 0; c < 3; c++)
        for (int64_t r = 0; r < 144; r++) {
            int x = (int)(r % 12), y = (int)(r / 12), cell = (x / 6 + y / 6) % 2;
            for (int j = 0; j < 49; j++)
                *ds_at(&d, c, r, j) = (float)((cell ? 0.05 : 0.02 * (c + 1)) *
                                              ds_profile(&d, j, cell ? 1.0 + 0.2 * c : 2.0));
        }
    in = ds_write(&d);
    double prev = INFINITY;
    for (int T = 1; T <= 4; T += 3) {
        char ts[8];
        snprintf(ts, sizeof ts, "%d", T);
        const char *a2[] = {"--method", "nmf", "-T", ts, NULL};
        assert_int_equal(run_factor(in, out, errtext, sizeof errtext, a2), 0);
        rel = ds_compare(&d, out, NULL);
        print_message("  checkerboard, T=%d: relative RMSE %.3g\n", T, rel);
        assert_true(rel < prev);
        prev = rel;
    }
    assert_true(prev < 0.05);
    const char *a3[] = {"--method", "nmf", "-T", "2", "--homog-exp", "0", "--iters", "50", NULL};
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, a3), 0);
    rel = ds_compare(&d, out, NULL);
    print_message("  checkerboard, T=2, exponent 0: relative RMSE %.3g\n", rel);
    assert_true(rel < 0.05);
    check_eval_paths(out);
    /* Bad arguments. */
    const char *bad[][8] = {{"--method", "nmf", "--homog-exp", "2", NULL},
                            {"--method", "svd", "--homog-exp", "0.5", NULL},
                            {"--method", "nmf", "--iters", "0", NULL},
                            {"--method", "nmf", "-C", "3", NULL}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        assert_int_equal(run_factor(in, out, errtext, sizeof errtext, bad[i]), 2);
    free(in);
    free(d.v);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(homogeneous_profile),
        cmocka_unit_test(hals_on_exact_nonnegative_data),
        cmocka_unit_test(end_to_end),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
