/* test_render_textured_emitters.c - a spot's projected texture and a projector's textured
 * irradiance against closed forms. An orthographic sensor looking straight down at a diffuse
 * plane shows rho / pi times the irradiance at each pixel's point. The textures are 8-bit PNGs
 * looked up by their nearest texel, so each texel lights a region of its own:
 * - spot (Mitsuba's `texture`): the irradiance at a point is I T(u, v) falloff(theta) cos / d^2,
 *   the direction's toWorld coordinates (x, y, z) giving u = 1/2 + x / (2 z tan(cutoffAngle)),
 *   v = 1/2 + y / (2 z tan(cutoffAngle)) (v = 0 the image's top row), and nothing outside the
 *   cutoff cone;
 * - projector (Mitsuba 3's textured `irradiance`): a plane facing it at distance z receives
 *   pi scale E(u, v) / z^2 with u = 1/2 - x / (2 z tan_x), v = 1/2 - y / (2 z tan_y), the frustum
 *   having the image's aspect ratio (fov along x: tan_y = tan_x height / width), nothing outside;
 *   the image's mean is that irradiance over the footprint;
 * - an irradiance given both as a colour and as a texture is refused.
 * The toWorld axes are Mitsuba's lookat: X = up x dir, Y = dir x X, Z = dir. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "opaline_render.h"
#include "scene/scene_color.h"
#include "test_support.h"

#define RES 64
#define ALBEDO 0.5

/* Writes an 8-bit PNG holding exactly bytes (w x h, RGB, rows from the top) and returns its
 * path; texel[] gets the linear values they stand for. */
static const char *write_png(int w, int h, const unsigned char *bytes, double *texel)
{
    const char *path = op_test_tmp_path("texture.png");
    op_error err = {0};
    op_image img;
    OP_ASSERT_OK(op_image_alloc(&img, w, h, 3, &err), err);
    for (int i = 0; i < 3 * w * h; i++) {
        texel[i] = op_srgb_to_linear(bytes[i] / 255.0);
        img.pixels[i] = (float)texel[i];
    }
    OP_ASSERT_OK(op_image_write_png(path, &img, 0.0f, &err), err);
    op_image_free(&img);
    return path;
}

/* The centre of pixel (i, j) on the plane. */
static void pixel_point(int i, int j, double *x, double *y)
{
    *x = -1.0 + (i + 0.5) * 2.0 / RES;
    *y = 1.0 - (j + 0.5) * 2.0 / RES;
}

/* Whether a pixel's square around (x, y) may reach the line c = 0 (margin: its diagonal). */
static int near(double c)
{
    return fabs(c) < 1.5 * 2.0 / RES;
}

/* Mitsuba's spot falloff at angle t (radians) from the axis. */
static double falloff(double t, double cutoff, double beam)
{
    return t >= cutoff ? 0.0 : t <= beam ? 1.0 : (cutoff - t) / (cutoff - beam);
}

static void test_spot_texture(void **state)
{
    (void)state;
    /* rows from the top: red, green / blue, grey */
    static const unsigned char bytes[12] = {200, 30, 0, 0, 150, 60, 20, 0, 250, 100, 110, 120};
    double texel[12];
    const char *png = write_png(2, 2, bytes, texel);
    const double intensity = 2.0, h = 1.0, cutoff = 40.0 * M_PI / 180.0,
                 beam = 30.0 * M_PI / 180.0;
    char light[2048];
    snprintf(light, sizeof light,
             "<emitter type=\"spot\"><transform name=\"toWorld\"><lookat origin=\"0,0,%g\" "
             "target=\"0,0,0\" up=\"0,1,0\"/></transform><rgb name=\"intensity\" value=\"%g\"/>"
             "<float name=\"cutoffAngle\" value=\"40\"/><float name=\"beamWidth\" value=\"30\"/>"
             "<texture type=\"bitmap\" name=\"texture\"><string name=\"filename\" value=\"%s\"/>"
             "<string name=\"filterType\" value=\"nearest\"/></texture></emitter>",
             h, intensity, png);
    op_image img = op_test_render_image(op_test_plane_scene(RES, ALBEDO, light), 16, 2, 0);
    double worst = 0.0;
    int checked = 0, dark = 0;
    for (int j = 0; j < RES; j++)
        for (int i = 0; i < RES; i++) {
            double x, y;
            pixel_point(i, j, &x, &y);
            double r = hypot(x, y), t = atan2(r, h);
            double rc = h * tan(cutoff), rb = h * tan(beam);
            const float *px = img.pixels + 4 * ((size_t)j * RES + i);
            if (r > rc + 2.0 * 2.0 / RES) { /* beyond the cone */
                dark += px[0] == 0.0f && px[1] == 0.0f && px[2] == 0.0f;
                if (px[0] != 0.0f || px[1] != 0.0f || px[2] != 0.0f)
                    fail_msg("spot: pixel (%d, %d) outside the cone is lit", i, j);
                continue;
            }
            if (near(x) || near(y) || near(r - rc) || near(r - rb))
                continue; /* texel edges and the falloff's kinks */
            /* the direction to the point in toWorld's axes: X = -x, Y = y, Z = h */
            double u = 0.5 + -x / (2.0 * h * tan(cutoff)), v = 0.5 + y / (2.0 * h * tan(cutoff));
            int col = u < 0.5 ? 0 : 1, row = v < 0.5 ? 0 : 1;
            double d2 = r * r + h * h, cos_t = h / sqrt(d2);
            for (int c = 0; c < 3; c++) {
                /* a pixel's mean against its centre's value, relative to the value before the
                 * falloff: within 3e-3 under the beam, 2e-2 where the falloff drops 4 per unit
                 * of radius (16 samples place a pixel's mean to about a percent of that) */
                double full = ALBEDO / M_PI * intensity * texel[3 * (2 * row + col) + c] *
                              cos_t / d2;
                double want = full * falloff(t, cutoff, beam), got = px[c];
                double rel = fabs(got - want) / full;
                worst = fmax(worst, r < rb ? rel : 0.0);
                if (rel > (r < rb ? 3e-3 : 2e-2))
                    fail_msg("spot: pixel (%d, %d) channel %d: %g, expected %g (texel %d, %d)", i,
                             j, c, got, want, col, row);
            }
            checked++;
        }
    op_image_free(&img);
    print_message("spot texture: %d pixels as expected (worst under the beam %.2e), %d dark "
                  "outside\n", checked, worst, dark);
    assert_true(checked > 500 && dark > 1000);
}

static void test_projector_texture(void **state)
{
    (void)state;
    /* one row: left texel, right texel */
    static const unsigned char bytes[6] = {220, 40, 90, 30, 180, 250};
    double texel[6];
    const char *png = write_png(2, 1, bytes, texel);
    const double z = 1.5, cx = 0.2, scale = 1.25, tan_x = tan(25.0 * M_PI / 180.0);
    const double tan_y = tan_x / 2.0; /* a 2 x 1 image */
    char light[2048];
    snprintf(light, sizeof light,
             "<emitter type=\"projector\"><float name=\"fov\" value=\"50\"/>"
             "<float name=\"scale\" value=\"%g\"/><texture type=\"bitmap\" name=\"irradiance\">"
             "<string name=\"filename\" value=\"%s\"/><string name=\"filterType\" "
             "value=\"nearest\"/></texture><transform name=\"toWorld\"><lookat "
             "origin=\"%g,0,%g\" target=\"%g,0,0\" up=\"0,1,0\"/></transform></emitter>",
             scale, png, cx, z, cx);
    op_image img = op_test_render_image(op_test_plane_scene(RES, ALBEDO, light), 16, 2, 0);
    double sum[3] = {0, 0, 0}, worst = 0.0;
    int checked = 0, outside = 0;
    for (int j = 0; j < RES; j++)
        for (int i = 0; i < RES; i++) {
            double x, y;
            pixel_point(i, j, &x, &y);
            const float *px = img.pixels + 4 * ((size_t)j * RES + i);
            for (int c = 0; c < 3; c++)
                sum[c] += px[c];
            double ex = fabs(x - cx) - z * tan_x, ey = fabs(y) - z * tan_y;
            if (near(ex) || near(ey) || near(x - cx))
                continue;
            if (ex > 0.0 || ey > 0.0) {
                outside++;
                if (px[0] != 0.0f || px[1] != 0.0f || px[2] != 0.0f)
                    fail_msg("projector: pixel (%d, %d) outside the frustum is lit", i, j);
                continue;
            }
            /* toWorld's X is -x: u = 1/2 + (x - cx) / (2 z tan_x) */
            int col = 0.5 + (x - cx) / (2.0 * z * tan_x) < 0.5 ? 0 : 1;
            for (int c = 0; c < 3; c++) {
                double want = ALBEDO / M_PI * M_PI * scale * texel[3 * col + c] / (z * z);
                double rel = fabs(px[c] - want) / want;
                worst = fmax(worst, rel);
                if (rel > 1e-5)
                    fail_msg("projector: pixel (%d, %d) channel %d: %g, expected %g (texel %d)",
                             i, j, c, px[c], want, col);
            }
            checked++;
        }
    op_image_free(&img);
    print_message("projector texture: %d pixels within 1e-5 (worst %.2e), %d dark outside\n",
                  checked, worst, outside);
    assert_true(checked > 400 && outside > 1000);
    /* the footprint 2 z tan_x by 2 z tan_y of the sensor's 2 x 2, each half its texel's */
    for (int c = 0; c < 3; c++) {
        double mean = sum[c] / ((double)RES * RES);
        double expect = ALBEDO * scale / (z * z) * 0.5 * (texel[c] + texel[3 + c]) *
                        (2.0 * z * tan_x) * (2.0 * z * tan_y) / 4.0;
        print_message("projector channel %d: image mean %.5f, expected %.5f\n", c, mean, expect);
        if (fabs(mean - expect) > 0.01 * expect)
            fail_msg("projector channel %d: image mean %.5f, expected %.5f", c, mean, expect);
    }
}

static void test_refusals(void **state)
{
    (void)state;
    op_scene *scene = NULL;
    op_error err = {0};
    const char *path = op_test_plane_scene(RES, ALBEDO, 
        "<emitter type=\"projector\"><rgb name=\"irradiance\" value=\"1\"/>"
        "<texture type=\"checkerboard\" name=\"irradiance\"/></emitter>");
    op_status st = op_scene_load(path, NULL, 0, &scene, &err);
    op_scene_free(scene);
    if (st != OP_ERR_INPUT || !strstr(err.message, "both as a colour and as a texture"))
        fail_msg("expected a refusal of a colour and a texture, got %s: %s", op_status_name(st),
                 err.message);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_spot_texture),
        cmocka_unit_test(test_projector_texture),
        cmocka_unit_test(test_refusals),
    };
    return op_test_exit_status(cmocka_run_group_tests(tests, NULL, NULL));
}
