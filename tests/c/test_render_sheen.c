/* test_render_sheen.c - the surface reflection of translucent shapes (a <bsdf> beside a
 * <subsurface>, docs/subsurface-rendering.md "The surface's reflection"):
 *  - energy: a flat slab in a uniform environment of radiance 1 (a white furnace), seen at 0 and
 *    60 degrees: pi L = F(theta) + (1 - F(theta)) x albedo, F the Fresnel reflectance written out
 *    here; for a white material (a raw material whose rows sum to 1) the surface reflection and
 *    the subsurface exitance sum to the incident power within 1 % (smooth coating and rough
 *    roughplastic), for albedo 0.5 and for the Marble dipole (Rd_total from the closed form of
 *    dipole_reference.h) they are below it, as predicted;
 *  - a sphere under a small area light shows a specular highlight with the bsdf and none
 *    without;
 *  - the bsdf types a translucent shape refuses, and coating elsewhere, are errors naming
 *    the line. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dipole_reference.h"
#include "opaline_render.h"
#include "test_support.h"

/* Unpolarized Fresnel reflectance of a dielectric of relative index eta, at cos mu outside. */
static double fresnel(double mu, double eta)
{
    double s2 = (1.0 - mu * mu) / (eta * eta);
    if (s2 >= 1.0)
        return 1.0;
    double ct = sqrt(1.0 - s2);
    double rs = (mu - eta * ct) / (mu + eta * ct), rp = (eta * mu - ct) / (eta * mu + ct);
    return 0.5 * (rs * rs + rp * rp);
}

/* A raw Gaussian material (op_test_write_gaussian_raw) of albedo a in every channel. */
static void write_grey(const char *path, double a)
{
    const double albedo[3] = {a, a, a};
    op_test_write_gaussian_raw(path, albedo, 0);
}

/* pi L / E (the mean radiance over the environment's), per channel, of an 8 x 8 view of the centre of a flat slab (a 2 x 2
 * rectangle in z = 0) in a constant environment of radiance 1, seen from theta degrees off the
 * normal; the slab's shape body (subsurface and bsdf) is given. */
static void furnace(const char *name, const char *body, double theta, double out[3])
{
    char text[4096];
    double t = theta * M_PI / 180.0;
    snprintf(text, sizeof text,
             "<scene version=\"0.6.0\"><integrator type=\"path\"/>"
             " <sensor type=\"perspective\"><float name=\"fov\" value=\"3\"/>"
             "  <transform name=\"toWorld\"><lookat origin=\"0,%.9g,%.9g\" target=\"0,0,0\" "
             "   up=\"0,%s\"/></transform>"
             "  <sampler type=\"independent\"><integer name=\"sampleCount\" value=\"16\"/>"
             "  </sampler><film type=\"hdrfilm\"><integer name=\"width\" value=\"8\"/>"
             "   <integer name=\"height\" value=\"8\"/><rfilter type=\"box\"/></film></sensor>"
             " <emitter type=\"constant\"><rgb name=\"radiance\" value=\"1\"/></emitter>"
             " <shape type=\"rectangle\">%s</shape>"
             "</scene>",
             -2.0 * sin(t), 2.0 * cos(t), theta == 0.0 ? "1,0" : "0,1", body);
    const char *path = op_test_write_temp(name, text);
    op_image img = op_test_render_image(path, 0, 2, 0);
    for (int c = 0; c < 3; c++) {
        double s = 0.0;
        for (int i = 0; i < 64; i++)
            s += img.pixels[4 * i + c];
        out[c] = s / 64.0; /* pi L / E with E = pi x 1 */
    }
    op_image_free(&img);
}

static void expect(const char *what, double theta, const double got[3], const double want[3],
                   double tol)
{
    for (int c = 0; c < 3; c++) {
        printf("%s, %g deg, channel %d: pi L / E = %.4f, expected %.4f (%+.2f %%)\n", what, theta,
               c, got[c], want[c], 100.0 * (got[c] / want[c] - 1.0));
        if (fabs(got[c] - want[c]) > tol * want[c])
            fail_msg("%s at %g degrees, channel %d: pi L / E = %.4f, expected %.4f", what, theta,
                     c, got[c], want[c]);
    }
}

static const char *raw_body(const char *mat, const char *bsdf, char *buf, size_t n)
{
    snprintf(buf, n,
             "<subsurface type=\"raw\"><string name=\"material\" value=\"%s\"/>"
             " <float name=\"sceneUnitsPerMetre\" value=\"80\"/><integer name=\"irrSamples\" value=\"16\"/>"
             "</subsurface>%s",
             mat, bsdf);
    return buf;
}

static void test_white_furnace(void **state)
{
    (void)state;
    char white[1024], half[1024], body[2048];
    snprintf(white, sizeof white, "%s", op_test_tmp_path("White.opm"));
    snprintf(half, sizeof half, "%s", op_test_tmp_path("Half.opm"));
    write_grey(white, 1.0);
    write_grey(half, 0.5);
    static const char *coat = "<bsdf type=\"coating\"><float name=\"intIOR\" value=\"1.5\"/>"
                              "<float name=\"extIOR\" value=\"1\"/></bsdf>";
    static const char *rough = "<bsdf type=\"roughplastic\"><float name=\"intIOR\" value=\"1.5\"/>"
                               "<float name=\"extIOR\" value=\"1\"/><string name=\"distribution\" "
                               "value=\"ggx\"/><float name=\"alpha\" value=\"0.3\"/></bsdf>";
    const double thetas[2] = {0.0, 60.0};
    for (int k = 0; k < 2; k++) {
        double th = thetas[k], got[3], one[3] = {1, 1, 1}, want[3];
        /* white: all the incident power comes back, part reflected, part through the medium */
        furnace("white-coat.xml", raw_body(white, coat, body, sizeof body), th, got);
        expect("white raw, coating", th, got, one, 0.01);
        furnace("white-rough.xml", raw_body(white, rough, body, sizeof body), th, got);
        expect("white raw, roughplastic alpha 0.3", th, got, one, 0.01);
        /* albedo 0.5: the reflection F plus half of what enters, (1 - F) / 2 */
        double f = fresnel(cos(th * M_PI / 180.0), 1.5);
        for (int c = 0; c < 3; c++)
            want[c] = f + (1.0 - f) * 0.5;
        furnace("half-coat.xml", raw_body(half, coat, body, sizeof body), th, got);
        expect("albedo 0.5 raw, coating", th, got, want, 0.01);
        for (int c = 0; c < 3; c++)
            assert_true(got[c] < 1.0);
        /* without the bsdf: no surface reflection, the Rd holds the boundary: pi L = albedo */
        furnace("half-plain.xml", raw_body(half, "", body, sizeof body), th, got);
        for (int c = 0; c < 3; c++)
            want[c] = 0.5;
        expect("albedo 0.5 raw, no bsdf", th, got, want, 0.02);
    }
}

static void test_dipole_furnace(void **state)
{
    (void)state;
    /* Marble (eta 1.5), a metre scene: the slab 2 m across, the view 0.2 m */
    static const double sp[3] = {2.19, 2.62, 3.00}, sa[3] = {0.0021, 0.0041, 0.0071};
    static const char *body =
        "<subsurface type=\"dipole\"><string name=\"material\" value=\"Marble\"/>"
        " <float name=\"sceneUnitsPerMetre\" value=\"1\"/><integer name=\"irrSamples\" value=\"8\"/>"
        "</subsurface><transform name=\"toWorld\"><scale value=\"0.2\"/></transform>"
        "<bsdf type=\"dielectric\"><float name=\"intIOR\" value=\"1.5\"/>"
        "<float name=\"extIOR\" value=\"1\"/></bsdf>";
    const double thetas[2] = {0.0, 60.0};
    for (int k = 0; k < 2; k++) {
        double th = thetas[k], got[3], want[3];
        double f = fresnel(cos(th * M_PI / 180.0), 1.5);
        for (int c = 0; c < 3; c++) {
            want[c] = f + (1.0 - f) * ref_dipole_total(sp[c], sa[c], 1.5);
            assert_true(want[c] < 1.0);
        }
        furnace("marble.xml", body, th, got);
        /* the dipole's truncation at R keeps 99.9 % of Rd_total */
        expect("Marble dipole, dielectric", th, got, want, 0.015);
    }
}

/* The brightest pixel of a translucent sphere under a small area light, with and without a
 * surface bsdf. */
static double brightest(const char *mat, const char *bsdf, op_image *keep)
{
    char text[4096];
    snprintf(text, sizeof text,
             "<scene version=\"0.6.0\"><integrator type=\"path\"/>"
             " <sensor type=\"perspective\"><float name=\"fov\" value=\"40\"/>"
             "  <transform name=\"toWorld\"><lookat origin=\"0,0,4\" target=\"0,0,0\" "
             "   up=\"0,1,0\"/></transform>"
             "  <sampler type=\"independent\"><integer name=\"sampleCount\" value=\"8\"/>"
             "  </sampler><film type=\"hdrfilm\"><integer name=\"width\" value=\"32\"/>"
             "   <integer name=\"height\" value=\"32\"/></film></sensor>"
             " <shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"0.3\"/>"
             "  <rotate x=\"1\" angle=\"160\"/><translate x=\"0\" y=\"2\" z=\"4\"/></transform>"
             "  <emitter type=\"area\"><rgb name=\"radiance\" value=\"40\"/></emitter></shape>"
             " <shape type=\"sphere\"><float name=\"radius\" value=\"1\"/>"
             "  <subsurface type=\"raw\"><string name=\"material\" value=\"%s\"/>"
             "  <float name=\"sceneUnitsPerMetre\" value=\"40\"/><integer name=\"irrSamples\" value=\"4\"/>"
             "  </subsurface>%s</shape>"
             "</scene>",
             mat, bsdf);
    const char *path = op_test_write_temp("sphere.xml", text);
    op_image img = op_test_render_image(path, 0, 2, 0);
    double best = 0.0;
    for (int i = 0; i < img.width * img.height; i++) {
        double l = img.pixels[4 * i] + img.pixels[4 * i + 1] + img.pixels[4 * i + 2];
        assert_true(isfinite(l));
        if (l > best)
            best = l;
    }
    *keep = img;
    return best;
}

static void test_highlight(void **state)
{
    (void)state;
    char mat[1024];
    snprintf(mat, sizeof mat, "%s", op_test_tmp_path("Grey.opm"));
    write_grey(mat, 0.7);
    op_image plain, coated, rough;
    double b0 = brightest(mat, "", &plain);
    double b1 = brightest(mat, "<bsdf type=\"coating\"/>", &coated);
    double b2 = brightest(mat, "<bsdf type=\"roughdielectric\"><float name=\"alpha\" "
                               "value=\"0.1\"/></bsdf>", &rough);
    printf("brightest pixel: no bsdf %.3f, coating %.3f, roughdielectric 0.1 %.3f\n", b0, b1, b2);
    /* the light's mirror image (radiance 40 x F ~ 1.6) outshines the diffuse exitance */
    assert_true(b1 > 2.0 * b0);
    assert_true(b2 > 1.3 * b0);
    op_image_free(&plain);
    op_image_free(&coated);
    op_image_free(&rough);
}

static op_status load(const char *text, op_error *err)
{
    const char *path = op_test_write_temp("bad.xml", text);
    op_scene *scene = NULL;
    op_status st = op_scene_load(path, NULL, 0, &scene, err);
    op_scene_free(scene);
    return st;
}

static void test_refused(void **state)
{
    (void)state;
    char mat[1024], text[4096];
    snprintf(mat, sizeof mat, "%s", op_test_tmp_path("Grey.opm"));
    write_grey(mat, 0.7);
    static const char *bad[] = {"<bsdf type=\"diffuse\"/>", "<bsdf type=\"conductor\"/>",
                                "<bsdf type=\"twosided\"><bsdf type=\"plastic\"/></bsdf>",
                                "<bsdf type=\"coating\"><bsdf type=\"diffuse\"/></bsdf>"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        snprintf(text, sizeof text,
                 "<scene version=\"0.6.0\">\n<shape type=\"sphere\">\n"
                 "<subsurface type=\"raw\"><string name=\"material\" value=\"%s\"/></subsurface>\n"
                 "%s\n</shape></scene>",
                 mat, bad[i]);
        op_error err = {0};
        assert_int_equal(load(text, &err), OP_ERR_INPUT);
        printf("refused: %s\n", err.message);
        assert_non_null(strstr(err.message, ":4:"));
    }
    /* coating only over a subsurface (roughdielectric elsewhere is frosted glass) */
    static const char *alone[] = {"coating"};
    for (int i = 0; i < 1; i++) {
        snprintf(text, sizeof text,
                 "<scene version=\"0.6.0\">\n<shape type=\"sphere\">\n<bsdf type=\"%s\"/>\n"
                 "</shape></scene>",
                 alone[i]);
        op_error err = {0};
        assert_int_equal(load(text, &err), OP_ERR_INPUT);
        printf("refused: %s\n", err.message);
        assert_non_null(strstr(err.message, ":3:"));
        assert_non_null(strstr(err.message, "subsurface"));
    }
}

int main(void)
{
    op_log_set_level(OP_LOG_WARN);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_white_furnace),
        cmocka_unit_test(test_dipole_furnace),
        cmocka_unit_test(test_highlight),
        cmocka_unit_test(test_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
