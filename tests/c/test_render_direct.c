/* test_render_direct.c - Mitsuba's `direct` integrator and envmap importance sampling.
 *
 * A camera with a narrow field of view looks straight down at a large diffuse plane (albedo
 * 0.6), so every pixel estimates the same radiance and, at one sample per pixel, the image is a
 * set of independent samples of the estimator: its mean and variance are measured over pixels.
 * - direct: emitterSamples and bsdfSamples are honoured (each combination converges to the
 *   analytic value; more samples lower the variance; bsdfSamples alone under a constant sky is
 *   exact, a point light is found by emitter samples only), MIS between them, thread-count
 *   independence, and bad counts are rejected.
 * - envmap: sampling by luminance * sin(theta) converges to the exact irradiance integral (as
 *   cosine-weighted BSDF sampling does), with the path tracer's MIS too, and with a variance far
 *   below what uniform sphere sampling would give (computed exactly from the map). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "opaline_render.h"
#include "test_support.h"

#define RES 64
#define ALBEDO 0.6

/* Mean and variance of channel c over the pixels of img. */
static void image_stats(const op_image *img, int c, double *mean, double *var)
{
    size_t n = (size_t)img->width * img->height;
    double s = 0.0, s2 = 0.0;
    for (size_t i = 0; i < n; i++) {
        double v = img->pixels[4 * i + c];
        s += v;
        s2 += v * v;
    }
    *mean = s / n;
    *var = s2 / n - *mean * *mean;
    if (*var < 0.0)
        *var = 0.0;
}

/* Renders the plane under `extra` (emitters, more shapes) with the given integrator element at
 * spp samples per pixel on threads workers; returns the image (free with op_image_free). */
static op_image render_plane(const char *integrator, const char *extra, int spp, int threads)
{
    char text[4096];
    int n = snprintf(
        text, sizeof text,
        "<scene version=\"0.6.0\">%s"
        " <sensor type=\"perspective\"><float name=\"fov\" value=\"1\"/>"
        "  <transform name=\"toWorld\"><lookat origin=\"0,0,4\" target=\"0,0,0\" up=\"0,1,0\"/>"
        "  </transform><sampler type=\"independent\"/>"
        "  <film type=\"hdrfilm\"><integer name=\"width\" value=\"%d\"/>"
        "   <integer name=\"height\" value=\"%d\"/><rfilter type=\"box\"/></film></sensor>"
        " <shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"100\"/></transform>"
        "  <bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"%g\"/></bsdf></shape>"
        "%s</scene>",
        integrator, RES, RES, ALBEDO, extra);
    assert_true(n > 0 && n < (int)sizeof text);
    return op_test_render_image(op_test_write_temp("scene.xml", text), spp, threads, 0);
}

/* A direct integrator element with the given sample counts. */
static const char *direct_el(int es, int bs)
{
    static char buf[256];
    snprintf(buf, sizeof buf,
             "<integrator type=\"direct\"><integer name=\"emitterSamples\" value=\"%d\"/>"
             "<integer name=\"bsdfSamples\" value=\"%d\"/></integrator>",
             es, bs);
    return buf;
}

/* A disk light of radius 0.5 and radiance 5 at height 1 facing the plane, transparent from
 * behind (a mask of opacity 0) so that the camera above it sees the plane: radiance at the
 * plane's centre rho Le R^2 / (h^2 + R^2) = 0.6. */
static const char *disk_light =
    " <shape type=\"disk\"><transform name=\"toWorld\"><scale value=\"0.5\"/>"
    "  <rotate x=\"1\" angle=\"180\"/><translate z=\"1\"/></transform>"
    "  <emitter type=\"area\"><rgb name=\"radiance\" value=\"5\"/></emitter>"
    "  <bsdf type=\"mask\"><float name=\"opacity\" value=\"0\"/></bsdf></shape>";

static void test_direct_sample_counts(void **state)
{
    (void)state;
    /* the 96-gon's area is 0.07 % below the disk's */
    const double expect =
        ALBEDO * 5.0 * 0.25 / 1.25 * (96.0 / (2.0 * M_PI) * sin(2.0 * M_PI / 96.0));
    const int counts[][2] = {{1, 1}, {4, 0}, {0, 4}, {3, 2}, {4, 4}};
    double var[5];
    for (int i = 0; i < 5; i++) {
        op_image img = render_plane(direct_el(counts[i][0], counts[i][1]), disk_light, 1, 2);
        double mean;
        image_stats(&img, 0, &mean, &var[i]);
        double se = sqrt(var[i] / (RES * RES));
        print_message("direct es=%d bs=%d: mean %.5f (expected %.5f, se %.5f), variance %.5f\n",
                      counts[i][0], counts[i][1], mean, expect, se, var[i]);
        if (fabs(mean - expect) > 4.0 * se + 2e-3 * expect)
            fail_msg("direct es=%d bs=%d: mean %.5f, expected %.5f (se %.5f)", counts[i][0],
                     counts[i][1], mean, expect, se);
        op_image_free(&img);
    }
    /* four times both sample counts: a quarter of the variance (within noise) */
    if (!(var[4] < 0.4 * var[0] && var[4] > 0.15 * var[0]))
        fail_msg("variance with 4+4 samples %.5f vs 1+1 %.5f: expected about a quarter", var[4],
                 var[0]);
}

static void test_direct_constant_sky(void **state)
{
    (void)state;
    const char *sky = " <emitter type=\"constant\"><rgb name=\"radiance\" value=\"2\"/></emitter>";
    /* cosine-weighted BSDF samples of an unoccluded uniform sky are exact: rho * L everywhere */
    op_image img = render_plane(direct_el(0, 1), sky, 1, 2);
    double mean, var;
    image_stats(&img, 0, &mean, &var);
    op_image_free(&img);
    if (fabs(mean - ALBEDO * 2.0) > 1e-4 || var > 1e-8)
        fail_msg("bsdfSamples only under a constant sky: mean %.6f variance %.3g, expected %.6f "
                 "exactly",
                 mean, var, ALBEDO * 2.0);
    /* uniform light samples: unbiased but noisy; with a BSDF sample as well the constant sky is
     * left to BSDF sampling (integrator.c), exact again */
    double v_light, v_mis;
    img = render_plane(direct_el(1, 0), sky, 1, 2);
    image_stats(&img, 0, &mean, &v_light);
    op_image_free(&img);
    assert_true(fabs(mean - 1.2) < 4.0 * sqrt(v_light / (RES * RES)));
    img = render_plane(direct_el(1, 1), sky, 1, 2);
    image_stats(&img, 0, &mean, &v_mis);
    op_image_free(&img);
    print_message("constant sky: variance light-only %.5f, MIS %.5f\n", v_light, v_mis);
    assert_true(fabs(mean - 1.2) < 1e-4 + 4.0 * sqrt(v_mis / (RES * RES)));
    assert_true(v_mis < 1e-8 && v_light > 0.1);
}

static void test_direct_point_light(void **state)
{
    (void)state;
    /* a point light at height 2: only emitter samples can find it */
    const char *point =
        " <emitter type=\"point\"><point name=\"position\" x=\"0\" y=\"0\" z=\"2\"/>"
        "  <rgb name=\"intensity\" value=\"4\"/></emitter>";
    op_image img = render_plane(direct_el(2, 0), point, 1, 2);
    double mean, var;
    image_stats(&img, 0, &mean, &var);
    op_image_free(&img);
    double expect = ALBEDO / M_PI * 4.0 / 4.0;
    if (fabs(mean / expect - 1.0) > 1e-3)
        fail_msg("point light, emitter samples: %.6f, expected %.6f", mean, expect);
    img = render_plane(direct_el(0, 3), point, 1, 2);
    image_stats(&img, 0, &mean, &var);
    op_image_free(&img);
    if (mean != 0.0)
        fail_msg("point light seen by BSDF samples only: %.6f, expected 0", mean);
}

static void test_direct_threads_and_errors(void **state)
{
    (void)state;
    const char *extra =
        " <emitter type=\"constant\"><rgb name=\"radiance\" value=\"0.5\"/></emitter>"
        " <shape type=\"sphere\"><point name=\"center\" x=\"0\" y=\"0\" z=\"0.2\"/>"
        "  <float name=\"radius\" value=\"0.01\"/></shape>";
    char el[256];
    snprintf(el, sizeof el, "%s", direct_el(2, 3));
    op_image a = render_plane(el, extra, 2, 1), b = render_plane(el, extra, 2, 3);
    assert_memory_equal(a.pixels, b.pixels, sizeof(float) * 4 * RES * RES);
    op_image_free(&a);
    op_image_free(&b);

    const char *bad = "<scene version=\"0.6.0\"><integrator type=\"direct\">"
                      "<integer name=\"emitterSamples\" value=\"-1\"/></integrator></scene>";
    op_scene *sc = NULL;
    op_error err;
    op_status st = op_scene_load(op_test_write_temp("bad.xml", bad), NULL, 0, &sc, &err);
    assert_int_equal(st, OP_ERR_INPUT);
    assert_non_null(strstr(err.message, "emitterSamples"));
    assert_null(sc);
}

/* The test envmap: 64 x 32, a dim sky of 0.2 and a 2 x 2 pixel "sun" of (300, 250, 200) about
 * 50 degrees from the zenith. */
#define EW 64
#define EH 32
static float env_value(int x, int y, int c)
{
    static const float sun[3] = {300.0f, 250.0f, 200.0f};
    if (y >= 8 && y < 10 && x >= 10 && x < 12)
        return sun[c];
    return 0.2f + 0.05f * (float)c;
}

/* Writes the envmap and returns the <emitter> element naming it, rotated by toWorld. */
static const char *write_envmap(void)
{
    op_image env;
    op_error err;
    OP_ASSERT_OK(op_image_alloc(&env, EW, EH, 3, &err), err);
    for (int y = 0; y < EH; y++)
        for (int x = 0; x < EW; x++)
            for (int c = 0; c < 3; c++)
                env.pixels[3 * (y * EW + x) + c] = env_value(x, y, c);
    const char *path = op_test_tmp_path("sky.exr");
    OP_ASSERT_OK(op_image_write_exr(path, &env, 0, &err), err);
    op_image_free(&env);
    /* the map's +Y (up) becomes the world's +Z, the plane's normal */
    static char el[1400];
    snprintf(el, sizeof el,
             " <emitter type=\"envmap\"><string name=\"filename\" value=\"%s\"/>"
             "  <float name=\"scale\" value=\"0.5\"/>"
             "  <transform name=\"toWorld\"><rotate y=\"1\" angle=\"30\"/>"
             "   <rotate x=\"1\" angle=\"90\"/></transform></emitter>",
             path);
    return el;
}

/* Exactly: the plane's radiance rho/pi * int Le cos over the upper hemisphere (rows 0..15 of
 * the map), and the second moment of the estimator that samples the sphere uniformly. */
static void envmap_exact(double *mean, double *second)
{
    double m = 0.0, m2 = 0.0;
    for (int y = 0; y < EH / 2; y++) {
        double t0 = M_PI * y / EH, t1 = M_PI * (y + 1) / EH;
        double cs = (sin(t1) * sin(t1) - sin(t0) * sin(t0)) / 2.0; /* int cos sin dtheta */
        double c2s = (pow(cos(t0), 3) - pow(cos(t1), 3)) / 3.0;    /* int cos^2 sin dtheta */
        for (int x = 0; x < EW; x++) {
            double le = 0.5 * env_value(x, y, 0), dphi = 2.0 * M_PI / EW;
            m += ALBEDO / M_PI * le * dphi * cs;
            /* X = rho/pi * Le cos * 4 pi with density 1/(4 pi) */
            m2 += pow(ALBEDO / M_PI * le * 4.0 * M_PI, 2) / (4.0 * M_PI) * dphi * c2s;
        }
    }
    *mean = m;
    *second = m2;
}

static void test_envmap_importance_sampling(void **state)
{
    (void)state;
    char env[1400];
    snprintf(env, sizeof env, "%s", write_envmap());
    double expect, second;
    envmap_exact(&expect, &second);
    double v_uniform = second - expect * expect;
    const char *ints[4];
    char d10[256], d01[256], d11[256];
    snprintf(d10, sizeof d10, "%s", direct_el(1, 0));
    snprintf(d01, sizeof d01, "%s", direct_el(0, 1));
    snprintf(d11, sizeof d11, "%s", direct_el(1, 1));
    ints[0] = d10; /* envmap samples only */
    ints[1] = d01; /* cosine-weighted BSDF samples only */
    ints[2] = d11; /* MIS of both */
    ints[3] = "<integrator type=\"path\"><integer name=\"maxDepth\" value=\"2\"/></integrator>";
    const char *names[4] = {"direct es=1 bs=0", "direct es=0 bs=1", "direct es=1 bs=1",
                            "path maxDepth=2"};
    double var[4];
    for (int i = 0; i < 4; i++) {
        op_image img = render_plane(ints[i], env, 1, 2);
        double mean;
        image_stats(&img, 0, &mean, &var[i]);
        op_image_free(&img);
        double se = sqrt(var[i] / (RES * RES));
        print_message("envmap, %s: mean %.5f (exact %.5f, se %.5f), variance %.4f (uniform "
                      "sphere sampling: %.4f)\n",
                      names[i], mean, expect, se, var[i], v_uniform);
        if (fabs(mean - expect) > 4.0 * se + 2e-3 * expect)
            fail_msg("envmap, %s: mean %.5f, exact %.5f (se %.5f)", names[i], mean, expect, se);
    }
    /* the sun holds most of the light: importance sampling removes most of the variance */
    if (!(var[0] < 0.05 * v_uniform))
        fail_msg("envmap sampling variance %.4f is not far below uniform sampling's %.4f", var[0],
                 v_uniform);
    if (!(var[2] < 0.05 * var[1]))
        fail_msg("MIS variance %.4f is not far below BSDF sampling's %.4f", var[2], var[1]);
}

int main(void)
{
    op_log_set_level(OP_LOG_WARN);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_direct_sample_counts),
        cmocka_unit_test(test_direct_constant_sky),
        cmocka_unit_test(test_direct_point_light),
        cmocka_unit_test(test_direct_threads_and_errors),
        cmocka_unit_test(test_envmap_importance_sampling),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
