/* test_medium_tracking.c - heterogeneous media (renderer/lib/medium/medium.h) against
 * Beer-Lambert's law in closed form, T = exp(-integral of sigma_t along the ray):
 * - a density rising linearly along the ray (different slopes per channel), whose integral
 *   is a + b / 2 over the grid: ratio tracking's mean transmittance in every channel; delta
 *   tracking's probability of passing for each hero channel, its null-collision weights as an
 *   estimate of the other channels' transmittance, the distribution of its collision distances
 *   (chi-square against 1 - exp(-a s - b s^2 / 2)) and its weight at a collision (the albedo);
 * - a constant volume, bounded and unbounded, equals the homogeneous medium's exp(-sigma_t d);
 * - one hot voxel among zeros at the first voxel of a brick, in either layout: rays that graze
 *   it only through the neighbouring bricks (where trilinear lookups still blend it in) lose
 *   exp(-integral of its trilinear hat), integrated numerically, by both trackings.
 * Means are compared within 4.5 standard errors; the chi-square at 9 bins within its 1e-4
 * tail. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "medium/medium.h"
#include "test_support.h"

#define N 200000

/* A 5 x 2 x 2 grid (Mitsuba 0.6 vertices, bounded by the unit cube) of value a + b u at unit
 * x coordinate u, per channel, written as a .vol file and read back. */
static op_volume *ramp(const double a[3], const double b[3])
{
    unsigned char buf[48 + 5 * 2 * 2 * 3 * 4];
    memcpy(buf, "VOL\3", 4);
    int32_t hdr[5] = {1, 5, 2, 2, 3};
    float box[6] = {0, 0, 0, 1, 1, 1};
    memcpy(buf + 4, hdr, sizeof hdr);
    memcpy(buf + 24, box, sizeof box);
    float *v = (float *)(void *)(buf + 48);
    for (int i = 0; i < 20; i++)
        for (int c = 0; c < 3; c++)
            v[3 * i + c] = (float)(a[c] + b[c] * (i % 5) / 4.0);
    op_volume *vol;
    op_error err;
    OP_ASSERT_OK(op_volume_parse(buf, sizeof buf, "ramp.vol", &vol, &err), err);
    op_matrix4 id = op_matrix4_identity();
    assert_true(op_volume_place(vol, &id, OP_VOLUME_VERTICES, 1));
    return vol;
}

static op_pmedium hetero(op_volume *ext, op_v3 albedo, float scale)
{
    op_pmedium m;
    memset(&m, 0, sizeof m);
    m.extinction = ext;
    m.albedo = op_volume_constant(albedo);
    assert_non_null(m.albedo);
    m.scale = scale;
    m.majorant = scale * v3_max(op_volume_max(ext));
    return m;
}

static void expect_mean(const char *what, int c, double sum, double sum2, double n, double want)
{
    double mean = sum / n, se = sqrt(fmax(sum2 / n - mean * mean, 0.0) / (n - 1.0));
    double z = (mean - want) / fmax(se, 1e-12);
    printf("%s, channel %d: %.5f (exact %.5f), z = %.2f\n", what, c, mean, want, z);
    if (!(fabs(mean - want) <= 4.5 * se + 1e-6))
        fail_msg("%s, channel %d: %g, expected %g (z = %.1f)", what, c, mean, want, z);
}

static const double ra[3] = {0.5, 0.2, 1.0}, rb[3] = {2.0, 0.5, 3.0};
static const float rscale = 1.5f;

/* Optical depth of the ramp medium from the grid's start to unit coordinate s. */
static double ramp_tau(int c, double s)
{
    return rscale * (ra[c] * s + rb[c] * s * s / 2.0);
}

static void test_ratio_tracking_ramp(void **state)
{
    (void)state;
    op_pmedium m = hetero(ramp(ra, rb), v3s(0.5f), rscale);
    op_rng rng = op_rng_seed(1, 2, 3);
    double s[3] = {0}, s2[3] = {0};
    for (int i = 0; i < N; i++) {
        op_v3 T = op_pmedium_transmittance(&m, v3(-0.5f, 0.5f, 0.5f), v3(1, 0, 0), 3.0f, &rng);
        for (int c = 0; c < 3; c++) {
            s[c] += v3_get(T, c);
            s2[c] += v3_get(T, c) * v3_get(T, c);
        }
    }
    for (int c = 0; c < 3; c++)
        expect_mean("ratio tracking through the ramp", c, s[c], s2[c], N, exp(-ramp_tau(c, 1)));
    op_pmedium_free(&m);
}

static void test_delta_tracking_ramp(void **state)
{
    (void)state;
    op_pmedium m = hetero(ramp(ra, rb), v3(0.25f, 0.5f, 0.75f), rscale);
    op_rng rng = op_rng_seed(4, 5, 6);
    for (int hero = 0; hero < 3; hero++) {
        enum { BINS = 8 };
        double pass = 0.0, est[3] = {0}, est2[3] = {0}, counts[BINS + 1] = {0};
        for (int i = 0; i < N; i++) {
            float t;
            op_v3 f, pdf;
            float u = op_rng_float(&rng);
            int hit = op_pmedium_sample_distance(&m, hero, v3(-0.5f, 0.5f, 0.5f), v3(1, 0, 0), 3.0f,
                                                 u, &rng, &t, &f, &pdf);
            float ph = v3_get(pdf, hero);
            assert_true(ph > 0.0f);
            if (hit) {
                assert_true(t >= 0.5f && t < 1.5f);
                /* one-channel estimate at a collision: the albedo */
                assert_true(fabsf(v3_get(f, hero) / ph - (0.25f + 0.25f * (float)hero)) < 1e-5f);
                int bin = (int)((t - 0.5f) * BINS);
                counts[bin < BINS ? bin : BINS - 1] += 1.0;
                continue;
            }
            assert_true(t == 3.0f);
            counts[BINS] += 1.0;
            pass += 1.0;
            for (int c = 0; c < 3; c++) {
                double w = v3_get(f, c) / ph;
                est[c] += w;
                est2[c] += w * w;
            }
        }
        char what[96];
        snprintf(what, sizeof what, "delta tracking (hero %d): probability of passing", hero);
        expect_mean(what, hero, pass, pass, N, exp(-ramp_tau(hero, 1)));
        snprintf(what, sizeof what, "delta tracking (hero %d): null weights as transmittance",
                 hero);
        for (int c = 0; c < 3; c++)
            expect_mean(what, c, est[c], est2[c], N, exp(-ramp_tau(c, 1)));
        double chi2 = 0.0;
        for (int b = 0; b <= BINS; b++) {
            double p = b < BINS ? exp(-ramp_tau(hero, (double)b / BINS)) -
                                      exp(-ramp_tau(hero, (double)(b + 1) / BINS))
                                : exp(-ramp_tau(hero, 1));
            chi2 += (counts[b] - N * p) * (counts[b] - N * p) / (N * p);
        }
        printf("delta tracking (hero %d): collision distances, chi-square %.2f (8 dof)\n", hero,
               chi2);
        assert_true(chi2 < 31.8); /* the 1e-4 tail of chi-square with 8 degrees of freedom */
    }
    op_pmedium_free(&m);
}

static void test_constant_equals_homogeneous(void **state)
{
    (void)state;
    const op_v3 sigma = v3(1.2f, 0.7f, 0.3f);
    op_pmedium homo;
    memset(&homo, 0, sizeof homo);
    homo.sigma_t = sigma;
    op_rng rng = op_rng_seed(7, 8, 9);
    for (int bounded = 0; bounded < 2; bounded++) {
        op_volume *v = op_volume_constant(sigma);
        assert_non_null(v);
        op_matrix4 sc = op_matrix4_scale(0.25, 0.25, 0.25); /* a cube of side 4 at the origin */
        assert_true(op_volume_place(v, &sc, OP_VOLUME_CELLS, bounded));
        op_pmedium m = hetero(v, v3s(1.0f), 1.0f);
        /* from (1, 1, 1) along +x to distance 2.5: inside the cube throughout */
        op_v3 want = op_pmedium_transmittance(&homo, v3s(0.0f), v3(1, 0, 0), 2.5f, &rng);
        double s[3] = {0}, s2[3] = {0};
        for (int i = 0; i < N / 4; i++) {
            op_v3 T = op_pmedium_transmittance(&m, v3s(1.0f), v3(1, 0, 0), 2.5f, &rng);
            for (int c = 0; c < 3; c++) {
                s[c] += v3_get(T, c);
                s2[c] += v3_get(T, c) * v3_get(T, c);
            }
        }
        for (int c = 0; c < 3; c++) {
            assert_true(fabs(v3_get(want, c) - exp(-v3_get(sigma, c) * 2.5)) < 1e-6);
            expect_mean(bounded ? "bounded constant volume" : "constant volume", c, s[c], s2[c],
                        N / 4, v3_get(want, c));
        }
        /* the bounded cube ends at x = 4: beyond it nothing more is lost */
        if (bounded) {
            double far = 0.0, far2 = 0.0;
            for (int i = 0; i < N / 4; i++) {
                float z = op_pmedium_transmittance(&m, v3s(1.0f), v3(1, 0, 0), 50.0f, &rng).z;
                far += z;
                far2 += (double)z * z;
            }
            expect_mean("bounded constant volume to x = 51", 2, far, far2, N / 4, exp(-0.3 * 3.0));
        }
        op_pmedium_free(&m);
    }
}

enum { HOT_N = 20, HOT_I = 8 };
static const float hot_value = 200.0f;

/* A HOT_N^3 grid (bounded by the unit cube) of zeros but hot_value at voxel (HOT_I, HOT_I,
 * HOT_I); n voxels per axis span it in the layout. */
static op_volume *hot_voxel(op_volume_layout layout)
{
    size_t n = HOT_N * HOT_N * HOT_N, size = 48 + 4 * n;
    unsigned char *buf = calloc(1, size);
    assert_non_null(buf);
    memcpy(buf, "VOL\3", 4);
    int32_t hdr[5] = {1, HOT_N, HOT_N, HOT_N, 1};
    float box[6] = {0, 0, 0, 1, 1, 1};
    memcpy(buf + 4, hdr, sizeof hdr);
    memcpy(buf + 24, box, sizeof box);
    memcpy(buf + 48 + 4 * ((HOT_I * HOT_N + HOT_I) * HOT_N + HOT_I), &hot_value, 4);
    op_volume *vol;
    op_error err;
    OP_ASSERT_OK(op_volume_parse(buf, size, "hot.vol", &vol, &err), err);
    free(buf);
    op_matrix4 id = op_matrix4_identity();
    assert_true(op_volume_place(vol, &id, layout, 1));
    return vol;
}

/* The hot voxel's value at unit point q: hot_value times the trilinear hat of each axis. */
static double hot_density(op_volume_layout layout, const double q[3])
{
    double w = hot_value;
    for (int a = 0; a < 3; a++) {
        double g = layout == OP_VOLUME_CELLS ? q[a] * HOT_N - 0.5 : q[a] * (HOT_N - 1);
        w *= fmax(1.0 - fabs(g - HOT_I), 0.0);
    }
    return w;
}

static void test_hot_voxel_grazed(void **state)
{
    (void)state;
    /* rays from p0 to p1 (unit cube), each staying in the bricks beside the hot voxel's */
    static const double rays[][2][3] = {
        {{0.0, 0.39, 0.39}, {1.0, 0.39, 0.39}},  /* along x, beside it in y and z */
        {{0.0, 0.39, 0.85}, {0.85, 0.385, 0.0}}, /* oblique, crossing bricks in x and z */
        {{0.38, 0.2, 0.1}, {0.395, 0.8, 0.9}},   /* steep, crossing bricks in y and z */
    };
    op_rng rng = op_rng_seed(10, 11, 12);
    for (int l = 0; l < 2; l++) {
        op_volume_layout layout = l ? OP_VOLUME_VERTICES : OP_VOLUME_CELLS;
        op_pmedium m = hetero(hot_voxel(layout), v3s(0.5f), 1.0f);
        for (size_t r = 0; r < sizeof rays / sizeof rays[0]; r++) {
            const double *p0 = rays[r][0], *p1 = rays[r][1];
            double len =
                sqrt((p1[0] - p0[0]) * (p1[0] - p0[0]) + (p1[1] - p0[1]) * (p1[1] - p0[1]) +
                     (p1[2] - p0[2]) * (p1[2] - p0[2]));
            enum { STEPS = 20000 };
            double tau = 0.0;
            for (int i = 0; i < STEPS; i++) {
                double s = (i + 0.5) / STEPS, q[3];
                for (int a = 0; a < 3; a++)
                    q[a] = p0[a] + s * (p1[a] - p0[a]);
                tau += hot_density(layout, q);
            }
            tau *= len / STEPS;
            assert_true(tau > 0.1); /* the ray does meet the hot voxel's footprint */
            op_v3 org = v3((float)p0[0], (float)p0[1], (float)p0[2]);
            op_v3 dir = v3((float)((p1[0] - p0[0]) / len), (float)((p1[1] - p0[1]) / len),
                           (float)((p1[2] - p0[2]) / len));
            double s = 0.0, s2 = 0.0, pass = 0.0;
            for (int i = 0; i < N / 10; i++) {
                float T = op_pmedium_transmittance(&m, org, dir, (float)len, &rng).x;
                s += T;
                s2 += (double)T * T;
                float t;
                op_v3 f, pdf;
                float u = op_rng_float(&rng);
                pass += !op_pmedium_sample_distance(&m, i % 3, org, dir, (float)len, u, &rng, &t,
                                                    &f, &pdf);
            }
            char what[96];
            snprintf(what, sizeof what, "hot voxel (%s), ray %zu: ratio tracking",
                     l ? "vertices" : "cells", r);
            expect_mean(what, 0, s, s2, N / 10, exp(-tau));
            snprintf(what, sizeof what, "hot voxel (%s), ray %zu: delta tracking passes",
                     l ? "vertices" : "cells", r);
            expect_mean(what, 0, pass, pass, N / 10, exp(-tau));
        }
        op_pmedium_free(&m);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ratio_tracking_ramp),
        cmocka_unit_test(test_delta_tracking_ramp),
        cmocka_unit_test(test_constant_equals_homogeneous),
        cmocka_unit_test(test_hot_voxel_grazed),
    };
    return op_test_exit_status(cmocka_run_group_tests(tests, NULL, NULL));
}
