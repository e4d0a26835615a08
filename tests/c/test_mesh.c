/* test_mesh.c - OBJ and PLY loading (written by the tests), every malformed case, the mesh
 * helpers, and the shared scanned meshes when ../shared is present. */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "geometry/mesh.h"

static const char *write_file(const char *suffix, const void *data, size_t n)
{
    static char path[4][1024];
    static int k;
    char *p = path[k++ % 4];
    snprintf(p, 1024, "%s", op_test_tmp_path(suffix));
    FILE *f = fopen(p, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, n, f), n);
    fclose(f);
    return p;
}

static const char *write_text(const char *suffix, const char *text)
{
    return write_file(suffix, text, strlen(text));
}

/* Loading must fail with OP_ERR_FORMAT and a message holding want. */
static void expect_bad(const char *suffix, const void *data, size_t n, const char *want)
{
    const char *path = write_file(suffix, data, n);
    op_mesh m;
    op_error err = {0};
    op_status st = op_mesh_load(path, &m, &err);
    if (st != OP_ERR_FORMAT || !strstr(err.message, want) || !strstr(err.message, path))
        fail_msg("expected a format error with '%s', got %s: '%s'", want, op_status_name(st),
                 err.message);
    assert_null(m.positions);
    assert_null(m.indices);
    unlink(path);
}

static void expect_bad_text(const char *suffix, const char *text, const char *want)
{
    expect_bad(suffix, text, strlen(text), want);
}

static void obj_full(void **state)
{
    const char *obj =
        "# a test\n"
        "mtllib x.mtl\n"
        "o first\n"
        "v 0 0 0\n"
        "v 1 0 0\n"
        "v 1 1 0\n"
        "v 0 1 0\n"
        "vt 0 0\n"
        "vt 1 0\n"
        "vt 1 1 0\n"
        "vt 0 1\n"
        "vn 0 0 1\n"
        "usemtl m\n"
        "s off\n"
        "f 1/1/1 2/2/1 3/3/1 4/4/1\n"    /* a quad: two triangles */
        "o second\n"
        "v 0 0 2.5e0\n"
        "v 1 0 +2\n"
        "v -.5 1 2   # trailing comment\n"
        "vt 0.25 0.75\n"
        "vn 0 0 -1\n"
        "g grp\n"
        "f -3/-1/-1 -2/-1/-1 -1/-1/-1\n" /* relative indices */
        "l 1 2\n"
        "f 1/1/1 2/2/1 3/3/1\r\n";       /* shares three corners with the quad */
    const char *path = write_text("a.obj", obj);
    op_mesh m;
    op_error err = {0};
    OP_ASSERT_OK(op_mesh_load_obj(path, &m, &err), err);
    assert_int_equal(m.ntris, 4);
    assert_int_equal(m.nverts, 7); /* 4 quad corners + 3 of the second object */
    assert_non_null(m.uvs);
    assert_non_null(m.normals);
    const uint32_t want_idx[12] = {0, 1, 2, 0, 2, 3, 4, 5, 6, 0, 1, 2};
    assert_memory_equal(m.indices, want_idx, sizeof want_idx);
    assert_true(m.positions[3 * 2] == 1 && m.positions[3 * 2 + 1] == 1);
    assert_true(m.positions[3 * 4 + 2] == 2.5f && m.positions[3 * 6] == -0.5f);
    assert_true(m.uvs[2 * 2] == 1 && m.uvs[2 * 2 + 1] == 1);
    assert_true(m.uvs[2 * 5] == 0.25f && m.uvs[2 * 5 + 1] == 0.75f);
    assert_true(m.normals[2] == 1 && m.normals[3 * 4 + 2] == -1);
    float lo[3], hi[3];
    op_mesh_bounds(&m, lo, hi);
    assert_true(lo[0] == -0.5f && lo[2] == 0 && hi[0] == 1 && hi[1] == 1 && hi[2] == 2.5f);
    op_mesh_flip_v(&m);
    assert_true(m.uvs[2 * 5 + 1] == 0.25f);
    op_mesh_drop_normals(&m);
    assert_null(m.normals);
    op_mesh_free(&m);
    assert_null(m.positions);
    op_mesh_free(&m); /* twice is fine */
    op_mesh_free(NULL);
    unlink(path);
}

static void obj_variants(void **state)
{
    op_mesh m;
    op_error err = {0};
    /* Positions only; an unreferenced vertex is left out; faces before vertices. */
    const char *path = write_text("b.obj", "f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 9 9 9\n");
    OP_ASSERT_OK(op_mesh_load(path, &m, &err), err);
    assert_int_equal(m.nverts, 3);
    assert_int_equal(m.ntris, 1);
    assert_null(m.uvs);
    assert_null(m.normals);
    op_mesh_free(&m);
    /* Normals on only some corners are dropped; uvs on some are kept with zeros. */
    path = write_text("c.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.5 0.5\nvn 0 0 1\n"
                               "f 1/1/1 2//1 3\n");
    OP_ASSERT_OK(op_mesh_load(path, &m, &err), err);
    assert_null(m.normals);
    assert_non_null(m.uvs);
    assert_true(m.uvs[0] == 0.5f && m.uvs[2] == 0 && m.uvs[3] == 0);
    op_mesh_free(&m);
    /* v/vt with the same position and two uvs: two mesh vertices (a texture seam). */
    path = write_text("d.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\n"
                               "f 1/1 2/1 3/1\nf 2/2 4/2 3/1\n");
    OP_ASSERT_OK(op_mesh_load(path, &m, &err), err);
    assert_int_equal(m.nverts, 5);
    op_mesh_free(&m);
    /* A file with no final newline and a single-value vt. */
    path = write_text("e.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.5\nf 1/1 2/1 3/1");
    OP_ASSERT_OK(op_mesh_load(path, &m, &err), err);
    assert_true(m.uvs[0] == 0.5f && m.uvs[1] == 0.0f);
    op_mesh_free(&m);
    unlink(path);
}

static void obj_errors(void **state)
{
    expect_bad_text("x.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
                    ":4: vertex index 4 is out of range (the file has 3)");
    expect_bad_text("x.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 0\n", ":5: vertex index 0");
    expect_bad_text("x.obj", "v 0 0 0\nv 1 0 0\nf -1 -2 -3\n", ":3: relative vertex index -3");
    expect_bad_text("x.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\n",
                    ":4: texture coordinate index 1 is out of range");
    expect_bad_text("x.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//2 2//2 3//2\n",
                    ":4: normal index 2 is out of range");
    expect_bad_text("x.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", ":4: a face needs at least three");
    expect_bad_text("x.obj", "v 0 0 0\nv 1 0.5.5 0\n", ":2: bad number");
    expect_bad_text("x.obj", "v 0 0 0\nv 1 nan 0\n", ":2: bad number");
    expect_bad_text("x.obj", "v 0 0 1e999\n", ":1: bad number");
    expect_bad_text("x.obj", "v 0 0\n", ":1: too few numbers");
    expect_bad_text("x.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3x\n", ":4: bad face corner");
    expect_bad_text("x.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999\n", ":4: bad face");
    expect_bad_text("x.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/a 2 3\n", ":4: bad texture");
    expect_bad("x.obj", "v 0 0 0\n\0\n", 10, ":2: not a text file");
    expect_bad_text("x.obj", "", "no faces");
    expect_bad_text("x.obj", "# only vertices\nv 0 0 0\n", "no faces");
    /* A missing file is bad input, named as such. */
    op_mesh m;
    op_error err = {0};
    assert_int_equal(op_mesh_load_obj(op_test_tmp_path("absent.obj"), &m, &err), OP_ERR_INPUT);
    assert_non_null(strstr(err.message, "absent.obj: no such file"));
    assert_int_equal(op_mesh_load(op_test_tmp_path("mesh.stl"), &m, &err), OP_ERR_INPUT);
}

static void ply_ascii(void **state)
{
    const char *ply =
        "ply\n"
        "format ascii 1.0\n"
        "comment made by hand\n"
        "element vertex 4\n"
        "property float x\n"
        "property float y\n"
        "property float z\n"
        "property float nx\n"
        "property float ny\n"
        "property float nz\n"
        "property float s\n"
        "property float t\n"
        "property uchar red\n"
        "element face 2\n"
        "property list uchar int vertex_indices\n"
        "property int flags\n"
        "element edge 1\n"
        "property int vertex1\n"
        "property list uint8 float junk\n"
        "end_header\n"
        "0 0 0 0 0 1 0 0 255\n"
        "1 0 0 0 0 1 1 0 255\n"
        "1 1 0 0 0 1 1 1 255\n"
        "0 1 0 0 0 1 0 1 255\n"
        "4 0 1 2 3 7\n"
        "3 0 2 1 7\n"
        "0 2 1.5 2.5\n";
    const char *path = write_text("a.ply", ply);
    op_mesh m;
    op_error err = {0};
    OP_ASSERT_OK(op_mesh_load(path, &m, &err), err);
    assert_int_equal(m.nverts, 4);
    assert_int_equal(m.ntris, 3);
    const uint32_t want[9] = {0, 1, 2, 0, 2, 3, 0, 2, 1};
    assert_memory_equal(m.indices, want, sizeof want);
    assert_non_null(m.normals);
    assert_non_null(m.uvs);
    assert_true(m.uvs[2 * 2] == 1 && m.uvs[2 * 3 + 1] == 1 && m.normals[3 * 3 + 2] == 1);
    assert_true(m.positions[3 * 2] == 1 && m.positions[3 * 2 + 1] == 1);
    op_mesh_free(&m);
    unlink(path);
}

/* A binary PLY: 3 vertices (double x y z, float texture_u texture_v) and faces with ushort
 * counts and uint indices, in the given byte order. */
static size_t make_binary(unsigned char *buf, int big, int nfaces, const uint32_t *idx)
{
    char head[512];
    int hn = snprintf(head, sizeof head,
                      "ply\nformat %s 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
                      "property double z\nproperty float texture_u\nproperty float texture_v\n"
                      "element face %d\nproperty list ushort uint vertex_indices\nend_header\n",
                      big ? "binary_big_endian" : "binary_little_endian", nfaces);
    memcpy(buf, head, (size_t)hn);
    size_t n = (size_t)hn;
    const double xyz[9] = {0, 0, 0, 2, 0, 0, 0, 3, -1};
    const float uv[6] = {0, 0, 1, 0, 0, 1};
#define PUT(ptr, size)                                                                              \
    do {                                                                                           \
        unsigned char t[8];                                                                        \
        memcpy(t, ptr, size);                                                                      \
        for (int b = 0; b < (int)(size); b++)                                                      \
            buf[n + (size_t)b] = big ? t[(size) - 1 - b] : t[b];                                   \
        n += (size);                                                                               \
    } while (0)
    for (int v = 0; v < 3; v++) {
        for (int k = 0; k < 3; k++)
            PUT(&xyz[3 * v + k], 8);
        for (int k = 0; k < 2; k++)
            PUT(&uv[2 * v + k], 4);
    }
    for (int f = 0; f < nfaces; f++) {
        uint16_t c = 3;
        PUT(&c, 2);
        for (int k = 0; k < 3; k++)
            PUT(&idx[3 * f + k], 4);
    }
#undef PUT
    return n;
}

static void ply_binary(void **state)
{
    unsigned char buf[1024];
    const uint32_t idx[6] = {0, 1, 2, 2, 1, 0};
    for (int big = 0; big <= 1; big++) {
        size_t n = make_binary(buf, big, 2, idx);
        const char *path = write_file("b.ply", buf, n);
        op_mesh m;
        op_error err = {0};
        OP_ASSERT_OK(op_mesh_load_ply(path, &m, &err), err);
        assert_int_equal(m.nverts, 3);
        assert_int_equal(m.ntris, 2);
        assert_memory_equal(m.indices, idx, sizeof idx);
        assert_true(m.positions[3] == 2 && m.positions[7] == 3 && m.positions[8] == -1);
        assert_true(m.uvs[2] == 1 && m.uvs[5] == 1);
        assert_null(m.normals);
        float lo[3], hi[3];
        op_mesh_bounds(&m, lo, hi);
        assert_true(lo[2] == -1 && hi[0] == 2 && hi[1] == 3);
        op_mesh_free(&m);
        unlink(path);

        /* Hostile variants of the same file. */
        const uint32_t bad_idx[3] = {0, 1, 3};
        n = make_binary(buf, big, 1, bad_idx);
        expect_bad("b.ply", buf, n, "face 0: vertex index 3 is out of range (3 vertices)");
        n = make_binary(buf, big, 2, idx);
        for (size_t cut = n - 1; cut > n - 30; cut -= 7)
            expect_bad("b.ply", buf, cut, "ends early");
        expect_bad("b.ply", buf, n - 10, "face 1: the file ends early");
    }
}

static void ply_errors(void **state)
{
    const char *h = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                    "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                    "end_header\n";
    char text[2048];
    snprintf(text, sizeof text, "%s0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", h);
    op_mesh m;
    op_error err = {0};
    const char *path = write_text("ok.ply", text);
    OP_ASSERT_OK(op_mesh_load(path, &m, &err), err);
    op_mesh_free(&m);
    unlink(path);

    snprintf(text, sizeof text, "%s0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n", h);
    expect_bad_text("e.ply", text, ":13: vertex index 5 is out of range");
    snprintf(text, sizeof text, "%s0 0 0\n1 0 0\n0 1 0\n3 0 1 -1\n", h);
    expect_bad_text("e.ply", text, ":13: vertex index -1 is out of range");
    snprintf(text, sizeof text, "%s0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n", h);
    expect_bad_text("e.ply", text, ":11: bad number 'zero'");
    snprintf(text, sizeof text, "%s0 0 0\n1 0 0\n0 1 0\n2 0 1\n", h);
    expect_bad_text("e.ply", text, ":13: a face needs at least three");
    snprintf(text, sizeof text, "%s0 0 0\n1 0 0\n0 1 0\n3 0 1", h);
    expect_bad_text("e.ply", text, "ends early");
    expect_bad_text("e.ply", "plx\n", "not a PLY file");
    expect_bad_text("e.ply", "", "not a PLY file");
    expect_bad_text("e.ply", "ply\nformat ascii 1.0\nelement vertex 1\n", "no end_header");
    expect_bad_text("e.ply", "ply\nformat binary_middle_endian 1.0\nend_header\n", "unknown format");
    expect_bad_text("e.ply", "ply\nelement vertex 1\nproperty float x\nend_header\n0\n",
                    "no format line");
    expect_bad_text("e.ply", "ply\nformat ascii 1.0\nelement vertex 99999999999\nend_header\n",
                    "bad element count");
    expect_bad_text("e.ply", "ply\nformat ascii 1.0\nelement vertex -1\nend_header\n",
                    "bad element count");
    expect_bad_text("e.ply", "ply\nformat ascii 1.0\nproperty float x\nend_header\n",
                    "property before any element");
    expect_bad_text("e.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n",
                    "unknown property type");
    expect_bad_text("e.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float y\n"
                             "property float z\nend_header\n0 0\n",
                    "lacks x, y or z");
    expect_bad_text("e.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                             "property float y\nproperty float z\nend_header\n0 0 0\n",
                    "no faces");
    expect_bad_text("e.ply", "ply\nformat ascii 1.0\nelement face 1\n"
                             "property list uchar int vertex_indices\nend_header\n3 0 1 2\n",
                    "no vertex element");
    expect_bad_text("e.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                             "property float y\nproperty float z\nelement face 1\n"
                             "property list uchar float vertex_indices\nend_header\n",
                    "must be integers");
    /* A huge count in a tiny file is refused before anything is allocated. */
    expect_bad_text("e.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 2000000000\n"
                             "property float x\nproperty float y\nproperty float z\nend_header\n"
                             "abcd",
                    "cannot fit");
    /* A list length beyond the file. */
    unsigned char bin[512];
    const char *hb = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty uchar x\n"
                     "property uchar y\nproperty uchar z\nelement face 1\n"
                     "property list uint int vertex_indices\nend_header\n";
    size_t n = strlen(hb);
    memcpy(bin, hb, n);
    memset(bin + n, 0, 9);
    n += 9;
    const uint32_t big = 0x7fffffff;
    memcpy(bin + n, &big, 4);
    n += 4;
    memset(bin + n, 0, 8);
    n += 8;
    expect_bad("e.ply", bin, n, "face 0: the file ends early (a list of 2.14748e+09 items)");
}

/* Deterministic byte mutations of valid files: every result is a mesh or a format error. */
static void mutations_never_crash(void **state)
{
    unsigned char base[2][1024], buf[1024];
    const uint32_t idx[6] = {0, 1, 2, 2, 1, 0};
    size_t n[2];
    n[0] = make_binary(base[0], 0, 2, idx);
    const char *obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1\n"
                      "f -1 -2 -3\n";
    n[1] = strlen(obj);
    memcpy(base[1], obj, n[1]);
    uint32_t rng = 12345;
    for (int iter = 0; iter < 400; iter++) {
        int kind = iter % 2;
        memcpy(buf, base[kind], n[kind]);
        size_t len = n[kind];
        for (int k = 0; k < 1 + iter % 4; k++) {
            rng = rng * 1664525u + 1013904223u;
            size_t at = (rng >> 8) % len;
            rng = rng * 1664525u + 1013904223u;
            buf[at] = (unsigned char)(rng >> 24);
        }
        if (iter % 5 == 0)
            len = (rng >> 4) % len;
        const char *path = write_file(kind ? "f.obj" : "f.ply", buf, len);
        op_mesh m;
        op_error err = {0};
        op_status st = op_mesh_load(path, &m, &err);
        assert_true(st == OP_OK || st == OP_ERR_FORMAT);
        if (st == OP_OK)
            for (uint32_t i = 0; i < 3 * m.ntris; i++)
                assert_true(m.indices[i] < m.nverts);
        op_mesh_free(&m);
        unlink(path);
    }
}

static void normals_helper(void **state)
{
    /* Two triangles of a unit square folded 90 degrees along y: (0,0,1) and (1,0,0) faces of
     * different areas. */
    const char *path = write_text("n.obj", "v 0 0 0\nv 0 1 0\nv 1 0 0\nv 0 0 -2\nv 0 1 -2\n"
                                           "vn 1 1 1\n"
                                           "f 1//1 3//1 2//1\nf 1//1 2//1 5//1 4//1\n");
    op_mesh m;
    op_error err = {0};
    OP_ASSERT_OK(op_mesh_load(path, &m, &err), err);
    assert_non_null(m.normals);
    OP_ASSERT_OK(op_mesh_compute_normals(&m, &err), err);
    /* The vertex at (1, 0, 0), only in the floor triangle, gets the floor's normal. */
    int v100 = -1, v000 = -1;
    for (uint32_t i = 0; i < m.nverts; i++) {
        const float *p = &m.positions[3 * i];
        if (p[0] == 1 && p[1] == 0 && p[2] == 0)
            v100 = (int)i;
        if (p[0] == 0 && p[1] == 0 && p[2] == 0)
            v000 = (int)i;
    }
    assert_true(v100 >= 0 && v000 >= 0);
    const float *n2 = &m.normals[3 * v100];
    assert_float_equal(n2[0], 0, 1e-6);
    assert_float_equal(n2[1], 0, 1e-6);
    assert_float_equal(fabs(n2[2]), 1, 1e-6);
    /* The origin is in the floor (area 0.5, normal along z) and both wall triangles (area 1
     * each, normal along x): area weighting makes |nx| / |nz| = 2 / 0.5. */
    const float *n0 = &m.normals[3 * v000];
    double len = sqrt((double)n0[0] * n0[0] + (double)n0[1] * n0[1] + (double)n0[2] * n0[2]);
    assert_float_equal(len, 1, 1e-6);
    assert_float_equal(n0[1], 0, 1e-6);
    assert_float_equal(fabs(n0[0]) / fabs(n0[2]), 4.0, 1e-5);
    op_mesh_drop_normals(&m);
    OP_ASSERT_OK(op_mesh_compute_normals(&m, &err), err); /* allocates when absent */
    assert_non_null(m.normals);
    op_mesh_free(&m);
    unlink(path);
}

static void shared_meshes(void **state)
{
    const char *bunny = op_test_shared_path("meshes/stanford-bunny.obj");
    const char *spot = op_test_shared_path("meshes/spot.obj");
    if (!bunny || !spot)
        skip();
    op_mesh m;
    op_error err = {0};
    float lo[3], hi[3];
    OP_ASSERT_OK(op_mesh_load(bunny, &m, &err), err);
    assert_int_equal(m.ntris, 69451);
    assert_true(m.nverts > 34000 && m.nverts <= 35947);
    assert_null(m.uvs);
    assert_null(m.normals);
    op_mesh_bounds(&m, lo, hi);
    assert_float_equal(lo[0], -0.094690, 1e-6);
    assert_float_equal(hi[1], 0.187321, 1e-6);
    assert_float_equal(lo[2], -0.061874, 1e-6);
    for (uint32_t i = 0; i < 3 * m.ntris; i++)
        assert_true(m.indices[i] < m.nverts);
    op_mesh_free(&m);

    OP_ASSERT_OK(op_mesh_load(spot, &m, &err), err);
    assert_int_equal(m.ntris, 5856);
    assert_non_null(m.uvs);
    assert_true(m.nverts >= 3225); /* at least one mesh vertex per texture coordinate */
    op_mesh_bounds(&m, lo, hi);
    assert_float_equal(lo[1], -0.736784, 1e-6);
    assert_float_equal(hi[2], 1.049, 1e-6);
    for (uint32_t i = 0; i < 2 * m.nverts; i++) /* the file's own range, slightly beyond [0, 1] */
        assert_true(m.uvs[i] >= -0.0523f && m.uvs[i] <= 1.0007f);
    op_mesh_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(obj_full),      cmocka_unit_test(obj_variants),
        cmocka_unit_test(obj_errors),    cmocka_unit_test(ply_ascii),
        cmocka_unit_test(ply_binary),    cmocka_unit_test(ply_errors),
        cmocka_unit_test(normals_helper), cmocka_unit_test(mutations_never_crash),
        cmocka_unit_test(shared_meshes),
    };
    return op_test_exit_status(cmocka_run_group_tests(tests, NULL, NULL));
}
