/* test_render_subsurface_methods.c - measured materials of every method through the subsurface
 * integrator: the plugin's long material names, the type attribute against the file's method,
 * energy (a flat slab under uniform irradiance shows the dataset's mean albedo), factored
 * against raw renders (image error falls with T in the order of the data error), invariance
 * under a rigid motion of the whole scene, and determinism across thread counts. A small
 * chessboard dataset is made with the factorizer's own commands. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "commands.h"
#include "opaline_material.h"
#include "opaline_render.h"
#include "scene/render_scene.h"
#include "integrator/integrator.h"
#include "scene/material_name.h"
#include "test_support.h"

static char dir[1024];      /* the scene folder: materials are found there by preset name */
static char dataset[1200];  /* the raw dataset */
static const double tile_m = 0.024; /* 2.4 cm: 1 mm pixels */

static int run(int (*cmd)(int, char **), const char **args)
{
    char *argv[32];
    int n = 0;
    while (args[n]) {
        argv[n] = (char *)args[n];
        n++;
    }
    argv[n] = NULL;
    return cmd(n, argv);
}

/* Factors the dataset into dir/NAME.opm; returns the command's exit code. */
static int factor(const char *name, const char *method, const char *t, const char *p)
{
    char out[1300];
    snprintf(out, sizeof out, "%s/%s.opm", dir, name);
    const char *args[20] = {"factor", dataset, "-o", out, "--method", method, "-q"};
    int n = 7;
    if (t) {
        args[n++] = "-T";
        args[n++] = t;
    }
    if (p) {
        args[n++] = "-P";
        args[n++] = p;
    }
    if (strcmp(method, "svd") == 0) {
        args[n++] = "--log-a";
        args[n++] = "100";
        args[n++] = "--log-b";
        args[n++] = "1";
    }
    args[n] = NULL;
    return run(op_cmd_factor, args);
}

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "%s", op_test_tmp_path("mats"));
    if (mkdir(dir, 0755) != 0)
        return -1;
    snprintf(dataset, sizeof dataset, "%s/data.opm", dir);
    const char *args[] = {"dataset", "chess4x4", "--pixels", "24x24", "--kernel", "7", "--size-cm",
                          "2.4x2.4", "-o", dataset, NULL};
    if (run(op_cmd_dataset, args) != 0)
        return -1;
    if (factor("RAW_Chess4x4", "raw", NULL, NULL) || factor("SVD_S1_Chess4x4", "svd", "1", NULL) ||
        factor("SVD_S2_Chess4x4", "svd", "2", NULL) || factor("SVD_S4_Chess4x4", "svd", "4", NULL) ||
        factor("SVD_S8_Chess4x4", "svd", "8", NULL) ||
        factor("TUCKER_T4_P2_Chess4x4", "tucker", "4", "2"))
        return -1;
    return 0;
}

/* A scene in dir with one translucent shape: `shape` (an element's opening and its children
 * before the subsurface), the subsurface of type/material, then `rest` (lights, camera). */
static const char *scene_file(const char *file, const char *shape, const char *type,
                              const char *material, const char *rest)
{
    static char path[1300];
    char text[8192];
    snprintf(path, sizeof path, "%s/%s", dir, file);
    snprintf(text, sizeof text,
             "<scene version=\"0.6.0\"><integrator type=\"path\"/>%s"
             " %s<subsurface type=\"%s\"><string name=\"material\" value=\"%s\"/>"
             " <integer name=\"irrSamples\" value=\"1\"/></subsurface></shape></scene>",
             rest, shape, type, material);
    op_test_write_text(path, text);
    return path;
}

static op_status try_load(const char *path, op_error *err)
{
    op_scene *scene = NULL;
    op_status st = op_scene_load(path, NULL, 0, &scene, err);
    op_scene_free(scene);
    return st;
}

static const char *rect = "<shape type=\"rectangle\">";

static void test_long_names(void **state)
{
    (void)state;
    char out[256];
    op_method m;
    double a, b;
    assert_true(op_parse_long_material_name("SVD S10 Div100 Add1 for Rd Chess4x4 v1(277x277x39x39)",
                                       out, sizeof out, &m, &a, &b));
    assert_string_equal(out, "SVD_S10_Chess4x4");
    assert_int_equal(m, OP_METHOD_SVD);
    assert_true(a == 100.0 && b == 1.0);
    assert_true(op_parse_long_material_name("TUCKER T15 P7 for Rd Chess4x4 v1(277x277x29x29)", out,
                                       sizeof out, &m, &a, &b));
    assert_string_equal(out, "TUCKER_T15_P7_Chess4x4");
    assert_int_equal(m, OP_METHOD_TUCKER);
    assert_true(a == 0.0 && b == 0.0);
    assert_false(op_parse_long_material_name("SVD_S10_Chess4x4", out, sizeof out, &m, &a, &b));
    assert_false(op_parse_long_material_name("FOO S10 for Rd Chess4x4", out, sizeof out, &m, &a, &b));
    assert_false(op_parse_long_material_name("SVD S10 Div100 Add1 for Rd", out, sizeof out, &m, &a, &b));

    op_error err = {0};
    op_status st = try_load(scene_file("l1.xml", rect, "svd",
                                       "SVD S4 Div100 Add1 for Rd Chess4x4 v1(24x24x7x7)", ""),
                            &err);
    OP_ASSERT_OK(st, err);
    st = try_load(scene_file("l2.xml", rect, "tucker", "TUCKER T4 P2 for Rd Chess4x4 v1", ""), &err);
    OP_ASSERT_OK(st, err);
    /* A and B must be those the file was made with; the message names both */
    st = try_load(scene_file("l3.xml", rect, "svd", "SVD S4 Div10 Add1 for Rd Chess4x4 v1", ""),
                  &err);
    assert_int_equal(st, OP_ERR_INPUT);
    if (!strstr(err.message, "A = 10,") || !strstr(err.message, "A = 100,"))
        fail_msg("%s", err.message);
    /* a missing preset names the long name and the preset looked for */
    st = try_load(scene_file("l4.xml", rect, "svd", "SVD S3 Div100 Add1 for Rd Chess4x4", ""), &err);
    assert_int_equal(st, OP_ERR_INPUT);
    assert_non_null(strstr(err.message, "SVD_S3_Chess4x4"));
    /* the type attribute must agree with the file's method; both are named */
    st = try_load(scene_file("l5.xml", rect, "tucker", "SVD_S4_Chess4x4", ""), &err);
    assert_int_equal(st, OP_ERR_INPUT);
    if (!strstr(err.message, "type=\"tucker\"") || !strstr(err.message, "method=svd"))
        fail_msg("%s", err.message);
    st = try_load(scene_file("l6.xml", rect, "kcta", "SVD_S4_Chess4x4", ""), &err);
    assert_int_equal(st, OP_ERR_INPUT);
    st = try_load(scene_file("l7.xml", rect, "marble", "SVD_S4_Chess4x4", ""), &err);
    assert_int_equal(st, OP_ERR_INPUT);

    /* the slides' own name resolves to the build's preset */
    const char *pd = getenv("OPALINE_PRESETS_DIR");
    if (!pd || !*pd) {
        op_test_skipping("the slides' preset name: the build makes no presets "
                         "(OPALINE_BUILD_PRESETS=OFF)");
        skip();
    }
    char preset[1200];
    snprintf(preset, sizeof preset, "%s/SVD_S10_Chess4x4.opm", pd);
    if (access(preset, R_OK) != 0)
        fail_msg("%s is not built", preset);
    setenv("OPALINE_PRESETS_PATH", pd, 1);
    st = try_load(scene_file("slides.xml", rect, "svd",
                             "SVD S10 Div100 Add1 for Rd Chess4x4 v1(277x277x39x39)", ""),
                  &err);
    unsetenv("OPALINE_PRESETS_PATH");
    OP_ASSERT_OK(st, err);
}

/* A flat square of 3 x 3 tiles without texture coordinates, so the material tiles at its
 * physical size (box projection): x, y in [-1.5, 1.5] tiles. */
static const char *slab_shape(void)
{
    static char shape[1400];
    char obj[1300];
    snprintf(obj, sizeof obj, "%s/slab.obj", dir);
    FILE *f = fopen(obj, "w");
    assert_non_null(f);
    double h = 1.5 * tile_m;
    fprintf(f, "v %g %g 0\nv %g %g 0\nv %g %g 0\nv %g %g 0\nf 1 2 3\nf 1 3 4\n", -h, -h, h, -h, h,
            h, -h, h);
    fclose(f);
    snprintf(shape, sizeof shape, "<shape type=\"obj\"><string name=\"filename\" value=\"%s\"/>",
             obj);
    return shape;
}

static const char *uniform_light =
    "<emitter type=\"directional\"><vector name=\"direction\" x=\"0\" y=\"0\" z=\"-1\"/>"
    "<rgb name=\"irradiance\" value=\"1\"/></emitter>";

/* Mean exitance over the central tile [0, tile)^2 (48 x 48 samples) of the scene at path. */
static void tile_exitance(const char *path, double out[3])
{
    op_error err = {0};
    op_scene *scene = NULL;
    op_status st = op_scene_load(path, NULL, 0, &scene, &err);
    OP_ASSERT_OK(st, err);
    op_sss_prepass_options o = {2, 0, NULL, NULL, NULL, 1, NULL, &op_path_transport};
    op_sss_prepass *cache = NULL;
    st = op_sss_prepass_run(scene, &o, &cache, &err);
    OP_ASSERT_OK(st, err);
    double s[3] = {0, 0, 0};
    for (int j = 0; j < 48; j++)
        for (int i = 0; i < 48; i++) {
            op_v3 p = v3((float)(tile_m * (i + 0.5) / 48), (float)(tile_m * (j + 0.5) / 48), 0.0f);
            op_v3 m = op_sss_exitance(cache, 0, p, v3(0.0f, 0.0f, 1.0f));
            s[0] += m.x;
            s[1] += m.y;
            s[2] += m.z;
        }
    for (int c = 0; c < 3; c++)
        out[c] = s[c] / (48.0 * 48.0);
    op_sss_prepass_free(cache);
    op_scene_free(scene);
}

static void mean_albedo(const char *path, double out[3])
{
    op_error err = {0};
    op_material *m;
    op_status st = op_material_open(path, &m, &err);
    OP_ASSERT_OK(st, err);
    const op_material_info *info = op_material_get_info(m);
    size_t px = (size_t)info->width * info->height;
    float *a = malloc(px * info->channels * sizeof *a);
    assert_non_null(a);
    st = op_material_albedo_map(m, a, &err);
    OP_ASSERT_OK(st, err);
    for (int c = 0; c < 3; c++) {
        double s = 0;
        for (size_t i = 0; i < px; i++)
            s += a[(c % info->channels) * px + i];
        out[c] = s / (double)px;
    }
    free(a);
    op_material_close(m);
}

static void test_energy(void **state)
{
    (void)state;
    static const struct {
        const char *name, *type;
        double tol_data; /* against the dataset's albedo */
    } cases[] = {
        /* SVD with 4 terms misses the blue albedo of this one-index (1.5) board by 1.1 % itself
         * (0.34722 against 0.35099) */
        {"RAW_Chess4x4", "raw", 0.01},     {"SVD_S4_Chess4x4", "svd", 0.02},
        {"SVD_S8_Chess4x4", "svd", 0.01},  {"TUCKER_T4_P2_Chess4x4", "tucker", 0.01},
        {"KCTA_Chess4x4", "kcta", 0.01},
        /* NMF with 4 terms misses this dataset's albedo by up to 7 % itself (its factor report
         * says 21 % relative RMSE): the renderer is held to its own albedo within 1 % */
        {"NMF_Chess4x4", "nmf", 0.10},
    };
    double data[3];
    mean_albedo(dataset, data);
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        char mat[1300];
        snprintf(mat, sizeof mat, "%s/%s.opm", dir, cases[k].name);
        /* every method is built in: a failure to factor is a failure of this test */
        if (access(mat, R_OK) != 0) {
            int rc = factor(cases[k].name, cases[k].type, "4", NULL);
            if (rc != 0)
                fail_msg("factoring %s with --method %s failed (exit %d)", cases[k].name,
                         cases[k].type, rc);
        }
        double own[3], m[3];
        mean_albedo(mat, own);
        tile_exitance(scene_file("e.xml", slab_shape(), cases[k].type, cases[k].name,
                                 uniform_light),
                      m);
        for (int c = 0; c < 3; c++) {
            printf("%s channel %d: exitance %.5f, its albedo %.5f, dataset albedo %.5f\n",
                   cases[k].name, c, m[c], own[c], data[c]);
            if (fabs(m[c] - own[c]) > 0.01 * own[c] ||
                fabs(m[c] - data[c]) > cases[k].tol_data * data[c])
                fail_msg("%s channel %d: exitance %.5f, its albedo %.5f, dataset albedo %.5f",
                         cases[k].name, c, m[c], own[c], data[c]);
        }
    }
}

/* RMSE of the material at path against the raw dataset over every row and offset. */
static double data_rmse(const char *path)
{
    op_error err = {0};
    op_material *m, *d;
    op_status st = op_material_open(path, &m, &err);
    OP_ASSERT_OK(st, err);
    st = op_material_open(dataset, &d, &err);
    OP_ASSERT_OK(st, err);
    const op_material_info *info = op_material_get_info(d);
    int K = info->kernel;
    float *ra = malloc((size_t)K * K * sizeof *ra), *rb = malloc((size_t)K * K * sizeof *rb);
    assert_true(ra && rb);
    double s = 0;
    long n = 0;
    for (int c = 0; c < info->channels; c++)
        for (int y = 0; y < info->height; y++)
            for (int x = 0; x < info->width; x++) {
                op_material_eval_row(m, c, x, y, ra);
                op_material_eval_row(d, c, x, y, rb);
                for (int k = 0; k < K * K; k++, n++)
                    s += (double)(ra[k] - rb[k]) * (ra[k] - rb[k]);
            }
    free(ra);
    free(rb);
    op_material_close(m);
    op_material_close(d);
    return sqrt(s / (double)n);
}

static const char *camera =
    "<sensor type=\"perspective\"><float name=\"fov\" value=\"8\"/>"
    " <transform name=\"toWorld\"><lookat origin=\"0.012,0.012,0.2\" target=\"0.012,0.012,0\" "
    "  up=\"0,1,0\"/></transform>"
    " <film type=\"hdrfilm\"><integer name=\"width\" value=\"24\"/>"
    "  <integer name=\"height\" value=\"24\"/><rfilter type=\"box\"/></film></sensor>";

static void test_rmse_falls_with_terms(void **state)
{
    (void)state;
    char rest[2048];
    snprintf(rest, sizeof rest, "%s%s", uniform_light, camera);
    const char *raw_scene = scene_file("r.xml", slab_shape(), "raw", "RAW_Chess4x4", rest);
    op_image raw = op_test_render_image(raw_scene, 2, 2, 0);
    static const char *names[] = {"SVD_S1_Chess4x4", "SVD_S2_Chess4x4", "SVD_S4_Chess4x4",
                                  "SVD_S8_Chess4x4"};
    double prev_img = INFINITY, prev_data = INFINITY;
    for (int k = 0; k < 4; k++) {
        char mat[1300];
        snprintf(mat, sizeof mat, "%s/%s.opm", dir, names[k]);
        double de = data_rmse(mat);
        const char *scene = scene_file("s.xml", slab_shape(), "svd", names[k], rest);
        op_image img = op_test_render_image(scene, 2, 2, 0);
        double ie = op_test_image_rmse(&img, &raw);
        printf("%s: data RMSE %.3g, image RMSE %.3g\n", names[k], de, ie);
        if (!(ie < prev_img) || !(de < prev_data))
            fail_msg("%s: image RMSE %.3g (before %.3g), data RMSE %.3g (before %.3g): not falling "
                     "together", names[k], ie, prev_img, de, prev_data);
        prev_img = ie;
        prev_data = de;
        op_image_free(&img);
    }
    op_image_free(&raw);
}

/* p -> R p + t for the rotation of `deg` degrees about the unit axis a (right-handed). */
static void motion(const double a[3], double deg, const double t[3], const double p[3], int point,
                   double out[3])
{
    double th = deg * M_PI / 180.0, c = cos(th), s = sin(th), d = a[0] * p[0] + a[1] * p[1] +
                                                                  a[2] * p[2];
    double cr[3] = {a[1] * p[2] - a[2] * p[1], a[2] * p[0] - a[0] * p[2], a[0] * p[1] - a[1] * p[0]};
    for (int i = 0; i < 3; i++)
        out[i] = p[i] * c + cr[i] * s + a[i] * d * (1 - c) + (point ? t[i] : 0.0);
}

/* The uv-mapped rectangle of one tile, lit by a spot light, seen from above; everything moved
 * by (axis, deg, t). */
static const char *moved_scene(const char *file, const double axis[3], double deg, const double t[3],
                               const char *type, const char *mat)
{
    double o[3] = {0.004, -0.01, 0.08}, tg[3] = {0, 0, 0}, up[3] = {0, 1, 0};
    double lo[3] = {-0.01, 0.005, 0.05}, mo[3], mt[3], mu[3], ml[3], mlt[3];
    motion(axis, deg, t, o, 1, mo);
    motion(axis, deg, t, tg, 1, mt);
    motion(axis, deg, t, up, 0, mu);
    motion(axis, deg, t, lo, 1, ml);
    motion(axis, deg, t, tg, 1, mlt);
    char rest[4096], shape[1024];
    snprintf(rest, sizeof rest,
             "<emitter type=\"spot\"><transform name=\"toWorld\"><lookat origin=\"%.9g,%.9g,%.9g\""
             " target=\"%.9g,%.9g,%.9g\"/></transform><spectrum name=\"intensity\" value=\"0.01\"/>"
             " <float name=\"cutoffAngle\" value=\"40\"/></emitter>"
             "<sensor type=\"perspective\"><float name=\"fov\" value=\"20\"/>"
             " <transform name=\"toWorld\"><lookat origin=\"%.9g,%.9g,%.9g\" "
             "  target=\"%.9g,%.9g,%.9g\" up=\"%.9g,%.9g,%.9g\"/></transform>"
             " <film type=\"hdrfilm\"><integer name=\"width\" value=\"24\"/>"
             "  <integer name=\"height\" value=\"24\"/><rfilter type=\"box\"/></film></sensor>",
             ml[0], ml[1], ml[2], mlt[0], mlt[1], mlt[2], mo[0], mo[1], mo[2], mt[0], mt[1], mt[2],
             mu[0], mu[1], mu[2]);
    snprintf(shape, sizeof shape,
             "<shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"%g\"/>"
             "<rotate x=\"%.9g\" y=\"%.9g\" z=\"%.9g\" angle=\"%g\"/>"
             "<translate x=\"%g\" y=\"%g\" z=\"%g\"/></transform>",
             tile_m / 2, axis[0], axis[1], axis[2], deg, t[0], t[1], t[2]);
    return scene_file(file, shape, type, mat, rest);
}

static void test_rigid_motion_and_threads(void **state)
{
    (void)state;
    double ax[3] = {0.6, 0.8, 0.0}, none[3] = {1, 0, 0}, t0[3] = {0, 0, 0}, t[3] = {0.3, -0.2, 0.5};
    static const char *types[] = {"svd", "tucker"}, *mats[] = {"SVD_S4_Chess4x4",
                                                                 "TUCKER_T4_P2_Chess4x4"};
    for (int k = 0; k < 2; k++) {
        const char *still = moved_scene("m0.xml", none, 0.0, t0, types[k], mats[k]);
        op_image a = op_test_render_image(still, 2, 2, 0);
        const char *moved = moved_scene("m1.xml", ax, 37.0, t, types[k], mats[k]);
        op_image b = op_test_render_image(moved, 2, 2, 0);
        double mean = 0;
        for (int i = 0; i < a.width * a.height; i++)
            mean += a.pixels[4 * i];
        mean /= a.width * a.height;
        double e = op_test_image_rmse(&a, &b);
        printf("%s: moved scene, RMSE %.3g of mean %.3g\n", types[k], e, mean);
        if (!(mean > 0.0) || e > 0.02 * mean)
            fail_msg("%s: the moved scene differs: RMSE %.3g, mean %.3g", types[k], e, mean);
        /* and one thread gives the same bits as two */
        op_image c = op_test_render_image(moved, 2, 1, 0);
        assert_memory_equal(b.pixels, c.pixels, (size_t)b.width * b.height * 4 * sizeof(float));
        op_image_free(&a);
        op_image_free(&b);
        op_image_free(&c);
    }
}

int main(void)
{
    op_log_set_level(OP_LOG_WARN);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_long_names),
        cmocka_unit_test(test_energy),
        cmocka_unit_test(test_rmse_falls_with_terms),
        cmocka_unit_test(test_rigid_motion_and_threads),
    };
    return op_test_exit_status(cmocka_run_group_tests(tests, setup, NULL));
}
