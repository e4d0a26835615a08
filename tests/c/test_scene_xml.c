/* test_scene_xml.c - the scene reader: values, colours, transforms, parameters, includes,
 * references, every error it reports, getters and the unused-parameter report. The scenes are
 * written by the tests themselves into the test tmp folder. */
#include "test_support.h"

#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "scene/scene_color.h"
#include "scene/scene_desc.h"
#include "math/transform.h"

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

/* Writes xml to a fresh file (its path left in path) and parses it. */
static op_status parse_text(const char *xml, const op_define *defs, int ndefs, op_node **root,
                            op_error *err, char path[1024])
{
    snprintf(path, 1024, "%s", op_test_tmp_path("scene.xml"));
    write_text(path, xml);
    return op_desc_parse(path, defs, ndefs, NULL, root, err);
}

/* Parsing must fail with OP_ERR_INPUT, naming the file, the line and the given words. */
static void expect_error(const char *xml, int line, const char *words)
{
    char path[1024], where[1100];
    op_error err = {0};
    op_node *root = (op_node *)1;
    op_status st = parse_text(xml, NULL, 0, &root, &err, path);
    if (st != OP_ERR_INPUT)
        fail_msg("expected an input error about '%s', got %s: %s", words, op_status_name(st),
                 err.message);
    assert_null(root);
    snprintf(where, sizeof where, "%s:%d: ", path, line);
    if (strncmp(err.message, where, strlen(where)) != 0 || !strstr(err.message, words))
        fail_msg("message '%s' does not start with '%s' or lacks '%s'", err.message, where, words);
}

#define HEAD "<?xml version=\"1.0\"?>\n<scene version=\"0.6.0\">\n"

static void values_and_structure(void **state)
{
    const char *xml = HEAD
        "  <shape type=\"obj\" id=\"bunny\">\n"                                   /* 3 */
        "    <string name=\"filename\" value=\"meshes/a b.obj\"/>\n"
        "    <float name=\"f\" value=\"-1.5e2\"/>\n"
        "    <integer name=\"i\" value=\" 42 \"/>\n"
        "    <boolean name=\"t\" value=\"true\"/>\n"
        "    <boolean name=\"u\" value=\"false\"/>\n"
        "    <point name=\"p\" x=\"1\" z=\"3\"/>\n"
        "    <vector name=\"v\" value=\"4, 5 6\"/>\n"
        "    <bsdf type=\"diffuse\" name=\"inner\">\n"                            /* 11 */
        "      <rgb name=\"reflectance\" value=\"0.2, 0.4, 0.6\"/>\n"
        "    </bsdf>\n"
        "    <!-- a comment -->\n"
        "  </shape>\n"
        "</scene>\n";
    char path[1024];
    op_error err = {0};
    op_node *root;
    OP_ASSERT_OK(parse_text(xml, NULL, 0, &root, &err, path), err);
    assert_string_equal(root->tag, "scene");
    assert_null(root->type);
    assert_int_equal(root->nchildren, 1);
    op_node *s = root->children[0];
    assert_string_equal(s->tag, "shape");
    assert_string_equal(s->type, "obj");
    assert_string_equal(s->id, "bunny");
    assert_int_equal(s->line, 3);
    assert_string_equal(s->file, path);
    const char *str;
    double f, v3[3];
    long long i;
    int b;
    OP_ASSERT_OK(op_node_string(s, "filename", NULL, &str, &err), err);
    assert_string_equal(str, "meshes/a b.obj");
    OP_ASSERT_OK(op_node_float(s, "f", 0, &f, &err), err);
    assert_float_equal(f, -150.0, 0);
    OP_ASSERT_OK(op_node_int(s, "i", 0, &i, &err), err);
    assert_int_equal(i, 42);
    OP_ASSERT_OK(op_node_float(s, "i", 0, &f, &err), err); /* integer accepted as float */
    assert_float_equal(f, 42.0, 0);
    OP_ASSERT_OK(op_node_bool(s, "t", 0, &b, &err), err);
    assert_int_equal(b, 1);
    OP_ASSERT_OK(op_node_bool(s, "u", 1, &b, &err), err);
    assert_int_equal(b, 0);
    OP_ASSERT_OK(op_node_vec3(s, "p", NULL, v3, &err), err);
    assert_true(v3[0] == 1 && v3[1] == 0 && v3[2] == 3);
    OP_ASSERT_OK(op_node_vec3(s, "v", NULL, v3, &err), err);
    assert_true(v3[0] == 4 && v3[1] == 5 && v3[2] == 6);
    /* Absent properties give the default. */
    OP_ASSERT_OK(op_node_float(s, "absent", 7.5, &f, &err), err);
    assert_float_equal(f, 7.5, 0);
    assert_false(op_node_has(s, "absent"));
    assert_true(op_node_has(s, "f"));
    /* Nested object. */
    assert_int_equal(op_node_count(s, "bsdf"), 1);
    op_node *bsdf = op_node_child(s, "bsdf", 0);
    assert_non_null(bsdf);
    assert_string_equal(op_node_child_name(s, 0), "inner");
    assert_int_equal(bsdf->line, 11);
    OP_ASSERT_OK(op_node_color(bsdf, "reflectance", NULL, v3, &err), err);
    assert_true(v3[0] == 0.2 && v3[1] == 0.4 && v3[2] == 0.6);
    /* Paths resolve against the defining file's folder. */
    char *resolved = op_node_resolve(s, str);
    assert_non_null(resolved);
    assert_non_null(strstr(resolved, "/meshes/a b.obj"));
    assert_true(strncmp(resolved, path, (size_t)(strrchr(path, '/') - path)) == 0);
    free(resolved);
    op_desc_free(root);
}

static void colours(void **state)
{
    char spec_path[1024];
    snprintf(spec_path, sizeof spec_path, "%s", op_test_tmp_path("flat.spd"));
    write_text(spec_path, "# flat\n360 0.25\n600 0.25\n\n830 0.25 # end\n");
    const char *base = strrchr(spec_path, '/') + 1;
    char xml[4096];
    snprintf(xml, sizeof xml, HEAD
             "  <bsdf type=\"x\">\n"
             "    <srgb name=\"s\" value=\"0.5\"/>\n"
             "    <srgb name=\"s3\" value=\"1, 0.5, 0\"/>\n"
             "    <rgb name=\"grey\" value=\"0.3\"/>\n"
             "    <rgb name=\"hex\" value=\"#FF8000\"/>\n"
             "    <srgb name=\"hex2\" value=\"#ff8000\"/>\n"
             "    <spectrum name=\"const\" value=\"0.5\"/>\n"
             "    <spectrum name=\"bins\" value=\"0.5, 0, 0.25\"/>\n"
             "    <spectrum name=\"flat\" value=\"360:0.7, 830:0.7\"/>\n"
             "    <spectrum name=\"red\" value=\"400:0, 580:0, 600:1, 700:1\"/>\n"
             "    <spectrum name=\"file\" filename=\"%s\"/>\n"
             "    <blackbody name=\"d65ish\" temperature=\"6504K\"/>\n"
             "    <blackbody name=\"warm\" temperature=\"2000\" scale=\"3\"/>\n"
             "    <float name=\"asgrey\" value=\"0.25\"/>\n"
             "  </bsdf>\n"
             "</scene>\n",
             base);
    char path[1024];
    op_error err = {0};
    op_node *root;
    OP_ASSERT_OK(parse_text(xml, NULL, 0, &root, &err, path), err);
    op_node *n = root->children[0];
    double c[3];
    OP_ASSERT_OK(op_node_color(n, "s", NULL, c, &err), err);
    for (int k = 0; k < 3; k++)
        assert_float_equal(c[k], 0.214041, 1e-5); /* sRGB 0.5 */
    OP_ASSERT_OK(op_node_color(n, "s3", NULL, c, &err), err);
    assert_float_equal(c[0], 1.0, 1e-12);
    assert_float_equal(c[1], 0.214041, 1e-5);
    assert_float_equal(c[2], 0.0, 1e-12);
    OP_ASSERT_OK(op_node_color(n, "grey", NULL, c, &err), err);
    assert_true(c[0] == 0.3 && c[1] == 0.3 && c[2] == 0.3);
    OP_ASSERT_OK(op_node_color(n, "hex", NULL, c, &err), err);
    assert_float_equal(c[0], 1.0, 1e-12);
    assert_float_equal(c[1], op_srgb_to_linear(128 / 255.0), 1e-12);
    assert_float_equal(c[2], 0.0, 1e-12);
    OP_ASSERT_OK(op_node_color(n, "hex2", NULL, c, &err), err);
    assert_float_equal(c[1], op_srgb_to_linear(128 / 255.0), 1e-12);
    OP_ASSERT_OK(op_node_color(n, "const", NULL, c, &err), err);
    assert_true(c[0] == 0.5 && c[1] == 0.5 && c[2] == 0.5); /* a constant spectrum is grey */
    OP_ASSERT_OK(op_node_color(n, "bins", NULL, c, &err), err);
    assert_true(c[0] == 0.5 && c[1] == 0 && c[2] == 0.25); /* Mitsuba 0.6's RGB bins */
    /* Mitsuba 0.6 reads spectra plainly: flat is the equal-energy white (1.205, 0.948, 0.909
     * in sRGB; the CIE fit's integrals agree with the tables to about 1 %) */
    double one[3] = {1, 1, 1}, e_white[3];
    op_color_xyz_to_rgb(one, e_white);
    assert_float_equal(e_white[0], 1.2049, 1e-3);
    OP_ASSERT_OK(op_node_color(n, "flat", NULL, c, &err), err);
    for (int k = 0; k < 3; k++)
        assert_float_equal(c[k], 0.7 * e_white[k], 0.02 * 0.7);
    OP_ASSERT_OK(op_node_color(n, "red", NULL, c, &err), err);
    assert_true(c[0] > 0.5 && c[0] > 5 * c[2] && c[0] > 2 * c[1]);
    OP_ASSERT_OK(op_node_color(n, "file", NULL, c, &err), err);
    for (int k = 0; k < 3; k++)
        assert_float_equal(c[k], 0.25 * e_white[k], 0.02 * 0.25);
    OP_ASSERT_OK(op_node_color(n, "d65ish", NULL, c, &err), err);
    for (int k = 0; k < 3; k++) /* close to white: D65 is near a 6504 K black body */
        assert_true(c[k] > 0.85 && c[k] < 1.15);
    OP_ASSERT_OK(op_node_color(n, "warm", NULL, c, &err), err);
    assert_true(c[0] > c[1] && c[1] > c[2]);
    assert_float_equal(0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2], 3.0, 0.05);
    OP_ASSERT_OK(op_node_color(n, "asgrey", NULL, c, &err), err); /* a float as a grey */
    assert_true(c[0] == 0.25 && c[2] == 0.25);
    op_desc_free(root);
    unlink(spec_path);

    /* Mitsuba 3 reads a reflectance's spectrum white-balanced, an emitter's plainly, and a
     * constant emitter spectrum as the equal-energy white scaled */
    OP_ASSERT_OK(parse_text("<scene version=\"3.0.0\">\n"
                            "  <bsdf type=\"x\"><spectrum name=\"flat\" value=\"360:0.7, 830:0.7\"/>"
                            "</bsdf>\n"
                            "  <emitter type=\"y\"><spectrum name=\"radiance\" value=\"2\"/>"
                            "<spectrum name=\"flat\" value=\"360:1, 830:1\"/></emitter>\n"
                            "</scene>\n", NULL, 0, &root, &err, path), err);
    OP_ASSERT_OK(op_node_color(root->children[0], "flat", NULL, c, &err), err);
    for (int k = 0; k < 3; k++)
        assert_float_equal(c[k], 0.7, 1e-9);
    OP_ASSERT_OK(op_node_color(root->children[1], "radiance", NULL, c, &err), err);
    for (int k = 0; k < 3; k++)
        assert_float_equal(c[k], 2 * e_white[k], 1e-9);
    OP_ASSERT_OK(op_node_color(root->children[1], "flat", NULL, c, &err), err);
    for (int k = 0; k < 3; k++)
        assert_float_equal(c[k], e_white[k], 0.02);
    op_desc_free(root);

    /* The colour module directly: XYZ of the D65 white maps to (1, 1, 1). */
    double xyz[3] = {0.95047, 1.0, 1.08883}, rgb[3];
    op_color_xyz_to_rgb(xyz, rgb);
    for (int k = 0; k < 3; k++)
        assert_float_equal(rgb[k], 1.0, 1e-3);
    assert_float_equal(op_srgb_to_linear(0.04045), 0.04045 / 12.92, 1e-12);
    assert_float_equal(op_srgb_to_linear(1.0), 1.0, 1e-12);
    assert_int_equal(op_color_parse_hex("#12345", rgb), 0);
    assert_int_equal(op_color_parse_hex("#12345g", rgb), 0);
}

static void assert_matrix(const op_matrix4 *m, const double want[16], double tol)
{
    for (int i = 0; i < 16; i++)
        if (fabs(m->m[i / 4][i % 4] - want[i]) > tol)
            fail_msg("entry (%d, %d) is %.9g, expected %.9g", i / 4, i % 4, m->m[i / 4][i % 4],
                     want[i]);
}

static void transforms(void **state)
{
    const char *xml = HEAD
        "  <shape type=\"sphere\">\n"
        "    <transform name=\"toWorld\">\n"
        "      <scale value=\"2\"/>\n"
        "      <rotate y=\"1\" angle=\"90\"/>\n"
        "      <translate x=\"1\" y=\"2\" z=\"3\"/>\n"
        "    </transform>\n"
        "    <transform name=\"aniso\">\n"
        "      <scale x=\"2\" z=\"4\"/>\n"
        "    </transform>\n"
        "    <transform name=\"m\">\n"
        "      <matrix value=\"1 2 3 4, 5 6 7 8, 9 10 11 12, 0 0 0 1\"/>\n"
        "      <translate value=\"1, 0, 0\"/>\n"
        "    </transform>\n"
        "    <transform name=\"look\">\n"
        "      <lookat origin=\"0, 0, 5\" target=\"0, 0, 0\" up=\"0, 1, 0\"/>\n"
        "    </transform>\n"
        "    <transform name=\"look2\">\n"
        "      <lookAt origin=\"1, 1, 1\" target=\"1, 1, 2\"/>\n"
        "    </transform>\n"
        "    <transform name=\"empty\"/>\n"
        "  </shape>\n"
        "</scene>\n";
    char path[1024];
    op_error err = {0};
    op_node *root;
    OP_ASSERT_OK(parse_text(xml, NULL, 0, &root, &err, path), err);
    op_node *s = root->children[0];
    op_matrix4 m;
    /* T * R_y(90) * S(2): scale first, then rotate, then translate. */
    OP_ASSERT_OK(op_node_transform(s, "toWorld", &m, &err), err);
    const double trs[16] = {0, 0, 2, 1, 0, 2, 0, 2, -2, 0, 0, 3, 0, 0, 0, 1};
    assert_matrix(&m, trs, 1e-12);
    double p[3] = {1, 0, 0};
    op_matrix4_point(&m, p, p);
    assert_float_equal(p[0], 1, 1e-12);
    assert_float_equal(p[1], 2, 1e-12);
    assert_float_equal(p[2], 1, 1e-12);
    double v[3] = {1, 0, 0};
    op_matrix4_vector(&m, v, v); /* vectors ignore the translation */
    assert_float_equal(v[2], -2, 1e-12);

    OP_ASSERT_OK(op_node_transform(s, "aniso", &m, &err), err);
    const double an[16] = {2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 4, 0, 0, 0, 0, 1};
    assert_matrix(&m, an, 0);
    /* Normals use the inverse transpose: scaling x by 2 halves a normal's x. */
    op_matrix4 inv;
    assert_true(op_matrix4_inverse(&m, &inv));
    double n[3] = {1, 1, 0};
    op_matrix4_normal(&inv, n, n);
    assert_float_equal(n[0], 0.5, 1e-12);
    assert_float_equal(n[1], 1.0, 1e-12);

    OP_ASSERT_OK(op_node_transform(s, "m", &m, &err), err);
    const double mm[16] = {1, 2, 3, 5, 5, 6, 7, 8, 9, 10, 11, 12, 0, 0, 0, 1};
    assert_matrix(&m, mm, 0);

    OP_ASSERT_OK(op_node_transform(s, "look", &m, &err), err);
    const double la[16] = {-1, 0, 0, 0, 0, 1, 0, 0, 0, 0, -1, 5, 0, 0, 0, 1};
    assert_matrix(&m, la, 1e-12);

    /* Without up, Mitsuba's coordinateSystem(dir) picks one. */
    OP_ASSERT_OK(op_node_transform(s, "look2", &m, &err), err);
    const double la2[16] = {0, 1, 0, 1, -1, 0, 0, 1, 0, 0, 1, 1, 0, 0, 0, 1};
    assert_matrix(&m, la2, 1e-12);

    OP_ASSERT_OK(op_node_transform(s, "empty", &m, &err), err);
    op_matrix4 id = op_matrix4_identity();
    assert_memory_equal(&m, &id, sizeof m);
    OP_ASSERT_OK(op_node_transform(s, "absent", &m, &err), err);
    assert_memory_equal(&m, &id, sizeof m);

    /* Inverse of a general affine matrix; a singular one is refused. */
    OP_ASSERT_OK(op_node_transform(s, "toWorld", &m, &err), err);
    assert_true(op_matrix4_inverse(&m, &inv));
    op_matrix4 prod = op_matrix4_mul(&m, &inv);
    const double ident[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    assert_matrix(&prod, ident, 1e-12);
    op_matrix4 sing = op_matrix4_scale(1, 0, 1);
    assert_false(op_matrix4_inverse(&sing, &inv));
    /* Rotation about a non-unit axis equals that about the unit axis. */
    double ax[3] = {0, 0, 5};
    op_matrix4 rz = op_matrix4_rotate(ax, 90);
    double q[3] = {1, 0, 0};
    op_matrix4_point(&rz, q, q);
    assert_float_equal(q[0], 0, 1e-12);
    assert_float_equal(q[1], 1, 1e-12);
    op_matrix4 t = op_matrix4_transpose(&rz);
    assert_float_equal(t.m[0][1], rz.m[1][0], 0);
    op_desc_free(root);
}

static void defaults_and_overrides(void **state)
{
    const char *xml = HEAD
        "  <sampler type=\"independent\">\n"
        "    <integer name=\"sampleCount\" value=\"$spp\"/>\n"
        "    <string name=\"label\" value=\"a-$name-b $$ $1\"/>\n"
        "  </sampler>\n"
        "  <default name=\"spp\" value=\"16\"/>\n"
        "  <default name=\"name\" value=\"x\"/>\n"
        "</scene>\n";
    char path[1024];
    op_error err = {0};
    op_node *root;
    long long spp;
    const char *label;
    OP_ASSERT_OK(parse_text(xml, NULL, 0, &root, &err, path), err);
    OP_ASSERT_OK(op_node_int(root->children[0], "sampleCount", 0, &spp, &err), err);
    assert_int_equal(spp, 16);
    OP_ASSERT_OK(op_node_string(root->children[0], "label", NULL, &label, &err), err);
    assert_string_equal(label, "a-x-b $ $1"); /* $$ is one literal $ */
    op_desc_free(root);

    const op_define defs[2] = {{"spp", "64"}, {"name", "with space"}};
    OP_ASSERT_OK(parse_text(xml, defs, 2, &root, &err, path), err);
    OP_ASSERT_OK(op_node_int(root->children[0], "sampleCount", 0, &spp, &err), err);
    assert_int_equal(spp, 64);
    OP_ASSERT_OK(op_node_string(root->children[0], "label", NULL, &label, &err), err);
    assert_string_equal(label, "a-with space-b $ $1");
    op_desc_free(root);

    /* An undefined parameter is an error naming it. */
    expect_error(HEAD "  <sampler type=\"independent\">\n"
                      "    <integer name=\"sampleCount\" value=\"$nope\"/>\n"
                      "  </sampler>\n</scene>\n",
                 4, "undefined parameter '$nope'");
    /* Parameters work in any attribute, the type included. */
    const op_define t[1] = {{"kind", "ldrfilm"}};
    OP_ASSERT_OK(parse_text(HEAD "  <sensor type=\"perspective\"><film type=\"$kind\"/></sensor>\n"
                                 "</scene>\n",
                            t, 1, &root, &err, path),
                 err);
    assert_string_equal(root->children[0]->children[0]->type, "ldrfilm");
    op_desc_free(root);
}

static void includes_refs_and_spaces(void **state)
{
    /* A folder with spaces holding the main scene and a sub-folder with the included file. */
    char dir[1024], sub[1100], inc[1200], main_path[1200];
    snprintf(dir, sizeof dir, "%s", op_test_tmp_path("my scenes"));
    assert_int_equal(mkdir(dir, 0755), 0);
    snprintf(sub, sizeof sub, "%s/sub dir", dir);
    assert_int_equal(mkdir(sub, 0755), 0);
    snprintf(inc, sizeof inc, "%s/part one.xml", sub);
    write_text(inc, HEAD
               "  <bsdf type=\"diffuse\" id=\"mat\">\n"
               "    <ref name=\"reflectance\" id=\"tex\"/>\n"   /* forward, into the main file */
               "  </bsdf>\n"
               "</scene>\n");
    snprintf(main_path, sizeof main_path, "%s/scene 1.xml", dir);
    write_text(main_path, HEAD
               "  <include filename=\"sub dir/part one.xml\"/>\n"
               "  <shape type=\"sphere\">\n"
               "    <ref id=\"mat\"/>\n"
               "  </shape>\n"
               "  <shape type=\"cube\">\n"
               "    <ref id=\"alias2\"/>\n"
               "  </shape>\n"
               "  <texture type=\"bitmap\" id=\"tex\">\n"
               "    <string name=\"filename\" value=\"t.png\"/>\n"
               "  </texture>\n"
               "  <alias id=\"mat\" as=\"alias2\"/>\n"
               "</scene>\n");
    op_error err = {0};
    op_node *root;
    OP_ASSERT_OK(op_desc_parse(main_path, NULL, 0, NULL, &root, &err), err);
    /* Scene children: the included bsdf, two shapes, the texture. */
    assert_int_equal(root->nchildren, 4);
    op_node *bsdf = root->children[0];
    assert_string_equal(bsdf->tag, "bsdf");
    assert_string_equal(bsdf->file, inc);
    assert_int_equal(bsdf->line, 3);
    op_node *tex = root->children[3];
    assert_ptr_equal(bsdf->children[0], tex); /* shared, not copied */
    assert_string_equal(op_node_child_name(bsdf, 0), "reflectance");
    assert_ptr_equal(root->children[1]->children[0], bsdf);
    assert_ptr_equal(root->children[2]->children[0], bsdf); /* through the alias */
    assert_null(op_node_child_name(root->children[1], 0));
    /* The texture's path resolves against the main file's folder. */
    const char *fn;
    OP_ASSERT_OK(op_node_string(tex, "filename", NULL, &fn, &err), err);
    char *res = op_node_resolve(tex, fn);
    char want[1300];
    snprintf(want, sizeof want, "%s/t.png", dir);
    assert_string_equal(res, want);
    free(res);
    op_desc_free(root);

    /* Include cycles and missing includes. */
    char a[1200], b[1200];
    snprintf(a, sizeof a, "%s/a.xml", dir);
    snprintf(b, sizeof b, "%s/b.xml", dir);
    write_text(a, HEAD "  <include filename=\"b.xml\"/>\n</scene>\n");
    write_text(b, HEAD "\n  <include filename=\"a.xml\"/>\n</scene>\n");
    assert_int_equal(op_desc_parse(a, NULL, 0, NULL, &root, &err), OP_ERR_INPUT);
    char where[1300];
    snprintf(where, sizeof where, "%s:4: <include>: include cycle", b);
    assert_string_equal(strstr(err.message, where) == err.message ? where : err.message, where);
    write_text(a, HEAD "  <include filename=\"missing file.xml\"/>\n</scene>\n");
    assert_int_equal(op_desc_parse(a, NULL, 0, NULL, &root, &err), OP_ERR_INPUT);
    snprintf(where, sizeof where, "%s:3: <include>: cannot read included file", a);
    assert_ptr_equal(strstr(err.message, where), err.message);
    assert_non_null(strstr(err.message, "missing file.xml"));
    /* A missing scene. */
    snprintf(a, sizeof a, "%s/absent.xml", dir);
    assert_int_equal(op_desc_parse(a, NULL, 0, NULL, &root, &err), OP_ERR_INPUT);
    assert_non_null(strstr(err.message, "absent.xml"));
    assert_null(root);
    unlink(inc);
    unlink(main_path);
    unlink(b);
    snprintf(a, sizeof a, "%s/a.xml", dir);
    unlink(a);
    rmdir(sub);
    rmdir(dir);
}

static void errors(void **state)
{
    /* Malformed XML: libxml2's message, captured (nothing printed), with its line. */
    char errpath[1024];
    snprintf(errpath, sizeof errpath, "%s", op_test_tmp_path("stderr.txt"));
    fflush(stderr);
    int saved = dup(2), fd = open(errpath, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    assert_true(saved >= 0 && fd >= 0);
    dup2(fd, 2);
    close(fd);
    char path[1024];
    op_error err = {0};
    op_node *root;
    op_status st = parse_text(HEAD "  <shape type=\"obj\">\n\n  </shap>\n</scene>\n", NULL, 0,
                              &root, &err, path);
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    assert_int_equal(st, OP_ERR_INPUT);
    struct stat sb;
    assert_int_equal(stat(errpath, &sb), 0);
    assert_int_equal(sb.st_size, 0); /* libxml2 printed nothing */
    unlink(errpath);
    char where[1100];
    snprintf(where, sizeof where, "%s:5: malformed XML", path);
    if (strncmp(err.message, where, strlen(where)) != 0)
        fail_msg("got '%s'", err.message);

    expect_error("", 1, "");
    expect_error(HEAD "  <shape type=\"obj\">\n    <foo name=\"x\"/>\n  </shape>\n</scene>\n", 4,
                 "<foo name=\"x\">: unknown element <foo>");
    expect_error(HEAD "  <shape type=\"obj\">\n    <boolean name=\"b\" value=\"yes\"/>\n"
                      "  </shape>\n</scene>\n",
                 4, "<boolean name=\"b\">: bad boolean 'yes'");
    expect_error(HEAD "  <shape type=\"obj\">\n    <boolean name=\"b\" value=\"True\"/>\n"
                      "  </shape>\n</scene>\n",
                 4, "bad boolean 'True'");
    expect_error("<scene version=\"3.0.0\">\n  <shape type=\"obj\">\n"
                 "    <boolean name=\"b\" value=\"no\"/>\n  </shape>\n</scene>\n",
                 3, "bad boolean 'no'");
    expect_error(HEAD "  <shape type=\"obj\">\n    <float name=\"f\" value=\"1.2.3\"/>\n"
                      "  </shape>\n</scene>\n",
                 4, "bad number '1.2.3'");
    expect_error(HEAD "  <shape type=\"obj\">\n    <float name=\"f\" value=\"nan\"/>\n"
                      "  </shape>\n</scene>\n",
                 4, "bad number");
    expect_error(HEAD "  <shape type=\"obj\">\n    <integer name=\"i\" value=\"3.5\"/>\n"
                      "  </shape>\n</scene>\n",
                 4, "bad integer '3.5'");
    expect_error(HEAD "  <shape type=\"obj\">\n    <point name=\"p\" x=\"1\" y=\"a\"/>\n"
                      "  </shape>\n</scene>\n",
                 4, "attribute y: bad number 'a'");
    expect_error(HEAD "  <shape type=\"obj\">\n    <rgb name=\"c\" value=\"1, 2\"/>\n"
                      "  </shape>\n</scene>\n",
                 4, "bad colour");
    expect_error(HEAD "  <shape type=\"obj\">\n    <spectrum name=\"c\" value=\"0.5, 0.2\"/>\n"
                      "  </shape>\n</scene>\n", 4, "three (linear RGB");
    expect_error(HEAD "  <shape type=\"obj\">\n    <spectrum name=\"c\" value=\"500:1, 400:1\"/>\n"
                      "  </shape>\n</scene>\n",
                 4, "wavelengths must increase");
    expect_error(HEAD "  <shape type=\"obj\">\n    <float value=\"1\"/>\n  </shape>\n</scene>\n", 4,
                 "missing attribute 'name'");
    expect_error(HEAD "\n  <shape id=\"s\"/>\n</scene>\n", 4, "missing attribute 'type'");
    expect_error(HEAD "  <shape type=\"obj\" colour=\"red\"/>\n</scene>\n", 3,
                 "unexpected attribute 'colour'");
    expect_error(HEAD "  <shape type=\"obj\">\n    <ref id=\"nothere\"/>\n  </shape>\n</scene>\n", 4,
                 "<ref id=\"nothere\">: unknown id 'nothere'");
    expect_error(HEAD "  <bsdf type=\"diffuse\" id=\"x\"/>\n  <bsdf type=\"diffuse\" id=\"x\"/>\n"
                      "</scene>\n",
                 4, "duplicate id 'x' (first defined at ");
    expect_error(HEAD "  <shape type=\"obj\">\n    <float name=\"f\" value=\"1\"/>\n"
                      "    <float name=\"f\" value=\"2\"/>\n  </shape>\n</scene>\n",
                 5, "parameter 'f' is given twice");
    expect_error("<scene version=\"4.0.0\">\n</scene>\n", 1, "bad version");
    /* a name in the other dialect's spelling is an error naming the right one */
    expect_error(HEAD "  <shape type=\"obj\">\n    <transform name=\"to_world\"/>\n  </shape>\n"
                      "</scene>\n", 4, "write 'toWorld'");
    expect_error("<scene version=\"3.0.0\">\n  <shape type=\"obj\">\n"
                 "    <float name=\"maxSmoothAngle\" value=\"1\"/>\n  </shape>\n</scene>\n",
                 3, "write 'max_smooth_angle'");
    expect_error("<scene version=\"2.1.0\">\n  <shape type=\"obj\">\n"
                 "    <float name=\"int_ior\" value=\"1\"/>\n    <float name=\"int_ior\" value=\"1\"/>\n"
                 "  </shape>\n</scene>\n", 4, "parameter 'int_ior' is given twice");
    expect_error(HEAD "  <path value=\"x\"/>\n  <shape type=\"obj\">\n    <path value=\"y\"/>\n"
                      "  </shape>\n</scene>\n", 5, "<path> must be directly inside <scene>");
    expect_error("<scene>\n</scene>\n", 1, "missing attribute 'version'");
    expect_error("<scene version=\"zero\">\n</scene>\n", 1, "bad version");
    expect_error("<mitsuba version=\"0.6.0\">\n</mitsuba>\n", 1, "root element must be <scene");
    expect_error(HEAD "  <float name=\"f\" value=\"1\"/>\n</scene>\n", 3, "inside an object");
    expect_error(HEAD "  <shape type=\"obj\">\n    <scene version=\"0.6.0\"/>\n  </shape>\n</scene>\n",
                 4, "root element");
    expect_error(HEAD "  <shape type=\"obj\">\n    <translate x=\"1\"/>\n  </shape>\n</scene>\n", 4,
                 "only allowed inside <transform>");
    expect_error(HEAD "  <shape type=\"obj\">\n    <transform name=\"t\">\n"
                      "      <rotate angle=\"30\"/>\n    </transform>\n  </shape>\n</scene>\n",
                 5, "axis");
    expect_error(HEAD "  <shape type=\"obj\">\n    <transform name=\"t\">\n"
                      "      <matrix value=\"1 2 3\"/>\n    </transform>\n  </shape>\n</scene>\n",
                 5, "16 numbers");
    expect_error(HEAD "  <shape type=\"obj\">\n    <transform name=\"t\">\n"
                      "      <lookat origin=\"1,1,1\" target=\"1,1,1\"/>\n    </transform>\n"
                      "  </shape>\n</scene>\n",
                 5, "degenerate look-at");
    expect_error(HEAD "  <shape type=\"obj\">\n    <transform name=\"t\">\n"
                      "      <float name=\"x\" value=\"1\"/>\n    </transform>\n  </shape>\n</scene>\n",
                 5, "not a transform operation");
    expect_error(HEAD "  <shape type=\"obj\">\n    <float name=\"f\" value=\"1\">2</float>\n"
                      "  </shape>\n</scene>\n",
                 4, "unexpected text");
    expect_error(HEAD "  <shape type=\"obj\">\n    stray words\n  </shape>\n</scene>\n", 3,
                 "unexpected text");
    expect_error(HEAD "  <bsdf type=\"twosided\" id=\"a\">\n    <ref id=\"a\"/>\n  </bsdf>\n"
                      "</scene>\n",
                 3, "reference cycle");
    expect_error(HEAD "  <alias id=\"nothing\" as=\"b\"/>\n</scene>\n", 3, "unknown id 'nothing'");
    /* External entities are never fetched or expanded. */
    expect_error("<?xml version=\"1.0\"?>\n<!DOCTYPE scene [\n"
                 "  <!ENTITY secret SYSTEM \"file:///etc/passwd\">\n]>\n"
                 "<scene version=\"0.6.0\">\n  <shape type=\"obj\">&secret;</shape>\n</scene>\n",
                 6, "entity references are not supported");
}

static void version_warning_only(void **state)
{
    char path[1024];
    op_error err = {0};
    op_node *root;
    OP_ASSERT_OK(parse_text("<scene version=\"0.4.0\"/>\n", NULL, 0, &root, &err, path), err);
    op_desc_free(root);
    OP_ASSERT_OK(parse_text("<scene version=\"0.5.0\"/>\n", NULL, 0, &root, &err, path), err);
    assert_int_equal(root->nchildren, 0);
    op_desc_free(root);
}

static void getters_check_kinds(void **state)
{
    const char *xml = HEAD
        "  <shape type=\"obj\">\n"
        "    <string name=\"filename\" value=\"a.obj\"/>\n"
        "    <float name=\"f\" value=\"1\"/>\n"
        "  </shape>\n"
        "</scene>\n";
    char path[1024], where[1100];
    op_error err = {0};
    op_node *root;
    OP_ASSERT_OK(parse_text(xml, NULL, 0, &root, &err, path), err);
    op_node *s = root->children[0];
    double f, c[3];
    long long i;
    int b;
    const char *str;
    op_matrix4 m;
    assert_int_equal(op_node_float(s, "filename", 0, &f, &err), OP_ERR_INPUT);
    snprintf(where, sizeof where,
             "%s:4: <shape type=\"obj\">: parameter 'filename': is a string, expected a float", path);
    assert_string_equal(err.message, where);
    assert_int_equal(op_node_int(s, "f", 0, &i, &err), OP_ERR_INPUT);
    assert_non_null(strstr(err.message, "is a float, expected an integer"));
    assert_int_equal(op_node_bool(s, "f", 0, &b, &err), OP_ERR_INPUT);
    assert_int_equal(op_node_string(s, "f", NULL, &str, &err), OP_ERR_INPUT);
    assert_int_equal(op_node_vec3(s, "f", NULL, c, &err), OP_ERR_INPUT);
    assert_int_equal(op_node_color(s, "filename", NULL, c, &err), OP_ERR_INPUT);
    assert_int_equal(op_node_transform(s, "f", &m, &err), OP_ERR_INPUT);
    /* The builder's own errors name the node. */
    assert_int_equal(op_node_error(s, &err, OP_ERR_INPUT, "cannot load %s", "a.obj"), OP_ERR_INPUT);
    snprintf(where, sizeof where, "%s:3: <shape type=\"obj\">: cannot load a.obj", path);
    assert_string_equal(err.message, where);
    op_desc_free(root);
}

static void unused_report(void **state)
{
    const char *xml = HEAD
        "  <shape type=\"obj\">\n"
        "    <string name=\"filename\" value=\"a.obj\"/>\n"
        "    <float name=\"unused1\" value=\"1\"/>\n"
        "    <bsdf type=\"diffuse\" id=\"m\">\n"
        "      <float name=\"x\" value=\"1\"/>\n"
        "    </bsdf>\n"
        "  </shape>\n"
        "  <shape type=\"sphere\">\n"
        "    <ref id=\"m\"/>\n"
        "    <float name=\"radius\" value=\"2\"/>\n"
        "  </shape>\n"
        "  <texture type=\"bitmap\" id=\"lonely\"/>\n"
        "</scene>\n";
    char path[1024];
    op_error err = {0};
    op_node *root;
    OP_ASSERT_OK(parse_text(xml, NULL, 0, &root, &err, path), err);
    /* Nothing consumed: the three top-level objects are unused (the shared bsdf is inside). */
    assert_int_equal(op_desc_report_unused(root, NULL), 3);
    op_node *s1 = root->children[0], *s2 = root->children[1];
    op_node_mark_used(s1);
    op_node_mark_used(s2);
    const char *fn;
    OP_ASSERT_OK(op_node_string(s1, "filename", NULL, &fn, &err), err);
    /* unused1, radius, the (unconsumed) bsdf counted once although shared, lonely texture. */
    assert_int_equal(op_desc_report_unused(root, NULL), 4);
    op_node *bsdf = op_node_child(s1, "bsdf", 0);
    op_node_mark_used(bsdf);
    double r;
    OP_ASSERT_OK(op_node_float(s2, "radius", 1, &r, &err), err);
    /* unused1, x of the bsdf, lonely texture. */
    assert_int_equal(op_desc_report_unused(root, NULL), 3);
    /* op_node_has does not mark used. */
    assert_true(op_node_has(s1, "unused1"));
    assert_int_equal(op_desc_report_unused(root, NULL), 3);
    op_desc_free(root);
}

static void realistic_scene(void **state)
{
    /* The shape of what Mitsuba 0.6 exporters write. */
    const char *xml =
        "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n"
        "<scene version=\"0.6.0\">\n"
        "  <integrator type=\"path\">\n"
        "    <integer name=\"maxDepth\" value=\"-1\"/>\n"
        "  </integrator>\n"
        "  <sensor type=\"perspective\">\n"
        "    <float name=\"fov\" value=\"39.3\"/>\n"
        "    <string name=\"fovAxis\" value=\"x\"/>\n"
        "    <transform name=\"toWorld\">\n"
        "      <lookat target=\"0, 0, 0\" origin=\"0, 1, 6.8\" up=\"0, 1, 0\"/>\n"
        "    </transform>\n"
        "    <sampler type=\"independent\"><integer name=\"sampleCount\" value=\"64\"/></sampler>\n"
        "    <film type=\"hdrfilm\">\n"
        "      <integer name=\"width\" value=\"320\"/><integer name=\"height\" value=\"240\"/>\n"
        "      <rfilter type=\"gaussian\"/>\n"
        "    </film>\n"
        "  </sensor>\n"
        "  <shape type=\"rectangle\">\n"
        "    <emitter type=\"area\"><spectrum name=\"radiance\" value=\"10\"/></emitter>\n"
        "  </shape>\n"
        "  <shape type=\"serialized\" id=\"mesh\">\n"
        "    <subsurface type=\"svd\">\n"
        "      <string name=\"material\" value=\"SVD_S10_Chess4x4\"/>\n"
        "      <float name=\"sceneUnitsPerMetre\" value=\"10\"/>\n"
        "    </subsurface>\n"
        "    <medium type=\"homogeneous\" name=\"interior\"><phase type=\"hg\"/></medium>\n"
        "  </shape>\n"
        "</scene>\n";
    char path[1024];
    op_error err = {0};
    op_node *root;
    OP_ASSERT_OK(parse_text(xml, NULL, 0, &root, &err, path), err);
    assert_int_equal(root->nchildren, 4);
    op_node *sensor = op_node_child(root, "sensor", 0);
    assert_non_null(sensor);
    assert_non_null(op_node_child(op_node_child(sensor, "film", 0), "rfilter", 0));
    op_node *sub = op_node_child(op_node_child(root, "shape", 1), "subsurface", 0);
    assert_string_equal(sub->type, "svd");
    const char *mat;
    OP_ASSERT_OK(op_node_string(sub, "material", NULL, &mat, &err), err);
    assert_string_equal(mat, "SVD_S10_Chess4x4");
    op_matrix4 m;
    OP_ASSERT_OK(op_node_transform(sensor, "toWorld", &m, &err), err);
    assert_float_equal(m.m[1][3], 1.0, 0);
    assert_float_equal(m.m[2][3], 6.8, 0);
    char desc[128];
    assert_string_equal(op_node_describe(op_node_child(root, "shape", 1), desc, sizeof desc),
                        "<shape type=\"serialized\" id=\"mesh\">");
    op_desc_free(root);
}

/* op_array_grow, behind every growing array of the reader and builder: makes index n writable,
 * zero-fills what it adds, and refuses (leaving the array as it was) counts whose int or
 * byte size would overflow. */
/* Mitsuba 2/3 files: snake_case names reach the builders as Mitsuba 0.6's, messages use the
 * file's own spelling, nodes know their dialect, <path> folders and <default> inside an object
 * work, and an included file keeps its own dialect. */
static void mitsuba3_dialect(void **state)
{
    (void)state;
    char dir[1024], sub[1100], inc[1200], main_path[1200], mesh[1300];
    snprintf(dir, sizeof dir, "%s", op_test_tmp_path("m3"));
    assert_int_equal(mkdir(dir, 0755), 0);
    snprintf(sub, sizeof sub, "%s/common", dir);
    assert_int_equal(mkdir(sub, 0755), 0);
    snprintf(mesh, sizeof mesh, "%s/mesh.obj", sub);
    write_text(mesh, "v 0 0 0\n");
    snprintf(inc, sizeof inc, "%s/old.xml", dir);
    write_text(inc, HEAD "  <bsdf type=\"roughplastic\" id=\"old\">\n"
                    "    <float name=\"intIOR\" value=\"1.4\"/>\n  </bsdf>\n</scene>\n");
    snprintf(main_path, sizeof main_path, "%s/scene.xml", dir);
    write_text(main_path,
               "<scene version=\"3.0.0\">\n"
               "  <path value=\"common\"/>\n"
               "  <include filename=\"old.xml\"/>\n"
               "  <shape type=\"obj\">\n"
               "    <default name=\"ior\" value=\"1.5\"/>\n"
               "    <string name=\"filename\" value=\"mesh.obj\"/>\n"
               "    <transform name=\"to_world\"><translate value=\"1, 2, 3\"/></transform>\n"
               "    <bsdf type=\"plastic\">\n"
               "      <float name=\"int_ior\" value=\"$ior\"/>\n"
               "      <rgb name=\"diffuse_reflectance\" value=\"0.1, 0.2, 0.3\"/>\n"
               "      <texture type=\"bitmap\" name=\"specular_reflectance\"/>\n"
               "    </bsdf>\n"
               "  </shape>\n"
               "</scene>\n");
    op_error err = {0};
    op_node *root;
    OP_ASSERT_OK(op_desc_parse(main_path, NULL, 0, NULL, &root, &err), err);
    assert_int_equal(root->dialect, OP_DIALECT_MITSUBA_3);
    op_node *old = root->children[0], *shape = root->children[1];
    assert_int_equal(old->dialect, OP_DIALECT_MITSUBA_0);
    assert_int_equal(shape->dialect, OP_DIALECT_MITSUBA_3);
    double ior;
    OP_ASSERT_OK(op_node_float(old, "intIOR", 0, &ior, &err), err);
    assert_true(ior == 1.4);
    op_matrix4 m;
    OP_ASSERT_OK(op_node_transform(shape, "toWorld", &m, &err), err);
    assert_true(m.m[0][3] == 1 && m.m[1][3] == 2 && m.m[2][3] == 3);
    op_node *bsdf = op_node_child(shape, "bsdf", 0);
    OP_ASSERT_OK(op_node_float(bsdf, "intIOR", 0, &ior, &err), err);
    assert_true(ior == 1.5);
    assert_non_null(op_node_prop(bsdf, "diffuseReflectance"));
    assert_string_equal(op_prop_name(op_node_prop(bsdf, "diffuseReflectance")),
                        "diffuse_reflectance");
    assert_string_equal(op_node_child_name(bsdf, 0), "specularReflectance");
    /* messages name the parameter as the file spells it */
    const char *s;
    assert_int_equal(op_node_string(bsdf, "intIOR", NULL, &s, &err), OP_ERR_INPUT);
    assert_non_null(strstr(err.message, "'int_ior'"));
    /* the mesh is found through <path>, relative to the file that gives it */
    const char *fn;
    OP_ASSERT_OK(op_node_string(shape, "filename", NULL, &fn, &err), err);
    char *res = op_node_resolve(shape, fn);
    assert_string_equal(res, mesh);
    free(res);
    /* a name found nowhere resolves beside the file that names it */
    res = op_node_resolve(shape, "nowhere.png");
    char want[1300];
    snprintf(want, sizeof want, "%s/nowhere.png", dir);
    assert_string_equal(res, want);
    free(res);
    op_desc_free(root);
    unlink(mesh);
    unlink(inc);
    unlink(main_path);
    rmdir(sub);
    rmdir(dir);
}

/* What Mitsuba 2/3 files written by exporters hold: booleans in any letter case (Mitsuba 2/3
 * compare them ignoring case, Mitsuba 0.6 does not) and objects named with a label that is no
 * parameter name ("mat-Material", kept as written in either dialect). */
static void exporter_spellings(void **state)
{
    (void)state;
    char path[1024];
    op_error err = {0};
    op_node *root;
    OP_ASSERT_OK(parse_text("<scene version=\"2.1.0\">\n"
                            "  <sampler type=\"stratified\">\n"
                            "    <boolean name=\"jitter\" value=\"False\"/>\n"
                            "    <boolean name=\"other\" value=\"TRUE\"/>\n"
                            "  </sampler>\n"
                            "  <bsdf type=\"twosided\" id=\"mat-Material\" name=\"mat-Material\">\n"
                            "    <bsdf type=\"diffuse\" name=\"bsdf\"/>\n"
                            "  </bsdf>\n"
                            "</scene>\n", NULL, 0, &root, &err, path), err);
    int b = -1;
    OP_ASSERT_OK(op_node_bool(root->children[0], "jitter", 1, &b, &err), err);
    assert_int_equal(b, 0);
    OP_ASSERT_OK(op_node_bool(root->children[0], "other", 0, &b, &err), err);
    assert_int_equal(b, 1);
    assert_string_equal(op_node_child_name(root, 1), "mat-Material");
    op_desc_free(root);
    OP_ASSERT_OK(parse_text(HEAD "  <bsdf type=\"diffuse\" id=\"a\" name=\"mat-Old_one\"/>\n</scene>\n",
                            NULL, 0, &root, &err, path), err);
    assert_string_equal(op_node_child_name(root, 0), "mat-Old_one");
    op_desc_free(root);
    unlink(path);
}

static void array_grow(void **state)
{
    (void)state;
    int *a = NULL, cap = 0;
    assert_true(op_array_grow((void **)&a, &cap, 0, sizeof *a));
    assert_int_equal(cap, 8);
    for (int i = 0; i < cap; i++)
        assert_int_equal(a[i], 0);
    a[7] = 5;
    assert_true(op_array_grow((void **)&a, &cap, 7, sizeof *a)); /* fits: unchanged */
    assert_int_equal(cap, 8);
    assert_true(op_array_grow((void **)&a, &cap, 100, sizeof *a)); /* past one doubling */
    assert_int_equal(cap, 128);
    assert_int_equal(a[7], 5);
    for (int i = 8; i < cap; i++)
        assert_int_equal(a[i], 0);
    int *before = a;
    assert_false(op_array_grow((void **)&a, &cap, INT_MAX, sizeof *a));
    assert_false(op_array_grow((void **)&a, &cap, -1, sizeof *a));
    assert_false(op_array_grow((void **)&a, &cap, 1 << 29, SIZE_MAX / 4)); /* bytes overflow */
    assert_true(a == before && cap == 128);
    free(a);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(array_grow),
        cmocka_unit_test(values_and_structure),
        cmocka_unit_test(colours),
        cmocka_unit_test(transforms),
        cmocka_unit_test(defaults_and_overrides),
        cmocka_unit_test(includes_refs_and_spaces),
        cmocka_unit_test(errors),
        cmocka_unit_test(version_warning_only),
        cmocka_unit_test(getters_check_kinds),
        cmocka_unit_test(unused_report),
        cmocka_unit_test(realistic_scene),
        cmocka_unit_test(mitsuba3_dialect),
        cmocka_unit_test(exporter_spellings),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
