/* test_render_emitters.c - Mitsuba's spot, directional and collimated emitters against closed
 * forms. An orthographic sensor looking straight down at a diffuse plane measures rho / pi
 * times the irradiance at each pixel's point, so the image's mean times the sensor's area is
 * rho / pi times the power reaching the plane.
 * - spot: that power is I 2 pi Int_0^cutoff falloff(theta) sin(theta) dtheta (Mitsuba's linear
 *   falloff in angle from beamWidth, by default 3/4 of cutoffAngle, to cutoffAngle), and the
 *   beam's centre shows I / h^2;
 * - collimated: power along one ray lights nothing a path tracer sees (as in Mitsuba), so a
 *   scene's image is the same with or without it;
 * - sky: the irradiance its tabulated map gives a plane facing up is the model's own, integrated
 *   numerically over the hemisphere; the sun's position (PSA algorithm) puts it overhead at the
 *   equator at an equinox's noon and at the tropic at a solstice's, in the east in the morning;
 *   a sun below the horizon is refused;
 * - projector (Mitsuba 3's, constant irradiance): a plane facing it at distance z receives
 *   pi scale irradiance / z^2 over the frustum's square footprint 2 z tan(fov / 2) wide, nothing
 *   outside;
 * - refusals: a directional light with both direction and toWorld, a sky whose sun is below
 *   the horizon or given twice. (Textured spots and projectors: test_render_textured_emitters.) */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "light/sky.h"
#include "opaline_render.h"
#include "test_support.h"

#define RES 64
#define ALBEDO 0.5

static double image_mean(const op_image *img)
{
    double s = 0.0;
    for (size_t i = 0; i < (size_t)img->width * img->height; i++)
        s += img->pixels[4 * i];
    return s / ((double)img->width * img->height);
}

/* I 2 pi Int_0^cutoff falloff sin, by the midpoint rule (angles in degrees). */
static double spot_power(double intensity, double cutoff, double beam)
{
    double c = cutoff * M_PI / 180.0, b = beam * M_PI / 180.0, sum = 0.0;
    const int n = 200000;
    for (int i = 0; i < n; i++) {
        double t = c * (i + 0.5) / n;
        double f = t <= b ? 1.0 : (c - t) / (c - b);
        sum += f * sin(t) * c / n;
    }
    return intensity * 2.0 * M_PI * sum;
}

static void check_spot(const char *params, double intensity, double cutoff, double beam)
{
    char light[1024];
    snprintf(light, sizeof light,
             "<emitter type=\"spot\"><transform name=\"toWorld\"><lookat origin=\"0.2,0,1\" "
             "target=\"0.2,0,0\" up=\"0,1,0\"/></transform><rgb name=\"intensity\" value=\"%g\"/>"
             "%s</emitter>",
             intensity, params);
    op_image img = op_test_render_image(op_test_plane_scene(RES, ALBEDO, light), 16, 2, 0);
    double power = image_mean(&img) * 4.0 * M_PI / ALBEDO;
    double expect = spot_power(intensity, cutoff, beam);
    /* the beam's centre, over x = 0.2: column 38 (x grows to the right, 1/32 per pixel) */
    double centre = img.pixels[4 * ((size_t)(RES / 2) * RES + 38)] * M_PI / ALBEDO;
    print_message("spot %s: power %.5f (expected %.5f), centre irradiance %.5f (expected %g)\n",
                  params, power, expect, centre, intensity);
    op_image_free(&img);
    if (fabs(power - expect) > 0.005 * expect)
        fail_msg("spot %s: power on the plane %.5f, expected %.5f", params, power, expect);
    if (fabs(centre - intensity) > 2e-3 * intensity) /* cos^3 within the pixel: 6e-4 */
        fail_msg("spot %s: irradiance under the beam %.5f, expected %g", params, centre,
                 intensity);
}

static void test_spot(void **state)
{
    (void)state;
    check_spot("", 2.0, 20.0, 15.0); /* Mitsuba's defaults: cutoff 20, beamWidth 3/4 of it */
    check_spot("<float name=\"cutoffAngle\" value=\"30\"/><float name=\"beamWidth\" value=\"10\"/>",
               1.5, 30.0, 10.0);
}

static void test_collimated(void **state)
{
    (void)state;
    const char *spot = "<emitter type=\"spot\"><transform name=\"toWorld\"><lookat "
                       "origin=\"0,0,1\" target=\"0,0,0\" up=\"0,1,0\"/></transform></emitter>";
    char both[2048];
    snprintf(both, sizeof both,
             "%s<emitter type=\"collimated\"><rgb name=\"power\" value=\"100\"/>"
             "<transform name=\"toWorld\"><lookat origin=\"0.1,0,2\" target=\"0.1,0,0\" "
             "up=\"0,1,0\"/></transform></emitter>",
             spot);
    op_image a = op_test_render_image(op_test_plane_scene(RES, ALBEDO, spot), 4, 2, 0);
    op_image b = op_test_render_image(op_test_plane_scene(RES, ALBEDO, both), 4, 2, 0);
    double diff = op_test_image_rmse(&a, &b), mean = image_mean(&a);
    op_image_free(&a);
    op_image_free(&b);
    if (!(mean > 0.0) || diff > 1e-6 * mean)
        fail_msg("a collimated beam changed the image (rmse %g, mean %g)", diff, mean);
}

static void test_sun_position(void **state)
{
    (void)state;
    double theta, phi;
    /* the March 2010 equinox was on the 20th at 17:32 UT: at noon UT over (0, 0) the sun is
     * within a degree of the declination 0 and of the meridian (equation of time -7 min) */
    op_sun_position(2010, 3, 20, 12.0, 7.5, 0.0, 0.0, 0.0, 0.0, &theta, &phi);
    print_message("equinox noon at (0, 0): zenith angle %.3f degrees\n", theta * 180.0 / M_PI);
    assert_true(theta * 180.0 / M_PI < 1.0);
    /* the June solstice (21 June 2010, 11:28 UT) at the tropic of Cancer, local noon at
     * longitude 0 in UTC: overhead; at the equator: 23.44 degrees to the north (azimuth 0) */
    op_sun_position(2010, 6, 21, 12.0, 1.5, 0.0, 23.44, 0.0, 0.0, &theta, &phi);
    assert_true(theta * 180.0 / M_PI < 1.0);
    op_sun_position(2010, 6, 21, 12.0, 1.5, 0.0, 0.0, 0.0, 0.0, &theta, &phi);
    assert_true(fabs(theta * 180.0 / M_PI - 23.44) < 0.5);
    assert_true(phi < 0.05 || phi > 2.0 * M_PI - 0.05);
    /* 8 am at the equinox: 60 degrees from the zenith, in the east (azimuth 90: +x) */
    op_sun_position(2010, 3, 20, 8.0, 7.5, 0.0, 0.0, 0.0, 0.0, &theta, &phi);
    assert_true(fabs(theta * 180.0 / M_PI - 60.0) < 1.0 && fabs(phi - 0.5 * M_PI) < 0.02);
}

static void test_sky(void **state)
{
    (void)state;
    const char *sky = "<emitter type=\"sky\"><float name=\"turbidity\" value=\"4.5\"/>"
                      "<float name=\"hour\" value=\"10\"/><float name=\"scale\" value=\"2\"/>"
                      "<transform name=\"toWorld\"><rotate x=\"1\" angle=\"90\"/></transform>"
                      "</emitter>"; /* the sky's +y up turned to the plane's +z */
    op_image img = op_test_render_image(op_test_plane_scene(RES, ALBEDO, sky), 16, 2, 0);
    double got[3] = {0, 0, 0};
    for (size_t i = 0; i < (size_t)RES * RES; i++)
        for (int c = 0; c < 3; c++)
            got[c] += img.pixels[4 * i + c] * M_PI / ALBEDO / ((double)RES * RES);
    op_image_free(&img);
    /* the model itself: Mitsuba's defaults but for turbidity, hour and scale (Tokyo, 10 July
     * 2010, 10 am), the upper hemisphere's cosine-weighted integral by the midpoint rule */
    double theta, phi, albedo[3] = {0.2, 0.2, 0.2}, expect[3] = {0, 0, 0};
    op_sun_position(2010, 7, 10, 10.0, 0.0, 0.0, 35.6894, 139.6917, 9.0, &theta, &phi);
    op_sky_model m;
    op_sky_model_init(&m, 4.5, albedo, theta, phi);
    m.scale = 2.0;
    const int nt = 600, np = 1200;
    for (int i = 0; i < nt; i++) {
        double t = 0.5 * M_PI * (i + 0.5) / nt;
        for (int j = 0; j < np; j++) {
            double rgb[3];
            op_sky_radiance(&m, t, 2.0 * M_PI * (j + 0.5) / np, rgb);
            for (int c = 0; c < 3; c++)
                expect[c] += rgb[c] * cos(t) * sin(t) * (0.5 * M_PI / nt) * (2.0 * M_PI / np);
        }
    }
    for (int c = 0; c < 3; c++) {
        print_message("sky irradiance, channel %d: %.5f (model %.5f)\n", c, got[c], expect[c]);
        if (!(expect[c] > 0.0) || fabs(got[c] - expect[c]) > 0.005 * expect[c])
            fail_msg("sky irradiance channel %d: %.5f, the model integrates to %.5f", c, got[c],
                     expect[c]);
    }
}

static void test_projector(void **state)
{
    (void)state;
    const double z = 1.5, half = z * tan(20.0 * M_PI / 180.0), irr = 0.8, scale = 1.25;
    char light[1024];
    snprintf(light, sizeof light,
             "<emitter type=\"projector\"><float name=\"fov\" value=\"40\"/>"
             "<rgb name=\"irradiance\" value=\"%g\"/><float name=\"scale\" value=\"%g\"/>"
             "<transform name=\"toWorld\"><lookat origin=\"0.2,0,%g\" target=\"0.2,0,0\" "
             "up=\"0,1,0\"/></transform></emitter>",
             irr, scale, z);
    op_image img = op_test_render_image(op_test_plane_scene(RES, ALBEDO, light), 16, 2, 0);
    double lit = ALBEDO * scale * irr / (z * z); /* rho / pi * pi scale E / z^2 */
    double mean = image_mean(&img), expect = lit * (2.0 * half) * (2.0 * half) / 4.0;
    /* the footprint's centre (0.2, 0) is column 38, row 32 (x to the right, y up) */
    double centre = img.pixels[4 * ((size_t)32 * RES + 38)];
    double corner = img.pixels[4 * ((size_t)2 * RES + 2)];
    op_image_free(&img);
    print_message("projector: mean %.5f (expected %.5f), centre %.6f (expected %.6f)\n", mean,
                  expect, centre, lit);
    if (fabs(centre - lit) > 1e-5 * lit || corner != 0.0)
        fail_msg("projector: %g inside (expected %g), %g outside", centre, lit, corner);
    if (fabs(mean - expect) > 0.01 * expect)
        fail_msg("projector: image mean %.5f, expected %.5f from the footprint", mean, expect);
}

static void expect_refused(const char *lights, const char *words)
{
    op_scene *scene = NULL;
    op_error err = {0};
    op_status st = op_scene_load(op_test_plane_scene(RES, ALBEDO, lights), NULL, 0, &scene, &err);
    op_scene_free(scene);
    if (st != OP_ERR_INPUT || !strstr(err.message, words))
        fail_msg("expected a refusal naming \"%s\", got %s: %s", words, op_status_name(st),
                 err.message);
}

static void test_refusals(void **state)
{
    (void)state;
    expect_refused("<emitter type=\"directional\"><vector name=\"direction\" value=\"0,0,-1\"/>"
                   "<transform name=\"toWorld\"><rotate x=\"1\" angle=\"10\"/></transform>"
                   "</emitter>",
                   "direction or toWorld");
    expect_refused("<emitter type=\"sky\"><float name=\"hour\" value=\"2\"/></emitter>",
                   "below the horizon");
    expect_refused("<emitter type=\"sky\"><vector name=\"sunDirection\" value=\"0,1,0\"/>"
                   "<float name=\"latitude\" value=\"10\"/></emitter>",
                   "sunDirection or the time and place");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_spot),
        cmocka_unit_test(test_collimated),
        cmocka_unit_test(test_sun_position),
        cmocka_unit_test(test_sky),
        cmocka_unit_test(test_projector),
        cmocka_unit_test(test_refusals),
    };
    return op_test_exit_status(cmocka_run_group_tests(tests, NULL, NULL));
}
