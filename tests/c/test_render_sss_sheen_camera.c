/* test_render_sss_sheen_camera.c - camera-driven marking follows a translucent surface's smooth
 * sheen: a camera segment that reaches a translucent shape carrying a smooth surface bsdf
 * (dielectric, plastic, coating) goes on along its mirror reflection, so a second translucent
 * shape seen only in that reflection gets its receivers. Scene: a translucent floor with a
 * dielectric sheen seen from above at 45 degrees, and a translucent wall out of the camera's
 * view, standing beyond the floor and facing it, seen only in the floor's reflection.
 *  - every point of the wall that a pixel's reflected ray reaches has exitance, bit-identical to
 *    the full (unmarked) computation's;
 *  - the image (every pixel, the renderer's own sample sequence) equals the one computed with
 *    the full pre-pass, and the renderer's image is that image. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "integrator/integrator.h"
#include "opaline_render.h"
#include "scene/render_scene.h"
#include "camera/sampler.h"
#include "test_support.h"

enum { W = 24, H = 24, SPP = 2 };

static const char *write_scene(void)
{
    char mat[1024], sss[1536], text[8192];
    static const double albedo[3] = {0.6, 0.4, 0.2};
    snprintf(mat, sizeof mat, "%s", op_test_tmp_path("grey.opm"));
    op_test_write_gaussian_raw(mat, albedo, 1);
    snprintf(sss, sizeof sss,
             "<subsurface type=\"raw\"><string name=\"material\" value=\"%s\"/>"
             "<float name=\"sceneUnitsPerMetre\" value=\"40\"/><integer name=\"irrSamples\" value=\"1\"/>"
             "</subsurface>",
             mat);
    /* camera at (0, -3, 3) looking at the origin (fov 20: it sees the floor only); the floor's
     * mirror sends its rays up towards +y, onto the wall in y = 3 (x in [-3, 3], z in [0, 6]),
     * which faces -y and lies some 38 degrees outside the view */
    snprintf(text, sizeof text,
             "<scene version=\"0.6.0\">"
             " <integrator type=\"path\"><integer name=\"maxDepth\" value=\"4\"/></integrator>"
             " <sensor type=\"perspective\"><float name=\"fov\" value=\"20\"/>"
             "  <transform name=\"toWorld\"><lookat origin=\"0,-3,3\" target=\"0,0,0\" "
             "   up=\"0,0,1\"/></transform>"
             "  <sampler type=\"independent\"><integer name=\"sampleCount\" value=\"%d\"/>"
             "  </sampler>"
             "  <film type=\"hdrfilm\"><integer name=\"width\" value=\"%d\"/>"
             "   <integer name=\"height\" value=\"%d\"/><rfilter type=\"box\"/></film></sensor>"
             " <emitter type=\"point\"><point name=\"position\" x=\"0.5\" y=\"0.5\" z=\"4\"/>"
             "  <rgb name=\"intensity\" value=\"20\"/></emitter>"
             " <shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"2\"/>"
             "  </transform>%s<bsdf type=\"dielectric\"><float name=\"intIOR\" value=\"1.5\"/>"
             "  </bsdf></shape>"
             " <shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"3\"/>"
             "  <rotate x=\"1\" angle=\"90\"/><translate y=\"3\" z=\"3\"/></transform>%s</shape>"
             "</scene>",
             SPP, W, H, sss, sss);
    return op_test_write_temp("sheen_mirror.xml", text);
}

/* The image of scene with the pre-pass's result given: the renderer's own pixel loop (render.c),
 * seed 0. */
static void image_with(const op_scene *s, const op_sss_prepass *pre, float *out)
{
    const op_trace_ctx ctx = {s, pre};
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double acc[3] = {0, 0, 0};
            for (int k = 0; k < SPP; k++) {
                op_path_sampler ps = op_path_sampler_begin(s->sampler.type == OP_SAMPLER_LD, 0,
                                                           (uint64_t)y * W + (uint64_t)x,
                                                           (uint32_t)k);
                float u[2], dx, dy, tmin, tmax, alpha;
                op_path_sample(&ps, OP_DIM_PIXEL, 2, u);
                op_film_sample_offset(&s->film, u[0], u[1], &dx, &dy);
                op_v3 org, dir;
                op_camera_ray(&s->camera, (float)x + 0.5f + dx, (float)y + 0.5f + dy, &org, &dir,
                              &tmin, &tmax);
                op_v3 L = op_li(&ctx, org, dir, tmin, tmax, &ps, &alpha);
                acc[0] += L.x;
                acc[1] += L.y;
                acc[2] += L.z;
            }
            for (int c = 0; c < 3; c++)
                out[3 * (y * W + x) + c] = (float)acc[c] * (1.0f / SPP);
        }
}

static void test_reflected_wall_is_marked(void **state)
{
    (void)state;
    const char *path = write_scene();
    op_error err = {0};
    op_scene *scene = NULL;
    op_status st = op_scene_load(path, NULL, 0, &scene, &err);
    OP_ASSERT_OK(st, err);
    assert_int_equal(scene->nsss, 2);
    op_sss_prepass_options full = {2, 0, NULL, NULL, NULL, 1, NULL, &op_path_transport};
    op_sss_prepass_options cam = {2, 0, NULL, NULL, NULL, 0, NULL, &op_path_transport};
    op_sss_prepass *cf = NULL, *cc = NULL;
    st = op_sss_prepass_run(scene, &full, &cf, &err);
    OP_ASSERT_OK(st, err);
    st = op_sss_prepass_run(scene, &cam, &cc, &err);
    OP_ASSERT_OK(st, err);
    int wall = scene->shapes[1].sss;

    /* the wall's points that the pixel centres' reflected rays reach */
    int seen = 0, missing = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            op_v3 org, dir;
            float tmin, tmax;
            op_camera_ray(&scene->camera, x + 0.5f, y + 0.5f, &org, &dir, &tmin, &tmax);
            assert_true(dir.z < 0.0f);
            float t = -org.z / dir.z, px = org.x + t * dir.x, py = org.y + t * dir.y;
            assert_true(fabsf(px) < 2.0f && fabsf(py) < 2.0f); /* on the floor */
            op_v3 r = v3(dir.x, dir.y, -dir.z);
            float s = (3.0f - py) / r.y;
            op_v3 q = v3(px + s * r.x, 3.0f, s * r.z);
            if (fabsf(q.x) > 2.8f || q.z < 0.2f || q.z > 5.8f)
                continue;
            op_v3 n = v3(0.0f, -1.0f, 0.0f), mf, mc;
            assert_true(op_sss_lookup(cf, wall, q, n, &mf));
            seen++;
            if (!op_sss_lookup(cc, wall, q, n, &mc)) {
                missing++;
                continue;
            }
            assert_memory_equal(&mf, &mc, sizeof mf);
        }
    printf("%d pixels see the wall in the floor's sheen; %d of them find no exitance\n", seen,
           missing);
    assert_true(seen > W * H / 2);
    if (missing)
        fail_msg("%d of %d reflected points of the wall have no exitance (not marked)", missing,
                 seen);

    /* the image: with the camera-marked pre-pass as with the full one, and as rendered */
    float *a = malloc(sizeof(float) * 3 * W * H), *b = malloc(sizeof(float) * 3 * W * H);
    assert_non_null(a);
    assert_non_null(b);
    image_with(scene, cf, a);
    image_with(scene, cc, b);
    int differ = 0;
    for (int i = 0; i < 3 * W * H; i++)
        differ += a[i] != b[i];
    printf("%d of %d values differ between the full and the camera-marked pre-pass\n", differ,
           3 * W * H);
    assert_int_equal(differ, 0);
    op_image img = op_test_render_image(path, 0, 2, 0);
    assert_int_equal(img.width, W);
    for (int i = 0; i < W * H; i++)
        for (int c = 0; c < 3; c++)
            if (img.pixels[4 * i + c] != b[3 * i + c])
                fail_msg("pixel %d channel %d: rendered %.9g, computed %.9g", i, c,
                         img.pixels[4 * i + c], b[3 * i + c]);
    op_image_free(&img);
    free(a);
    free(b);
    op_sss_prepass_free(cf);
    op_sss_prepass_free(cc);
    op_scene_free(scene);
}

int main(void)
{
    op_log_set_level(OP_LOG_WARN);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_reflected_wall_is_marked),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
