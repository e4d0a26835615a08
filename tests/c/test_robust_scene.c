/* test_robust_scene.c - bad scenes and resource bombs: positions beyond what single precision
 * can trace are refused at load (so --check and rendering agree) with the element's
 * line; entity references in attributes are refused at once; images, kernels and irradiance
 * points over a limit are refused naming the limit and accepted when it is raised; rejected
 * shapes free their meshes (LeakSanitizer runs on this program); `$$` is a literal `$`; a
 * missing preset is bad input even without an op_error. Everything lives in one temporary
 * folder, removed at the end. */
#define _XOPEN_SOURCE 700
#include "test_support.h"

#include "opaline_material.h"
#include "opaline_material_write.h"

#include <ftw.h>
#include <math.h>
#include <stdarg.h>
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
/* A sphere textured with tex.png (a line break inside: one line). */
#define TEX_SPHERE                                                                                 \
    "<shape type=\"sphere\"><bsdf type=\"diffuse\"><texture type=\"bitmap\" "                    \
    "name=\"reflectance\">\n<string name=\"filename\" value=\"tex.png\"/></texture></bsdf>"       \
    "</shape>\n"

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

/* 20000 references to an internal entity in one attribute: refused at once (expanding them
 * would take time quadratic in their number); a billion-laughs nest too. */
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
    /* libxml2 2.13 and later refuse the file itself ("entity amplification factor") */
    expect_refused("ent.xml", xml, NULL, 4, "entity references|entity amplification");
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
    const char *tex = HEAD SENSOR LOOK "</sensor>\n" TEX_SPHERE "</scene>\n";
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
             "<string name=\"material\" value=\"%s\"/><float name=\"sceneUnitsPerMetre\" value=\"%s\"/>"
             "<integer name=\"maxPoints\" value=\"%s\"/></subsurface></shape>\n</scene>\n",
             material, scale, max_points);
    return buf;
}

static void kernel_and_points_limits(void **state)
{
    (void)state;
    /* the bomb of the issue: a 12.5 MB material of one pixel with kernel 1023 */
    write_material(in_dir("k1023.opm"), 1, 1, 1023, 1.0);
    expect_refused("k1023.xml", sss_scene("k1023.opm", "100", "1000"), NULL, 7,
                   "kernel size 1023, over the limit of 255 (kernel");
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

/* A growing text buffer for the large scenes below. */
typedef struct text {
    char *s;
    size_t n, cap;
} text;

static void put(text *t, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

static void put(text *t, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int k = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    assert_true(k >= 0);
    if (t->n + (size_t)k + 1 > t->cap) {
        t->cap = (t->n + (size_t)k + 1) * 2;
        t->s = realloc(t->s, t->cap);
        assert_non_null(t->s);
    }
    va_start(ap, fmt);
    vsnprintf(t->s + t->n, t->cap - t->n, fmt, ap);
    va_end(ap);
    t->n += (size_t)k;
}

/* Include fan-out: five small files, each including the next 30 times, would read 837,930
 * includes (k = 30 never finished): refused at the include-count limit, naming it; the
 * include-bytes limit counts every inclusion of a file; both load when raised. */
static void include_limits(void **state)
{
    (void)state;
    for (int level = 1; level <= 4; level++) {
        text t = {0};
        put(&t, "<scene version=\"0.6.0\">\n");
        for (int i = 0; i < 30 && level < 4; i++)
            put(&t, "<include filename=\"fan%d.xml\"/>\n", level + 1);
        if (level == 4)
            put(&t, "<bsdf type=\"diffuse\"/>\n");
        put(&t, "</scene>\n");
        char name[32];
        snprintf(name, sizeof name, "fan%d.xml", level);
        op_test_write_text(in_dir(name), t.s);
        free(t.s);
    }
    text t = {0};
    put(&t, HEAD SENSOR LOOK "</sensor>\n" SPHERE);
    for (int i = 0; i < 30; i++)
        put(&t, "<include filename=\"fan1.xml\"/>\n");
    put(&t, "</scene>\n");
    expect_refused("fan.xml", t.s, NULL, 0, "more than 100000 <include> elements are read "
                   "(include-count");
    /* include-bytes: 30 inclusions of a 30-byte leaf are 900 bytes besides the main file */
    op_test_write_text(in_dir("leaf.xml"), "<scene version=\"0.6.0\"></scene>\n");
    text u = {0};
    put(&u, HEAD SENSOR LOOK "</sensor>\n" SPHERE);
    for (int i = 0; i < 30; i++)
        put(&u, "<include filename=\"leaf.xml\"/>\n");
    put(&u, "</scene>\n");
    op_scene_limits lim;
    op_scene_limits_init(&lim);
    op_error err = {0};
    char set[64];
    snprintf(set, sizeof set, "include-bytes=%zu", u.n + 29 * 32);
    OP_ASSERT_OK(op_scene_limits_set(&lim, set, &err), err);
    expect_refused("leaves.xml", u.s, &lim, 37, "<include>: with its 32 "
                   "bytes the scene file and its includes add up to more than the limit");
    expect_refused("leaves.xml", u.s, &lim, 0, "--limit include-bytes=VALUE");
    snprintf(set, sizeof set, "include-bytes=%zu", u.n + 30 * 32);
    OP_ASSERT_OK(op_scene_limits_set(&lim, set, &err), err);
    expect_loads("leaves.xml", u.s, &lim);
    OP_ASSERT_OK(op_scene_limits_set(&lim, "include-count=29", &err), err);
    expect_refused("leaves.xml", u.s, &lim, 37, "more than 29 <include> elements");
    free(u.s);
    free(t.s);
}

/* A <default> "billion laughs": d1 is d0 ten times, d2 is d1 ten times, ... d9 would be 10 GB
 * from a file of a few hundred bytes. Refused at the attribute-bytes limit (d8's 1 GB) before
 * it is allocated; a flat variant (one 64 KiB value used 300 times) under a lower limit. */
static void default_bomb(void **state)
{
    (void)state;
    text t = {0};
    put(&t, HEAD "<default name=\"d0\" value=\"0123456789\"/>\n");
    for (int i = 1; i <= 9; i++)
        put(&t, "<default name=\"d%d\" value=\"$d%d$d%d$d%d$d%d$d%d$d%d$d%d$d%d$d%d$d%d\"/>\n", i,
            i - 1, i - 1, i - 1, i - 1, i - 1, i - 1, i - 1, i - 1, i - 1, i - 1);
    put(&t, SENSOR LOOK "</sensor>\n<shape type=\"sphere\" id=\"$d9\"/>\n</scene>\n");
    expect_refused("laughs_default.xml", t.s, NULL, 14, "<default name=\"d8\">: attribute value: "
                   "the attribute values after $parameter expansion add up to more than the "
                   "limit of 268435456 bytes (attribute-bytes; raise it with --limit "
                   "attribute-bytes=VALUE)");
    free(t.s);
    text f = {0};
    put(&f, HEAD "<default name=\"big\" value=\"");
    for (int i = 0; i < 1 << 16; i++)
        put(&f, "x");
    put(&f, "\"/>\n" SENSOR LOOK "</sensor>\n");
    for (int i = 0; i < 300; i++)
        put(&f, "<bsdf type=\"diffuse\" id=\"b%d$big\"/>\n", i);
    put(&f, "</scene>\n");
    op_scene_limits lim;
    op_scene_limits_init(&lim);
    op_error err = {0};
    OP_ASSERT_OK(op_scene_limits_set(&lim, "attribute-bytes=10000000", &err), err);
    expect_refused("flat.xml", f.s, &lim, 0, "attribute id: the attribute values after "
                   "$parameter expansion add up to more than the limit of 10000000 bytes");
    OP_ASSERT_OK(op_scene_limits_set(&lim, "attribute-bytes=60000", &err), err);
    expect_refused("flat.xml", f.s, &lim, 6, "<default name=\"big\">: attribute value");
    OP_ASSERT_OK(op_scene_limits_set(&lim, "attribute-bytes=30000000", &err), err);
    expect_loads("flat.xml", f.s, &lim);
    free(f.s);
}

/* 200,000 <default>s, each used once: parameters are looked up in a hash table (a linear list
 * made this quadratic: 6 minutes; the test's ctest timeout would stop it). */
static void many_defaults(void **state)
{
    (void)state;
    enum { N = 200000 };
    text t = {0};
    put(&t, HEAD);
    for (int i = 0; i < N; i++)
        put(&t, "<default name=\"p%d\" value=\"%d\"/>\n", i, i);
    put(&t, SENSOR LOOK "</sensor>\n<shape type=\"sphere\"><bsdf type=\"diffuse\" "
        "id=\"x-$p0-$p%d\"/></shape>\n</scene>\n", N - 1);
    expect_loads("defaults.xml", t.s, NULL);
    free(t.s);
}

/* Spheres share one tessellated unit sphere, placed as instances: 100 spheres hold one mesh
 * (2,500 spheres each tessellated and put in the BVH would take 5 GB and 44 s for --check). */
static void spheres_share_one_mesh(void **state)
{
    (void)state;
    text t = {0};
    put(&t, HEAD SENSOR LOOK "</sensor>\n");
    for (int i = 0; i < 100; i++)
        put(&t, "<shape type=\"sphere\"><point name=\"center\" x=\"%d\" y=\"0\" z=\"5\"/>"
            "<float name=\"radius\" value=\"0.4\"/></shape>\n", i - 50);
    put(&t, "</scene>\n");
    op_test_write_text(in_dir("spheres.xml"), t.s);
    free(t.s);
    op_scene *scene = NULL;
    op_error err = {0};
    OP_ASSERT_OK(op_scene_load(in_dir("spheres.xml"), NULL, 0, &scene, &err), err);
    op_scene_info info;
    op_scene_get_info(scene, &info);
    assert_int_equal(info.shapes, 100);
    assert_int_equal(info.instances, 100);
    /* one sphere's mesh (16,128 triangles, about 1 MB) and its BVH, not a hundred */
    if (info.geometry_bytes > 8 << 20)
        fail_msg("100 spheres hold %lld bytes of geometry", info.geometry_bytes);
    op_scene_free(scene);
}

/* The triangles limit counts what the scene stores: a mesh shared by instances once. */
static void triangles_limit(void **state)
{
    (void)state;
    const char *two = HEAD SENSOR LOOK "</sensor>\n" SPHERE
        "<shape type=\"sphere\"><point name=\"center\" x=\"3\" y=\"0\" z=\"0\"/></shape>\n"
        "</scene>\n";
    const char *lit = HEAD SENSOR LOOK "</sensor>\n" SPHERE
        "<shape type=\"sphere\"><emitter type=\"area\"/></shape>\n</scene>\n";
    op_scene_limits lim;
    op_scene_limits_init(&lim);
    op_error err = {0};
    OP_ASSERT_OK(op_scene_limits_set(&lim, "triangles=16127", &err), err);
    expect_refused("two.xml", two, &lim, 7, "<shape type=\"sphere\">: with its 16128 triangles "
                   "the scene holds more than the limit of 16127 triangles (triangles; raise it "
                   "with --limit triangles=VALUE)");
    OP_ASSERT_OK(op_scene_limits_set(&lim, "triangles=16128", &err), err);
    expect_loads("two.xml", two, &lim);
    /* an emitting sphere is not an instance: its own world-space triangles count */
    expect_refused("lit.xml", lit, &lim, 8, "the limit of 16128 triangles");
    OP_ASSERT_OK(op_scene_limits_set(&lim, "triangles=32256", &err), err);
    expect_loads("lit.xml", lit, &lim);
    assert_int_equal(op_scene_limits_set(&lim, "triangles=3e9", &err), OP_ERR_INPUT);
}

/* The load-memory estimate: 144 bytes per stored triangle, an image's floats. */
static void load_memory_limit(void **state)
{
    (void)state;
    write_png(in_dir("tex.png"), 64, 32);
    const char *xml = HEAD SENSOR LOOK "</sensor>\n" TEX_SPHERE "</scene>\n";
    op_scene_limits lim;
    op_scene_limits_init(&lim);
    op_error err = {0};
    char set[64];
    snprintf(set, sizeof set, "load-memory=%d", 16128 * 144 - 1);
    OP_ASSERT_OK(op_scene_limits_set(&lim, set, &err), err);
    expect_refused("lm.xml", xml, &lim, 7, "<shape type=\"sphere\">: with its triangles (2322432 "
                   "bytes) the scene is estimated to take 2322432 bytes to load, more than the "
                   "limit of 2322431 bytes (load-memory; raise it with --limit "
                   "load-memory=VALUE)");
    snprintf(set, sizeof set, "load-memory=%d", 16128 * 144 + 64 * 32 * 3 * 4 - 1);
    OP_ASSERT_OK(op_scene_limits_set(&lim, set, &err), err);
    expect_refused("lm.xml", xml, &lim, 7, "<shape type=\"sphere\">: with its images (");
    snprintf(set, sizeof set, "load-memory=%d", 16128 * 144 + 64 * 32 * 4 * 4);
    OP_ASSERT_OK(op_scene_limits_set(&lim, set, &err), err);
    expect_loads("lm.xml", xml, &lim);
}

/* A film larger than an image can hold (40000 x 40000 = 1.6e9 pixels) is refused while the
 * scene loads, so --check and --estimate refuse it as the render does. */
static void film_too_large(void **state)
{
    (void)state;
    expect_refused("film.xml", HEAD "<sensor type=\"perspective\"><film type=\"hdrfilm\">"
                   "<integer name=\"width\" value=\"40000\"/><integer name=\"height\" "
                   "value=\"40000\"/></film>\n" LOOK "</sensor>\n" SPHERE "</scene>\n", NULL, 6,
                   "<film>: size 40000x40000 = 1600000000 pixels is more than the 1073741824 "
                   "pixels (2^30) an image can hold");
    expect_loads("film2.xml", HEAD "<sensor type=\"perspective\"><film type=\"hdrfilm\">"
                 "<integer name=\"width\" value=\"32768\"/><integer name=\"height\" "
                 "value=\"32768\"/><integer name=\"cropWidth\" value=\"4\"/><integer "
                 "name=\"cropHeight\" value=\"4\"/></film>\n" LOOK "</sensor>\n" SPHERE
                 "</scene>\n", NULL);
}

/* Denormal numbers are numbers: strtod's ERANGE for them does not refuse them. */
static void denormal_numbers(void **state)
{
    (void)state;
    expect_loads("denormal.xml", HEAD SENSOR LOOK "</sensor>\n"
                 "<shape type=\"sphere\"><transform name=\"toWorld\"><translate x=\"1e-310\"/>"
                 "</transform><bsdf type=\"diffuse\"><rgb name=\"reflectance\" "
                 "value=\"0.5, 2.5e-320, 0.5\"/></bsdf></shape>\n"
                 "<shape type=\"rectangle\"><bsdf type=\"diffuse\"><spectrum name=\"reflectance\" "
                 "value=\"4e-315\"/></bsdf></shape>\n</scene>\n", NULL);
}

/* A look-at whose up is zero, or parallel to the viewing direction (up to rounding), is
 * refused; without up Mitsuba's default frame is used. */
static void lookat_up(void **state)
{
    (void)state;
    const char *fmt = HEAD SENSOR "<transform name=\"toWorld\">\n<lookat origin=\"0,0,0\" "
                      "target=\"1,2,3\"%s/></transform></sensor>\n" SPHERE "</scene>\n";
    char xml[2048];
    snprintf(xml, sizeof xml, fmt, " up=\"0,0,0\"");
    expect_refused("up0.xml", xml, NULL, 7, "degenerate look-at: target equals origin, or up is "
                   "zero or parallel to the viewing direction");
    snprintf(xml, sizeof xml, fmt, " up=\"2,4,6\"");
    expect_refused("uppar.xml", xml, NULL, 7, "degenerate look-at");
    snprintf(xml, sizeof xml, fmt, " up=\"-1e-3,-2e-3,-3e-3\"");
    expect_refused("upanti.xml", xml, NULL, 7, "degenerate look-at");
    /* 1e-13 radians off: the frame would come from the rounding of up x dir */
    snprintf(xml, sizeof xml, fmt, " up=\"1,2,3.0000000000005\"");
    expect_refused("upnear.xml", xml, NULL, 7, "degenerate look-at");
    snprintf(xml, sizeof xml, fmt, "");
    expect_loads("upnone.xml", xml, NULL);
    snprintf(xml, sizeof xml, fmt, " up=\"0,1e-300,0\"");
    expect_loads("upsmall.xml", xml, NULL);
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
        cmocka_unit_test(include_limits),
        cmocka_unit_test(default_bomb),
        cmocka_unit_test(many_defaults),
        cmocka_unit_test(spheres_share_one_mesh),
        cmocka_unit_test(triangles_limit),
        cmocka_unit_test(load_memory_limit),
        cmocka_unit_test(film_too_large),
        cmocka_unit_test(denormal_numbers),
        cmocka_unit_test(lookat_up),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
