/* test_render_meters.c - Mitsuba's measuring sensors against closed forms.
 * - irradiancemeter under a uniform sky of radiance L: every direction of the front hemisphere
 *   sees L, so the mean irradiance is pi L exactly (each sample's estimate is pi L), in every
 *   pixel of a film of several pixels too.
 * - irradiancemeter under a small spherical emitter of radius r and radiance L whose centre is
 *   at distance d, at angle theta from the meter's normal, wholly above its horizon: the
 *   irradiance is pi L (r / d)^2 cos theta exactly (the inverse-square cosine law of a source of
 *   intensity pi r^2 L); the same sphere behind the meter reads 0, and with flipNormals the
 *   meter reads it again (the meter looks out of its shape's front).
 * - irradiancemeter on a rectangle with a film of 4 x 2 pixels: each pixel is a patch of the
 *   rectangle (Mitsuba's rectangle maps position samples linearly onto it), so under an emitting
 *   strip close below the left quarter only the left column of pixels reads pi L.
 * - radiancemeter: the radiance of the area emitter it looks at, exactly, in both of its
 *   placements (toWorld, Mitsuba 3's origin and direction).
 * - mfilm: the text matrix of its image (MATLAB's and Mathematica's layouts), and a file that
 *   cannot be written is refused and the previous one kept.
 * - what Mitsuba refuses: an irradiancemeter with a toWorld, outside a shape, or of an
 *   index-matched shape; a second sensor. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "opaline_render.h"
#include "test_support.h"

/* The red channel of the 1 x 1 image of the scene text rendered at spp. */
static double render_value(const char *text, int spp)
{
    op_image img = op_test_render_image(op_test_write_temp("scene.xml", text), spp, 1, 0);
    assert_int_equal(img.width * img.height, 1);
    double v = img.pixels[0];
    op_image_free(&img);
    return v;
}

static void test_sky(void **state)
{
    (void)state;
    const double L = 0.7;
    const char *text =
        "<scene version=\"0.6.0\"><shape type=\"disk\"><transform name=\"toWorld\">"
        "<scale value=\"0.1\"/><rotate x=\"1\" angle=\"30\"/><translate z=\"2\"/></transform>"
        "<sensor type=\"irradiancemeter\"><film type=\"mfilm\"><integer name=\"width\" "
        "value=\"2\"/><integer name=\"height\" value=\"3\"/></film></sensor></shape>"
        "<emitter type=\"constant\"><rgb name=\"radiance\" value=\"0.7\"/></emitter></scene>";
    op_image img = op_test_render_image(op_test_write_temp("scene.xml", text), 64, 2, 0);
    assert_int_equal(img.width, 2);
    assert_int_equal(img.height, 3);
    for (int i = 0; i < 6; i++)
        for (int c = 0; c < 3; c++)
            if (fabs(img.pixels[4 * i + c] - M_PI * L) > 1e-5 * M_PI * L)
                fail_msg("pixel %d channel %d: %.7g, expected pi L = %.7g", i, c,
                         img.pixels[4 * i + c], M_PI * L);
    op_image_free(&img);
}

/* A meter disk of radius 0.05 at the origin (normal +z, or -z with flip) under a sphere of
 * radius 0.5 and radiance 2 centred at (1, 0, z). */
static double sphere_reading(double z, int flip, int spp)
{
    char text[1024];
    snprintf(text, sizeof text,
             "<scene version=\"0.6.0\"><integrator type=\"path\"><integer name=\"maxDepth\" "
             "value=\"1\"/></integrator><shape type=\"disk\"><boolean name=\"flipNormals\" "
             "value=\"%s\"/><transform name=\"toWorld\"><scale value=\"0.05\"/></transform>"
             "<sensor type=\"irradiancemeter\"><film type=\"mfilm\"/></sensor></shape>"
             "<shape type=\"sphere\"><float name=\"radius\" value=\"0.5\"/><point name=\"center\" "
             "x=\"1\" y=\"0\" z=\"%.17g\"/><emitter type=\"area\"><rgb name=\"radiance\" "
             "value=\"2\"/></emitter></shape></scene>",
             flip ? "true" : "false", z);
    return render_value(text, spp);
}

static void test_inverse_square_cosine(void **state)
{
    (void)state;
    const int spp = 400000;
    const double r = 0.5, d = 2.0, cos_t = sqrt(3.0) / 2.0, L = 2.0;
    double expect = M_PI * L * (r / d) * (r / d) * cos_t;
    /* each sample reads pi L with probability p = (r / d)^2 cos theta, else 0 */
    double p = (r / d) * (r / d) * cos_t;
    double sigma = expect * sqrt((1.0 - p) / (p * spp));
    double above = sphere_reading(sqrt(3.0), 0, spp);
    print_message("sphere above: %.5f, expected %.5f (sigma %.5f)\n", above, expect, sigma);
    if (fabs(above - expect) > 4.0 * sigma)
        fail_msg("sphere above the meter: %.5f, expected %.5f +- 4 x %.5f", above, expect, sigma);
    double behind = sphere_reading(-sqrt(3.0), 0, 20000);
    if (behind != 0.0)
        fail_msg("sphere behind the meter: %g, expected 0", behind);
    double flipped = sphere_reading(-sqrt(3.0), 1, spp);
    if (fabs(flipped - expect) > 4.0 * sigma)
        fail_msg("sphere behind a flipped meter: %.5f, expected %.5f +- 4 x %.5f", flipped,
                 expect, sigma);
}

static void test_rectangle_patches(void **state)
{
    (void)state;
    /* the meter: the square [-1, 1]^2 at z = 0, looking down (-z); the emitter: the strip
     * x in [-1, -0.5], 1e-3 below, emitting up, radiance 1 */
    const char *text =
        "<scene version=\"0.6.0\"><integrator type=\"path\"><integer name=\"maxDepth\" "
        "value=\"1\"/></integrator><shape type=\"rectangle\"><boolean name=\"flipNormals\" "
        "value=\"true\"/><sensor type=\"irradiancemeter\"><film type=\"mfilm\"><integer "
        "name=\"width\" value=\"4\"/><integer name=\"height\" value=\"2\"/></film></sensor>"
        "</shape><shape type=\"rectangle\"><transform name=\"toWorld\"><scale x=\"0.25\"/>"
        "<translate x=\"-0.75\" z=\"-0.001\"/></transform><emitter type=\"area\"><rgb "
        "name=\"radiance\" value=\"1\"/></emitter></shape></scene>";
    op_image img = op_test_render_image(op_test_write_temp("scene.xml", text), 4096, 2, 0);
    assert_int_equal(img.width, 4);
    assert_int_equal(img.height, 2);
    for (int y = 0; y < 2; y++)
        for (int x = 0; x < 4; x++) {
            double v = img.pixels[4 * (y * 4 + x)], expect = x == 0 ? M_PI : 0.0;
            print_message("pixel (%d, %d): %.4f\n", x, y, v);
            /* the edge: a grazing ray from near the strip's edge still hits it (1e-3 below) */
            if (fabs(v - expect) > 0.02 * M_PI)
                fail_msg("pixel (%d, %d): %.4f, expected %.4f", x, y, v, expect);
        }
    op_image_free(&img);
}

static void test_radiancemeter_area_light(void **state)
{
    (void)state;
    const char *placements[] = {
        "<transform name=\"toWorld\"><lookat origin=\"0.2,0.1,-1\" target=\"0.3,0,2\"/>"
        "</transform>",
        "<point name=\"origin\" value=\"0.2,0.1,-1\"/><vector name=\"direction\" "
        "value=\"0.1,-0.1,3\"/>"};
    for (int k = 0; k < 2; k++) {
        char text[1024];
        snprintf(text, sizeof text,
                 "<scene version=\"0.6.0\"><sensor type=\"radiancemeter\">%s<film type=\"mfilm\">"
                 "<string name=\"pixelFormat\" value=\"rgb\"/></film></sensor>"
                 "<shape type=\"rectangle\"><boolean name=\"flipNormals\" value=\"true\"/>"
                 "<transform name=\"toWorld\"><translate z=\"2\"/></transform>"
                 "<emitter type=\"area\"><rgb name=\"radiance\" value=\"0.25, 0.5, 0.75\"/>"
                 "</emitter></shape></scene>",
                 placements[k]);
        op_image img = op_test_render_image(op_test_write_temp("scene.xml", text), 16, 1, 0);
        const float want[3] = {0.25f, 0.5f, 0.75f};
        for (int c = 0; c < 3; c++)
            if (img.pixels[c] != want[c])
                fail_msg("placement %d channel %d: %.9g, expected %.9g", k, c, img.pixels[c],
                         want[c]);
        op_image_free(&img);
    }
}

/* The text of the file at path (freed by the caller). */
static char *slurp(const char *path)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    char *buf = calloc(1, 4096);
    assert_non_null(buf);
    size_t n = fread(buf, 1, 4095, f);
    buf[n] = '\0';
    fclose(f);
    return buf;
}

/* Loads the scene text, writes img through its film to out; returns the status. */
static op_status write_through_film(const char *text, const op_image *img, const char *out,
                                    op_error *err)
{
    op_scene *s = NULL;
    op_error lerr = {0};
    op_status st = op_scene_load(op_test_write_temp("scene.xml", text), NULL, 0, &s, &lerr);
    OP_ASSERT_OK(st, lerr);
    st = op_scene_write_image(s, img, out, err);
    op_scene_free(s);
    return st;
}

static void test_mfilm_text(void **state)
{
    (void)state;
    op_image img;
    op_error err = {0};
    OP_ASSERT_OK(op_image_alloc(&img, 2, 2, 4, &err), err);
    const float px[16] = {0.25f, 0.5f, 0.75f, 1, 1e-5f, 2, 3, 1, 1234567, 0, 0, 1,
                          -1.5f, 0, 0.125f, 1};
    memcpy(img.pixels, px, sizeof px);
    char out[4096];
    snprintf(out, sizeof out, "%s", op_test_write_temp("out.m", "previous"));
    OP_ASSERT_OK(write_through_film("<scene version=\"0.6.0\"><sensor type=\"radiancemeter\">"
                                    "<film type=\"mfilm\"><integer name=\"width\" value=\"2\"/>"
                                    "<integer name=\"height\" value=\"2\"/><string "
                                    "name=\"pixelFormat\" value=\"rgb\"/></film></sensor></scene>",
                                    &img, out, &err),
                 err);
    char *text = slurp(out);
    const char *matlab = "data = [0.25, 1e-05;\n\t1.235e+06, -1.5];\n"
                         "\ndata(:, :, 2) = [0.5, 2;\n\t0, 0];\n"
                         "\ndata(:, :, 3) = [0.75, 3;\n\t0, 0.125];\n";
    if (strcmp(text, matlab) != 0)
        fail_msg("MATLAB text:\n%s\nexpected:\n%s", text, matlab);
    /* parsed back: the values to the 4 digits written */
    double v[4];
    assert_int_equal(sscanf(text, "data = [%lf, %lf;\n\t%lf, %lf];", &v[0], &v[1], &v[2], &v[3]), 4);
    for (int i = 0; i < 4; i++)
        assert_true(fabs(v[i] - px[4 * i]) <= 5e-4 * fabs(px[4 * i]));
    free(text);

    OP_ASSERT_OK(write_through_film("<scene version=\"0.6.0\"><sensor type=\"radiancemeter\">"
                                    "<film type=\"mfilm\"><integer name=\"width\" value=\"2\"/>"
                                    "<integer name=\"height\" value=\"2\"/><string "
                                    "name=\"fileFormat\" value=\"mathematica\"/><integer "
                                    "name=\"digits\" value=\"3\"/><string name=\"variable\" "
                                    "value=\"E_1\"/></film></sensor></scene>",
                                    &img, out, &err),
                 err);
    text = slurp(out);
    /* luminance: 0.2126 R + 0.7152 G + 0.0722 B */
    char expect[256];
    snprintf(expect, sizeof expect, "E_1 = {{%.3g, %.3g},\n\t{%.3g, %.3g}};\n",
             (double)(0.2126f * 0.25f + 0.7152f * 0.5f + 0.0722f * 0.75f),
             (double)(0.2126f * 1e-5f + 0.7152f * 2 + 0.0722f * 3), (double)(0.2126f * 1234567),
             (double)(0.2126f * -1.5f + 0.0722f * 0.125f));
    char *e = strchr(expect, 'e'); /* 2.62e+05 in Mathematica's spelling */
    assert_non_null(e);
    memmove(e + 2, e + 1, strlen(e + 1) + 1);
    e[0] = '*';
    e[1] = '^';
    if (strcmp(text, expect) != 0)
        fail_msg("Mathematica text:\n%s\nexpected:\n%s", text, expect);
    free(text);

    /* a folder that does not exist: refused, and the file written before stays */
    char bad[4200];
    snprintf(bad, sizeof bad, "%s.missing/out.m", out);
    op_status st = write_through_film("<scene version=\"0.6.0\"><sensor type=\"radiancemeter\">"
                                      "<film type=\"mfilm\"/></sensor></scene>",
                                      &img, bad, &err);
    assert_int_not_equal(st, OP_OK);
    text = slurp(out);
    assert_non_null(strstr(text, "E_1 = {{"));
    free(text);
    op_image_free(&img);
}

static void test_refused(void **state)
{
    (void)state;
    const struct {
        const char *text, *message;
    } cases[] = {
        {"<shape type=\"disk\"><sensor type=\"irradiancemeter\"><transform name=\"toWorld\">"
         "<translate z=\"1\"/></transform></sensor></shape>",
         "no toWorld"},
        {"<sensor type=\"irradiancemeter\"/><shape type=\"disk\"/>", "must be the child"},
        {"<shape type=\"disk\"><sensor type=\"perspective\"/></shape>", "only an irradiancemeter"},
        {"<sensor type=\"perspective\"/><shape type=\"disk\"><sensor type=\"irradiancemeter\"/>"
         "</shape>",
         "a second <sensor>"},
        {"<shape type=\"disk\"><bsdf type=\"null\"/><sensor type=\"irradiancemeter\"/></shape>",
         "index-matched"},
        {"<sensor type=\"radiancemeter\"><film type=\"mfilm\"><string name=\"fileFormat\" "
         "value=\"csv\"/></film></sensor>",
         "fileFormat"},
        {"<sensor type=\"radiancemeter\"><film type=\"mfilm\"><string name=\"variable\" "
         "value=\"2x\"/></film></sensor>",
         "variable"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char text[1024];
        snprintf(text, sizeof text, "<scene version=\"0.6.0\">%s</scene>", cases[i].text);
        op_scene *s = NULL;
        op_error err = {0};
        op_status st = op_scene_load(op_test_write_temp("scene.xml", text), NULL, 0, &s, &err);
        op_scene_free(s);
        if (st != OP_ERR_INPUT || !strstr(err.message, cases[i].message))
            fail_msg("case %zu: status %d, message \"%s\", expected one with \"%s\"", i, st,
                     err.message, cases[i].message);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sky),
        cmocka_unit_test(test_inverse_square_cosine),
        cmocka_unit_test(test_rectangle_patches),
        cmocka_unit_test(test_radiancemeter_area_light),
        cmocka_unit_test(test_mfilm_text),
        cmocka_unit_test(test_refused),
    };
    return op_test_exit_status(cmocka_run_group_tests(tests, NULL, NULL));
}
