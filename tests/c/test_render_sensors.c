/* test_render_sensors.c - Mitsuba's sensors against closed forms.
 * - focalLength: a 36 x 24 film's focal length f gives a field of view along x of
 *   2 atan(18 / f) exactly when the image has the film's 3 : 2 aspect, and the scene's
 *   focalLength reaches the camera that way; fov and focalLength together are refused.
 * - orthographic: the sensor plane is [-1, 1] x [-h/w, h/w] scaled by toWorld, +X to the left
 *   of the image: an emitting rectangle whose edges lie on pixel boundaries covers exactly its
 *   pixels, and a diffuse plane under a directional light shows rho E cos / pi in every pixel.
 * - thinlens: with apertureRadius 0 its rays are the perspective sensor's; with an aperture,
 *   a plane at the focus distance stays sharp and one off focus blurs an edge into the
 *   convolution with the circle of confusion (radius A |D - F| / F on the plane at D).
 * - radiancemeter: every pixel is the one ray's radiance. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "camera/camera.h"
#include "opaline_render.h"
#include "scene/describe.h"
#include "test_support.h"

/* The camera of the scene text (describing it only). */
static op_camera describe_camera(const char *text)
{
    op_scene_description *d = NULL;
    op_error err = {0};
    op_status st = op_scene_describe(op_test_write_temp("scene.xml", text), NULL, 0, NULL, &d,
                                     &err);
    OP_ASSERT_OK(st, err);
    op_camera cam = d->camera;
    op_scene_description_free(d);
    return cam;
}

static op_status describe_status(const char *text, op_error *err)
{
    op_scene_description *d = NULL;
    op_status st = op_scene_describe(op_test_write_temp("scene.xml", text), NULL, 0, NULL, &d,
                                     err);
    op_scene_description_free(d);
    return st;
}

static void test_focal_length(void **state)
{
    (void)state;
    const double f[] = {20.0, 35.0, 50.0, 85.0};
    for (int i = 0; i < 4; i++) {
        double fov = op_camera_fov_from_focal_length(f[i], 360, 240);
        double expect = 2.0 * atan(18.0 / f[i]) * 180.0 / M_PI;
        if (fabs(fov - expect) > 1e-9)
            fail_msg("%g mm on a 3:2 image: fov %.12f, expected %.12f", f[i], fov, expect);
    }
    /* a square image: the 43.27 mm diagonal's field of view on the image's diagonal */
    double sq = op_camera_fov_from_focal_length(50.0, 100, 100);
    double half_diag = sqrt(36.0 * 36.0 + 24.0 * 24.0) / 100.0;
    double expect = 2.0 * atan(half_diag / sqrt(2.0)) * 180.0 / M_PI;
    if (fabs(sq - expect) > 1e-9 || fabs(sq - 34.02) > 0.01)
        fail_msg("50 mm on a square image: fov %.6f, expected %.6f", sq, expect);

    op_camera cam = describe_camera(
        "<scene version=\"0.6.0\"><sensor type=\"perspective\">"
        "<string name=\"focalLength\" value=\"50mm\"/><film type=\"hdrfilm\">"
        "<integer name=\"width\" value=\"300\"/><integer name=\"height\" value=\"200\"/></film>"
        "</sensor></scene>");
    assert_true(fabs(cam.tan_x - 0.36) < 1e-6 && fabs(cam.tan_y - 0.24) < 1e-6);
    cam = describe_camera(
        "<scene version=\"0.6.0\"><sensor type=\"thinlens\">"
        "<string name=\"focalLength\" value=\"25\"/><float name=\"apertureRadius\" value=\"0\"/>"
        "<film type=\"hdrfilm\"><integer name=\"width\" value=\"300\"/>"
        "<integer name=\"height\" value=\"200\"/></film></sensor></scene>");
    assert_true(fabs(cam.tan_x - 0.72) < 1e-6 && fabs(cam.tan_y - 0.48) < 1e-6);
    /* fov along y on the same film */
    cam = describe_camera(
        "<scene version=\"0.6.0\"><sensor type=\"perspective\"><float name=\"fov\" value=\"90\"/>"
        "<string name=\"fovAxis\" value=\"y\"/><film type=\"hdrfilm\">"
        "<integer name=\"width\" value=\"300\"/><integer name=\"height\" value=\"200\"/></film>"
        "</sensor></scene>");
    assert_true(fabs(cam.tan_y - 1.0) < 1e-6 && fabs(cam.tan_x - 1.5) < 1e-6);

    op_error err = {0};
    assert_int_equal(describe_status("<scene version=\"0.6.0\"><sensor type=\"perspective\">"
                                     "<string name=\"focalLength\" value=\"50mm\"/>"
                                     "<float name=\"fov\" value=\"40\"/></sensor></scene>",
                                     &err),
                     OP_ERR_INPUT);
    assert_non_null(strstr(err.message, "either fov or focalLength"));
    assert_int_equal(describe_status("<scene version=\"0.6.0\"><sensor type=\"perspective\">"
                                     "<string name=\"focalLength\" value=\"fifty\"/></sensor>"
                                     "</scene>",
                                     &err),
                     OP_ERR_INPUT);
    assert_non_null(strstr(err.message, "focalLength"));
    assert_int_equal(describe_status("<scene version=\"0.6.0\"><sensor type=\"thinlens\">"
                                     "</sensor></scene>",
                                     &err),
                     OP_ERR_INPUT);
    assert_non_null(strstr(err.message, "apertureRadius"));
}

/* An orthographic sensor of half width 2 over 64 x 32 pixels (so [-2, 2] x [-1, 1], a
 * sixteenth of a unit per pixel) looking down -z from height 5 at what `body` holds. */
static op_image render_ortho(const char *body, int spp)
{
    char text[4096];
    int n = snprintf(
        text, sizeof text,
        "<scene version=\"0.6.0\"><sensor type=\"orthographic\">"
        " <transform name=\"toWorld\"><scale x=\"2\" y=\"2\"/>"
        "  <lookat origin=\"0,0,5\" target=\"0,0,0\" up=\"0,1,0\"/></transform>"
        " <sampler type=\"independent\"/><film type=\"hdrfilm\">"
        "  <integer name=\"width\" value=\"64\"/><integer name=\"height\" value=\"32\"/>"
        "  <rfilter type=\"box\"/></film></sensor>%s</scene>",
        body);
    assert_true(n > 0 && n < (int)sizeof text);
    return op_test_render_image(op_test_write_temp("scene.xml", text), spp, 2, 0);
}

static void test_orthographic(void **state)
{
    (void)state;
    /* an emitting rectangle over x in [0.5, 1.5], y in [-0.5, 0.25] */
    op_image img = render_ortho(
        "<shape type=\"rectangle\"><transform name=\"toWorld\"><scale x=\"0.5\" y=\"0.375\"/>"
        " <translate x=\"1\" y=\"-0.125\"/></transform>"
        " <emitter type=\"area\"><rgb name=\"radiance\" value=\"2\"/></emitter></shape>",
        4);
    /* lookat from +z down to the origin with up +y: camera +X is world -x, so world x grows
     * to the right; world x in [0.5, 1.5] is columns 40..55, y in [-0.5, 0.25] rows 12..23 */
    int wrong = 0;
    for (int y = 0; y < 32; y++)
        for (int x = 0; x < 64; x++) {
            int inside = x >= 40 && x < 56 && y >= 12 && y < 24;
            float v = img.pixels[4 * ((size_t)y * 64 + x)];
            if (fabsf(v - (inside ? 2.0f : 0.0f)) > 1e-6f) {
                if (wrong++ < 5)
                    print_message("pixel (%d, %d): %g, expected %g\n", x, y, v,
                                  inside ? 2.0 : 0.0);
            }
        }
    op_image_free(&img);
    if (wrong)
        fail_msg("%d pixels differ from the rectangle's exact footprint", wrong);

    /* a diffuse plane (albedo 0.5) under a directional light of irradiance 3 at 60 degrees:
     * rho E cos(60) / pi everywhere */
    img = render_ortho(
        "<shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"10\"/></transform>"
        " <bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.5\"/></bsdf></shape>"
        "<emitter type=\"directional\"><vector name=\"direction\" value=\"0.8660254037844386,"
        "0,-0.5\"/><rgb name=\"irradiance\" value=\"3\"/></emitter>",
        1);
    double expect = 0.5 * 3.0 * 0.5 / M_PI, worst = 0.0;
    for (size_t i = 0; i < (size_t)64 * 32; i++)
        worst = fmax(worst, fabs(img.pixels[4 * i] - expect));
    op_image_free(&img);
    if (worst > 1e-5 * expect)
        fail_msg("orthographic Lambert plane: worst deviation %g from %g", worst, expect);
}

static void test_thinlens_zero_aperture(void **state)
{
    (void)state;
    const char *fmt = "<scene version=\"0.6.0\"><sensor type=\"%s\"><float name=\"fov\" "
                      "value=\"50\"/>%s<transform name=\"toWorld\"><lookat origin=\"1,2,3\" "
                      "target=\"0,0.5,0\" up=\"0,1,0\"/></transform><film type=\"hdrfilm\">"
                      "<integer name=\"width\" value=\"40\"/><integer name=\"height\" "
                      "value=\"30\"/></film></sensor></scene>";
    char a[2048], b[2048];
    snprintf(a, sizeof a, fmt, "perspective", "");
    snprintf(b, sizeof b, fmt, "thinlens", "<float name=\"apertureRadius\" value=\"0\"/>"
                                           "<float name=\"focusDistance\" value=\"2.5\"/>");
    op_camera p = describe_camera(a), t = describe_camera(b);
    assert_int_equal(op_camera_lens_dims(&p), 0);
    assert_int_equal(op_camera_lens_dims(&t), 2);
    for (int k = 0; k < 200; k++) {
        float fx = 40.0f * (float)((k * 37) % 101) / 101.0f, fy = 30.0f * (float)((k * 53) % 97) / 97.0f;
        float lu = (float)((k * 29) % 89) / 89.0f, lv = (float)((k * 17) % 83) / 83.0f;
        op_v3 o1, d1, o2, d2;
        float n1, f1, n2, f2;
        op_camera_ray(&p, fx, fy, &o1, &d1, &n1, &f1);
        op_camera_ray_lens(&t, fx, fy, lu, lv, &o2, &d2, &n2, &f2);
        if (v3_len(v3_sub(o1, o2)) > 1e-6f || v3_len(v3_sub(d1, d2)) > 1e-6f ||
            fabsf(n1 - n2) > 1e-6f * n1 || fabsf(f1 - f2) > 1e-6f * f1)
            fail_msg("ray %d: thinlens with aperture 0 differs from perspective", k);
    }
}

/* The fraction of a disk of radius 1 beyond a chord at signed distance d from its centre. */
static double disk_beyond(double d)
{
    if (d >= 1.0)
        return 0.0;
    if (d <= -1.0)
        return 1.0;
    return (acos(d) - d * sqrt(1.0 - d * d)) / M_PI;
}

/* A thin lens (aperture 0.2, focus 4, fov 20) looks down at an emitting half plane x > 0 at
 * distance D; returns the image's middle row, averaged over the rows. */
static void edge_profile(double plane_dist, double *row)
{
    char text[4096];
    snprintf(text, sizeof text,
             "<scene version=\"0.6.0\"><sensor type=\"thinlens\"><float name=\"fov\" value=\"20\"/>"
             "<float name=\"apertureRadius\" value=\"0.2\"/><float name=\"focusDistance\" "
             "value=\"4\"/><transform name=\"toWorld\"><lookat origin=\"0,0,%g\" target=\"0,0,0\" "
             "up=\"0,1,0\"/></transform><sampler type=\"ldsampler\"/><film type=\"hdrfilm\">"
             "<integer name=\"width\" value=\"64\"/><integer name=\"height\" value=\"4\"/>"
             "<rfilter type=\"box\"/></film></sensor>"
             "<shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"50\"/>"
             "<translate x=\"50\"/></transform><emitter type=\"area\"><rgb name=\"radiance\" "
             "value=\"1\"/></emitter></shape></scene>",
             plane_dist);
    op_image img = op_test_render_image(op_test_write_temp("scene.xml", text), 256, 2, 0);
    for (int x = 0; x < 64; x++) {
        row[x] = 0.0;
        for (int y = 0; y < 4; y++)
            row[x] += img.pixels[4 * ((size_t)y * 64 + x)] / 4.0;
    }
    op_image_free(&img);
}

static void test_thinlens_focus(void **state)
{
    (void)state;
    double row[64];
    const double tan_x = tan(10.0 * M_PI / 180.0);
    /* in focus: one pixel column of transition at most (the edge falls on a pixel boundary) */
    edge_profile(4.0, row);
    for (int x = 0; x < 64; x++)
        if (fabs(row[x] - (x >= 32 ? 1.0 : 0.0)) > 1e-6)
            fail_msg("in focus, column %d: %g", x, row[x]);
    /* at D = 8: blur radius 0.2 * 4 / 4 = 0.2 on the plane; a pixel is 2 D tan_x / 64 wide */
    double D = 8.0, r = 0.2 * (D - 4.0) / 4.0, px = 2.0 * D * tan_x / 64.0, worst = 0.0;
    edge_profile(D, row);
    for (int x = 0; x < 64; x++) {
        /* the pixel's mean of the disk-convolved edge, by the midpoint rule over 64 steps */
        double expect = 0.0;
        for (int k = 0; k < 64; k++) {
            double xw = ((double)x + (k + 0.5) / 64.0 - 32.0) * px;
            expect += (1.0 - disk_beyond(xw / r)) / 64.0;
        }
        worst = fmax(worst, fabs(row[x] - expect));
    }
    print_message("defocused edge: worst deviation %g\n", worst);
    if (worst > 0.02)
        fail_msg("defocused edge differs from the circle of confusion's by %g", worst);
}

static void test_radiancemeter(void **state)
{
    (void)state;
    /* looking down at a diffuse plane (albedo 0.4) under a directional light of irradiance 2
     * straight down; every pixel of a 3 x 2 film is the one ray's rho E / pi */
    const char *text =
        "<scene version=\"0.6.0\"><sensor type=\"radiancemeter\"><transform name=\"toWorld\">"
        "<lookat origin=\"0.3,0.2,2\" target=\"0.5,0,0\"/></transform><film type=\"hdrfilm\">"
        "<integer name=\"width\" value=\"3\"/><integer name=\"height\" value=\"2\"/></film>"
        "</sensor><shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"10\"/>"
        "</transform><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.4\"/></bsdf>"
        "</shape><emitter type=\"directional\"><vector name=\"direction\" value=\"0,0,-1\"/>"
        "<rgb name=\"irradiance\" value=\"2\"/></emitter></scene>";
    op_image img = op_test_render_image(op_test_write_temp("scene.xml", text), 4, 1, 0);
    double expect = 0.4 * 2.0 / M_PI;
    for (int i = 0; i < 6; i++)
        if (fabs(img.pixels[4 * i] - expect) > 1e-5 * expect)
            fail_msg("radiancemeter pixel %d: %g, expected %g", i, img.pixels[4 * i], expect);
    op_image_free(&img);
    /* origin and direction (Mitsuba 3's form) give the same ray as the lookat */
    op_camera a = describe_camera("<scene version=\"0.6.0\"><sensor type=\"radiancemeter\">"
                                  "<point name=\"origin\" value=\"1,2,3\"/><vector "
                                  "name=\"direction\" value=\"0,-2,0\"/></sensor></scene>");
    op_v3 o, d;
    float tmin, tmax;
    op_camera_ray(&a, 100.0f, 7.0f, &o, &d, &tmin, &tmax);
    assert_true(v3_len(v3_sub(o, v3(1, 2, 3))) < 1e-6f && v3_len(v3_sub(d, v3(0, -1, 0))) < 1e-6f);
    assert_true(isinf(tmax));
}

static void test_subsurface_refused(void **state)
{
    (void)state;
    op_error err = {0};
    op_status st = describe_status(
        "<scene version=\"0.6.0\"><sensor type=\"orthographic\"/><shape type=\"sphere\">"
        "<subsurface type=\"dipole\"><string name=\"material\" value=\"skin1\"/></subsurface>"
        "</shape></scene>",
        &err);
    assert_int_equal(st, OP_ERR_INPUT);
    assert_non_null(strstr(err.message, "translucent shapes"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_focal_length),
        cmocka_unit_test(test_orthographic),
        cmocka_unit_test(test_thinlens_zero_aperture),
        cmocka_unit_test(test_thinlens_focus),
        cmocka_unit_test(test_radiancemeter),
        cmocka_unit_test(test_subsurface_refused),
    };
    return op_test_exit_status(cmocka_run_group_tests(tests, NULL, NULL));
}
