/* test_render_subsurface.c - the irradiance-point subsurface integrator: a flat translucent
 * rectangle of a homogeneous measured material under uniform light shows exitance = albedo x
 * irradiance; preset lookup through OPALINE_PRESETS_PATH; bit-identical across thread counts. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "opaline_render.h"
#include "test_support.h"

static const double albedo[3] = {0.6, 0.4, 0.2};

static void write_homogeneous(const char *path)
{
    op_test_write_gaussian_raw(path, albedo, 0);
}

static op_image render(const char *path, int threads)
{
    op_error err = {0};
    op_scene *scene = NULL;
    op_status st = op_scene_load(path, NULL, 0, &scene, &err);
    OP_ASSERT_OK(st, err);
    op_scene_info info;
    op_scene_get_info(scene, &info);
    assert_int_equal(info.subsurface_shapes, 1);
    op_scene_free(scene);
    return op_test_render_image(path, 0, threads, 0);
}

static void test_flat_uniform_exitance(void **state)
{
    (void)state;
    char mat[1024], scene[1024], text[4096];
    snprintf(mat, sizeof mat, "%s", op_test_tmp_path("Homog.opm"));
    write_homogeneous(mat);
    snprintf(scene, sizeof scene, "%s", op_test_tmp_path("flat.xml"));
    /* 2 x 2 units; scale 80 makes a material pixel 0.05 units: 40 pixels across. Irradiance 1
     * at normal incidence, nothing else in the scene: L = albedo / pi. */
    snprintf(text, sizeof text,
             "<scene version=\"0.6.0\">"
             " <integrator type=\"path\"/>"
             " <sensor type=\"perspective\"><float name=\"fov\" value=\"20\"/>"
             "  <transform name=\"toWorld\"><lookat origin=\"0,0,4\" target=\"0,0,0\" "
             "   up=\"0,1,0\"/></transform>"
             "  <sampler type=\"independent\"><integer name=\"sampleCount\" value=\"4\"/></sampler>"
             "  <film type=\"hdrfilm\"><integer name=\"width\" value=\"16\"/>"
             "   <integer name=\"height\" value=\"16\"/><rfilter type=\"box\"/></film></sensor>"
             " <emitter type=\"directional\"><vector name=\"direction\" x=\"0\" y=\"0\" z=\"-1\"/>"
             "  <rgb name=\"irradiance\" value=\"1\"/></emitter>"
             " <shape type=\"rectangle\"><subsurface type=\"raw\">"
             "  <string name=\"material\" value=\"%s\"/><float name=\"sceneUnitsPerMetre\" value=\"80\"/>"
             "  <integer name=\"irrSamples\" value=\"1\"/></subsurface></shape>"
             "</scene>",
             mat);
    op_test_write_text(scene, text);
    op_image img = render(scene, 2);
    double sum[3] = {0, 0, 0};
    int n = 0;
    for (int y = 2; y < 14; y++)
        for (int x = 2; x < 14; x++) {
            for (int c = 0; c < 3; c++)
                sum[c] += M_PI * img.pixels[4 * (y * 16 + x) + c];
            n++;
        }
    for (int c = 0; c < 3; c++) {
        double m = sum[c] / n;
        if (fabs(m - albedo[c]) > 0.03 * albedo[c])
            fail_msg("channel %d: pi L = %.4f, expected the albedo %.4f", c, m, albedo[c]);
    }
    /* and pixel to pixel it is flat (no blotches from the point distribution) */
    for (int y = 2; y < 14; y++)
        for (int x = 2; x < 14; x++) {
            double v = M_PI * img.pixels[4 * (y * 16 + x)];
            if (fabs(v - albedo[0]) > 0.08 * albedo[0])
                fail_msg("pixel (%d, %d): pi L = %.4f, expected %.4f", x, y, v, albedo[0]);
        }
    op_image_free(&img);
}

static void test_preset_path_and_threads(void **state)
{
    (void)state;
    char mat[1100], dir[1024], scene[1024];
    /* look the material up by preset name through OPALINE_PRESETS_PATH */
    snprintf(dir, sizeof dir, "%s", op_test_tmp_path("presets"));
    assert_int_equal(mkdir(dir, 0755), 0);
    snprintf(mat, sizeof mat, "%s/HomogTest.opm", dir);
    write_homogeneous(mat);
    char env[1100];
    snprintf(env, sizeof env, "/nonexistent:%s", dir);
    setenv("OPALINE_PRESETS_PATH", env, 1);
    snprintf(scene, sizeof scene, "%s", op_test_tmp_path("sphere.xml"));
    op_test_write_text(scene,
               "<scene version=\"0.6.0\">"
               " <integrator type=\"path\"/>"
               " <sensor type=\"perspective\"><float name=\"fov\" value=\"40\"/>"
               "  <transform name=\"toWorld\"><lookat origin=\"0,-4,2\" target=\"0,0,0.5\" "
               "   up=\"0,0,1\"/></transform>"
               "  <film type=\"hdrfilm\"><integer name=\"width\" value=\"24\"/>"
               "   <integer name=\"height\" value=\"18\"/></film></sensor>"
               " <emitter type=\"spot\"><transform name=\"toWorld\"><lookat origin=\"0,0,5\" "
               "  target=\"0,0,0\"/></transform><spectrum name=\"intensity\" value=\"40\"/>"
               " </emitter>"
               " <shape type=\"sphere\"><point name=\"center\" x=\"0\" y=\"0\" z=\"0.5\"/>"
               "  <float name=\"radius\" value=\"0.5\"/><subsurface type=\"raw\">"
               "  <string name=\"material\" value=\"HomogTest\"/><float name=\"sceneUnitsPerMetre\" value=\"10\"/>"
               "  <integer name=\"irrSamples\" value=\"2\"/></subsurface></shape>"
               " <shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"3\"/>"
               "  </transform></shape>"
               "</scene>");
    op_image a = render(scene, 1), b = render(scene, 2);
    unsetenv("OPALINE_PRESETS_PATH");
    assert_memory_equal(a.pixels, b.pixels, (size_t)a.width * a.height * 4 * sizeof(float));
    /* the sphere's top (lit by the spot) is bright, and nothing is NaN */
    float top = a.pixels[4 * (5 * 24 + 12)];
    for (int i = 0; i < a.width * a.height * 4; i++)
        assert_true(isfinite(a.pixels[i]));
    assert_true(top > 0.05f);
    op_image_free(&a);
    op_image_free(&b);
}

int main(void)
{
    op_log_set_level(OP_LOG_WARN);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_flat_uniform_exitance),
        cmocka_unit_test(test_preset_path_and_threads),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
