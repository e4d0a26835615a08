/* test_dataset_import.c - `opaline-factor import`: NumPy .npy arrays (written here) with their
 * JSON sidecar become raw materials; bad shapes, dtypes, values and sidecars give exit code 2
 * and no output file. */
#include "test_support.h"

#include "commands.h"
#include "opaline_material.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Writes a version 1.0 .npy file: header dict `dict`, then n values of itemsize bytes. */
static void write_npy(const char *path, const char *descr, const char *fortran, const char *shape,
                      const double *v, size_t n, int itemsize, size_t truncate_to)
{
    char dict[256];
    int len = snprintf(dict, sizeof dict, "{'descr': '%s', 'fortran_order': %s, 'shape': %s, }",
                       descr, fortran, shape);
    int total = 10 + len + 1;
    int pad = (64 - total % 64) % 64;
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    unsigned hlen = (unsigned)(len + pad + 1);
    fwrite("\x93NUMPY\x01\x00", 1, 8, f);
    fputc((int)(hlen & 0xff), f);
    fputc((int)(hlen >> 8), f);
    fwrite(dict, 1, (size_t)len, f);
    for (int i = 0; i < pad; i++)
        fputc(' ', f);
    fputc('\n', f);
    for (size_t i = 0; i < n && i < truncate_to; i++) {
        if (itemsize == 4) {
            float x = (float)v[i];
            fwrite(&x, 4, 1, f);
        } else if (itemsize == 8) {
            fwrite(&v[i], 8, 1, f);
        } else {
            int32_t x = (int32_t)v[i];
            fwrite(&x, 4, 1, f);
        }
    }
    fclose(f);
}

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

static int import(const char *npy, const char *sidecar, const char *out)
{
    char *argv[8];
    int n = 0;
    argv[n++] = "import";
    argv[n++] = (char *)npy;
    if (sidecar) {
        argv[n++] = "--sidecar";
        argv[n++] = (char *)sidecar;
    }
    argv[n++] = "-o";
    argv[n++] = (char *)out;
    argv[n] = NULL;
    return op_cmd_import(n, argv);
}

/* op_test_tmp_path's buffers are reused: keep a copy. */
typedef struct path {
    char s[1024];
} path;

static path tmp(const char *suffix)
{
    path p;
    snprintf(p.s, sizeof p.s, "%s", op_test_tmp_path(suffix));
    return p;
}

enum { H = 4, W = 5, K = 3, N = 3 * H * W * K * K };

/* value [c, y, x, ky, kx] of the test array: small, positive, rows sum below 1 */
static double value_at(int c, int y, int x, int ky, int kx)
{
    return 0.01 * (c + 1) + 0.001 * y + 0.0001 * x + 0.003 * ky + 0.0005 * kx;
}

static void fill(double *v)
{
    size_t i = 0;
    for (int c = 0; c < 3; c++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++)
                for (int ky = 0; ky < K; ky++)
                    for (int kx = 0; kx < K; kx++)
                        v[i++] = value_at(c, y, x, ky, kx);
}

static void imports_float32_and_float64(void **state)
{
    double v[N];
    fill(v);
    for (int pass = 0; pass < 2; pass++) {
        path np = tmp(pass ? "m64.npy" : "m32.npy");
        const char *npy = np.s;
        char json[1024], out[1024];
        snprintf(json, sizeof json, "%.*s.json", (int)strlen(npy) - 4, npy); /* default sidecar */
        snprintf(out, sizeof out, "%s.opm", npy);
        write_npy(npy, pass ? "<f8" : "<f4", "False", "(3, 4, 5, 3, 3)", v, N, pass ? 8 : 4, N);
        write_text(json, "{\n  \"size_cm\": [2.5, 2.0],\n  \"name\": \"Measured\\tMarble\",\n"
                         "  \"source\": \"lab rig 3\", \"extra\": {\"a\": [1, 2, null]}\n}\n");
        assert_int_equal(import(npy, NULL, out), 0);
        op_material *m;
        op_error err = {0};
        op_status st = op_material_open(out, &m, &err);
        OP_ASSERT_OK(st, err);
        const op_material_info *i = op_material_get_info(m);
        assert_int_equal(i->method, OP_METHOD_RAW);
        assert_int_equal(i->width, W);
        assert_int_equal(i->height, H);
        assert_int_equal(i->kernel, K);
        assert_int_equal(i->channels, 3);
        assert_true(fabs(i->size_x_cm - 2.5) < 1e-12 && fabs(i->size_y_cm - 2.0) < 1e-12);
        assert_string_equal(i->name, "Measured Marble");
        assert_string_equal(i->generator, "import lab rig 3");
        for (int c = 0; c < 3; c++)
            for (int y = 0; y < H; y++)
                for (int x = 0; x < W; x++)
                    for (int dy = -1; dy <= 1; dy++)
                        for (int dx = -1; dx <= 1; dx++)
                            assert_true(op_material_eval(m, c, x, y, dx, dy) ==
                                        (float)value_at(c, y, x, dy + 1, dx + 1));
        uint64_t bytes;
        uint32_t crc = 0;
        const char *tags[3] = {"RD.R", "RD.G", "RD.B"};
        for (int c = 0; c < 3; c++) {
            const void *sec = op_material_section(m, tags[c], &bytes);
            crc = op_crc32(crc, sec, bytes);
        }
        assert_int_equal(i->dataset_crc, crc);
        op_material_close(m);
    }
}

/* Negative noise is clamped to 0 (with a warning), the rest kept. */
static void clamps_negative_noise(void **state)
{
    double v[N];
    fill(v);
    v[7] = -1e-4;
    path np = tmp("neg.npy"), jp = tmp("neg.json"), op = tmp("neg.opm");
    const char *npy = np.s, *json = jp.s, *out = op.s;
    write_npy(npy, "<f4", "False", "(3, 4, 5, 3, 3)", v, N, 4, N);
    write_text(json, "{\"size_cm\": [1, 1]}");
    assert_int_equal(import(npy, json, out), 0);
    op_material *m;
    op_error err = {0};
    op_status st = op_material_open(out, &m, &err);
    OP_ASSERT_OK(st, err);
    assert_true(op_material_eval(m, 0, 0, 0, -1 + 7 % 3, -1 + 7 / 3) == 0.0f);
    op_material_close(m);
}

static void rejects_bad_input(void **state)
{
    double v[N], hot[N], nan_v[N];
    fill(v);
    fill(hot);
    fill(nan_v);
    for (int i = 0; i < 9; i++)
        hot[2 * H * W * K * K + 9 * 6 + i] = 0.2; /* channel B, pixel 6: row sum 1.8 */
    nan_v[100] = NAN;
    path good = tmp("good.json");
    const char *good_json = good.s;
    write_text(good_json, "{\"size_cm\": [1.5, 1.5]}");
    struct {
        const char *descr, *fortran, *shape;
        const double *v;
        size_t n;
        int itemsize;
        size_t truncate;
        const char *json; /* NULL: good_json */
    } cases[] = {
        {"<f4", "False", "(3, 4, 5, 3)", v, N, 4, N, NULL},           /* 4-D */
        {"<f4", "False", "(2, 4, 5, 3, 3)", v, N, 4, N, NULL},        /* 2 channels */
        {"<f4", "False", "(3, 4, 5, 3, 5)", v, N, 4, N, NULL},        /* K x K' */
        {"<f4", "False", "(3, 4, 5, 2, 2)", v, 3 * 4 * 5 * 4, 4, N, NULL}, /* K even */
        {"<f4", "False", "(3, 0, 5, 3, 3)", v, 0, 4, N, NULL},        /* no pixels */
        {"<i4", "False", "(3, 4, 5, 3, 3)", v, N, 3, N, NULL},        /* int32 */
        {"<f2", "False", "(3, 4, 5, 3, 3)", v, N / 2, 4, N, NULL},    /* float16 */
        {"<f4", "True", "(3, 4, 5, 3, 3)", v, N, 4, N, NULL},         /* Fortran order */
        {"<f4", "False", "(3, 4, 5, 3, 3)", v, N, 4, N - 1, NULL},    /* truncated */
        {"<f4", "False", "(3, 4, 5, 3, 3)", hot, N, 4, N, NULL},      /* albedo > 1 */
        {"<f8", "False", "(3, 4, 5, 3, 3)", nan_v, N, 8, N, NULL},    /* NaN */
        {"<f4", "False", "(3, 4, 5, 3, 3)", v, N, 4, N, "{\"size_cm\": [0, 1]}"},
        {"<f4", "False", "(3, 4, 5, 3, 3)", v, N, 4, N, "{\"size_cm\": [1]}"},
        {"<f4", "False", "(3, 4, 5, 3, 3)", v, N, 4, N, "{\"name\": \"x\"}"},
        {"<f4", "False", "(3, 4, 5, 3, 3)", v, N, 4, N, "{\"size_cm\": [1, 1],}"},
        {"<f4", "False", "(3, 4, 5, 3, 3)", v, N, 4, N, "[1, 2]"},
        {"<f4", "False", "(3, 4, 5, 3, 3)", v, N, 4, N, ""},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        path npy_p = tmp("bad.npy"), out_p = tmp("bad.opm"), json_p = tmp("bad.json");
        const char *npy = npy_p.s, *out = out_p.s, *json = good_json;
        if (cases[i].json) {
            json = json_p.s;
            write_text(json, cases[i].json);
        }
        write_npy(npy, cases[i].descr, cases[i].fortran, cases[i].shape, cases[i].v, cases[i].n,
                  cases[i].itemsize, cases[i].truncate);
        int rc = import(npy, json, out);
        if (rc != 2)
            fail_msg("case %zu: exit code %d, want 2", i, rc);
        assert_int_not_equal(access(out, F_OK), 0);
    }
    /* Not a .npy at all, a missing file, a missing sidecar, missing arguments. */
    path junk_p = tmp("junk.npy"), out_p = tmp("junk.opm"), absent_p = tmp("absent.npy"),
         npy_p = tmp("nosidecar.npy");
    const char *junk = junk_p.s, *out = out_p.s;
    write_text(junk, "hello");
    assert_int_equal(import(junk, good_json, out), 2);
    assert_int_equal(import(absent_p.s, good_json, out), 2);
    const char *npy = npy_p.s;
    write_npy(npy, "<f4", "False", "(3, 4, 5, 3, 3)", v, N, 4, N);
    assert_int_equal(import(npy, NULL, out), 2);
    assert_int_not_equal(access(out, F_OK), 0);
    char *argv[] = {"import", (char *)npy, NULL};
    assert_int_equal(op_cmd_import(2, argv), 2);
    char *help[] = {"import", "--help", NULL};
    assert_int_equal(op_cmd_import(2, help), 0);
}

int main(void)
{
    op_log_set_level(OP_LOG_WARN);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(imports_float32_and_float64),
        cmocka_unit_test(clamps_negative_noise),
        cmocka_unit_test(rejects_bad_input),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
