/* test_material_file.c - the .opm container: round trips, and truncated, corrupt or hostile
 * files, which must give OP_ERR_FORMAT and never a crash. Files are built here byte by byte by
 * an independent implementation of docs/formats.md, so the tests also check the specification. */
#include "test_support.h"

#include "opaline_material.h"
#include "opaline_material_write.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------ an independent .opm builder */

typedef struct sec {
    const char *tag;
    const void *data;
    size_t bytes;
} sec;

typedef struct blob {
    unsigned char *p;
    size_t n;
} blob;

static void put32(unsigned char *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (unsigned char)(v >> (8 * i));
}

static void put64(unsigned char *p, uint64_t v)
{
    put32(p, (uint32_t)v);
    put32(p + 4, (uint32_t)(v >> 32));
}

/* Header, 64-byte aligned sections, table; all checksums right. */
static blob build(const sec *s, int n)
{
    size_t pos = 64;
    for (int i = 0; i < n; i++)
        pos = (pos + 63) / 64 * 64 + s[i].bytes;
    size_t table = (pos + 63) / 64 * 64, total = table + 32 * (size_t)n;
    blob b = {calloc(1, total), total};
    pos = 64;
    for (int i = 0; i < n; i++) {
        pos = (pos + 63) / 64 * 64;
        memcpy(b.p + pos, s[i].data, s[i].bytes);
        unsigned char *e = b.p + table + 32 * (size_t)i;
        memcpy(e, s[i].tag, strlen(s[i].tag));
        put64(e + 8, pos);
        put64(e + 16, s[i].bytes);
        put32(e + 24, op_crc32(0, s[i].data, s[i].bytes));
        pos += s[i].bytes;
    }
    memcpy(b.p, "OPALINEM", 8);
    put32(b.p + 8, 1);
    put32(b.p + 12, (uint32_t)n);
    put64(b.p + 16, total);
    put64(b.p + 24, table);
    put32(b.p + 32, op_crc32(0, b.p + table, 32 * (size_t)n));
    put32(b.p + 36, op_crc32(0, b.p, 36));
    return b;
}

/* Recomputes the table and header checksums after an edit. */
static void reseal(blob *b)
{
    uint32_t n = (uint32_t)b->p[12] | (uint32_t)b->p[13] << 8;
    uint64_t table = 0;
    for (int i = 7; i >= 0; i--)
        table = table << 8 | b->p[24 + i];
    if (table + 32ull * n <= b->n)
        put32(b->p + 32, op_crc32(0, b->p + table, 32 * (size_t)n));
    put32(b->p + 36, op_crc32(0, b->p, 36));
}

static const char *save(const blob *b, size_t n)
{
    const char *path = op_test_tmp_path("m.opm");
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(b->p, 1, n, f), n);
    fclose(f);
    return path;
}

static op_status open_status(const blob *b, size_t n, op_error *err)
{
    op_material *m = NULL;
    const char *path = save(b, n);
    op_status st = op_material_open(path, &m, err);
    op_material_close(m);
    remove(path);
    return st;
}

/* Builds a file of the n sections and asserts that opening it fails with OP_ERR_FORMAT; the
 * message is left in *err. */
static void expect_format_error(const sec *s, int n, op_error *err)
{
    blob b = build(s, n);
    assert_int_equal(open_status(&b, b.n, err), OP_ERR_FORMAT);
    free(b.p);
}

/* A 3 x 2 pixel, K = 3, one-channel raw material with Rd = index / 1000 (rows sum to < 1). */
static const char raw_meta[] = "method=raw\nwidth=3\nheight=2\nkernel=3\nchannels=1\n"
                               "size_x_cm=1.5\nsize_y_cm=1\nname=tiny\n";
static float raw_values[6 * 9];

static blob tiny_raw(const char *meta)
{
    for (int i = 0; i < 6 * 9; i++)
        raw_values[i] = (float)i / 1000.0f;
    sec s[2] = {{"META", meta, strlen(meta)}, {"RD.Y", raw_values, sizeof raw_values}};
    return build(s, 2);
}

/* ------------------------------------------------------------ tests */

static void writer_round_trip(void **state)
{
    op_material_info info = {0};
    info.method = OP_METHOD_RAW;
    info.width = 4;
    info.height = 3;
    info.kernel = 3;
    info.channels = 3;
    info.size_x_cm = 2.0;
    info.size_y_cm = 1.5;
    info.dataset_crc = 0xdeadbeef;
    snprintf(info.name, sizeof info.name, "round trip");
    snprintf(info.generator, sizeof info.generator, "test");
    float rd[3][12 * 9];
    for (int c = 0; c < 3; c++)
        for (int i = 0; i < 12 * 9; i++)
            rd[c][i] = (float)(c + 1) * 0.0001f * (float)i; /* rows sum to < 1 */
    const char *path = op_test_tmp_path("rt.opm");
    op_error err = {0};
    op_material_writer *w;
    OP_ASSERT_OK(op_material_writer_open(path, &info, &w, &err), err);
    OP_ASSERT_OK(op_material_writer_add(w, "RD.R", rd[0], sizeof rd[0], &err), err);
    OP_ASSERT_OK(op_material_writer_add(w, "RD.G", rd[1], sizeof rd[1], &err), err);
    assert_int_equal(op_material_writer_add(w, "RD.G", rd[1], sizeof rd[1], &err),
                     OP_ERR_INTERNAL);
    OP_ASSERT_OK(op_material_writer_add(w, "RD.B", rd[2], sizeof rd[2], &err), err);
    OP_ASSERT_OK(op_material_writer_commit(w, &err), err);

    op_material *m;
    OP_ASSERT_OK(op_material_open(path, &m, &err), err);
    const op_material_info *in = op_material_get_info(m);
    assert_int_equal(in->method, OP_METHOD_RAW);
    assert_int_equal(in->width, 4);
    assert_int_equal(in->height, 3);
    assert_int_equal(in->channels, 3);
    assert_true(in->size_y_cm == 1.5);
    assert_int_equal(in->dataset_crc, 0xdeadbeef);
    assert_string_equal(in->name, "round trip");
    assert_string_equal(in->tool_version, op_version());
    /* Pixel (x=2, y=1) is row 6; offset (dx=1, dy=-1) is column 0 * 3 + 2. */
    assert_true(op_material_eval(m, 1, 2, 1, 1, -1) == rd[1][6 * 9 + 2]);
    assert_true(op_material_eval(m, 1, 2, 1, 2, 0) == 0.0f); /* outside the kernel */
    float row[9], albedo[3 * 12];
    op_material_eval_row(m, 2, 3, 2, row);
    assert_memory_equal(row, rd[2] + 11 * 9, sizeof row);
    OP_ASSERT_OK(op_material_albedo_map(m, albedo, &err), err);
    double sum = 0;
    for (int j = 0; j < 9; j++)
        sum += rd[0][5 * 9 + j];
    assert_float_equal(albedo[5], sum, 1e-6);
    uint64_t bytes = 0;
    const void *sec_ptr = op_material_section(m, "RD.B", &bytes);
    assert_non_null(sec_ptr);
    assert_int_equal(bytes, sizeof rd[2]);
    assert_int_equal((uintptr_t)sec_ptr % 64, 0);
    assert_null(op_material_section(m, "RD.X", NULL));
    op_material_close(m);
}

static void independent_builder_matches(void **state)
{
    blob b = tiny_raw(raw_meta);
    op_material *m;
    op_error err = {0};
    OP_ASSERT_OK(op_material_open(save(&b, b.n), &m, &err), err);
    assert_true(op_material_eval(m, 0, 1, 1, 0, 0) == raw_values[4 * 9 + 4]);
    op_material_close(m);
    free(b.p);
}

static void truncated_at_every_length(void **state)
{
    blob b = tiny_raw(raw_meta);
    for (size_t n = 0; n < b.n; n++) {
        op_error err = {0};
        op_status st = open_status(&b, n, &err);
        if (st != OP_ERR_FORMAT)
            fail_msg("truncated to %zu of %zu bytes: %s (%s)", n, b.n, op_status_name(st),
                     err.message);
    }
    free(b.p);
}

static void flipped_bytes(void **state)
{
    /* Every byte that matters is under a checksum; padding may change harmlessly. */
    blob b = tiny_raw(raw_meta);
    for (size_t i = 0; i < b.n; i++) {
        for (int bit = 0; bit < 8; bit += 7) {
            b.p[i] ^= (unsigned char)(1u << bit);
            op_error err = {0};
            op_material *m = NULL;
            const char *path = save(&b, b.n);
            op_status st = op_material_open(path, &m, &err);
            remove(path);
            if (st == OP_OK) {
                float row[9];
                op_material_eval_row(m, 0, 1, 1, row);
                assert_memory_equal(row, raw_values + 4 * 9, sizeof row);
                op_material_close(m);
            } else if (st != OP_ERR_FORMAT) {
                fail_msg("byte %zu bit %d: %s", i, bit, op_status_name(st));
            }
            b.p[i] ^= (unsigned char)(1u << bit);
        }
    }
    free(b.p);
}

static void hostile_section_tables(void **state)
{
    blob good = tiny_raw(raw_meta);
    size_t table = good.n - 64;
    /* Each edit keeps valid checksums so the structural checks themselves are exercised. */
    struct {
        const char *what;
        size_t at;
        uint64_t value;
        int width;
    } edits[] = {
        {"offset past the end", table + 8, 1u << 30, 8},
        {"offset not aligned", table + 8, 65, 8},
        {"offset inside the header", table + 8, 0, 8},
        {"size past the table", table + 16, 1u << 20, 8},
        {"huge size", table + 16, UINT64_MAX, 8},
        {"huge offset", table + 8, UINT64_MAX - 63, 8},
        {"section count zero", 12, 0, 4},
        {"section count huge", 12, 0xffffffffu, 4},
        {"section count past the file", 12, 3, 4},
        {"table offset past the end", 24, 1u << 30, 8},
        {"table offset in the header", 24, 8, 8},
        {"declared size wrong", 16, 12345, 8},
        {"version 2", 8, 2, 4},
        {"tag with a space", table + 32, 0x20592e4452ull, 8},
        {"empty tag", table + 32, 0, 8},
        {"duplicate tag", table + 32, 0x4154454dull, 8}, /* "META" */
    };
    for (size_t i = 0; i < sizeof edits / sizeof edits[0]; i++) {
        blob b = {malloc(good.n), good.n};
        memcpy(b.p, good.p, good.n);
        if (edits[i].width == 8)
            put64(b.p + edits[i].at, edits[i].value);
        else
            put32(b.p + edits[i].at, (uint32_t)edits[i].value);
        reseal(&b);
        op_error err = {0};
        op_status st = open_status(&b, b.n, &err);
        if (st != OP_ERR_FORMAT)
            fail_msg("%s: %s (%s)", edits[i].what, op_status_name(st), err.message);
        assert_non_null(strstr(err.message, "m.opm"));
        free(b.p);
    }
    free(good.p);
}

static void wrong_meta(void **state)
{
    const char *metas[] = {
        "method=raw\nwidth=3\nheight=2\nkernel=3\n" /* no channels */,
        "method=teapot\nwidth=3\nheight=2\nkernel=3\nchannels=1\nsize_x_cm=1\nsize_y_cm=1\n",
        "method=raw\nwidth=3\nheight=2\nkernel=4\nchannels=1\nsize_x_cm=1\nsize_y_cm=1\n",
        "method=raw\nwidth=3\nheight=2\nkernel=3\nchannels=2\nsize_x_cm=1\nsize_y_cm=1\n",
        "method=raw\nwidth=3\nheight=2\nkernel=3\nchannels=1\nsize_x_cm=-1\nsize_y_cm=1\n",
        "method=raw\nwidth=3\nheight=2\nkernel=3\nchannels=1\nsize_x_cm=nan\nsize_y_cm=1\n",
        "method=raw\nwidth=3x\nheight=2\nkernel=3\nchannels=1\nsize_x_cm=1\nsize_y_cm=1\n",
        "method=raw\nwidth=99999999999\nheight=2\nkernel=3\nchannels=1\nsize_x_cm=1\n",
        "method=raw\nwidth=3\nheight=2\nkernel=3\nchannels=1\nsize_x_cm=1\nsize_y_cm=1\nbad\n",
        "method=raw\nwidth=4\nheight=2\nkernel=3\nchannels=1\nsize_x_cm=1\nsize_y_cm=1\n",
        "method=raw\nwidth=3\nheight=2\nkernel=3\nchannels=3\nsize_x_cm=1\nsize_y_cm=1\n",
        "method=svd\nwidth=3\nheight=2\nkernel=3\nchannels=1\nsize_x_cm=1\nsize_y_cm=1\n",
        "method=kcta\nwidth=3\nheight=2\nkernel=3\nchannels=1\nsize_x_cm=1\nsize_y_cm=1\n",
    };
    for (size_t i = 0; i < sizeof metas / sizeof metas[0]; i++) {
        blob b = tiny_raw(metas[i]);
        op_error err = {0};
        op_status st = open_status(&b, b.n, &err);
        if (st != OP_ERR_FORMAT)
            fail_msg("META %zu: %s (%s)", i, op_status_name(st), err.message);
        free(b.p);
    }
    /* A line longer than the parser's buffer. */
    char *lng = malloc(2000);
    strcpy(lng, raw_meta);
    strcat(lng, "generator=");
    memset(lng + strlen(lng), 'x', 1000);
    lng[strlen(raw_meta) + 10 + 1000] = '\0';
    blob b = tiny_raw(lng);
    op_error err = {0};
    assert_int_equal(open_status(&b, b.n, &err), OP_ERR_FORMAT);
    free(b.p);
    free(lng);
}

static void hostile_values(void **state)
{
    /* Raw: a NaN and a negative value. */
    static const char meta[] = "method=raw\nwidth=3\nheight=2\nkernel=3\nchannels=1\n"
                               "size_x_cm=1\nsize_y_cm=1\n";
    float bad[6 * 9] = {0};
    bad[17] = NAN;
    sec s[2] = {{"META", meta, strlen(meta)}, {"RD.Y", bad, sizeof bad}};
    blob b = build(s, 2);
    op_error err = {0};
    assert_int_equal(open_status(&b, b.n, &err), OP_ERR_FORMAT);
    assert_non_null(strstr(err.message, "17"));
    free(b.p);

    /* SVD, one term: every invariant broken in turn. */
    static const char svd_meta[] = "method=svd\nwidth=3\nheight=2\nkernel=3\nchannels=1\n"
                                   "size_x_cm=1\nsize_y_cm=1\nterms=1\nshifted=1\nlog_a=100\n"
                                   "log_b=1\n";
    float u[6] = {0.01f, 0.01f, 0.01f, 0.01f, 0.01f, 0.01f}, v[9] = {1, 1, 1, 1, 1, 1, 1, 1, 1};
    float mx[6] = {1, 1, 1, 1, 1, 1};
    uint32_t sh[6] = {0, 1, 2, 3, 4, 5};
    sec ok[5] = {{"META", svd_meta, strlen(svd_meta)}, {"U.Y", u, sizeof u}, {"V.Y", v, sizeof v},
                 {"SHIFT.Y", sh, sizeof sh}, {"MAX.Y", mx, sizeof mx}};
    b = build(ok, 5);
    op_material *m;
    OP_ASSERT_OK(op_material_open(save(&b, b.n), &m, &err), err);
    float expect = 100.0f * expm1f(0.01f);
    assert_float_equal(op_material_eval(m, 0, 1, 0, 0, 0), expect, 1e-6);
    op_material_close(m);
    free(b.p);

    sh[3] = 9; /* shift out of range */
    expect_format_error(ok, 5, &err);
    sh[3] = 3;
    u[2] = 1e30f; /* exp would overflow */
    expect_format_error(ok, 5, &err);
    u[2] = INFINITY;
    expect_format_error(ok, 5, &err);
    u[2] = 0.01f;
    mx[1] = -1; /* negative maximum */
    expect_format_error(ok, 5, &err);
    mx[1] = 1;
    ok[2].bytes -= 4; /* V one value short */
    expect_format_error(ok, 5, &err);
    ok[2].bytes += 4;
    static const char svd_bad_a[] = "method=svd\nwidth=3\nheight=2\nkernel=3\nchannels=1\n"
                                    "size_x_cm=1\nsize_y_cm=1\nterms=1\nshifted=1\nlog_a=0\n"
                                    "log_b=1\n";
    ok[0].data = svd_bad_a;
    ok[0].bytes = strlen(svd_bad_a);
    expect_format_error(ok, 5, &err);
    ok[0].data = svd_meta;
    ok[0].bytes = strlen(svd_meta);
    expect_format_error(ok, 4, &err); /* MAX.Y missing */
    assert_non_null(strstr(err.message, "MAX.Y"));

    /* Tucker: coefficients that would overflow, and a good one. */
    static const char tk_meta[] = "method=tucker\nwidth=3\nheight=2\nkernel=3\nchannels=1\n"
                                  "size_x_cm=1\nsize_y_cm=1\nterms=1\ndegree=2\nshifted=0\n";
    float range[12] = {0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1};
    float beta[18] = {0};
    for (int r = 0; r < 6; r++)
        beta[r * 3 + 1] = 1.0f; /* T_1(t) = t */
    sec tk[5] = {{"META", tk_meta, strlen(tk_meta)}, {"U", u, sizeof u}, {"V", v, sizeof v},
                 {"RANGE", range, sizeof range}, {"BETA", beta, sizeof beta}};
    b = build(tk, 5);
    OP_ASSERT_OK(op_material_open(save(&b, b.n), &m, &err), err);
    assert_float_equal(op_material_eval(m, 0, 0, 0, 1, 1), 0.01f, 1e-7);
    op_material_close(m);
    free(b.p);
    range[3] = 1e30f;
    expect_format_error(tk, 5, &err);
}

/* kcta and nmf: a good file of each, then every invariant broken in turn. */
static void hostile_kcta_nmf(void **state)
{
    static const char km_meta[] = "method=kcta\nwidth=3\nheight=2\nkernel=3\nchannels=1\n"
                                  "size_x_cm=1\nsize_y_cm=1\nterms=1\nclusters=2\nshifted=0\n";
    uint32_t par[2] = {2, 2};
    float basis[2 * 9], coef[6 * 2];
    uint16_t idx[6 * 2];
    for (int j = 0; j < 9; j++) {
        basis[j] = j == 4;      /* cluster 0: the centre */
        basis[9 + j] = j == 0;  /* cluster 1: the corner */
    }
    for (int r = 0; r < 6; r++) {
        idx[2 * r] = (uint16_t)(r % 2);
        idx[2 * r + 1] = (uint16_t)(1 - r % 2);
        coef[2 * r] = 0.5f;
        coef[2 * r + 1] = -0.25f; /* negative sums clamp to 0 */
    }
    sec k[4] = {{"META", km_meta, strlen(km_meta)}, {"KCTA", par, sizeof par},
                {"BASIS.Y", basis, sizeof basis}, {"KIDX.Y", idx, sizeof idx}};
    sec k5[5] = {k[0], k[1], k[2], k[3], {"KCOEF.Y", coef, sizeof coef}};
    blob b = build(k5, 5);
    op_material *m;
    op_error err = {0};
    OP_ASSERT_OK(op_material_open(save(&b, b.n), &m, &err), err);
    assert_float_equal(op_material_eval(m, 0, 0, 0, 0, 0), 0.5f, 1e-7);  /* row 0: cluster 0 */
    assert_float_equal(op_material_eval(m, 0, 0, 0, -1, -1), 0.0f, 0);   /* -0.25 clamped */
    assert_float_equal(op_material_eval(m, 0, 1, 0, -1, -1), 0.5f, 1e-7); /* row 1: cluster 1 */
    op_material_close(m);
    free(b.p);
    idx[3] = 2; /* cluster out of range */
    expect_format_error(k5, 5, &err);
    assert_non_null(strstr(err.message, "KIDX.Y"));
    idx[3] = 1;
    idx[2] = 1; /* the same cluster twice in row 1 */
    expect_format_error(k5, 5, &err);
    idx[2] = 0;
    par[0] = 3; /* K_m above C */
    expect_format_error(k5, 5, &err);
    par[0] = 2;
    par[1] = 4; /* index width disagrees with the section size */
    expect_format_error(k5, 5, &err);
    par[1] = 2;
    coef[5] = NAN;
    expect_format_error(k5, 5, &err);
    coef[5] = -0.25f;
    coef[4] = 1e30f;
    basis[4] = 1e30f; /* row 2's cluster 0 term would overflow */
    expect_format_error(k5, 5, &err);
    coef[4] = 0.5f;
    basis[4] = 1.0f;
    expect_format_error(k, 4, &err); /* KCOEF.Y missing */

    static const char nm_meta[] = "method=nmf\nwidth=3\nheight=2\nkernel=3\nchannels=1\n"
                                  "size_x_cm=1\nsize_y_cm=1\nterms=1\n";
    float prof[9], scale[6], w[6], h[9];
    for (int j = 0; j < 9; j++)
        prof[j] = 1.0f / 9, h[j] = 1.0f;
    for (int r = 0; r < 6; r++)
        scale[r] = 0.9f, w[r] = 2.0f;
    sec n5[5] = {{"META", nm_meta, strlen(nm_meta)}, {"PROF.Y", prof, sizeof prof},
                 {"SCALE.Y", scale, sizeof scale}, {"W.Y", w, sizeof w}, {"H.Y", h, sizeof h}};
    b = build(n5, 5);
    OP_ASSERT_OK(op_material_open(save(&b, b.n), &m, &err), err);
    assert_float_equal(op_material_eval(m, 0, 2, 1, 1, 0), 0.2f, 1e-6);
    op_material_close(m);
    free(b.p);
    w[3] = -1.0f; /* negative factor */
    expect_format_error(n5, 5, &err);
    assert_non_null(strstr(err.message, "W.Y"));
    w[3] = 2.0f;
    h[2] = INFINITY;
    expect_format_error(n5, 5, &err);
    h[2] = 3e38f;
    scale[0] = 3e38f; /* would overflow */
    expect_format_error(n5, 5, &err);
    h[2] = 1.0f;
    scale[0] = 0.9f;
    n5[1].bytes -= 4; /* profile one value short */
    expect_format_error(n5, 5, &err);
}

/* The svd reconstruction Rd = A (e^x - 1) + A (1 - B) is computed in single precision: over
 * x from -83 to 83 (what the range check lets through) and for tiny |x|, within 3 ulp of the
 * value in double, and eval_row gives eval's bits. */
static void svd_reconstruction_precision(void **state)
{
    (void)state;
    enum { N = 4000 };
    static const char meta[] = "method=svd\nwidth=4000\nheight=1\nkernel=1\nchannels=1\n"
                               "size_x_cm=1\nsize_y_cm=1\nterms=1\nshifted=0\nlog_a=100\n"
                               "log_b=1\n";
    static float u[N];
    float v[1] = {1.0f};
    for (int i = 0; i < N; i++) { /* magnitudes 1e-8 .. 83, both signs */
        double mag = 1e-8 * pow(83.0 / 1e-8, (double)(i / 2) / (N / 2 - 1));
        u[i] = (float)(i % 2 ? -mag : mag);
    }
    sec s[3] = {{"META", meta, strlen(meta)}, {"U.Y", u, sizeof u}, {"V.Y", v, sizeof v}};
    blob b = build(s, 3);
    op_material *m;
    op_error err = {0};
    OP_ASSERT_OK(op_material_open(save(&b, b.n), &m, &err), err);
    double worst = 0.0;
    for (int i = 0; i < N; i++) {
        float got = op_material_eval(m, 0, i, 0, 0, 0), row;
        op_material_eval_row(m, 0, i, 0, &row);
        assert_memory_equal(&got, &row, sizeof got);
        double want = 100.0 * expm1((double)u[i]);
        if (want <= 0.0) { /* clamped at 0 */
            assert_true(got == 0.0f);
            continue;
        }
        double ulp = ldexp(1.0, ilogb(want) - 23), e = fabs((double)got - want) / ulp;
        worst = e > worst ? e : worst;
    }
    printf("svd reconstruction: worst %.2f ulp of single precision over %d values\n", worst, N / 2);
    assert_true(worst <= 3.0);
    op_material_close(m);
    free(b.p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(writer_round_trip),
        cmocka_unit_test(independent_builder_matches),
        cmocka_unit_test(truncated_at_every_length),
        cmocka_unit_test(flipped_bytes),
        cmocka_unit_test(hostile_section_tables),
        cmocka_unit_test(wrong_meta),
        cmocka_unit_test(hostile_values),
        cmocka_unit_test(hostile_kcta_nmf),
        cmocka_unit_test(svd_reconstruction_precision),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
