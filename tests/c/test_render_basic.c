/* test_render_basic.c - the renderer against closed forms: the white furnace, a Lambertian plane
 * under a point light (which also pins the camera's orientation), and the CLI-facing API. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "opaline_render.h"
#include "test_support.h"

static void test_white_furnace(void **state)
{
    (void)state;
    /* A diffuse sphere of albedo 0.5 inside a uniform environment of radiance 1: every pixel on
     * the sphere is 0.5 (light reflected once leaves the convex sphere for good). */
    const char *path = op_test_write_temp("scene.xml", 
        "<scene version=\"0.6.0\">"
        " <integrator type=\"path\"/>"
        " <sensor type=\"perspective\"><float name=\"fov\" value=\"30\"/>"
        "  <transform name=\"toWorld\"><lookat origin=\"0,0,-5\" target=\"0,0,0\" up=\"0,1,0\"/>"
        "  </transform>"
        "  <film type=\"hdrfilm\"><integer name=\"width\" value=\"24\"/>"
        "   <integer name=\"height\" value=\"24\"/><rfilter type=\"box\"/></film></sensor>"
        " <emitter type=\"constant\"><rgb name=\"radiance\" value=\"1\"/></emitter>"
        " <shape type=\"sphere\"><float name=\"radius\" value=\"1\"/>"
        "  <bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.5\"/></bsdf></shape>"
        "</scene>");
    op_renderer *r = op_test_render(path, 64, 2, 0);
    const op_image *img = op_renderer_image(r);
    assert_non_null(img);
    double sum[3] = {0, 0, 0};
    int n = 0;
    for (int y = 8; y < 16; y++)
        for (int x = 8; x < 16; x++) {
            const float *p = img->pixels + 4 * (y * img->width + x);
            for (int c = 0; c < 3; c++)
                sum[c] += p[c];
            assert_true(fabsf(p[3] - 1.0f) < 1e-6f);
            n++;
        }
    for (int c = 0; c < 3; c++) {
        double mean = sum[c] / n;
        if (fabs(mean - 0.5) > 0.01)
            fail_msg("furnace: channel %d mean %.4f, expected 0.5", c, mean);
    }
    /* the background is the environment itself */
    const float *corner = img->pixels;
    assert_true(fabsf(corner[0] - 1.0f) < 1e-5f && corner[3] == 0.0f);
    op_renderer_free(r);
}

/* A scene seen straight down from z = 4 with up = +y (world +x is to the right of the image and
 * +y up), fov degrees across a 40 x height film (box filter, 16 stratified samples, the direct
 * integrator by default), over a rectangle at z = 0 scaled by scale that carries bsdf, lit by
 * emitter. Returns its path. */
static const char *plane_scene(double fov, int height, double scale, const char *emitter,
                               const char *bsdf)
{
    char text[4096];
    snprintf(text, sizeof text,
             "<scene version=\"0.6.0\">"
             " <sensor type=\"perspective\"><float name=\"fov\" value=\"%g\"/>"
             "  <transform name=\"toWorld\"><lookat origin=\"0,0,4\" target=\"0,0,0\" "
             "   up=\"0,1,0\"/></transform>"
             "  <sampler type=\"stratified\"><integer name=\"sampleCount\" value=\"16\"/>"
             "  </sampler>"
             "  <film type=\"hdrfilm\"><integer name=\"width\" value=\"40\"/>"
             "   <integer name=\"height\" value=\"%d\"/><rfilter type=\"box\"/></film></sensor>"
             " %s"
             " <shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"%g\"/>"
             "  </transform>%s</shape>"
             "</scene>",
             fov, height, emitter, scale, bsdf);
    return op_test_write_temp("scene.xml", text);
}

/* The point (*px, *py, 0) that the centre of pixel (x, y) of a plane_scene image sees. */
static void plane_point(const op_image *img, double fov, int x, int y, double *px, double *py)
{
    double tx = tan(0.5 * fov * M_PI / 180.0), ty = tx * img->height / img->width;
    double sx = 2.0 * (x + 0.5) / img->width - 1.0, sy = 2.0 * (y + 0.5) / img->height - 1.0;
    *px = 4.0 * sx * tx;
    *py = -4.0 * sy * ty;
}

static void test_lambertian_plane(void **state)
{
    (void)state;
    /* A point light at (0.5, 0, 1) of intensity 2 over a plane of albedo 0.6:
     * L(x) = 0.6 / pi * I * h / d^3. The light's offset to +x pins the orientation. */
    const char *path = plane_scene(
        60, 30, 10,
        "<emitter type=\"point\"><point name=\"position\" x=\"0.5\" y=\"0\" z=\"1\"/>"
        " <rgb name=\"intensity\" value=\"2\"/></emitter>",
        "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.6\"/></bsdf>");
    op_renderer *r = op_test_render(path, 0, 2, 0);
    const op_image *img = op_renderer_image(r);
    int w = img->width, h = img->height;
    double worst = 0.0;
    int brightest_x = -1;
    float brightest = -1.0f;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double px, py;
            plane_point(img, 60, x, y, &px, &py);
            double dx = 0.5 - px, dy = -py, d2 = dx * dx + dy * dy + 1.0;
            double expect = 0.6 / M_PI * 2.0 * 1.0 / (d2 * sqrt(d2));
            float got = img->pixels[4 * (y * w + x)];
            double rel = fabs(got - expect) / expect;
            if (rel > worst)
                worst = rel;
            if (got > brightest) {
                brightest = got;
                brightest_x = x;
            }
        }
    /* a pixel averages L over its footprint; the curvature of L makes that ~1 % off centre */
    if (worst > 0.03)
        fail_msg("plane: worst relative error %.4f", worst);
    /* the light is at +x: the brightest pixel is right of centre */
    assert_true(brightest_x > w / 2);
    op_renderer_free(r);
}

static void test_bad_scenes(void **state)
{
    (void)state;
    op_error err = {0};
    op_scene *scene = NULL;
    const char *path = op_test_write_temp("scene.xml", "<scene version=\"0.6.0\">\n"
                                   " <shape type=\"teapot\"/>\n"
                                   "</scene>\n");
    op_status st = op_scene_load(path, NULL, 0, &scene, &err);
    assert_int_equal(st, OP_ERR_INPUT);
    assert_null(scene);
    assert_non_null(strstr(err.message, ":2:"));
    assert_non_null(strstr(err.message, "teapot"));

    path = op_test_write_temp("scene.xml", "<scene version=\"0.6.0\"><shape type=\"sphere\">"
                       "<subsurface type=\"svd\"><string name=\"material\" "
                       "value=\"NoSuchPreset_XYZ\"/></subsurface></shape></scene>");
    st = op_scene_load(path, NULL, 0, &scene, &err);
    assert_int_equal(st, OP_ERR_INPUT);
    assert_non_null(strstr(err.message, "NoSuchPreset_XYZ"));
}

static void test_clamping_and_info(void **state)
{
    (void)state;
    /* reflectance 100 and cutoffAngle 200 (as in the plugin slides' scene) are clamped */
    const char *path = op_test_write_temp("scene.xml", 
        "<scene version=\"0.6.0\">"
        " <sensor type=\"perspective\"><film type=\"hdrfilm\"><integer name=\"width\" value=\"8\"/>"
        "  <integer name=\"height\" value=\"6\"/><string name=\"filename\" value=\"x.exr\"/>"
        "  </film></sensor>"
        " <emitter type=\"spot\"><float name=\"cutoffAngle\" value=\"200\"/>"
        "  <spectrum name=\"intensity\" value=\"100\"/></emitter>"
        " <shape type=\"cube\"><bsdf type=\"diffuse\">"
        "  <rgb name=\"diffuseReflectance\" value=\"100, 100, 100\"/></bsdf></shape>"
        "</scene>");
    op_error err = {0};
    op_scene *scene = NULL;
    op_status st = op_scene_load(path, NULL, 0, &scene, &err);
    OP_ASSERT_OK(st, err);
    op_scene_info info;
    op_scene_get_info(scene, &info);
    assert_int_equal(info.width, 8);
    assert_int_equal(info.height, 6);
    assert_int_equal(info.spp, 4);
    assert_string_equal(info.film_filename, "x.exr");
    assert_string_equal(info.integrator, "direct");
    assert_int_equal(info.triangles, 12);
    op_scene_free(scene);

    /* What the clamps do, seen in an image: a spot of intensity 1 at height 1 pointing down at a
     * plane of diffuseReflectance 100, seen from z = 4 over +-60 degrees (the plane out to
     * about 80 degrees from the spot's axis). Clamped, the reflectance is 1 and the cutoff 90
     * degrees, so the beam (0.75 cutoff) is 67.5 degrees with a linear falloff to 90 beyond it:
     * L = 1 / pi * falloff(theta) * cos(theta) / d^2. Unclamped, the image would be 100 times
     * as bright, and the beam (150 degrees) would light the whole plane without falloff. */
    path = plane_scene(
        120, 40, 20,
        "<emitter type=\"spot\"><transform name=\"toWorld\"><lookat origin=\"0,0,1\" "
        " target=\"0,0,0\"/></transform><float name=\"cutoffAngle\" value=\"200\"/>"
        " <spectrum name=\"intensity\" value=\"1\"/></emitter>",
        "<bsdf type=\"diffuse\"><rgb name=\"diffuseReflectance\" value=\"100, 100, 100\"/>"
        "</bsdf>");
    op_renderer *r = op_test_render(path, 0, 2, 0);
    const op_image *img = op_renderer_image(r);
    int w = img->width, h = img->height;
    double worst = 0.0, outer_got = 0.0, outer_full = 0.0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double px, py;
            plane_point(img, 120, x, y, &px, &py);
            double d2 = px * px + py * py + 1.0;
            double theta = atan(sqrt(px * px + py * py)) * 180.0 / M_PI;
            double fall = theta <= 67.5 ? 1.0 : (90.0 - theta) / 22.5;
            double full = 1.0 / M_PI / (d2 * sqrt(d2)), expect = fall * full;
            float got = img->pixels[4 * (y * w + x)];
            /* the falloff's kink at 67.5 degrees is averaged over a pixel: judge the rest */
            if (fabs(theta - 67.5) > 2.0) {
                double rel = fabs(got - expect) / expect;
                if (rel > worst)
                    worst = rel;
            }
            if (theta > 75.0) {
                outer_got += got;
                outer_full += full;
            }
        }
    print_message("  clamped spot on a clamped plane: worst relative error %.4f; beyond 75 "
                  "degrees %.3f of the unclamped beam\n", worst, outer_got / outer_full);
    if (worst > 0.05)
        fail_msg("clamped scene: worst relative error %.4f", worst);
    /* the falloff between 67.5 and 90 degrees is there: at most (90 - 75) / 22.5 of full */
    assert_true(outer_full > 0.0 && outer_got < 0.7 * outer_full);
    op_renderer_free(r);
}

int main(void)
{
    op_log_set_level(OP_LOG_WARN);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_white_furnace),
        cmocka_unit_test(test_lambertian_plane),
        cmocka_unit_test(test_bad_scenes),
        cmocka_unit_test(test_clamping_and_info),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
