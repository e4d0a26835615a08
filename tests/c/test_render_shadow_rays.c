/* test_render_shadow_rays.c - what camera and shadow rays cross and where they end, against
 * closed forms. An orthographic sensor looking straight down at a diffuse plane of albedo rho
 * measures rho / pi times the irradiance at each pixel's point.
 * - thindielectric (Mitsuba's thin slab): seen through at normal incidence it lets 1 - R'(1)
 *   through, and a point light's shadow ray crossing it at angle theta carries 1 - R'(cos
 *   theta), R' = 2 R / (1 + R) with R the Fresnel reflectance of the index ratio;
 * - a mask with a textured opacity: over an emitter of radiance 1, each cell of a checkerboard
 *   opacity shows 1 - its opacity, per channel in a Mitsuba 0.6 file, as the luminance in a
 *   Mitsuba 3 file;
 * - an area light away from the origin: the irradiance under the centre of a square light
 *   4 L A / sqrt(1 + A^2) atan(A / sqrt(1 + A^2)) (A = half side / height; the view factor of
 *   a parallel rectangle), also where the offset of rays' origins off the receiving surface,
 *   which grows with the distance from the origin, is more than the margin a shadow ray keeps
 *   short of the light. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "opaline_render.h"
#include "test_support.h"

#define RES 64
#define ALBEDO 0.5

/* The scene: an orthographic sensor over [-s, s]^2 around (cx, cy), at height h looking down,
 * `integrator`, and `body`. */
static const char *scene(const char *version, const char *integrator, double s, double cx,
                         double cy, double h, const char *body)
{
    static char text[8192];
    int n = snprintf(
        text, sizeof text,
        "<scene version=\"%s\">%s<sensor type=\"orthographic\"><transform name=\"%s\">"
        " <scale x=\"%g\" y=\"%g\"/>"
        " <lookat origin=\"%g,%g,%g\" target=\"%g,%g,0\" up=\"0,1,0\"/></transform>"
        " <film type=\"hdrfilm\"><integer name=\"width\" value=\"%d\"/>"
        " <integer name=\"height\" value=\"%d\"/><rfilter type=\"box\"/></film></sensor>"
        "%s</scene>",
        version, integrator, version[0] == '3' ? "to_world" : "toWorld", s, s, cx, cy, h, cx, cy,
        RES, RES, body);
    assert_true(n > 0 && n < (int)sizeof text);
    return op_test_write_temp("scene.xml", text);
}

/* Fresnel reflectance of an unpolarized ray at cosine c on an interface of index ratio eta. */
static double fresnel(double c, double eta)
{
    double s2 = (1.0 - c * c) / (eta * eta);
    if (s2 >= 1.0)
        return 1.0;
    double ct = sqrt(1.0 - s2);
    double rs = (c - eta * ct) / (c + eta * ct), rp = (eta * c - ct) / (eta * c + ct);
    return 0.5 * (rs * rs + rp * rp);
}

/* The thin slab's transmittance at cosine c. */
static double thin_t(double c, double eta)
{
    double r = fresnel(c, eta);
    return 1.0 - 2.0 * r / (1.0 + r);
}

/* z-score of the image's channel-k mean against expect(x, y) averaged over each pixel, from
 * the spread of the pixels' differences (independent estimates). */
static double zscore(const op_image *img, int k, double (*expect)(double x, double y, void *u),
                     void *u, double s, double *rel)
{
    double sum = 0.0, sum2 = 0.0, esum = 0.0;
    for (int y = 0; y < RES; y++)
        for (int x = 0; x < RES; x++) {
            double e = 0.0;
            for (int j = 0; j < 4; j++)
                for (int i = 0; i < 4; i++) /* world x grows with the column, y with the row up */
                    e += expect(s * (2.0 * (x + (i + 0.5) / 4.0) / RES - 1.0),
                                s * (1.0 - 2.0 * (y + (j + 0.5) / 4.0) / RES), u) /
                         16.0;
            double d = img->pixels[4 * ((size_t)y * RES + (size_t)x) + (size_t)k] - e;
            sum += d;
            sum2 += d * d;
            esum += e;
        }
    double n = (double)RES * RES, mean = sum / n;
    double var = (sum2 / n - mean * mean) / (n - 1.0);
    *rel = 1.0 + sum / esum;
    return mean / sqrt(var > 0.0 ? var : 1e-30);
}

/* Floor radiance under a point light of intensity 1 at height 2, seen and lit through a thin
 * slab of index ratio *eta at height 1. */
static double thin_floor(double x, double y, void *u)
{
    double eta = *(double *)u, d2 = x * x + y * y + 4.0, c = 2.0 / sqrt(d2);
    return thin_t(1.0, eta) * ALBEDO / M_PI * c / d2 * thin_t(c, eta);
}

static void test_thin_dielectric(void **state)
{
    (void)state;
    double eta = 1.5;
    char body[2048];
    snprintf(body, sizeof body,
             "<shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"10\"/>"
             "</transform><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"%g\"/></bsdf>"
             "</shape>"
             "<shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"10\"/>"
             "<translate z=\"1\"/></transform><bsdf type=\"thindielectric\">"
             "<float name=\"intIOR\" value=\"%g\"/><float name=\"extIOR\" value=\"1\"/></bsdf>"
             "</shape>"
             "<emitter type=\"point\"><point name=\"position\" x=\"0\" y=\"0\" z=\"2\"/>"
             "<rgb name=\"intensity\" value=\"1\"/></emitter>",
             ALBEDO, eta);
    /* depth 2: the floor lit directly; the slab's mirror sends camera rays to a black sky */
    const char *path = scene("0.6.0", "<integrator type=\"path\"><integer name=\"maxDepth\" "
                             "value=\"2\"/></integrator>", 1.0, 0.0, 0.0, 3.0, body);
    op_image img = op_test_render_image(path, 16, 2, 0);
    double rel, z = zscore(&img, 0, thin_floor, &eta, 1.0, &rel);
    print_message("thindielectric: z %.2f, relative difference %+.4f\n", z, rel - 1.0);
    op_image_free(&img);
    if (fabs(z) > 4.0 || fabs(rel - 1.0) > 0.01)
        fail_msg("thindielectric: floor seen and lit through the slab off its closed form: z "
                 "%.2f, relative difference %+.4f",
                 z, rel - 1.0);
}

/* A mask of checkerboard opacity (color0 c0, color1 0.5) over [-1, 1]^2 at height 1, black
 * behind its cut-outs' complement, over an emitter of radiance 1 facing up. */
static op_image render_checker_mask(const char *version, const char *c0)
{
    const int m3 = version[0] == '3';
    char body[2048];
    snprintf(body, sizeof body,
             "<shape type=\"rectangle\"><emitter type=\"area\"><rgb name=\"radiance\" "
             "value=\"1\"/></emitter><transform name=\"%s\"><scale value=\"10\"/></transform>"
             "</shape>"
             "<shape type=\"rectangle\"><transform name=\"%s\"><translate z=\"1\"/></transform>"
             "<bsdf type=\"mask\"><texture type=\"checkerboard\" name=\"opacity\">"
             "<rgb name=\"color0\" value=\"%s\"/><rgb name=\"color1\" value=\"0.5\"/></texture>"
             "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0\"/></bsdf></bsdf>"
             "</shape>",
             m3 ? "to_world" : "toWorld", m3 ? "to_world" : "toWorld", c0);
    const char *path = scene(version, "", 1.0, 0.0, 0.0, 3.0, body);
    return op_test_render_image(path, 64, 2, 0);
}

/* Mean of channel k over the image quadrant (qx, qy). */
static double quadrant(const op_image *img, int qx, int qy, int k)
{
    double s = 0.0;
    for (int y = qy * RES / 2; y < (qy + 1) * RES / 2; y++)
        for (int x = qx * RES / 2; x < (qx + 1) * RES / 2; x++)
            s += img->pixels[4 * ((size_t)y * RES + (size_t)x) + (size_t)k];
    return s / ((double)RES * RES / 4.0);
}

/* The quadrants hold the checkerboard's two cells diagonally: one pair shows 1 - c0[k], the
 * other 1 - 0.5, each within tol. */
static void check_checker(const op_image *img, const char *what, const double c0[3], double tol)
{
    for (int k = 0; k < 3; k++) {
        double a = quadrant(img, 0, 0, k), b = quadrant(img, 1, 1, k);
        double c = quadrant(img, 1, 0, k), d = quadrant(img, 0, 1, k);
        double cell0 = 1.0 - c0[k], cell1 = 0.5;
        int diag0 = fabs(a - cell0) <= tol && fabs(b - cell0) <= tol && fabs(c - cell1) <= tol &&
                    fabs(d - cell1) <= tol;
        int diag1 = fabs(a - cell1) <= tol && fabs(b - cell1) <= tol && fabs(c - cell0) <= tol &&
                    fabs(d - cell0) <= tol;
        print_message("%s channel %d: quadrants %.4f %.4f | %.4f %.4f (cells %.4f, %.4f)\n",
                      what, k, a, b, c, d, cell0, cell1);
        if (!diag0 && !diag1)
            fail_msg("%s channel %d: quadrants %.4f %.4f | %.4f %.4f, expected the cells %.4f "
                     "and %.4f on the diagonals",
                     what, k, a, b, c, d, cell0, cell1);
    }
}

static void test_textured_mask(void **state)
{
    (void)state;
    /* per channel in a Mitsuba 0.6 file */
    op_image img = render_checker_mask("0.6.0", "0.2, 0.6, 0.9");
    check_checker(&img, "0.6 mask", (const double[3]){0.2, 0.6, 0.9}, 0.01);
    op_image_free(&img);
    /* one value, the luminance, in a Mitsuba 3 file (Rec. 709 weights) */
    double lum = 0.212671 * 0.2 + 0.715160 * 0.6 + 0.072169 * 0.9;
    img = render_checker_mask("3.0.0", "0.2, 0.6, 0.9");
    check_checker(&img, "3 mask", (const double[3]){lum, lum, lum}, 0.01);
    op_image_free(&img);
}

/* The floor's radiance under the centre of a square light of radiance 1, half side 1, at
 * height 1 (the view is small enough for the irradiance to be the centre's). */
static double square_light(double x, double y, void *u)
{
    (void)x, (void)y, (void)u;
    double a = 1.0 / sqrt(2.0);
    return ALBEDO / M_PI * 4.0 * a * atan(a);
}

static void test_area_light_far_from_origin(void **state)
{
    (void)state;
    /* 20: the origins leave the floor 0.0028 up, more than 1e-4 of the way to the light (the
     * margin a shadow ray keeps short of it), and little enough (0.3 %) to keep the closed form
     * for rays that start there */
    const double offsets[] = {0.0, 20.0};
    for (int i = 0; i < 2; i++) {
        double o = offsets[i];
        char body[2048];
        snprintf(body, sizeof body,
                 "<shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"10\"/>"
                 "<translate x=\"%g\" y=\"%g\"/></transform><bsdf type=\"diffuse\">"
                 "<rgb name=\"reflectance\" value=\"%g\"/></bsdf></shape>"
                 "<shape type=\"rectangle\"><transform name=\"toWorld\"><rotate x=\"1\" "
                 "angle=\"180\"/><translate x=\"%g\" y=\"%g\" z=\"1\"/></transform>"
                 "<emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter>"
                 "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0\"/></bsdf></shape>",
                 o, o, ALBEDO, o, o);
        /* the sensor below the light */
        const char *path = scene("0.6.0", "<integrator type=\"direct\"/>", 0.01, o, o, 0.5,
                                 body);
        op_image img = op_test_render_image(path, 16, 2, 0);
        double rel, z = zscore(&img, 0, square_light, NULL, 0.01, &rel);
        print_message("square light, scene at (%g, %g): z %.2f, relative difference %+.4f\n", o,
                      o, z, rel - 1.0);
        op_image_free(&img);
        if (fabs(z) > 4.0 || fabs(rel - 1.0) > 0.01)
            fail_msg("square light over a scene at (%g, %g): irradiance off the closed form: z "
                     "%.2f, relative difference %+.4f",
                     o, o, z, rel - 1.0);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_thin_dielectric),
        cmocka_unit_test(test_textured_mask),
        cmocka_unit_test(test_area_light_far_from_origin),
    };
    return op_test_exit_status(cmocka_run_group_tests(tests, NULL, NULL));
}
