/* test_render_sss_camera.c - the subsurface pre-pass computes only what camera paths need: a
 * translucent shape behind the camera gets no irradiance points at all; on a large translucent
 * plane of which the camera sees a small part, only a few of the points get irradiance and
 * exitance, the exitance there is bit-identical to the full computation's, and the image does
 * not depend on the thread count. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "opaline_render.h"
#include "integrator/integrator.h"
#include "test_support.h"

/* Writes to path a raw material of 16 x 16 pixels, kernel 5, 1 x 1 cm: a normalized Gaussian
 * row of albedo 0.6 / 0.4 / 0.2, varying a little from pixel to pixel (so positions matter). */
static void write_material(const char *path)
{
    static const double albedo[3] = {0.6, 0.4, 0.2};
    op_test_write_gaussian_raw(path, albedo, 1);
}

/* The camera looks down from z = 4 (fov 20: it sees |x|, |y| < 0.71 of the plane z = 0) over a
 * point light; `shapes` adds the objects. Returns the scene file's path (static storage). */
static const char *write_scene(const char *name, const char *shapes)
{
    static char path[1024];
    snprintf(path, sizeof path, "%s", op_test_tmp_path(name));
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fprintf(f,
            "<scene version=\"0.6.0\">"
            " <integrator type=\"path\"><integer name=\"maxDepth\" value=\"3\"/></integrator>"
            " <sensor type=\"perspective\"><float name=\"fov\" value=\"20\"/>"
            "  <transform name=\"toWorld\"><lookat origin=\"0,0,4\" target=\"0,0,0\" "
            "   up=\"0,1,0\"/></transform>"
            "  <sampler type=\"independent\"><integer name=\"sampleCount\" value=\"2\"/></sampler>"
            "  <film type=\"hdrfilm\"><integer name=\"width\" value=\"24\"/>"
            "   <integer name=\"height\" value=\"24\"/><rfilter type=\"box\"/></film></sensor>"
            " <emitter type=\"point\"><point name=\"position\" x=\"0.3\" y=\"0.2\" z=\"2\"/>"
            "  <rgb name=\"intensity\" value=\"4\"/></emitter>"
            "%s</scene>",
            shapes);
    fclose(f);
    return path;
}

/* The translucent shape: subsurface of the material at mat, scale 80 (pixels of 0.05 units). */
static void sss_element(char *out, size_t n, const char *mat)
{
    snprintf(out, n,
             "<subsurface type=\"raw\"><string name=\"material\" value=\"%s\"/>"
             "<float name=\"sceneUnitsPerMetre\" value=\"80\"/><integer name=\"irrSamples\" value=\"1\"/>"
             "</subsurface>",
             mat);
}

static op_renderer *render(const char *path, int threads, op_render_stats *stats)
{
    op_renderer *r = op_test_render(path, 0, threads, 0);
    op_renderer_get_stats(r, stats);
    return r;
}

static void test_behind_camera_costs_nothing(void **state)
{
    (void)state;
    char mat[1024], sss[1536], shapes[4096];
    snprintf(mat, sizeof mat, "%s", op_test_tmp_path("Varied.opm"));
    write_material(mat);
    sss_element(sss, sizeof sss, mat);
    /* a diffuse floor in view and a translucent sphere above the camera, out of view */
    snprintf(shapes, sizeof shapes,
             " <shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"3\"/>"
             "  </transform><bsdf type=\"diffuse\"/></shape>"
             " <shape type=\"sphere\"><point name=\"center\" x=\"0\" y=\"0\" z=\"6\"/>"
             "  <float name=\"radius\" value=\"0.5\"/>%s</shape>",
             sss);
    op_render_stats st;
    op_renderer *r = render(write_scene("behind.xml", shapes), 2, &st);
    print_message("behind the camera: %lld points, %lld sources, %lld receivers\n", st.sss_points,
                  st.sss_sources, st.sss_receivers);
    assert_int_equal(st.sss_shapes_reached, 0);
    assert_true(st.sss_points == 0 && st.sss_sources == 0 && st.sss_receivers == 0);
    const op_image *img = op_renderer_image(r);
    assert_true(img->pixels[4 * (12 * 24 + 12)] > 0.0f); /* the floor is lit and rendered */
    assert_true(st.render_seconds > 0.0); /* the camera pass ran */
    op_renderer_free(r);
}

static void test_partly_seen_plane(void **state)
{
    (void)state;
    char mat[1024], sss[1536], shapes[4096];
    snprintf(mat, sizeof mat, "%s", op_test_tmp_path("Varied.opm"));
    write_material(mat);
    sss_element(sss, sizeof sss, mat);
    /* a 6 x 6 translucent plane (14400 material pixels) of which the camera sees 1.4 x 1.4 */
    snprintf(shapes, sizeof shapes,
             " <shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"3\"/>"
             "  </transform>%s</shape>",
             sss);
    const char *path = write_scene("plane.xml", shapes);
    op_render_stats st, st3;
    op_renderer *r1 = render(path, 1, &st);
    op_renderer *r3 = render(path, 3, &st3);
    print_message("partly seen plane: %lld points, %lld sources, %lld receivers\n", st.sss_points,
                  st.sss_sources, st.sss_receivers);
    assert_int_equal(st.sss_shapes_reached, 1);
    assert_true(st.sss_points >= 14400);
    /* the seen part plus a kernel footprint and a grid cell around it: well under half */
    assert_true(st.sss_receivers > 0 && st.sss_sources >= st.sss_receivers);
    assert_true(st.sss_sources * 2 < st.sss_points);
    assert_true(st.sss_sources == st3.sss_sources && st.sss_receivers == st3.sss_receivers);
    const op_image *a = op_renderer_image(r1), *b = op_renderer_image(r3);
    assert_memory_equal(a->pixels, b->pixels, (size_t)24 * 24 * 4 * sizeof(float));
    op_renderer_free(r1);
    op_renderer_free(r3);

    /* where the camera looks, the exitance is bit for bit the full computation's */
    op_error err = {0};
    op_scene *scene = NULL;
    op_status s = op_scene_load(path, NULL, 0, &scene, &err);
    OP_ASSERT_OK(s, err);
    op_sss_prepass_options full = {2, 0, NULL, NULL, NULL, 1, NULL, &op_path_transport};
    op_sss_prepass_options cam = {2, 0, NULL, NULL, NULL, 0, NULL, &op_path_transport};
    op_sss_prepass *cf = NULL, *cc = NULL;
    s = op_sss_prepass_run(scene, &full, &cf, &err);
    OP_ASSERT_OK(s, err);
    s = op_sss_prepass_run(scene, &cam, &cc, &err);
    OP_ASSERT_OK(s, err);
    int outside = 0;
    for (int j = 0; j <= 40; j++)
        for (int i = 0; i <= 40; i++) {
            op_v3 p = v3((float)(-0.7 + 1.4 * i / 40), (float)(-0.7 + 1.4 * j / 40), 0.0f);
            op_v3 mf, mc;
            assert_true(op_sss_lookup(cf, 0, p, v3(0.0f, 0.0f, 1.0f), &mf));
            if (!op_sss_lookup(cc, 0, p, v3(0.0f, 0.0f, 1.0f), &mc))
                fail_msg("no exitance at the seen point (%g, %g)", p.x, p.y);
            assert_true(mf.x > 0.0f);
            assert_memory_equal(&mf, &mc, sizeof mf);
        }
    /* far outside the view nothing was computed */
    op_v3 m;
    outside = op_sss_lookup(cc, 0, v3(2.5f, 2.5f, 0.0f), v3(0.0f, 0.0f, 1.0f), &m);
    assert_int_equal(outside, 0);
    op_sss_prepass_free(cf);
    op_sss_prepass_free(cc);
    op_scene_free(scene);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_behind_camera_costs_nothing),
        cmocka_unit_test(test_partly_seen_plane),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
