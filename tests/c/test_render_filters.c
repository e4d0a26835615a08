/* test_render_filters.c - reconstruction filters with negative lobes (Mitsuba's mitchell,
 * catmullrom and lanczos), applied by filter importance sampling with signed weights.
 * An orthographic sensor, one pixel per unit, looks at an emitting half-plane x < 0 of
 * radiance 1; a pixel centred at c then sees the normalized integral of the filter's profile
 * over the part of its footprint inside the half-plane: F(-c) = int_{-R}^{-c} f / int f. The
 * profiles are the published formulas (Mitchell and Netravali 1988, B = C = 1/3 and the
 * Catmull-Rom B = 0, C = 1/2; Lanczos sinc(x) sinc(x / 3)), integrated here by Simpson's rule,
 * and every column across the edge must agree within 4.5 standard errors; for Catmull-Rom
 * and Lanczos the overshoot beyond 1 and below 0 beside the edge, which only negative lobes
 * make, must show (Mitchell's is below the noise). Bad parameters are refused naming the file
 * and line. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "opaline_render.h"
#include "test_support.h"

enum { W = 16, H = 16, SPP = 8192 };

static double mitchell(double x, double b, double c)
{
    x = fabs(x);
    if (x < 1.0)
        return ((12 - 9 * b - 6 * c) * x * x * x + (-18 + 12 * b + 6 * c) * x * x + (6 - 2 * b)) /
               6.0;
    if (x < 2.0)
        return ((-b - 6 * c) * x * x * x + (6 * b + 30 * c) * x * x + (-12 * b - 48 * c) * x +
                (8 * b + 24 * c)) / 6.0;
    return 0.0;
}

static double sinc(double x)
{
    return fabs(x) < 1e-9 ? 1.0 : sin(M_PI * x) / (M_PI * x);
}

/* which: 0 mitchell, 1 catmullrom, 2 lanczos (3 lobes) */
static double profile(int which, double x)
{
    if (which == 2)
        return fabs(x) < 3.0 ? sinc(x) * sinc(x / 3.0) : 0.0;
    return mitchell(x, which == 0 ? 1.0 / 3.0 : 0.0, which == 0 ? 1.0 / 3.0 : 0.5);
}

/* int_a^b of the profile (of its magnitude when absolute) by composite Simpson with n (even)
 * intervals */
static double integral_of(int which, double a, double b, int absolute)
{
    if (b <= a)
        return 0.0;
    const int n = 4000;
    double h = (b - a) / n, s = 0.0;
    for (int i = 0; i <= n; i++) {
        double f = profile(which, a + i * h);
        s += (absolute ? fabs(f) : f) * (i == 0 || i == n ? 1.0 : i % 2 ? 4.0 : 2.0);
    }
    return s * h / 3.0;
}

static double integral(int which, double a, double b)
{
    return integral_of(which, a, b, 0);
}

static void check_edge(int which, const char *filter)
{
    double radius = which == 2 ? 3.0 : 2.0;
    char text[2048];
    snprintf(text, sizeof text,
             "<scene version=\"0.6.0\"><sensor type=\"orthographic\"><transform name=\"toWorld\">"
             " <scale x=\"%d\" y=\"%d\"/><lookat origin=\"0,0,5\" target=\"0,0,0\" up=\"0,1,0\"/>"
             " </transform><sampler type=\"independent\"/><film type=\"hdrfilm\">"
             " <integer name=\"width\" value=\"%d\"/><integer name=\"height\" value=\"%d\"/>"
             " <rfilter type=\"%s\"/></film></sensor>"
             "<shape type=\"rectangle\"><transform name=\"toWorld\"><scale x=\"50\" y=\"50\"/>"
             " <translate x=\"-50\"/></transform>"
             " <emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter></shape>"
             "</scene>",
             W / 2, W / 2, W, H, filter);
    op_image img = op_test_render_image(op_test_write_temp("scene.xml", text), SPP, 2, 7);
    double total = integral(which, -radius, radius);
    /* a sample's value is 0 or its weight, whose magnitude is about (int |f| / int f)^2 (x and
     * y): a conservative standard error of a column's mean */
    double ratio = integral_of(which, -radius, radius, 1) / total;
    double se = ratio * ratio / sqrt((double)SPP * H);
    int failures = 0;
    double before = 0.0, after = 0.0; /* the columns centred 1.5 before and after the edge */
    for (int x = 0; x < W; x++) {
        double c = x + 0.5 - W / 2.0; /* the column centre's world x */
        double expect = integral(which, -radius, fmin(-c, radius)) / total;
        double mean = 0.0;
        for (int y = 0; y < H; y++)
            mean += img.pixels[4 * ((size_t)y * W + x)] / H;
        if (c == -1.5)
            before = mean;
        if (c == 1.5)
            after = mean;
        if (fabs(mean - expect) > 4.5 * se) {
            print_message("%s: column %d (centre %.1f): %.5f, expected %.5f (+- %.5f)\n", filter,
                          x, c, mean, expect, 4.5 * se);
            failures++;
        }
    }
    op_image_free(&img);
    if (failures)
        fail_msg("%s: %d columns across the edge differ from the filter's integral", filter,
                 failures);
    /* negative lobes: the columns beside the edge overshoot, above 1 inside and below 0
     * outside (Catmull-Rom by 0.013 each, Lanczos by 0.0175) */
    if (which != 0 && !((before - 1.0) - after > 3.0 * sqrt(2.0) * se))
        fail_msg("%s: no overshoot across the edge (%.4f inside, %.4f outside)", filter, before,
                 after);
}

static void test_mitchell(void **state)
{
    (void)state;
    check_edge(0, "mitchell");
}

static void test_catmullrom(void **state)
{
    (void)state;
    check_edge(1, "catmullrom");
}

static void test_lanczos(void **state)
{
    (void)state;
    check_edge(2, "lanczos");
}

static void expect_refused(const char *rfilter, const char *words)
{
    char text[1024];
    snprintf(text, sizeof text,
             "<scene version=\"0.6.0\"><sensor type=\"perspective\"><film type=\"hdrfilm\">\n"
             "%s</film></sensor></scene>",
             rfilter);
    const char *path = op_test_write_temp("bad.xml", text);
    op_scene *scene = NULL;
    op_error err = {0};
    op_status st = op_scene_load(path, NULL, 0, &scene, &err);
    op_scene_free(scene);
    if (st == OP_OK)
        fail_msg("%s was accepted", rfilter);
    if (!strstr(err.message, words) || !strstr(err.message, "bad.xml:2"))
        fail_msg("%s: message '%s' lacks '%s' or the file and line", rfilter, err.message, words);
}

static void test_bad_parameters(void **state)
{
    (void)state;
    expect_refused("<rfilter type=\"lanczos\"><integer name=\"lobes\" value=\"0\"/></rfilter>",
                   "lobes 0 is not in 1 .. 16");
    expect_refused("<rfilter type=\"mitchell\"><float name=\"radius\" value=\"-1\"/></rfilter>",
                   "radius -1 is not in (0, 16]");
    expect_refused("<rfilter type=\"catmullrom\"><float name=\"B\" value=\"1e9\"/></rfilter>",
                   "are not both in [-10, 10]");
    expect_refused("<rfilter type=\"sinc\"/>", "unknown filter");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mitchell),
        cmocka_unit_test(test_catmullrom),
        cmocka_unit_test(test_lanczos),
        cmocka_unit_test(test_bad_parameters),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
