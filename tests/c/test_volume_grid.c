/* test_volume_grid.c - the .vol reader and grid lookups (renderer/lib/medium/volume_grid.h):
 * - a float32 and a uint8 grid read back value for value, at Mitsuba 3's cell centres and at
 *   Mitsuba 0.6's vertices, interpolated trilinearly between them, clamped (3) or 0 (0.6)
 *   outside, with their per-channel minima and maxima;
 * - Mitsuba 3's other lookups: nearest cells, grids repeated or mirrored beyond their cube, and
 *   the brick bounds of a repeated grid covering what a face's lookups blend in;
 * - every kind of bad file (wrong magic, version, encoding, channel count, sizes; truncated
 *   header or values, sizes whose product overflows, non-finite values) is an OP_ERR_INPUT that
 *   names the file and the fault. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "medium/volume_grid.h"
#include "test_support.h"

static op_v3 eval_x(const op_volume *v, double x)
{
    return op_volume_eval(v, v3((float)x, 0.5f, 0.5f));
}

/* A .vol file's bytes: header of (encoding, res, channels, bbox) then nvals values (float32 or
 * uint8 per encoding; vals as floats). Returns its size. */
static size_t make_vol(unsigned char *buf, int version, int encoding, int nx, int ny, int nz,
                       int channels, const float bbox[6], const float *vals, size_t nvals)
{
    memcpy(buf, "VOL", 3);
    buf[3] = (unsigned char)version;
    int32_t hdr[5] = {encoding, nx, ny, nz, channels};
    memcpy(buf + 4, hdr, sizeof hdr); /* little-endian hosts (the tests' and CI's) */
    memcpy(buf + 24, bbox, 6 * sizeof(float));
    size_t n = 48;
    for (size_t i = 0; i < nvals; i++) {
        if (encoding == 3) {
            buf[n++] = (unsigned char)vals[i];
        } else {
            memcpy(buf + n, &vals[i], sizeof(float));
            n += sizeof(float);
        }
    }
    return n;
}

static const float unit_box[6] = {0, 0, 0, 1, 1, 1};

/* Writes the bytes to a fresh .vol file and reads it. */
static op_status read_bytes(const unsigned char *buf, size_t n, const char **path, op_volume **v,
                            op_error *err)
{
    *path = op_test_tmp_path("grid.vol");
    FILE *f = fopen(*path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(buf, 1, n, f), n);
    fclose(f);
    return op_volume_read(*path, v, err);
}

static void near(op_v3 got, double x, double y, double z)
{
    if (fabs(got.x - x) > 1e-5 || fabs(got.y - y) > 1e-5 || fabs(got.z - z) > 1e-5)
        fail_msg("got (%g, %g, %g), expected (%g, %g, %g)", got.x, got.y, got.z, x, y, z);
}

/* A 2 x 3 x 2 float grid whose value at voxel (x, y, z) is x + 10 y + 100 z: linear, so
 * trilinear interpolation reproduces it exactly between the sample points. */
static void test_float_grid(void **state)
{
    (void)state;
    float vals[12];
    for (int z = 0, i = 0; z < 2; z++)
        for (int y = 0; y < 3; y++)
            for (int x = 0; x < 2; x++)
                vals[i++] = (float)(x + 10 * y + 100 * z);
    unsigned char buf[256];
    const float box[6] = {-1, -2, -3, 1, 2, 3};
    size_t n = make_vol(buf, 3, 1, 2, 3, 2, 1, box, vals, 12);
    const char *path;
    op_volume *v;
    op_error err;
    OP_ASSERT_OK(read_bytes(buf, n, &path, &v, &err), err);
    assert_int_equal(op_volume_channels(v), 1);
    double lo[3], hi[3];
    op_volume_file_bbox(v, lo, hi);
    assert_true(lo[0] == -1 && lo[2] == -3 && hi[1] == 2 && hi[2] == 3);
    near(op_volume_min(v), 0, 0, 0);
    near(op_volume_max(v), 121, 121, 121);
    /* unplaced: Mitsuba 3's cells of the unit cube; centre of voxel (1, 2, 0) */
    near(op_volume_eval(v, v3(0.75f, 5.0f / 6.0f, 0.25f)), 21, 21, 21);
    /* halfway between the centres of voxels (0, 0, 0) and (1, 1, 1) */
    near(op_volume_eval(v, v3(0.5f, 1.0f / 3.0f, 0.5f)), 0.5 + 5 + 50, 0.5 + 5 + 50, 55.5);
    /* clamped beyond the outer centres, and beyond the cube when unbounded */
    near(op_volume_eval(v, v3(0.1f, 0.05f, 0.1f)), 0, 0, 0);
    near(op_volume_eval(v, v3(2.0f, 2.0f, 2.0f)), 121, 121, 121);
    /* Mitsuba 0.6: vertices at the cube's corners; (u, v, w) -> x = u, y = 2 v, z = w */
    op_matrix4 id = op_matrix4_identity();
    assert_true(op_volume_place(v, &id, OP_VOLUME_VERTICES, 1));
    near(op_volume_eval(v, v3(0.25f, 0.75f, 0.5f)), 0.25 + 15 + 50, 65.25, 65.25);
    near(op_volume_eval(v, v3(0.0f, 0.0f, 0.0f)), 0, 0, 0);
    near(op_volume_eval(v, v3(-0.01f, 0.5f, 0.5f)), 0, 0, 0);
    near(op_volume_eval(v, v3(0.5f, 0.5f, 1.0f)), 0, 0, 0); /* a last plane has no cell: 0 */
    float t0, t1;
    assert_true(op_volume_ray_span(v, v3(-1, 0.5f, 0.5f), v3(1, 0, 0), &t0, &t1));
    assert_true(fabsf(t0 - 1.0f) < 1e-6f && fabsf(t1 - 2.0f) < 1e-6f);
    op_volume_free(v);
}

/* A 2 x 1 x 1 uint8 grid of 3 channels: bytes map to byte / 255. */
static void test_uint8_grid(void **state)
{
    (void)state;
    const float vals[6] = {0, 51, 255, 255, 102, 0};
    unsigned char buf[128];
    size_t n = make_vol(buf, 3, 3, 2, 1, 1, 3, unit_box, vals, 6);
    const char *path;
    op_volume *v;
    op_error err;
    OP_ASSERT_OK(read_bytes(buf, n, &path, &v, &err), err);
    assert_int_equal(op_volume_channels(v), 3);
    near(op_volume_min(v), 0, 0.2, 0);
    near(op_volume_max(v), 1, 0.4, 1);
    near(op_volume_eval(v, v3(0.25f, 0.5f, 0.5f)), 0, 0.2, 1);
    near(op_volume_eval(v, v3(0.5f, 0.5f, 0.5f)), 0.5, 0.3, 0.5);
    op_volume_free(v);
}

/* Reads buf and expects OP_ERR_INPUT with a message naming the file and holding what. */
static void expect_bad(const char *label, const unsigned char *buf, size_t n, const char *what)
{
    const char *path;
    op_volume *v = (op_volume *)buf;
    op_error err;
    op_status st = read_bytes(buf, n, &path, &v, &err);
    printf("%s: %s\n", label, st == OP_OK ? "accepted" : err.message);
    if (st != OP_ERR_INPUT)
        fail_msg("%s: status %s, expected input error", label, op_status_name(st));
    assert_null(v);
    assert_non_null(strstr(err.message, path));
    if (!strstr(err.message, what))
        fail_msg("%s: message lacks \"%s\"", label, what);
}

static void test_bad_files(void **state)
{
    (void)state;
    float vals[8] = {1, 2, 3, 4, 5, 6, 7, 8};
    unsigned char buf[256], bad[256];
    size_t n = make_vol(buf, 3, 1, 2, 2, 2, 1, unit_box, vals, 8);
    expect_bad("empty", buf, 0, "does not start with \"VOL\"");
    memcpy(bad, buf, n);
    bad[0] = 'X';
    expect_bad("magic", bad, n, "does not start with \"VOL\"");
    n = make_vol(bad, 2, 1, 2, 2, 2, 1, unit_box, vals, 8);
    expect_bad("version", bad, n, "version 2");
    n = make_vol(bad, 3, 2, 2, 2, 2, 1, unit_box, vals, 8);
    expect_bad("float16", bad, n, "encoding 2");
    n = make_vol(bad, 3, 1, 2, 2, 2, 2, unit_box, vals, 8);
    expect_bad("channels", bad, n, "2 channels");
    n = make_vol(bad, 3, 1, 2, 0, 2, 1, unit_box, vals, 8);
    expect_bad("zero size", bad, n, "must be positive");
    n = make_vol(bad, 3, 1, 2, -4, 2, 1, unit_box, vals, 8);
    expect_bad("negative size", bad, n, "must be positive");
    expect_bad("short header", buf, 30, "truncated volume header");
    n = make_vol(bad, 3, 1, 2, 2, 2, 1, unit_box, vals, 8);
    expect_bad("short values", bad, n - 1, "truncated");
    n = make_vol(bad, 3, 1, 2, 2, 2, 3, unit_box, vals, 8);
    expect_bad("3 channels of 8 values", bad, n, "truncated");
    n = make_vol(bad, 3, 1, 0x7fffffff, 0x7fffffff, 0x7fffffff, 3, unit_box, vals, 8);
    expect_bad("overflowing sizes", bad, n, "truncated");
    vals[5] = NAN;
    n = make_vol(bad, 3, 1, 2, 2, 2, 1, unit_box, vals, 8);
    expect_bad("NaN", bad, n, "voxel (1, 0, 1) is not finite");
    vals[5] = INFINITY;
    n = make_vol(bad, 3, 1, 2, 2, 2, 1, unit_box, vals, 8);
    expect_bad("infinity", bad, n, "not finite");
    op_volume *v;
    op_error err;
    const char *missing = op_test_tmp_path("missing.vol");
    assert_int_not_equal(op_volume_read(missing, &v, &err), OP_OK);
    assert_non_null(strstr(err.message, missing));
}

/* A row of 4 cells holding 1, 2, 3, 4 (and 1 x 1 across), looked up along x: nearest cells,
 * then repeated and mirrored beyond the cube, trilinear and nearest. */
static void test_filters_and_wraps(void **state)
{
    (void)state;
    unsigned char buf[256];
    const float vals[4] = {1, 2, 3, 4};
    size_t n = make_vol(buf, 3, 1, 4, 1, 1, 1, unit_box, vals, 4);
    const char *path;
    op_volume *v = NULL;
    op_error err = {0};
    OP_ASSERT_OK(read_bytes(buf, n, &path, &v, &err), err);
    /* clamped trilinear (the default): cell centres at 0.125 + k / 4 */
    near(eval_x(v, 0.25), 1.5, 1.5, 1.5);
    near(eval_x(v, -3.0), 1, 1, 1);
    near(eval_x(v, 7.0), 4, 4, 4);
    op_volume_set_lookup(v, OP_VOLUME_NEAREST, OP_VOLUME_CLAMP);
    near(eval_x(v, 0.01), 1, 1, 1);
    near(eval_x(v, 0.249), 1, 1, 1);
    near(eval_x(v, 0.251), 2, 2, 2);
    near(eval_x(v, 0.99), 4, 4, 4);
    near(eval_x(v, 1.7), 4, 4, 4);
    op_volume_set_lookup(v, OP_VOLUME_NEAREST, OP_VOLUME_REPEAT);
    near(eval_x(v, 1.1), 1, 1, 1);
    near(eval_x(v, -0.1), 4, 4, 4);
    near(eval_x(v, -1.6), 2, 2, 2);
    op_volume_set_lookup(v, OP_VOLUME_NEAREST, OP_VOLUME_MIRROR);
    near(eval_x(v, 1.1), 4, 4, 4);
    near(eval_x(v, 1.3), 3, 3, 3);
    near(eval_x(v, -0.1), 1, 1, 1);
    near(eval_x(v, -0.3), 2, 2, 2);
    near(eval_x(v, 2.1), 1, 1, 1);
    op_volume_set_lookup(v, OP_VOLUME_TRILINEAR, OP_VOLUME_REPEAT);
    near(eval_x(v, 0.0), 2.5, 2.5, 2.5); /* halfway between the last cell and the first */
    near(eval_x(v, 1.0), 2.5, 2.5, 2.5);
    near(eval_x(v, 1.25), 1.5, 1.5, 1.5);
    op_volume_set_lookup(v, OP_VOLUME_TRILINEAR, OP_VOLUME_MIRROR);
    near(eval_x(v, 0.0), 1, 1, 1);
    near(eval_x(v, 1.0), 4, 4, 4);
    near(eval_x(v, 1.25), 3.5, 3.5, 3.5);
    op_volume_free(v);
}

/* A 16-cell row, 0 but for a hot last cell: repeated and trilinear, lookups at the first face blend
 * it in, so the first brick's bound covers it (clamped, the first brick's bound is 0). */
static void test_repeat_brick_bounds(void **state)
{
    (void)state;
    unsigned char buf[256];
    float vals[16] = {0};
    vals[15] = 8;
    size_t n = make_vol(buf, 3, 1, 16, 1, 1, 1, unit_box, vals, 16);
    const char *path;
    op_volume *v = NULL;
    op_error err = {0};
    for (int wrap = 0; wrap < 2; wrap++) {
        OP_ASSERT_OK(read_bytes(buf, n, &path, &v, &err), err);
        op_volume_set_lookup(v, OP_VOLUME_TRILINEAR, wrap ? OP_VOLUME_REPEAT : OP_VOLUME_CLAMP);
        op_volume_walk w;
        op_volume_walk_start(&w, v, v3(0.0f, 0.5f, 0.5f), v3(1, 0, 0), 0.0f, 0.2f);
        float a, b, bound, worst = 0;
        while (op_volume_walk_next(&w, &a, &b, &bound))
            worst = fmaxf(worst, bound);
        double got = op_volume_eval(v, v3(0.001f, 0.5f, 0.5f)).x;
        printf("wrap %d: value at the first face %.4f, bound over the first brick %.4f\n", wrap,
               got, worst);
        assert_true(worst >= got);
        assert_true(wrap ? got > 3.5 : got == 0.0);
        op_volume_free(v);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_float_grid),
        cmocka_unit_test(test_uint8_grid),
        cmocka_unit_test(test_bad_files),
        cmocka_unit_test(test_filters_and_wraps),
        cmocka_unit_test(test_repeat_brick_bounds),
    };
    return op_test_exit_status(cmocka_run_group_tests(tests, NULL, NULL));
}
