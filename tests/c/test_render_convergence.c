/* test_render_convergence.c - the image is bit-identical for any thread count (independent and
 * low-discrepancy samplers), the error of a Cornell-like box falls as 1/sqrt(spp) with the
 * independent sampler, and the low-discrepancy sampler's error is clearly lower at equal spp and
 * falls at least as fast. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "opaline_render.h"
#include "test_support.h"

/* A small closed box: white walls, a red and a green wall, an area light in the ceiling and a
 * diffuse cube, seen through the open front. */
static const char *cornell =
    "<scene version=\"0.6.0\">"
    " <integrator type=\"path\"><integer name=\"maxDepth\" value=\"5\"/>"
    "  <boolean name=\"hideEmitters\" value=\"true\"/></integrator>"
    " <sensor type=\"perspective\"><float name=\"fov\" value=\"45\"/>"
    "  <transform name=\"toWorld\"><lookat origin=\"0,0,-3.4\" target=\"0,0,0\" up=\"0,1,0\"/>"
    "  </transform><film type=\"hdrfilm\"><integer name=\"width\" value=\"20\"/>"
    "  <integer name=\"height\" value=\"20\"/><rfilter type=\"tent\"/></film></sensor>"
    " <bsdf type=\"diffuse\" id=\"white\"><rgb name=\"reflectance\" value=\"0.7\"/></bsdf>"
    " <shape type=\"rectangle\"><transform name=\"toWorld\"><rotate x=\"1\" angle=\"-90\"/>"
    "  <translate y=\"-1\"/></transform><ref id=\"white\"/></shape>"
    " <shape type=\"rectangle\"><transform name=\"toWorld\"><rotate x=\"1\" angle=\"90\"/>"
    "  <translate y=\"1\"/></transform><ref id=\"white\"/></shape>"
    " <shape type=\"rectangle\"><transform name=\"toWorld\"><rotate x=\"1\" angle=\"180\"/>"
    "  <translate z=\"1\"/></transform><ref id=\"white\"/></shape>"
    " <shape type=\"rectangle\"><transform name=\"toWorld\"><rotate y=\"1\" angle=\"90\"/>"
    "  <translate x=\"-1\"/></transform><bsdf type=\"diffuse\"><rgb name=\"reflectance\""
    "  value=\"0.7,0.1,0.1\"/></bsdf></shape>"
    " <shape type=\"rectangle\"><transform name=\"toWorld\"><rotate y=\"1\" angle=\"-90\"/>"
    "  <translate x=\"1\"/></transform><bsdf type=\"diffuse\"><rgb name=\"reflectance\""
    "  value=\"0.1,0.7,0.1\"/></bsdf></shape>"
    " <shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"0.3\"/>"
    "  <rotate x=\"1\" angle=\"90\"/><translate y=\"0.99\"/></transform>"
    "  <emitter type=\"area\"><rgb name=\"radiance\" value=\"12\"/></emitter></shape>"
    " <shape type=\"cube\"><transform name=\"toWorld\"><scale value=\"0.3\"/>"
    "  <rotate y=\"1\" angle=\"30\"/><translate x=\"0.3\" y=\"-0.7\" z=\"0.2\"/></transform>"
    "  <ref id=\"white\"/></shape>"
    "</scene>";

/* A floor and a box lit by a point light and a grey sky (bench/bench_cycles_noise.py's scene):
 * the shadow is lit by the sky and by light bounced off the floor and the box. */
static const char *sky =
    "<scene version=\"0.6.0\">"
    " <integrator type=\"path\"><integer name=\"maxDepth\" value=\"6\"/></integrator>"
    " <sensor type=\"perspective\"><float name=\"fov\" value=\"40\"/>"
    "  <transform name=\"toWorld\"><lookat origin=\"0,4,-5\" target=\"0,0.3,0\" up=\"0,1,0\"/>"
    "  </transform><sampler type=\"%s\"/><film type=\"hdrfilm\">"
    "  <integer name=\"width\" value=\"24\"/><integer name=\"height\" value=\"24\"/></film>"
    " </sensor>"
    " <emitter type=\"constant\"><rgb name=\"radiance\" value=\"0.2\"/></emitter>"
    " <emitter type=\"point\"><point name=\"position\" x=\"1.5\" y=\"3\" z=\"1\"/>"
    "  <rgb name=\"intensity\" value=\"24\"/></emitter>"
    " <shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"10\"/>"
    "  <rotate x=\"1\" angle=\"-90\"/></transform>"
    "  <bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.8\"/></bsdf></shape>"
    " <shape type=\"cube\"><transform name=\"toWorld\"><scale value=\"0.5\"/>"
    "  <translate y=\"0.5\"/></transform>"
    "  <bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.6,0.5,0.4\"/></bsdf></shape>"
    "</scene>";

/* The same box with a sampler of the given type in its sensor (a fresh string; free it). */
static char *cornell_with_sampler(const char *type)
{
    const char *at = strstr(cornell, "<film ");
    size_t n = strlen(cornell) + 64;
    char *out = malloc(n);
    assert_non_null(out);
    snprintf(out, n, "%.*s<sampler type=\"%s\"/>%s", (int)(at - cornell), cornell, type, at);
    return out;
}

static void check_threads_bit_identical(const char *xml)
{
    const char *path = op_test_write_temp("cornell.xml", xml);
    char keep[1024];
    snprintf(keep, sizeof keep, "%s", path);
    op_image a = op_test_render_image(keep, 8, 1, 0), b = op_test_render_image(keep, 8, 2, 0), c = op_test_render_image(keep, 8, 3, 0);
    size_t n = (size_t)a.width * a.height * 4 * sizeof(float);
    assert_memory_equal(a.pixels, b.pixels, n);
    assert_memory_equal(a.pixels, c.pixels, n);
    /* and the picture is not trivially black */
    double sum = 0;
    for (size_t i = 0; i < (size_t)a.width * a.height * 4; i++)
        sum += a.pixels[i];
    assert_true(sum > 1.0);
    op_image_free(&a);
    op_image_free(&b);
    op_image_free(&c);
}

static void test_threads_bit_identical(void **state)
{
    (void)state;
    check_threads_bit_identical(cornell);
    char *ld = cornell_with_sampler("sobol");
    check_threads_bit_identical(ld);
    /* Mitsuba 3's multijitter and orthogonal samplers select the same low-discrepancy sampler */
    const char *path = op_test_write_temp("cornell.xml", ld);
    char keep[1024];
    snprintf(keep, sizeof keep, "%s", path);
    op_image a = op_test_render_image(keep, 8, 1, 0);
    free(ld);
    const char *mitsuba3[] = {"multijitter", "orthogonal"};
    for (int k = 0; k < 2; k++) {
        ld = cornell_with_sampler(mitsuba3[k]);
        path = op_test_write_temp("cornell.xml", ld);
        snprintf(keep, sizeof keep, "%s", path);
        op_image b = op_test_render_image(keep, 8, 1, 0);
        assert_memory_equal(a.pixels, b.pixels, (size_t)a.width * a.height * 4 * sizeof(float));
        op_image_free(&b);
        free(ld);
    }
    op_image_free(&a);
}

static void test_error_falls_as_inverse_sqrt_spp(void **state)
{
    (void)state;
    const char *path = op_test_write_temp("cornell.xml", cornell);
    char keep[1024];
    snprintf(keep, sizeof keep, "%s", path);
    /* an independent reference (another seed) with 32x the largest sample count */
    op_image ref = op_test_render_image(keep, 1024, 2, 12345);
    double e[3];
    int spp[3] = {2, 8, 32};
    /* (the light is hidden from the camera: its few edge pixels would dominate the error) */
    for (int i = 0; i < 3; i++) {
        op_image img = op_test_render_image(keep, spp[i], 2, 7);
        e[i] = op_test_image_rmse(&img, &ref);
        op_image_free(&img);
    }
    double ratio1 = e[0] / e[1], ratio2 = e[1] / e[2];
    print_message("rmse at 2, 8, 32 spp: %.5f %.5f %.5f\n", e[0], e[1], e[2]);
    /* 4x the samples: the error halves (ratio 2), within the noise of the estimate */
    if (ratio1 < 1.6 || ratio1 > 2.5 || ratio2 < 1.6 || ratio2 > 2.5)
        fail_msg("rmse at 2, 8, 32 spp: %.5f %.5f %.5f (ratios %.3f %.3f, want ~2)", e[0], e[1],
                 e[2], ratio1, ratio2);
    op_image_free(&ref);
}

/* RMSE of renders of scene xml at each of n sample counts against ref. */
static void errors(const char *xml, const op_image *ref, const int *spp, int n, double *e)
{
    const char *path = op_test_write_temp("ld.xml", xml);
    char keep[1024];
    snprintf(keep, sizeof keep, "%s", path);
    for (int i = 0; i < n; i++) {
        op_image img = op_test_render_image(keep, spp[i], 2, 7);
        e[i] = op_test_image_rmse(&img, ref);
        op_image_free(&img);
    }
}

/* Errors of the independent and the low-discrepancy sampler at 16 and 64 spp against a
 * low-discrepancy reference of another seed (another scrambling) with 32x the samples; fails
 * unless the low-discrepancy error at 64 spp is `gain` times lower and falls at least as fast. */
static void check_low_discrepancy_gain(const char *name, const char *ind, const char *ld,
                                       double gain)
{
    const char *path = op_test_write_temp("ld.xml", ld);
    char keep[1024];
    snprintf(keep, sizeof keep, "%s", path);
    op_image ref = op_test_render_image(keep, 2048, 2, 12345);
    int spp[2] = {16, 64};
    double ei[2], el[2];
    errors(ind, &ref, spp, 2, ei);
    errors(ld, &ref, spp, 2, el);
    print_message("%s: rmse at 16, 64 spp: independent %.5f %.5f, sobol %.5f %.5f (%.2fx at 64)\n",
                  name, ei[0], ei[1], el[0], el[1], ei[1] / el[1]);
    if (ei[1] < gain * el[1])
        fail_msg("%s: at 64 spp the low-discrepancy error %.5f is not %.2fx below the "
                 "independent %.5f", name, el[1], gain, ei[1]);
    if (el[0] / el[1] < 0.95 * (ei[0] / ei[1]))
        fail_msg("%s: 16 -> 64 spp: low-discrepancy error falls %.3fx, independent %.3fx", name,
                 el[0] / el[1], ei[0] / ei[1]);
    op_image_free(&ref);
}

static void test_low_discrepancy_beats_independent(void **state)
{
    (void)state;
    char ind[4096], ld[4096];
    snprintf(ind, sizeof ind, sky, "independent");
    snprintf(ld, sizeof ld, sky, "sobol");
    /* the shadow is lit indirectly only: by the sky and by light bounced off floor and box */
    check_low_discrepancy_gain("floor and box", ind, ld, 1.5);
    /* five bounces in a closed box with an area light: a smaller gain */
    char *cl = cornell_with_sampler("sobol");
    check_low_discrepancy_gain("cornell box", cornell, cl, 1.3);
    free(cl);
}

int main(void)
{
    op_log_set_level(OP_LOG_WARN);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_threads_bit_identical),
        cmocka_unit_test(test_error_falls_as_inverse_sqrt_spp),
        cmocka_unit_test(test_low_discrepancy_beats_independent),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
