/* test_sampler.c - the hash-scrambled Sobol sampler (renderer/lib/camera/sampler.h): values in
 * [0, 1), stratification of every dimension, the (0, k, 2)-net of the first two dimensions of a
 * key, prefixes of any length, determinism, decorrelation of keys and pixels, and a lower
 * integration error than independent numbers; Mitsuba's sampler types. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "camera/film.h"
#include "opaline_render.h"
#include "scene/render_scene.h"
#include "camera/sampler.h"
#include "test_support.h"

/* a few pixel seeds and keys the tests run over */
static const uint64_t pixels[] = {0, 1, 77, 123456789};
static const uint32_t keys[] = {OP_DIM_PIXEL, OP_DIM(0, OP_DIM_LIGHT, 0), OP_DIM(0, OP_DIM_BSDF, 0),
                                OP_DIM(3, OP_DIM_RR, 0), OP_DIM(1, OP_DIM_LIGHT, 5)};
#define NP (sizeof pixels / sizeof pixels[0])
#define NK (sizeof keys / sizeof keys[0])

static void point(uint64_t pixel, uint32_t key, uint32_t index, float u[4])
{
    op_path_sampler ps = op_path_sampler_begin(1, 42, pixel, index);
    op_path_sample(&ps, key, 4, u);
}

static void test_values_in_unit_interval(void **state)
{
    (void)state;
    for (size_t p = 0; p < NP; p++)
        for (size_t k = 0; k < NK; k++)
            for (uint32_t i = 0; i < 4096; i++) {
                float u[4];
                point(pixels[p], keys[k], i, u);
                for (int d = 0; d < 4; d++)
                    if (!(u[d] >= 0.0f && u[d] < 1.0f))
                        fail_msg("pixel %llu key %u index %u dim %d: %g", (unsigned long long)pixels[p],
                                 keys[k], i, d, u[d]);
            }
}

/* Each of the 2^m intervals [i / 2^m, (i+1) / 2^m) of each dimension holds exactly one of the
 * first 2^m points, for every m up to 12. */
static void test_one_dimensional_stratification(void **state)
{
    (void)state;
    enum { MAXM = 12, N = 1 << MAXM };
    static float u[N][4];
    static unsigned char hits[N];
    for (size_t p = 0; p < NP; p++)
        for (size_t k = 0; k < NK; k++) {
            for (uint32_t i = 0; i < N; i++)
                point(pixels[p], keys[k], i, u[i]);
            for (int m = 0; m <= MAXM; m++)
                for (int d = 0; d < 4; d++) {
                    int n = 1 << m;
                    memset(hits, 0, (size_t)n);
                    for (int i = 0; i < n; i++) {
                        int cell = (int)(u[i][d] * (float)n);
                        if (hits[cell]++)
                            fail_msg("pixel %llu key %u dim %d: two of the first %d points in "
                                     "interval %d", (unsigned long long)pixels[p], keys[k], d, n,
                                     cell);
                    }
                }
        }
}

/* The first two dimensions: for every m and every split a + b = m, each 2^-a x 2^-b box holds
 * exactly one of the first 2^m points (a (0, m, 2)-net). */
static void test_two_dimensional_net(void **state)
{
    (void)state;
    enum { MAXM = 10, N = 1 << MAXM };
    static float u[N][4];
    static unsigned char hits[N];
    for (size_t p = 0; p < NP; p++)
        for (size_t k = 0; k < NK; k++) {
            for (uint32_t i = 0; i < N; i++)
                point(pixels[p], keys[k], i, u[i]);
            for (int m = 0; m <= MAXM; m++)
                for (int a = 0; a <= m; a++) {
                    int n = 1 << m, nx = 1 << a, ny = 1 << (m - a);
                    memset(hits, 0, (size_t)n);
                    for (int i = 0; i < n; i++) {
                        int cell = (int)(u[i][0] * (float)nx) * ny + (int)(u[i][1] * (float)ny);
                        if (hits[cell]++)
                            fail_msg("pixel %llu key %u: the first %d points are not a net in "
                                     "%d x %d boxes", (unsigned long long)pixels[p], keys[k], n,
                                     nx, ny);
                    }
                }
        }
}

/* Any prefix, not only powers of two: of the first n points each 1/2^m interval with 2^m <= n
 * holds floor(n / 2^m) or that plus one. */
static void test_any_prefix_is_balanced(void **state)
{
    (void)state;
    int counts[64];
    for (int n = 1; n <= 200; n++)
        for (int m = 0; (1 << m) <= n && m <= 6; m++) {
            int cells = 1 << m;
            memset(counts, 0, sizeof counts);
            for (int i = 0; i < n; i++) {
                float u[4];
                point(5, OP_DIM(2, OP_DIM_BSDF, 0), (uint32_t)i, u);
                counts[(int)(u[0] * (float)cells)]++;
            }
            for (int c = 0; c < cells; c++)
                if (counts[c] < n / cells || counts[c] > n / cells + 1)
                    fail_msg("first %d points: %d in interval %d of %d", n, counts[c], c, cells);
        }
}

static void test_deterministic_and_decorrelated(void **state)
{
    (void)state;
    float a[4], b[4];
    point(9, OP_DIM(1, OP_DIM_BSDF, 0), 17, a);
    point(9, OP_DIM(1, OP_DIM_BSDF, 0), 17, b);
    assert_memory_equal(a, b, sizeof a);
    /* the same index under another key, pixel or seed gives other numbers */
    point(9, OP_DIM(2, OP_DIM_BSDF, 0), 17, b);
    assert_true(a[0] != b[0] && a[1] != b[1]);
    point(10, OP_DIM(1, OP_DIM_BSDF, 0), 17, b);
    assert_true(a[0] != b[0] && a[1] != b[1]);
    op_path_sampler ps = op_path_sampler_begin(1, 43, 9, 17);
    op_path_sample(&ps, OP_DIM(1, OP_DIM_BSDF, 0), 4, b);
    assert_true(a[0] != b[0] && a[1] != b[1]);
    /* sample j of m is index * m + j of the key's sequence */
    ps = op_path_sampler_begin(1, 42, 9, 5);
    op_path_sample_k(&ps, OP_DIM(1, OP_DIM_BSDF, 0), 2, 3, 4, b);
    assert_memory_equal(a, b, sizeof a);
    /* two keys of one pixel are uncorrelated: correlation of dimension 0 over 4096 samples */
    double sx = 0, sy = 0, sxy = 0, sxx = 0, syy = 0;
    int n = 4096;
    for (int i = 0; i < n; i++) {
        float x[4], y[4];
        point(3, OP_DIM(0, OP_DIM_LIGHT, 0), (uint32_t)i, x);
        point(3, OP_DIM(0, OP_DIM_BSDF, 0), (uint32_t)i, y);
        sx += x[0];
        sy += y[0];
        sxy += (double)x[0] * y[0];
        sxx += (double)x[0] * x[0];
        syy += (double)y[0] * y[0];
    }
    double cov = sxy / n - sx / n * sy / n;
    double r = cov / sqrt((sxx / n - sx / n * sx / n) * (syy / n - sy / n * sy / n));
    print_message("correlation of two keys: %.4f\n", r);
    assert_true(fabs(r) < 0.05);
    /* the independent kind draws the (seed, pixel, sample) stream in order */
    op_path_sampler ip = op_path_sampler_begin(0, 42, 9, 17);
    op_rng rng = op_rng_seed(42, 9, 17);
    op_path_sample(&ip, OP_DIM_PIXEL, 2, a);
    assert_true(a[0] == op_rng_float(&rng) && a[1] == op_rng_float(&rng));
    assert_true(op_path_random(&ip) == op_rng_float(&rng));
}

/* A discontinuous and a smooth integrand over [0,1)^2 estimated per pixel with n points: the
 * RMS error over pixels falls much faster than with independent numbers (Owen-scrambled nets:
 * about n^-0.75 for the disc's edge, n^-1.5 for a smooth function, against n^-0.5). */
static double integrand(int which, float x, float y)
{
    if (which == 0)
        return (x - 0.5f) * (x - 0.5f) + (y - 0.4f) * (y - 0.4f) < 0.15f ? 1.0 : 0.0;
    return exp(-(double)x) * sin(3.0 * (double)y);
}

static void test_integration_error(void **state)
{
    (void)state;
    double exact[2] = {M_PI * 0.15, (1.0 - exp(-1.0)) * (1.0 - cos(3.0)) / 3.0};
    for (int which = 0; which < 2; which++) {
        double err[2][2];
        int ns[2] = {16, 256};
        for (int ld = 0; ld < 2; ld++)
            for (int t = 0; t < 2; t++) {
                double se = 0.0;
                int npix = 200;
                for (int p = 0; p < npix; p++) {
                    double sum = 0.0;
                    for (int i = 0; i < ns[t]; i++) {
                        op_path_sampler ps = op_path_sampler_begin(ld, 1, (uint64_t)p, (uint32_t)i);
                        float u[2];
                        op_path_sample(&ps, OP_DIM(0, OP_DIM_BSDF, 0), 2, u);
                        sum += integrand(which, u[0], u[1]);
                    }
                    double e = sum / ns[t] - exact[which];
                    se += e * e;
                }
                err[ld][t] = sqrt(se / npix);
            }
        print_message("%s integrand: rms error independent %.5f %.5f, ld %.5f %.5f (16, 256 "
                      "points)\n", which ? "smooth" : "disc", err[0][0], err[0][1], err[1][0],
                      err[1][1]);
        /* independent: 16x the points, 1/4 the error; ld: far below it and falling faster */
        assert_true(err[0][0] / err[0][1] > 2.5 && err[0][0] / err[0][1] < 6.0);
        assert_true(err[1][0] < 0.7 * err[0][0]);
        assert_true(err[1][1] < 0.35 * err[0][1]);
        assert_true(err[1][0] / err[1][1] > (which ? 20.0 : 6.0));
    }
}

/* Mitsuba's sampler types: which kind each selects, its sampleCount rounding, and dimension /
 * scramble accepted. */
static void test_mitsuba_sampler_types(void **state)
{
    (void)state;
    static const struct {
        const char *type, *extra;
        int ld, spp;
    } cases[] = {
        {"independent", "", 0, 5},
        {"stratified", "<integer name=\"dimension\" value=\"6\"/>", 1, 9},
        {"ldsampler", "<integer name=\"dimension\" value=\"6\"/>", 1, 8},
        {"sobol", "<integer name=\"scramble\" value=\"3\"/>", 1, 5},
        {"halton", "<integer name=\"scramble\" value=\"-1\"/>", 1, 5},
        {"hammersley", "<integer name=\"scramble\" value=\"0\"/>", 1, 5},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char xml[1024];
        snprintf(xml, sizeof xml,
                 "<scene version=\"0.6.0\"><sensor type=\"perspective\"><sampler type=\"%s\">"
                 "<integer name=\"sampleCount\" value=\"5\"/>%s</sampler><film type=\"hdrfilm\">"
                 "<integer name=\"width\" value=\"4\"/><integer name=\"height\" value=\"4\"/>"
                 "</film></sensor><shape type=\"sphere\"/></scene>",
                 cases[i].type, cases[i].extra);
        const char *path = op_test_write_temp("sampler.xml", xml);
        op_scene *scene = NULL;
        op_error err;
        memset(&err, 0, sizeof err);
        if (op_scene_load(path, NULL, 0, &scene, &err) != OP_OK)
            fail_msg("%s: %s", cases[i].type, err.message);
        assert_int_equal(scene->sampler.type == OP_SAMPLER_LD, cases[i].ld);
        assert_int_equal(scene->sampler.spp, cases[i].spp);
        op_scene_free(scene);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_values_in_unit_interval),
        cmocka_unit_test(test_one_dimensional_stratification),
        cmocka_unit_test(test_two_dimensional_net),
        cmocka_unit_test(test_any_prefix_is_balanced),
        cmocka_unit_test(test_deterministic_and_decorrelated),
        cmocka_unit_test(test_integration_error),
        cmocka_unit_test(test_mitsuba_sampler_types),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
