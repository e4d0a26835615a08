/* test_mesh_serialized.c - Mitsuba serialized meshes (written here with zlib): versions 3 and
 * 4, single and double precision, the optional arrays, shape index selection, every malformed
 * case (header, dictionary, zlib stream, counts, truncation), and the published matpreview
 * meshes when ../shared is present (counts from tests/serialized_mesh.py's independent reader). */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <zlib.h>

#include "geometry/mesh.h"

enum { F_NORMALS = 0x1, F_UVS = 0x2, F_COLORS = 0x8, F_FACE = 0x10, F_SINGLE = 0x1000,
       F_DOUBLE = 0x2000 };

typedef struct buf {
    unsigned char *p;
    size_t n;
} buf;

static void put(buf *b, const void *data, size_t n)
{
    b->p = realloc(b->p, b->n + n + 1);
    assert_non_null(b->p);
    memcpy(b->p + b->n, data, n);
    b->n += n;
}

static void put_le(buf *b, uint64_t v, int size)
{
    unsigned char le[8];
    for (int i = 0; i < size; i++)
        le[i] = (unsigned char)(v >> (8 * i));
    put(b, le, (size_t)size);
}

/* Values in the file's precision. */
static void put_values(buf *b, const double *v, size_t n, int dbl)
{
    for (size_t i = 0; i < n; i++) {
        if (dbl) {
            uint64_t u;
            memcpy(&u, &v[i], 8);
            put_le(b, u, 8);
        } else {
            float f = (float)v[i];
            uint32_t u;
            memcpy(&u, &f, 4);
            put_le(b, u, 4);
        }
    }
}

/* The unit quad: 4 vertices, 2 triangles, shifted by dz so that meshes differ. */
typedef struct quad_opts {
    int version, flags;
    double dz;
    uint64_t nverts, ntris; /* the counts written (0: the true ones) */
    uint32_t last_index;    /* the last triangle's last index (0: the true one, 3) */
} quad_opts;

/* Appends one mesh (header and zlib stream) to file. */
static void put_mesh(buf *file, quad_opts o)
{
    double pos[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    double nrm[12] = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
    double uv[8] = {0, 0, 1, 0, 1, 1, 0, 1};
    double rgb[12] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1};
    uint32_t idx[6] = {0, 1, 2, 0, 2, o.last_index ? o.last_index : 3};
    for (int v = 0; v < 4; v++)
        pos[3 * v + 2] = o.dz;
    int dbl = (o.flags & F_DOUBLE) != 0;
    buf body = {0};
    put_le(&body, (uint32_t)o.flags, 4);
    if (o.version == 4)
        put(&body, "quad", 5);
    put_le(&body, o.nverts ? o.nverts : 4, 8);
    put_le(&body, o.ntris ? o.ntris : 2, 8);
    put_values(&body, pos, 12, dbl);
    if (o.flags & F_NORMALS)
        put_values(&body, nrm, 12, dbl);
    if (o.flags & F_UVS)
        put_values(&body, uv, 8, dbl);
    if (o.flags & F_COLORS)
        put_values(&body, rgb, 12, dbl);
    for (int i = 0; i < 6; i++)
        put_le(&body, idx[i], 4);
    uLongf zn = compressBound(body.n);
    unsigned char *z = malloc(zn);
    assert_non_null(z);
    assert_int_equal(compress2(z, &zn, body.p, body.n, 9), Z_OK);
    put_le(file, 0x041C, 2);
    put_le(file, (uint64_t)o.version, 2);
    put(file, z, zn);
    free(z);
    free(body.p);
}

/* A file of n meshes (mesh k shifted by dz = k) and its dictionary of version-sized offsets. */
static buf make_file(int version, int flags, int n)
{
    buf f = {0};
    size_t offsets[8];
    for (int k = 0; k < n; k++) {
        offsets[k] = f.n;
        put_mesh(&f, (quad_opts){version, flags, k, 0, 0, 0});
    }
    for (int k = 0; k < n; k++)
        put_le(&f, offsets[k], version == 4 ? 8 : 4);
    put_le(&f, (uint64_t)n, 4);
    return f;
}

static const char *write_buf(const buf *b)
{
    static char path[1024];
    snprintf(path, sizeof path, "%s", op_test_tmp_path("mesh.serialized"));
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(b->p, 1, b->n, f), b->n);
    fclose(f);
    return path;
}

/* Mesh index of b must be refused with status st and a message naming the file, the shape
 * index and want. */
static void expect_bad(const buf *b, uint32_t index, op_status st, const char *want)
{
    const char *path = write_buf(b);
    char named[64];
    snprintf(named, sizeof named, "shape index %u", index);
    op_mesh m;
    op_error err = {0};
    op_status got = op_mesh_load_serialized(path, index, &m, &err);
    if (got != st || !strstr(err.message, want) || !strstr(err.message, path) ||
        !strstr(err.message, named))
        fail_msg("expected %s with '%s', got %s: '%s'", op_status_name(st), want,
                 op_status_name(got), err.message);
    assert_null(m.positions);
    assert_null(m.indices);
    unlink(path);
}

/* The quad of mesh index (dz = index) with the arrays flags promise. */
static void expect_quad(const char *path, uint32_t index, int flags)
{
    op_mesh m;
    op_error err = {0};
    OP_ASSERT_OK(op_mesh_load_serialized(path, index, &m, &err), err);
    assert_int_equal(m.nverts, 4);
    assert_int_equal(m.ntris, 2);
    assert_float_equal(m.positions[3], 1.0, 0);
    assert_float_equal(m.positions[7], 1.0, 0);
    for (int v = 0; v < 4; v++)
        assert_float_equal(m.positions[3 * v + 2], (double)index, 0);
    assert_int_equal(m.indices[4], 2);
    assert_int_equal(m.indices[5], 3);
    assert_int_equal(m.normals != NULL, (flags & F_NORMALS) != 0);
    assert_int_equal(m.uvs != NULL, (flags & F_UVS) != 0);
    if (m.normals)
        assert_float_equal(m.normals[11], 1.0, 0);
    if (m.uvs) {
        assert_float_equal(m.uvs[4], 1.0, 0);
        assert_float_equal(m.uvs[7], 1.0, 0);
    }
    op_mesh_free(&m);
    uint64_t nv, nt;
    OP_ASSERT_OK(op_mesh_serialized_counts(path, index, &nv, &nt, &err), err);
    assert_int_equal(nv, 4);
    assert_int_equal(nt, 2);
}

static void versions_and_arrays(void **state)
{
    (void)state;
    const int flag_sets[] = {F_SINGLE, F_SINGLE | F_NORMALS, F_SINGLE | F_UVS,
                             F_SINGLE | F_NORMALS | F_UVS | F_COLORS | F_FACE, F_DOUBLE,
                             F_DOUBLE | F_NORMALS | F_UVS, F_DOUBLE | F_COLORS, 0};
    for (int version = 3; version <= 4; version++)
        for (size_t k = 0; k < sizeof flag_sets / sizeof flag_sets[0]; k++) {
            buf b = make_file(version, flag_sets[k], 3);
            const char *path = write_buf(&b);
            for (uint32_t index = 0; index < 3; index++)
                expect_quad(path, index, flag_sets[k]);
            op_mesh m;
            op_error err = {0};
            OP_ASSERT_OK(op_mesh_load(path, &m, &err), err); /* by extension: the first */
            assert_float_equal(m.positions[2], 0.0, 0);
            op_mesh_free(&m);
            unlink(path);
            free(b.p);
        }
}

static void dictionary(void **state)
{
    (void)state;
    buf b = {0}; /* one mesh and no dictionary: the first is read, as Mitsuba does */
    put_mesh(&b, (quad_opts){3, F_SINGLE, 0, 0, 0, 0});
    expect_quad(write_buf(&b), 0, F_SINGLE);
    expect_bad(&b, 1, OP_ERR_FORMAT, "dictionary");
    free(b.p);

    for (int version = 3; version <= 4; version++) {
        size_t entry = version == 4 ? 8 : 4;
        b = make_file(version, F_SINGLE, 2);
        expect_bad(&b, 2, OP_ERR_INPUT, "out of range: the file holds 2 meshes");
        expect_bad(&b, 4000000000u, OP_ERR_INPUT, "out of range");
        size_t count_at = b.n - 4, second = b.n - 4 - entry;
        b.p[second] = 0xff; /* the second offset past the meshes */
        expect_bad(&b, 1, OP_ERR_FORMAT, "beyond the meshes");
        b.p[second] = 3; /* inside the first mesh: no header there */
        expect_bad(&b, 1, OP_ERR_FORMAT, "the mesh at byte 3 has no serialized mesh header");
        b.p[count_at + 3] = 0x40; /* a count whose dictionary cannot fit */
        expect_bad(&b, 1, OP_ERR_FORMAT, "missing or damaged");
        memset(&b.p[count_at], 0, 4);
        expect_bad(&b, 1, OP_ERR_FORMAT, "missing or damaged");
        free(b.p);
    }
    /* a second mesh of another version than the first */
    b.p = NULL, b.n = 0;
    put_mesh(&b, (quad_opts){4, F_SINGLE, 0, 0, 0, 0});
    size_t second = b.n;
    put_mesh(&b, (quad_opts){3, F_SINGLE, 1, 0, 0, 0});
    put_le(&b, 0, 8);
    put_le(&b, second, 8);
    put_le(&b, 2, 4);
    expect_bad(&b, 1, OP_ERR_FORMAT, "version 3, the file's first mesh 4");
    free(b.p);
}

static void bad_headers(void **state)
{
    (void)state;
    buf b = make_file(4, F_SINGLE, 1);
    b.p[0] = 0x04, b.p[1] = 0x1C;
    expect_bad(&b, 0, OP_ERR_FORMAT, "Mitsuba before 0.3");
    b.p[0] = 'P', b.p[1] = 'K';
    expect_bad(&b, 0, OP_ERR_FORMAT, "has no serialized mesh header");
    b.p[0] = 0x1C, b.p[1] = 0x04, b.p[2] = 5;
    expect_bad(&b, 0, OP_ERR_FORMAT, "format version 5 (versions 3 and 4 are read)");
    b.p[2] = 4;
    b.p[4] ^= 0xff; /* the zlib header */
    expect_bad(&b, 0, OP_ERR_FORMAT, "compressed data is corrupt");
    b.n = 3;
    expect_bad(&b, 0, OP_ERR_FORMAT, "too short");
    b.n = 0;
    expect_bad(&b, 0, OP_ERR_FORMAT, "too short");
    free(b.p);

    b.p = NULL, b.n = 0;
    put_mesh(&b, (quad_opts){4, F_SINGLE | F_DOUBLE, 0, 0, 0, 0});
    expect_bad(&b, 0, OP_ERR_FORMAT, "both single and double precision");
    free(b.p);
}

static void bad_counts(void **state)
{
    (void)state;
    const struct {
        uint64_t nverts, ntris;
        uint32_t last_index;
        const char *want;
    } cases[] = {
        {1ull << 31, 2, 0, "a mesh holds at most 2147483647"},
        {4, 1ull << 40, 0, "a mesh holds at most"},
        {(1ull << 32) + 1, 2, 0, "a mesh holds at most"}, /* 64-bit indices from here on */
        {UINT64_MAX, UINT64_MAX, 0, "a mesh holds at most"},
        {100000000, 2, 0, "cannot come from the"},
        {4, 50000000, 0, "cannot come from the"},
        {5, 2, 0, "the mesh's compressed data ends before its triangle indices"},
        {4, 3, 0, "the mesh's compressed data ends before its triangle indices"},
        {4, 2, 4, "triangle 1: vertex index 4 is out of range (4 vertices)"},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        buf b = {0};
        put_mesh(&b, (quad_opts){k % 2 ? 3 : 4, F_SINGLE, 0, cases[k].nverts, cases[k].ntris,
                                 cases[k].last_index});
        expect_bad(&b, 0, OP_ERR_FORMAT, cases[k].want);
        free(b.p);
    }
}

static void bad_values(void **state)
{
    (void)state;
    for (int dbl = 0; dbl <= 1; dbl++) {
        buf b = {0};
        put_mesh(&b, (quad_opts){4, dbl ? F_DOUBLE : F_SINGLE, NAN, 0, 0, 0});
        expect_bad(&b, 0, OP_ERR_FORMAT, "vertex 0: a value of its position");
        free(b.p);
    }
    buf b = {0};
    put_mesh(&b, (quad_opts){4, F_DOUBLE, 1e300, 0, 0, 0});
    expect_bad(&b, 0, OP_ERR_FORMAT, "is not a finite float");
    free(b.p);
}

/* Every truncation fails cleanly, or (cut within the zlib trailer or the dictionary) gives
 * the whole mesh. */
static void truncations(void **state)
{
    (void)state;
    for (int version = 3; version <= 4; version++) {
        buf b = make_file(version, F_SINGLE | F_NORMALS | F_UVS, 2);
        size_t full = b.n;
        for (size_t cut = 0; cut < full; cut++) {
            b.n = cut;
            const char *path = write_buf(&b);
            for (uint32_t index = 0; index < 2; index++) {
                op_mesh m;
                op_error err = {0};
                op_status st = op_mesh_load_serialized(path, index, &m, &err);
                if (st == OP_OK) {
                    assert_true(cut > full / 4);
                    assert_int_equal(m.ntris, 2);
                    assert_float_equal(m.positions[2], (double)index, 0);
                    op_mesh_free(&m);
                    continue;
                }
                assert_int_equal(op_exit_code(st), 2);
                assert_non_null(strstr(err.message, "shape index"));
                assert_null(m.positions);
            }
        }
        unlink(write_buf(&b));
        free(b.p);
    }
}

static void shared_matpreview(void **state)
{
    (void)state;
    const char *path = op_test_shared_path("scenes/mitsuba/lajolla/scenes/matpreview/"
                                           "matpreview.serialized");
    if (!path)
        skip();
    /* tests/serialized_mesh.py counts FILE I */
    const uint32_t want[3][2] = {{289, 512}, {2078, 3936}, {29439, 57152}};
    for (uint32_t i = 0; i < 3; i++) {
        op_mesh m;
        op_error err = {0};
        uint64_t nv, nt;
        OP_ASSERT_OK(op_mesh_serialized_counts(path, i, &nv, &nt, &err), err);
        OP_ASSERT_OK(op_mesh_load_serialized(path, i, &m, &err), err);
        assert_int_equal(m.nverts, want[i][0]);
        assert_int_equal(m.ntris, want[i][1]);
        assert_int_equal(nv, want[i][0]);
        assert_int_equal(nt, want[i][1]);
        for (size_t k = 0; k < 3 * (size_t)m.ntris; k++)
            assert_true(m.indices[k] < m.nverts);
        op_mesh_free(&m);
    }
    op_mesh m;
    op_error err = {0};
    assert_int_equal(op_mesh_load_serialized(path, 3, &m, &err), OP_ERR_INPUT);
    assert_non_null(strstr(err.message, "shape index 3: out of range: the file holds 3 meshes"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(versions_and_arrays), cmocka_unit_test(dictionary),
        cmocka_unit_test(bad_headers),         cmocka_unit_test(bad_counts),
        cmocka_unit_test(bad_values),          cmocka_unit_test(truncations),
        cmocka_unit_test(shared_matpreview),
    };
    return op_test_exit_status(cmocka_run_group_tests(tests, NULL, NULL));
}
