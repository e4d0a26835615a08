/* test_render_cylinder.c - Mitsuba's cylinder shape: an open tube (no caps) from p0 to p1 of
 * the given radius, normals outward unless flipNormals.
 * - Seen from the side by an orthographic sensor, an emitting tube from (-1, 0, 0) to
 *   (1, 0, 0) of radius 0.5 covers exactly the 2 x 1 rectangle of its projected area, and its
 *   surface area is the tessellation's share (sin(pi/N) / (pi/N)) of 2 pi r L.
 * - Seen from its axis by a perspective sensor, the default tube (p0 = 0, p1 = (0, 0, 1),
 *   radius 1, black so that only emission is seen) shows its inner wall, emitting with
 *   flipNormals and black without, between the angles of its near and far openings, and
 *   nothing through the far opening (no cap). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "opaline_render.h"
#include "scene/describe.h"
#include "test_support.h"

static void test_side_view(void **state)
{
    (void)state;
    const char *text =
        "<scene version=\"0.6.0\"><sensor type=\"orthographic\"><transform name=\"toWorld\">"
        " <scale x=\"2\" y=\"2\"/><lookat origin=\"0,0,5\" target=\"0,0,0\" up=\"0,1,0\"/>"
        " </transform><sampler type=\"independent\"/><film type=\"hdrfilm\">"
        " <integer name=\"width\" value=\"64\"/><integer name=\"height\" value=\"32\"/>"
        " <rfilter type=\"box\"/></film></sensor>"
        "<shape type=\"cylinder\"><point name=\"p0\" value=\"-1,0,0\"/>"
        " <point name=\"p1\" value=\"1,0,0\"/><float name=\"radius\" value=\"0.5\"/>"
        " <emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter></shape></scene>";
    const char *path = op_test_write_temp("scene.xml", text);
    op_image img = op_test_render_image(path, 4, 2, 0);
    /* x in [-1, 1]: columns 16..47; y in [-0.5, 0.5]: rows 8..23 */
    int wrong = 0;
    for (int y = 0; y < 32; y++)
        for (int x = 0; x < 64; x++) {
            int inside = x >= 16 && x < 48 && y >= 8 && y < 24;
            if (fabsf(img.pixels[4 * ((size_t)y * 64 + x)] - (inside ? 1.0f : 0.0f)) > 1e-6f &&
                wrong++ < 5)
                print_message("pixel (%d, %d): %g\n", x, y, img.pixels[4 * ((size_t)y * 64 + x)]);
        }
    op_image_free(&img);
    if (wrong)
        fail_msg("%d pixels differ from the tube's projected 2 x 1 rectangle", wrong);

    op_scene *scene = NULL;
    op_error err = {0};
    op_status st = op_scene_load(path, NULL, 0, &scene, &err);
    OP_ASSERT_OK(st, err);
    double n = OP_CYLINDER_SEGMENTS;
    double expect = 2.0 * M_PI * 0.5 * 2.0 * sin(M_PI / n) / (M_PI / n);
    double area = scene->shapes[0].mesh.area;
    op_scene_free(scene);
    if (fabs(area - expect) > 1e-5 * expect)
        fail_msg("tube area %.7f, expected %.7f", area, expect);
}

/* The default tube seen along its axis from (0, 0, -1) by a 64 x 64 perspective sensor of
 * fov 120; returns how many pixels differ from the expected inner-wall ring. */
static int axis_view(int flip)
{
    char text[2048];
    snprintf(text, sizeof text,
             "<scene version=\"0.6.0\"><sensor type=\"perspective\"><float name=\"fov\" "
             "value=\"120\"/><transform name=\"toWorld\"><lookat origin=\"0,0,-1\" "
             "target=\"0,0,0\" up=\"0,1,0\"/></transform><sampler type=\"independent\"/>"
             "<film type=\"hdrfilm\"><integer name=\"width\" value=\"64\"/>"
             "<integer name=\"height\" value=\"64\"/><rfilter type=\"box\"/></film></sensor>"
             "<shape type=\"cylinder\"><boolean name=\"flipNormals\" value=\"%s\"/>"
             "<emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter>"
             "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0\"/></bsdf></shape>"
             "</scene>",
             flip ? "true" : "false");
    op_image img = op_test_render_image(op_test_write_temp("scene.xml", text), 1, 2, 0);
    const double t = tan(60.0 * M_PI / 180.0), near = 26.565, far = 45.0; /* degrees */
    int wrong = 0, lit = 0;
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < 64; x++) {
            /* the angle from the axis of the pixel's corners: skip pixels it spans a boundary */
            double lo = 90.0, hi = 0.0;
            for (int k = 0; k < 4; k++) {
                double sx = (2.0 * (x + (k & 1)) / 64.0 - 1.0) * t;
                double sy = (2.0 * (y + (k >> 1)) / 64.0 - 1.0) * t;
                double a = atan(sqrt(sx * sx + sy * sy)) * 180.0 / M_PI;
                lo = fmin(lo, a);
                hi = fmax(hi, a);
            }
            double v = img.pixels[4 * ((size_t)y * 64 + x)];
            int ring = lo > near + 0.5 && hi < far - 0.5;
            int outside = hi < near - 0.5 || lo > far + 0.5;
            if (!ring && !outside)
                continue;
            double expect = ring && flip ? 1.0 : 0.0;
            lit += expect > 0.0;
            if (fabs(v - expect) > 1e-6 && wrong++ < 5)
                print_message("flip %d, pixel (%d, %d) at %.1f..%.1f degrees: %g\n", flip, x, y,
                              lo, hi, v);
        }
    op_image_free(&img);
    if (flip && lit < 500)
        fail_msg("only %d ring pixels checked", lit);
    return wrong;
}

static void test_axis_view(void **state)
{
    (void)state;
    int w1 = axis_view(1), w0 = axis_view(0);
    if (w1 || w0)
        fail_msg("%d (flipNormals) and %d (outward normals) pixels differ from the open tube's "
                 "inner wall",
                 w1, w0);
}

static void test_degenerate(void **state)
{
    (void)state;
    op_scene *scene = NULL;
    op_error err = {0};
    op_status st = op_scene_load(
        op_test_write_temp("scene.xml", "<scene version=\"0.6.0\"><shape type=\"cylinder\">"
                                        "<point name=\"p1\" value=\"0,0,0\"/></shape></scene>"),
        NULL, 0, &scene, &err);
    op_scene_free(scene);
    assert_int_equal(st, OP_ERR_INPUT);
    assert_non_null(strstr(err.message, "cylinder"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_side_view),
        cmocka_unit_test(test_axis_view),
        cmocka_unit_test(test_degenerate),
    };
    return op_test_exit_status(cmocka_run_group_tests(tests, NULL, NULL));
}
