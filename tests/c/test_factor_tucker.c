/* test_factor_tucker.c - the Tucker method: the polynomial colour fit stays accurate up to
 * degree 10 (and normal equations on raw powers would not), exact recovery of data that fits
 * the model, a regression check on chessboard-like data, and a higher degree never making the
 * stored fit worse (up to P = 20, on chessboards and on random data). */
#include "factor_test_util.h"

#include "tucker.h"

#include <lapacke.h>

/* Values clustered near 0 like a normalized kernel row: most are small, one is 1. */
static void clustered_points(double *x, int n)
{
    for (int i = 0; i < n; i++)
        x[i] = exp(-8.0 * (double)i / n);
}

/* The textbook mistake: normal equations V^T V c = V^T y on raw powers, by Cholesky. Returns
 * the largest error of the fit, or INFINITY when the factorization fails outright. */
static double normal_equations_error(const double *x, const double *y, int n, int degree)
{
    int np = degree + 1;
    double g[21 * 21] = {0}, b[21] = {0};
    for (int i = 0; i < n; i++) {
        double pi = 1;
        for (int p = 0; p < np; p++, pi *= x[i]) {
            double pj = 1;
            for (int q = 0; q < np; q++, pj *= x[i])
                g[p * np + q] += pi * pj;
            b[p] += pi * y[i];
        }
    }
    if (LAPACKE_dposv(LAPACK_ROW_MAJOR, 'U', np, 1, g, np, b, 1) != 0)
        return INFINITY;
    double worst = 0;
    for (int i = 0; i < n; i++) {
        double v = 0, pw = 1;
        for (int p = 0; p < np; p++, pw *= x[i])
            v += b[p] * pw;
        worst = fmax(worst, fabs(v - y[i]));
    }
    return worst;
}

static void polyfit_accurate_to_degree_ten(void **state)
{
    enum { N = 841 };
    double x[N], y[N], coef[11];
    clustered_points(x, N);
    double lo = x[N - 1], hi = x[0];
    for (int degree = 3; degree <= 10; degree++) {
        /* A function that is exactly a polynomial of this degree: any good fit is exact. */
        for (int i = 0; i < N; i++) {
            double t = x[i], v = 0;
            for (int p = degree; p >= 0; p--)
                v = v * t + (p % 2 ? -1.0 : 1.0) * (1.0 + p) / 4.0;
            y[i] = v;
        }
        op_error err = {0};
        double t[N];
        for (int i = 0; i < N; i++)
            t[i] = (x[i] - 0.5 * (lo + hi)) * 2.0 / (hi - lo);
        OP_ASSERT_OK(op_polyfit_chebyshev(t, y, N, 1, degree, coef, NULL, &err), err);
        double worst = 0;
        for (int i = 0; i < N; i++)
            worst = fmax(worst, fabs(op_chebyshev_eval(coef, degree, t[i]) - y[i]));
        double ne = normal_equations_error(x, y, N, degree);
        print_message("  degree %2d: Chebyshev + QR max error %.3g, normal equations on powers "
                      "%.3g\n", degree, worst, ne);
        assert_true(worst < 1e-9);
        if (degree == 10)
            assert_true(ne > 1e3 * worst); /* the difference the method avoids */
    }
}

static void polyfit_rank_deficient(void **state)
{
    /* Three distinct x for a degree-5 fit: the quadratic through them (degrees the points
     * cannot determine are not kept), finite. */
    double x[9] = {0, 0, 0, 0.5, 0.5, 0.5, 1, 1, 1}, y[9] = {1, 1, 1, 2, 2, 2, 5, 5, 5};
    double coef[6];
    op_error err = {0};
    double t[9];
    for (int i = 0; i < 9; i++)
        t[i] = (x[i] - 0.5) * 2.0;
    OP_ASSERT_OK(op_polyfit_chebyshev(t, y, 9, 1, 5, coef, NULL, &err), err);
    for (int i = 0; i < 9; i++)
        assert_float_equal(op_chebyshev_eval(coef, 5, t[i]), y[i], 1e-8);
}

static void exact_when_data_fits_the_model(void **state)
{
    /* mean = amp(row) * profile: rank 1 after normalization; channels are quadratics of the
     * normalized mean, so T = 1, P = 2 reproduce them. */
    ds_spec d = ds_new(9, 7, 5, 3);
    for (int64_t r = 0; r < 63; r++) {
        double amp = 0.01 + 0.002 * (double)(r % 5);
        for (int j = 0; j < 25; j++) {
            double p = ds_profile(&d, j, 1.2 + 0.0 * (double)r), m = amp * p;
            double red = m * (1.0 + 0.2 * p), green = m;
            *ds_at(&d, 0, r, j) = (float)red;
            *ds_at(&d, 1, r, j) = (float)green;
            *ds_at(&d, 2, r, j) = (float)(3.0 * m - red - green);
        }
    }
    char *in = ds_write(&d);
    char errtext[8192], out[1024];
    snprintf(out, sizeof out, "%s", op_test_tmp_path("tk.opm"));
    const char *args[] = {"--method", "tucker", "-T", "1", "-P", "2", NULL};
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, args), 0);
    double rel = ds_compare(&d, out, NULL);
    print_message("  model data, T=1 P=2: relative RMSE %.3g\n", rel);
    assert_true(rel < 1e-5);
    check_eval_paths(out);
    free(in);
    free(d.v);
}

/* Chessboard-like data: kernel width and per-channel brightness differ between the cells, and
 * the widths differ per channel, so the colour regression has real work to do. */
static ds_spec chess_data(int w, int h, int k)
{
    ds_spec d = ds_new(w, h, k, 3);
    for (int c = 0; c < 3; c++)
        for (int64_t r = 0; r < (int64_t)w * h; r++) {
            int x = (int)(r % w), y = (int)(r / w), cell = (4 * x / w + 4 * y / h) % 2;
            double s = cell ? 1.0 + 0.4 * c : 2.2 - 0.3 * c;
            double amp = cell ? 0.05 - 0.01 * c : 0.02 + 0.01 * c;
            s += 0.2 * sin(0.3 * x + 0.2 * y);
            for (int j = 0; j < k * k; j++)
                *ds_at(&d, c, r, j) = (float)(amp * ds_profile(&d, j, s));
        }
    return d;
}

static void regression_on_chessboard(void **state)
{
    ds_spec d = chess_data(20, 20, 9);
    char *in = ds_write(&d);
    char errtext[8192], out[1024], report[1024];
    snprintf(out, sizeof out, "%s", op_test_tmp_path("tkc.opm"));
    snprintf(report, sizeof report, "%s", op_test_tmp_path("tkc.json"));
    double rel[3];
    const char *degrees[3] = {"1", "4", "10"};
    for (int i = 0; i < 3; i++) {
        const char *args[] = {"--method", "tucker", "-T", "8", "-P", degrees[i], "--report",
                              report, NULL};
        assert_int_equal(run_factor(in, out, errtext, sizeof errtext, args), 0);
        rel[i] = ds_compare(&d, out, NULL);
        print_message("  chessboard T=8 P=%s: relative RMSE %.4g\n", degrees[i], rel[i]);
    }
    /* Regression bounds (measured: P=1 0.12, P=4 0.0068, P=10 0.00011), and a higher degree
     * never hurts: P = 10 stays accurate. */
    assert_true(rel[1] < 0.03);
    assert_true(rel[2] <= rel[1] * 1.05);
    assert_true(rel[1] < rel[0]);
    check_eval_paths(out);
    op_material *m = open_valid(out);
    const op_material_info *info = op_material_get_info(m);
    assert_int_equal(info->method, OP_METHOD_TUCKER);
    assert_int_equal(info->terms, 8);
    assert_int_equal(info->degree, 10);
    op_material_close(m);
    check_file_contains(report, "\"method\": \"tucker\"");
    check_file_contains(report, "\"degree\": 10,");
    /* Unshifted works too. */
    const char *ns[] = {"--method", "tucker", "-T", "8", "-P", "4", "--no-shift", NULL};
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, ns), 0);
    assert_true(ds_compare(&d, out, NULL) < 0.05);
    const char *bad[] = {"--method", "tucker", "-P", "21", NULL};
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, bad), 2);
    free(in);
    free(d.v);
}

/* Random kernels: nothing for the colour fit to find, so high degrees only risk overfitting
 * with huge coefficients. */
static ds_spec random_data(int w, int h, int k)
{
    ds_spec d = ds_new(w, h, k, 3);
    uint64_t seed = 7;
    for (size_t i = 0; i < (size_t)3 * w * h * k * k; i++)
        d.v[i] = (float)(0.02 * ds_uniform(&seed));
    return d;
}

static void error_never_grows_with_degree(void **state)
{
    static const int degrees[] = {0, 1, 2, 4, 7, 10, 15, 20};
    enum { ND = sizeof degrees / sizeof degrees[0] };
    struct { ds_spec d; const char *terms; } cases[2] = {{chess_data(24, 24, 9), "5"},
                                                         {random_data(8, 8, 5), "3"}};
    char errtext[8192], out[1024];
    snprintf(out, sizeof out, "%s", op_test_tmp_path("tkp.opm"));
    for (int k = 0; k < 2; k++) {
        char *in = ds_write(&cases[k].d);
        double prev = INFINITY;
        for (int i = 0; i < ND; i++) {
            char p[8];
            snprintf(p, sizeof p, "%d", degrees[i]);
            const char *args[] = {"--method", "tucker", "-T", cases[k].terms, "-P", p, NULL};
            assert_int_equal(run_factor(in, out, errtext, sizeof errtext, args), 0);
            double rel = ds_compare(&cases[k].d, out, NULL);
            print_message("  %s T=%s P=%2d: relative RMSE %.5g\n", k ? "random" : "chessboard",
                          cases[k].terms, degrees[i], rel);
            assert_true(rel <= prev * 1.01); /* within 1 % of the lower degree's, or better */
            prev = fmin(prev, rel);
        }
        if (k == 0)
            assert_true(prev < 0.015); /* measured 0.0102 from P = 7 on (0.097 at P = 7 before) */
        /* Stored as float32, the coefficients cost less than 1e-4 of the data, and stay small. */
        ds_spec *d = &cases[k].d;
        int64_t rows = (int64_t)d->w * d->h;
        int cols = d->k * d->k;
        const float *ch[3];
        for (int c = 0; c < 3; c++)
            ch[c] = d->v + (size_t)c * (size_t)rows * (size_t)cols;
        op_rsvd_options opt = op_rsvd_defaults();
        for (int i = 0; i < ND; i++) {
            op_tucker_result r;
            op_error err = {0};
            OP_ASSERT_OK(op_tucker_factor(ch, 3, rows, cols, atoi(cases[k].terms), degrees[i], 1,
                                          &opt, 2, &r, &err),
                         err);
            double storage = sqrt(r.fit.storage_sq / r.fit.data_sq);
            print_message("  %s P=%2d: storage error %.3g, largest coefficient %.3g, "
                          "condition %.3g\n",
                          k ? "random" : "chessboard", degrees[i], storage, r.fit.coef_max,
                          r.fit.cond_max);
            assert_true(storage < 1e-4);
            assert_true(r.fit.coef_max < 1e3);
            assert_true(r.fit.fits == (uint64_t)rows * 3);
            op_tucker_free(&r);
        }
        free(in);
    }
    for (int k = 0; k < 2; k++)
        free(cases[k].d.v);
}

/* Tucker counts the dataset's values in the SVD's first pass (not in a scan before it): a NaN
 * or infinity is still refused naming the first, nothing written, and --sanitize replaces them
 * and reports their count. */
static void nan_and_inf(void **state)
{
    (void)state;
    ds_spec d = ds_chess(8, 8, 5, 0);
    *ds_at(&d, 1, 5, 7) = NAN;
    *ds_at(&d, 2, 9, 3) = INFINITY;
    *ds_at(&d, 0, 2, 1) = -1e-3f; /* noise */
    char *in = ds_write(&d);
    char errtext[8192], out[1024], report[1024];
    snprintf(out, sizeof out, "%s", op_test_tmp_path("nan.opm"));
    snprintf(report, sizeof report, "%s", op_test_tmp_path("nan.json"));
    const char *args[] = {"--method", "tucker", "-T", "3", "-P", "2", "--report", report, NULL};
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, args), 2);
    assert_non_null(strstr(errtext, "RD.G"));
    assert_non_null(strstr(errtext, "row 5, column 7"));
    assert_non_null(strstr(errtext, "NaN"));
    assert_int_equal(access(out, F_OK), -1); /* nothing written */
    const char *san[] = {"--method", "tucker", "-T", "3", "-P", "2", "--report", report,
                         "--sanitize", NULL};
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, san), 0);
    assert_non_null(strstr(errtext, "replaced 2 non-finite"));
    check_file_contains(report, "\"nonfinite_replaced\": 2,");
    check_file_contains(report, "\"negative_values\": 1,");
    free(in);
    free(d.v);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(polyfit_accurate_to_degree_ten),
        cmocka_unit_test(polyfit_rank_deficient),
        cmocka_unit_test(exact_when_data_fits_the_model),
        cmocka_unit_test(regression_on_chessboard),
        cmocka_unit_test(error_never_grows_with_degree),
        cmocka_unit_test(nan_and_inf),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
