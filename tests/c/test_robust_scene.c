/* test_robust_scene.c - bad scenes and resource bombs (issue 14): positions beyond what single
 * precision can trace are refused at load (so --check and rendering agree) with the element's
 * line; entity references in attributes are refused at once; images, kernels and irradiance
 * points over a limit are refused naming the limit and accepted when it is raised; rejected
 * shapes free their meshes (LeakSanitizer runs on this program); `$$` is a literal `$`; a
 * missing preset is bad input even without an op_error. Everything lives in one temporary
 * folder, removed at the end. */
#define _XOPEN_SOURCE 700
#include "test_support.h"

#include <ftw.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static char g_dir[1024];

static const char *in_dir(const char *name)
{
    static char buf[4][1200];
    static int k;
    char *out = buf[k++ % 4];
    snprintf(out, sizeof buf[0], "%s/%s", g_dir, name);
    return out;
}

static int remove_entry(const char *path, const struct stat *sb, int flag, struct FTW *ftw)
{
    (void)sb;
    (void)flag;
    (void)ftw;
    return remove(path);
}

static int setup(void **state)
{
    (void)state;
    const char *tmp = getenv("OPALINE_TEST_TMP");
    snprintf(g_dir, sizeof g_dir, "%s/robust_scene-XXXXXX", tmp && *tmp ? tmp : "/tmp");
    return mkdtemp(g_dir) ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    return nftw(g_dir, remove_entry, 16, FTW_DEPTH | FTW_PHYS);
}

/* The scene head: a tiny film (lines 1-5); the test's elements start on line 6. */
#define HEAD                                                                                       \
    "<scene version=\"0.6.0\">\n"                                                                 \
    "<integrator type=\"path\"><integer name=\"maxDepth\" value=\"3\"/></integrator>\n"           \
    "<emitter type=\"constant\"/>\n"                                                             \
    "<!-- line 4 -->\n"                                                                          \
    "<!-- line 5 -->\n"
#define SENSOR                                                                                     \
    "<sensor type=\"perspective\"><film type=\"hdrfilm\"><integer name=\"width\" value=\"8\"/>"   \
    "<integer name=\"height\" value=\"8\"/></film>"                                               \
    "<sampler type=\"independent\"><integer name=\"sampleCount\" value=\"1\"/></sampler>"
#define LOOK "<transform name=\"toWorld\"><lookat origin=\"0,0,-4\" target=\"0,0,0\"/></transform>"
#define SPHERE "<shape type=\"sphere\"/>\n"

/* Loads xml (written to the test folder as name) within lim (NULL: the defaults). */
static op_status load(const char *name, const char *xml, const op_scene_limits *lim,
                      op_error *err)
{
    op_test_write_text(in_dir(name), xml);
    op_scene *scene = NULL;
    op_status st = op_scene_load_limited(in_dir(name), NULL, 0, lim, &scene, err);
    if (st == OP_OK)
        assert_non_null(scene);
    else
        assert_null(scene);
    op_scene_free(scene);
    return st;
}

/* Whether msg holds words, or one of its alternatives separated by '|'. */
static int holds_words(const char *msg, const char *words)
{
    char alt[256];
    for (const char *p = words;;) {
        const char *bar = strchr(p, '|');
        size_t n = bar ? (size_t)(bar - p) : strlen(p);
        snprintf(alt, sizeof alt, "%.*s", (int)n, p);
        if (strstr(msg, alt))
            return 1;
        if (!bar)
            return 0;
        p = bar + 1;
    }
}

/* Loading must fail with OP_ERR_INPUT, the message naming name:line and holding words (or one
 * of its '|'-separated alternatives). */
static void expect_refused(const char *name, const char *xml, const op_scene_limits *lim,
                           int line, const char *words)
{
    op_error err = {0};
    op_status st = load(name, xml, lim, &err);
    char where[1300];
    snprintf(where, sizeof where, "%s:%d: ", in_dir(name), line);
    if (st != OP_ERR_INPUT)
        fail_msg("%s: expected an input error about '%s', got %s: %s", name, words,
                 op_status_name(st), err.message);
    if ((line > 0 && strncmp(err.message, where, strlen(where)) != 0) ||
        !holds_words(err.message, words))
        fail_msg("%s: message '%s' does not start with '%s' or lacks '%s'", name, err.message,
                 where, words);
}

static void expect_loads(const char *name, const char *xml, const op_scene_limits *lim)
{
    op_error err = {0};
    op_status st = load(name, xml, lim, &err);
    OP_ASSERT_OK(st, err);
}

static void far_camera_light_and_shapes(void **state)
{
    (void)state;
    expect_refused("cam.xml", HEAD
                   SENSOR "\n<transform name=\"toWorld\"><translate x=\"1e19\"/></transform>"
                   "</sensor>\n" SPHERE "</scene>\n", NULL, 6, "coordinate limit of 1e+07");
    expect_refused("point.xml", HEAD SENSOR LOOK "</sensor>\n" SPHERE
                   "<emitter type=\"point\"><point name=\"position\" x=\"1e39\" y=\"0\" z=\"0\"/>"
                   "</emitter>\n</scene>\n", NULL, 8, "the light's position");
    expect_refused("spot.xml", HEAD SENSOR LOOK "</sensor>\n" SPHERE
                   "<emitter type=\"spot\">\n<transform name=\"toWorld\"><translate y=\"-2e7\"/>"
                   "</transform></emitter>\n</scene>\n", NULL, 8, "coordinate limit");
    expect_refused("rect.xml", HEAD SENSOR LOOK "</sensor>\n"
                   "<shape type=\"rectangle\"><transform name=\"toWorld\"><translate z=\"1e19\"/>"
                   "</transform></shape>\n</scene>\n", NULL, 7, "a corner of its bounds");
    expect_refused("sphere.xml", HEAD SENSOR LOOK "</sensor>\n"
                   "<shape type=\"sphere\"><float name=\"radius\" value=\"1e30\"/></shape>\n"
                   "</scene>\n", NULL, 7, "radius 1e+30");
    /* an instance: the same OBJ placed twice, once too far */
    op_test_write_text(in_dir("tri.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    const char *inst = HEAD SENSOR LOOK "</sensor>\n"
        "<shape type=\"obj\"><string name=\"filename\" value=\"tri.obj\"/></shape>\n"
        "<shape type=\"obj\"><string name=\"filename\" value=\"tri.obj\"/>\n"
        "<transform name=\"toWorld\"><translate x=\"-3e8\"/></transform></shape>\n</scene>\n";
    expect_refused("inst.xml", inst, NULL, 8, "coordinate limit");
    /* raised, the same scenes load */
    op_scene_limits lim;
    op_scene_limits_init(&lim);
    op_error err = {0};
    OP_ASSERT_OK(op_scene_limits_set(&lim, "coordinate=1e9", &err), err);
    expect_loads("inst.xml", inst, &lim);
    /* and the hard range of the limit is kept */
    assert_int_equal(op_scene_limits_set(&lim, "coordinate=1e30", &err), OP_ERR_INPUT);
    assert_non_null(strstr(err.message, "coordinate"));
    assert_int_equal(op_scene_limits_set(&lim, "colour=3", &err), OP_ERR_INPUT);
    assert_non_null(strstr(err.message, "image-pixels"));
}

/* Directions too long for float and far rays: normalized in double, rendered without an abort;
 * a camera at the limit with a far clip of 1e30 renders too. */
static void huge_directions_render(void **state)
{
    (void)state;
    const char *xml = HEAD SENSOR
        "<float name=\"farClip\" value=\"1e30\"/>"
        "<transform name=\"toWorld\"><scale value=\"1e300\"/>"
        "<lookat origin=\"0,0,-9e6\" target=\"0,0,0\"/></transform></sensor>\n"
        "<emitter type=\"directional\"><vector name=\"direction\" x=\"1e300\" y=\"-1e300\" "
        "z=\"1e300\"/></emitter>\n"
        "<emitter type=\"spot\"><transform name=\"toWorld\"><scale value=\"1e-300\"/>"
        "</transform></emitter>\n"
        "<shape type=\"sphere\"><float name=\"radius\" value=\"1e6\"/></shape>\n</scene>\n";
    op_test_write_text(in_dir("dirs.xml"), xml);
    op_renderer *r = op_test_render(in_dir("dirs.xml"), 1, 1, 0);
    const op_image *img = op_renderer_image(r);
    for (int i = 0; i < img->width * img->height * 4; i++)
        assert_true(isfinite(img->pixels[i]));
    op_renderer_free(r);
    /* a direction that is no direction is refused */
    expect_refused("dir0.xml", HEAD SENSOR LOOK "</sensor>\n" SPHERE
                   "<emitter type=\"directional\"><vector name=\"direction\" x=\"0\" y=\"0\" "
                   "z=\"0\"/></emitter>\n</scene>\n", NULL, 8, "direction");
}

/* 20000 references to an internal entity in one attribute: refused at once (expanding it was
 * quadratic: a 54 KB file took 90 s); a billion-laughs nest too. */
static void entities_refused_quickly(void **state)
{
    (void)state;
    size_t n = 20000, cap = n * 3 + 4096;
    char *xml = malloc(cap);
    assert_non_null(xml);
    size_t k = (size_t)snprintf(xml, cap, "<?xml version=\"1.0\"?>\n<!DOCTYPE scene [<!ENTITY a "
                                "\"%0500d\">]>\n<scene version=\"0.6.0\">\n<shape type=\"sphere\" "
                                "id=\"", 0);
    for (size_t i = 0; i < n; i++)
        k += (size_t)snprintf(xml + k, cap - k, "&a;");
    snprintf(xml + k, cap - k, "\"/>\n</scene>\n");
    double t0 = op_monotonic_seconds();
    /* libxml2 2.13 and later refuse the file itself ("entity amplification factor") */
    expect_refused("ent.xml", xml, NULL, 4, "entity references|entity amplification");
    double s = op_monotonic_seconds() - t0;
    if (s > 2.0)
        fail_msg("refusing the entity file took %.2f s", s);
    free(xml);
    expect_refused("laughs.xml",
                   "<?xml version=\"1.0\"?>\n<!DOCTYPE scene [\n<!ENTITY a \"aaaaaaaaaa\">\n"
                   "<!ENTITY b \"&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;\">\n"
                   "<!ENTITY c \"&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;\">\n"
                   "<!ENTITY d \"&c;&c;&c;&c;&c;&c;&c;&c;&c;&c;\">\n]>\n"
                   "<scene version=\"0.6.0\">\n<integrator type=\"&d;&d;&d;&d;\"/>\n</scene>\n",
                   NULL, 9, "entity");
}

/* A small RGB PNG of w x h. */
static void write_png(const char *path, int w, int h)
{
    op_image img;
    op_error err = {0};
    OP_ASSERT_OK(op_image_alloc(&img, w, h, 3, &err), err);
    for (int i = 0; i < w * h * 3; i++)
        img.pixels[i] = 0.5f;
    OP_ASSERT_OK(op_image_write_png(path, &img, 0.0f, &err), err);
    op_image_free(&img);
}

static void image_pixels_limit(void **state)
{
    (void)state;
    write_png(in_dir("tex.png"), 64, 32);
    const char *tex = HEAD SENSOR LOOK "</sensor>\n"
        "<shape type=\"sphere\"><bsdf type=\"diffuse\"><texture type=\"bitmap\" "
        "name=\"reflectance\">\n<string name=\"filename\" value=\"tex.png\"/></texture></bsdf>"
        "</shape>\n</scene>\n";
    const char *env = HEAD SENSOR LOOK "</sensor>\n" SPHERE
        "<emitter type=\"envmap\"><string name=\"filename\" value=\"tex.png\"/></emitter>\n"
        "</scene>\n";
    op_scene_limits lim;
    op_scene_limits_init(&lim);
    op_error err = {0};
    OP_ASSERT_OK(op_scene_limits_set(&lim, "image-pixels=2000", &err), err);
    expect_refused("tex.xml", tex, &lim, 7, "2048 pixels is over the limit of 2000 pixels "
                   "(image-pixels)");
    /* the envmap replaces the constant emitter: drop it for this scene */
    char *env2 = strdup(env);
    assert_non_null(env2);
    memcpy(strstr(env2, "<emitter type=\"constant\"/>"), "<!-- no constant here! -->", 26);
    expect_refused("env.xml", env2, &lim, 8, "over the limit of 2000 pixels");
    OP_ASSERT_OK(op_scene_limits_set(&lim, "image-pixels=2048", &err), err);
    expect_loads("tex.xml", tex, &lim);
    expect_loads("env.xml", env2, &lim);
    free(env2);
}

/* A raw material of w x h pixels with kernel K (Rd spread evenly over the kernel). */
static void write_material(const char *path, int w, int h, int K, double size_cm)
{
    op_material_info info;
    memset(&info, 0, sizeof info);
    info.method = OP_METHOD_RAW;
    info.width = w;
    info.height = h;
    info.kernel = K;
    info.channels = 3;
    info.size_x_cm = info.size_y_cm = size_cm;
    snprintf(info.name, sizeof info.name, "K%d", K);
    snprintf(info.generator, sizeof info.generator, "test_robust_scene");
    size_t n = (size_t)w * h * K * K;
    float *rd = malloc(n * sizeof(float));
    assert_non_null(rd);
    for (size_t i = 0; i < n; i++)
        rd[i] = 0.5f / (float)(K * K);
    op_error err = {0};
    op_material_writer *wr;
    OP_ASSERT_OK(op_material_writer_open(path, &info, &wr, &err), err);
    static const char *tags[3] = {"RD.R", "RD.G", "RD.B"};
    for (int c = 0; c < 3; c++)
        OP_ASSERT_OK(op_material_writer_add(wr, tags[c], rd, n * sizeof(float), &err), err);
    OP_ASSERT_OK(op_material_writer_commit(wr, &err), err);
    free(rd);
}

static const char *sss_scene(const char *material, const char *scale, const char *max_points)
{
    static char buf[2048];
    snprintf(buf, sizeof buf, HEAD SENSOR LOOK "</sensor>\n"
             "<shape type=\"rectangle\"><subsurface type=\"raw\">\n"
             "<string name=\"material\" value=\"%s\"/><float name=\"scale\" value=\"%s\"/>"
             "<integer name=\"maxPoints\" value=\"%s\"/></subsurface></shape>\n</scene>\n",
             material, scale, max_points);
    return buf;
}

static void kernel_and_points_limits(void **state)
{
    (void)state;
    /* the bomb of the issue: a 12.5 MB material of one pixel with kernel 1023 */
    write_material(in_dir("k1023.opm"), 1, 1, 1023, 1.0);
    double t0 = op_monotonic_seconds();
    expect_refused("k1023.xml", sss_scene("k1023.opm", "100", "1000"), NULL, 7,
                   "kernel size 1023, over the limit of 255 (kernel");
    assert_true(op_monotonic_seconds() - t0 < 2.0);
    /* a small one: refused under a lower limit, accepted at its size */
    write_material(in_dir("k9.opm"), 2, 2, 9, 1.0);
    op_scene_limits lim;
    op_scene_limits_init(&lim);
    op_error err = {0};
    OP_ASSERT_OK(op_scene_limits_set(&lim, "kernel=7", &err), err);
    expect_refused("k9.xml", sss_scene("k9.opm", "100", "1000"), &lim, 7,
                   "kernel size 9, over the limit of 7");
    OP_ASSERT_OK(op_scene_limits_set(&lim, "kernel=9", &err), err);
    expect_loads("k9.xml", sss_scene("k9.opm", "100", "1000"), &lim);
    /* a material pixel of 1e-300 scene units asked for "inf" points: refused before any */
    expect_refused("tiny.xml", sss_scene("k9.opm", "1e-300", "1000"), NULL, 7,
                   "is out of range");
    /* the total of irradiance points: 2 x 2 units of 0.5 cm pixels at scale 100 need 16 */
    OP_ASSERT_OK(op_scene_limits_set(&lim, "sss-points=15", &err), err);
    expect_refused("pts.xml", sss_scene("k9.opm", "100", "1000"), &lim, 7,
                   "need 16 irradiance points so far, over the limit of 15 (sss-points");
    OP_ASSERT_OK(op_scene_limits_set(&lim, "sss-points=16", &err), err);
    expect_loads("pts.xml", sss_scene("k9.opm", "100", "1000"), &lim);
}

/* Each rejection after a shape's mesh exists frees it (LeakSanitizer fails the program
 * otherwise). */
static void rejected_shapes_free_their_meshes(void **state)
{
    (void)state;
    op_test_write_text(in_dir("line.obj"), "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
    expect_refused("zero.xml", HEAD SENSOR LOOK "</sensor>\n"
                   "<shape type=\"obj\"><string name=\"filename\" value=\"line.obj\"/></shape>\n"
                   "</scene>\n", NULL, 7, "zero area");
    expect_refused("inf.xml", HEAD SENSOR LOOK "</sensor>\n"
                   "<shape type=\"cube\"><transform name=\"toWorld\"><scale value=\"1e300\"/>"
                   "</transform></shape>\n</scene>\n", NULL, 7, "not finite");
    expect_refused("sing.xml", HEAD SENSOR LOOK "</sensor>\n"
                   "<shape type=\"disk\"><transform name=\"toWorld\"><scale x=\"0\"/>"
                   "</transform></shape>\n</scene>\n", NULL, 7, "singular");
    expect_refused("big.xml", HEAD SENSOR LOOK "</sensor>\n"
                   "<shape type=\"sphere\"><float name=\"radius\" value=\"1e6\"/>"
                   "<transform name=\"toWorld\"><translate x=\"9.5e6\"/></transform></shape>\n"
                   "</scene>\n", NULL, 7, "a corner of its bounds");
    /* an emitter refused after its envmap was read */
    write_png(in_dir("env.png"), 8, 4);
    expect_refused("env2.xml", HEAD SENSOR LOOK "</sensor>\n" SPHERE
                   "<emitter type=\"envmap\"><string name=\"filename\" value=\"env.png\"/>"
                   "</emitter>\n</scene>\n", NULL, 8, "only one environment emitter");
}

/* $$ is one literal $: a file named m$a.obj can be referenced. */
static void dollar_escape(void **state)
{
    (void)state;
    op_test_write_text(in_dir("m$a.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    expect_refused("dollar.xml", HEAD SENSOR LOOK "</sensor>\n"
                   "<shape type=\"obj\"><string name=\"filename\" value=\"m$a.obj\"/></shape>\n"
                   "</scene>\n", NULL, 7, "undefined parameter '$a'");
    expect_loads("dollar.xml", HEAD SENSOR LOOK "</sensor>\n"
                 "<shape type=\"obj\"><string name=\"filename\" value=\"m$$a.obj\"/></shape>\n"
                 "</scene>\n", NULL);
    /* and after substitution: $$$name is '$' then the parameter */
    op_scene_define def = {"which", "a.obj"};
    op_test_write_text(in_dir("dollar2.xml"), HEAD SENSOR LOOK "</sensor>\n"
                       "<shape type=\"obj\"><string name=\"filename\" value=\"m$$$which\"/>"
                       "</shape>\n</scene>\n");
    op_scene *scene = NULL;
    op_error err = {0};
    OP_ASSERT_OK(op_scene_load(in_dir("dollar2.xml"), &def, 1, &scene, &err), err);
    op_scene_free(scene);
}

/* A missing preset is bad input with or without an op_error to fill. */
static void missing_preset_is_input(void **state)
{
    (void)state;
    const char *xml = sss_scene("NoSuchPresetAnywhere", "1", "1000");
    op_test_write_text(in_dir("preset.xml"), xml);
    op_scene *scene = NULL;
    assert_int_equal(op_scene_load(in_dir("preset.xml"), NULL, 0, &scene, NULL), OP_ERR_INPUT);
    assert_null(scene);
    op_error err = {0};
    assert_int_equal(op_scene_load(in_dir("preset.xml"), NULL, 0, &scene, &err), OP_ERR_INPUT);
    assert_non_null(strstr(err.message, "NoSuchPresetAnywhere"));
    /* any other refusal keeps its status without an op_error too */
    op_test_write_text(in_dir("far.xml"), HEAD SENSOR "<transform name=\"toWorld\">"
                       "<translate x=\"1e19\"/></transform></sensor>\n</scene>\n");
    assert_int_equal(op_scene_load(in_dir("far.xml"), NULL, 0, &scene, NULL), OP_ERR_INPUT);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(far_camera_light_and_shapes),
        cmocka_unit_test(huge_directions_render),
        cmocka_unit_test(entities_refused_quickly),
        cmocka_unit_test(image_pixels_limit),
        cmocka_unit_test(kernel_and_points_limits),
        cmocka_unit_test(rejected_shapes_free_their_meshes),
        cmocka_unit_test(dollar_escape),
        cmocka_unit_test(missing_preset_is_input),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
