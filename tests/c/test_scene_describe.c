/* test_scene_describe.c - a scene's description (op_scene_describe) against its build: the
 * same film, sampler, counts and files for several scenes; a mesh or material whose content
 * is garbage still describes (describing reads no mesh, opens no material) and fails to build;
 * a missing file is refused with the build's words; and the run's record of inputs, what the
 * content key (--estimate's key=, the tiles' tag) hashes, is the same after describing as after
 * building. */
#include "test_support.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The run's record of inputs (op_file_inputs_each), copied. */
typedef struct inputs {
    char *paths[64];
    int n;
} inputs;

static void add_input(void *user, const char *path)
{
    inputs *in = user;
    if (in->n < 64)
        in->paths[in->n++] = strdup(path);
}

static void inputs_take(inputs *in)
{
    memset(in, 0, sizeof *in);
    op_file_inputs_each(add_input, in);
}

static void inputs_free(inputs *in)
{
    for (int i = 0; i < in->n; i++)
        free(in->paths[i]);
    in->n = 0;
}

static void assert_inputs_equal(const inputs *a, const inputs *b)
{
    assert_int_equal(a->n, b->n);
    for (int i = 0; i < a->n; i++)
        assert_string_equal(a->paths[i], b->paths[i]);
}

static void assert_same_string(const char *a, const char *b)
{
    if (!a || !b)
        assert_ptr_equal(a, b);
    else
        assert_string_equal(a, b);
}

/* Describes and builds path: their infos agree on everything a description knows, and
 * building opens no file that describing did not. */
static void check_scene(const char *path)
{
    op_error err = {0};
    op_scene_description *d = NULL;
    op_status st = op_scene_describe(path, NULL, 0, NULL, &d, &err);
    OP_ASSERT_OK(st, err);
    inputs described, built;
    inputs_take(&described);
    op_scene *s = NULL;
    st = op_scene_load(path, NULL, 0, &s, &err);
    OP_ASSERT_OK(st, err);
    inputs_take(&built);
    assert_inputs_equal(&described, &built);
    inputs_free(&described);
    inputs_free(&built);

    op_scene_info a, b;
    op_scene_description_get_info(d, &a);
    op_scene_get_info(s, &b);
    assert_int_equal(a.width, b.width);
    assert_int_equal(a.height, b.height);
    assert_int_equal(a.full_width, b.full_width);
    assert_int_equal(a.full_height, b.full_height);
    assert_int_equal(a.spp, b.spp);
    assert_string_equal(a.film_type, b.film_type);
    assert_same_string(a.film_filename, b.film_filename);
    assert_same_string(a.film_extension, b.film_extension);
    assert_string_equal(a.integrator, b.integrator);
    assert_int_equal(a.shapes, b.shapes);
    assert_int_equal(a.emitters, b.emitters);
    assert_int_equal(a.subsurface_shapes, b.subsurface_shapes);
    if (a.triangles >= 0)
        assert_int_equal(a.triangles, b.triangles);
    assert_int_equal(a.instances, -1);
    assert_int_equal(a.geometry_bytes, -1);
    assert_true(a.load_bytes > 0);
    assert_int_equal(a.load_bytes, b.load_bytes);
    assert_int_equal(a.nfiles, b.nfiles);
    for (int i = 0; i < a.nfiles; i++)
        assert_string_equal(a.files[i], b.files[i]);
    op_scene_free(s);
    op_scene_description_free(d);
}

static const char *scene_dir(void)
{
    static char dir[1024];
    const char *tmp = getenv("OPALINE_TEST_TMP");
    snprintf(dir, sizeof dir, "%s/describe-XXXXXX", tmp && *tmp ? tmp : "/tmp");
    assert_non_null(mkdtemp(dir));
    return dir;
}

static const char *in(const char *dir, const char *name)
{
    static char buf[4][1200];
    static int k;
    char *out = buf[k++ % 4];
    snprintf(out, sizeof buf[0], "%s/%s", dir, name);
    return out;
}

#define HEAD                                                                                       \
    "<scene version=\"0.6.0\">\n<integrator type=\"path\"/>\n"                                    \
    "<sensor type=\"perspective\"><film type=\"ldrfilm\"><integer name=\"width\" value=\"12\"/>"  \
    "<integer name=\"height\" value=\"10\"/></film><sampler type=\"independent\">"                \
    "<integer name=\"sampleCount\" value=\"3\"/></sampler></sensor>\n"

static void test_describe_matches_build(void **state)
{
    (void)state;
    const char *dir = scene_dir();
    op_image tex;
    op_error err = {0};
    OP_ASSERT_OK(op_image_alloc(&tex, 6, 5, 3, &err), err);
    OP_ASSERT_OK(op_image_write_png(in(dir, "tex.png"), &tex, 0.0f, &err), err);
    op_image_free(&tex);
    op_test_write_text(in(dir, "tex.xml"), HEAD
        "<shape type=\"rectangle\"><bsdf type=\"twosided\"><bsdf type=\"diffuse\"><texture "
        "type=\"bitmap\" name=\"reflectance\"><string name=\"filename\" value=\"tex.png\"/>"
        "</texture></bsdf></bsdf></shape>\n"
        "<shape type=\"sphere\"/><shape type=\"sphere\"><point name=\"center\" x=\"3\" y=\"0\" "
        "z=\"0\"/></shape>\n<shape type=\"disk\"><emitter type=\"area\"/></shape>\n"
        "<emitter type=\"constant\"/>\n</scene>\n");
    check_scene(in(dir, "tex.xml"));
    op_test_write_text(in(dir, "dipole.xml"), HEAD
        "<shape type=\"cube\"><subsurface type=\"dipole\"><string name=\"material\" "
        "value=\"Skimmilk\"/></subsurface><bsdf type=\"dielectric\"/></shape>\n"
        "<emitter type=\"point\"><point name=\"position\" x=\"0\" y=\"0\" z=\"3\"/></emitter>\n"
        "</scene>\n");
    check_scene(in(dir, "dipole.xml"));
    const char *src = getenv("OPALINE_SOURCE_DIR");
    assert_non_null(src);
    char demo[1024];
    snprintf(demo, sizeof demo, "%s/scenes/demo/demo.xml", src);
    check_scene(demo);
    const char *spot = op_test_shared_path("meshes/spot.obj");
    if (spot) {
        char xml[2048];
        snprintf(xml, sizeof xml, HEAD "<shape type=\"obj\"><string name=\"filename\" value=\"%s\"/>"
                 "</shape>\n<shape type=\"obj\"><string name=\"filename\" value=\"%s\"/>"
                 "<transform name=\"toWorld\"><translate x=\"2\"/></transform></shape>\n"
                 "<emitter type=\"constant\"/>\n</scene>\n", spot, spot);
        op_test_write_text(in(dir, "spot.xml"), xml);
        check_scene(in(dir, "spot.xml"));
    }
}

/* Describing reads no mesh and opens no material: garbage in both still describes (and lists
 * them), and building refuses it. */
static void test_describe_reads_no_content(void **state)
{
    (void)state;
    const char *dir = scene_dir();
    op_test_write_text(in(dir, "junk.obj"), "f 1 2 99999\nv x y z\n\x01\x02 not a mesh\n");
    op_test_write_text(in(dir, "junk.ply"), "ply\nformat ascii 1.0\nelement face banana\n");
    op_test_write_text(in(dir, "junk.opm"), "not a material");
    op_test_write_text(in(dir, "mesh.xml"), HEAD
        "<shape type=\"obj\"><string name=\"filename\" value=\"junk.obj\"/></shape>\n"
        "<shape type=\"ply\"><string name=\"filename\" value=\"junk.ply\"/></shape>\n"
        "<shape type=\"sphere\"><subsurface type=\"svd\"><string name=\"material\" "
        "value=\"junk.opm\"/></subsurface></shape>\n</scene>\n");
    op_error err = {0};
    op_scene_description *d = NULL;
    op_status st = op_scene_describe(in(dir, "mesh.xml"), NULL, 0, NULL, &d, &err);
    OP_ASSERT_OK(st, err);
    op_scene_info info;
    op_scene_description_get_info(d, &info);
    assert_int_equal(info.shapes, 3);
    assert_int_equal(info.subsurface_shapes, 1);
    assert_int_equal(info.triangles, -1);
    assert_int_equal(info.nfiles, 3);
    assert_string_equal(info.files[0], in(dir, "junk.obj"));
    assert_string_equal(info.files[1], in(dir, "junk.ply"));
    assert_string_equal(info.files[2], in(dir, "junk.opm"));
    op_scene_description_free(d);
    op_scene *s = NULL;
    assert_int_not_equal(op_scene_load(in(dir, "mesh.xml"), NULL, 0, &s, &err), OP_OK);
    assert_null(s);
}

/* A missing file is refused by describing with the words and status of building. */
static void test_describe_refuses_missing_files(void **state)
{
    (void)state;
    const char *dir = scene_dir();
    static const char *const shapes[] = {
        "<shape type=\"obj\"><string name=\"filename\" value=\"none.obj\"/></shape>",
        "<shape type=\"rectangle\"><bsdf type=\"diffuse\"><texture type=\"bitmap\" "
        "name=\"reflectance\"><string name=\"filename\" value=\"none.png\"/></texture></bsdf>"
        "</shape>",
        "<shape type=\"sphere\"><subsurface type=\"svd\"><string name=\"material\" "
        "value=\"none.opm\"/></subsurface></shape>",
        "<emitter type=\"envmap\"><string name=\"filename\" value=\"none.exr\"/></emitter>",
        "<shape type=\"sphere\"><subsurface type=\"svd\"><string name=\"material\" "
        "value=\"NoSuchPreset\"/></subsurface></shape>",
    };
    for (size_t i = 0; i < sizeof shapes / sizeof shapes[0]; i++) {
        char xml[2048];
        snprintf(xml, sizeof xml, HEAD "%s\n</scene>\n", shapes[i]);
        op_test_write_text(in(dir, "missing.xml"), xml);
        op_error described = {0}, built = {0};
        op_scene_description *d = NULL;
        op_scene *s = NULL;
        op_status a = op_scene_describe(in(dir, "missing.xml"), NULL, 0, NULL, &d, &described);
        assert_int_equal(a, OP_ERR_INPUT);
        assert_null(d);
        assert_int_equal(op_scene_load(in(dir, "missing.xml"), NULL, 0, &s, &built), a);
        assert_string_equal(described.message, built.message);
        assert_non_null(strstr(described.message, "missing.xml:4: "));
    }
}

/* The built-in shapes' triangles are counted against the limits as the build counts them (a
 * shared unit sphere once): describing refuses what building refuses, with its words. */
static void test_describe_counts_limits(void **state)
{
    (void)state;
    const char *dir = scene_dir();
    op_test_write_text(in(dir, "spheres.xml"), HEAD "<shape type=\"sphere\"/><shape type=\"sphere\">"
                       "<point name=\"center\" x=\"3\" y=\"0\" z=\"0\"/></shape>\n</scene>\n");
    op_scene_limits lim;
    op_scene_limits_init(&lim);
    op_error err = {0};
    OP_ASSERT_OK(op_scene_limits_set(&lim, "triangles=20000", &err), err);
    op_scene_description *d = NULL;
    OP_ASSERT_OK(op_scene_describe(in(dir, "spheres.xml"), NULL, 0, &lim, &d, &err), err);
    op_scene_description_free(d);
    OP_ASSERT_OK(op_scene_limits_set(&lim, "load-memory=1e6", &err), err);
    op_error described = {0}, built = {0};
    assert_int_equal(op_scene_describe(in(dir, "spheres.xml"), NULL, 0, &lim, &d, &described),
                     OP_ERR_INPUT);
    op_scene *s = NULL;
    assert_int_equal(op_scene_load_limited(in(dir, "spheres.xml"), NULL, 0, &lim, &s, &built),
                     OP_ERR_INPUT);
    assert_string_equal(described.message, built.message);
    assert_non_null(strstr(described.message, "(load-memory;"));
}

int main(void)
{
    op_file_protect_inputs(); /* the record of inputs starts here */
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_describe_matches_build),
        cmocka_unit_test(test_describe_reads_no_content),
        cmocka_unit_test(test_describe_refuses_missing_files),
        cmocka_unit_test(test_describe_counts_limits),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
