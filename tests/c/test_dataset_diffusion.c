/* test_dataset_diffusion.c - generator 2 (segment-averaged dipole): its dipole against the
 * closed form, exact reciprocity, energy, visible heterogeneity, the file it writes and the
 * dataset command's handling of bad input. */
#include "test_support.h"

#include "commands.h"
#include "dataset_generate.h"
#include "dataset_diffusion.h"
#include "opaline.h"
#include "opaline_material.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static op_dataset_spec small_spec(const char *name, int w, int h, int k, double sx, double sy)
{
    op_dataset_spec s;
    op_error err = {0};
    op_status st = op_dataset_spec_defaults(name, &s, &err);
    OP_ASSERT_OK(st, err);
    s.width = w;
    s.height = h;
    s.kernel = k;
    s.size_x_cm = sx;
    s.size_y_cm = sy;
    s.threads = 2;
    return s;
}

static void generate(const op_dataset_spec *s, op_dataset *d)
{
    op_error err = {0};
    op_status st = op_dataset_generate(s, d, NULL, &err);
    OP_ASSERT_OK(st, err);
}

/* The pixel-integrated dipole summed over a kernel that holds the whole response equals the
 * closed-form total diffuse reflectance. */
static void dipole_sums_to_closed_form(void **state)
{
    const op_medium *m = op_medium_lookup("skin1");
    assert_non_null(m);
    for (int c = 0; c < 3; c++) {
        op_dipole d;
        op_dipole_init(&d, m->sigma_s[c], m->sigma_a[c], m->eta);
        double sum = 0;
        for (int y = -60; y <= 60; y++)
            for (int x = -60; x <= 60; x++)
                sum += op_dipole_pixel(&d, x * 0.5, y * 0.5, 0.5, 0.5, abs(x) + abs(y) < 6 ? 10 : 3);
        double total = op_dipole_total(m->sigma_s[c], m->sigma_a[c], m->eta);
        assert_true(fabs(sum - total) < 0.01 * total);
    }
}

/* A homogeneous dataset's rows equal the pixel-integrated dipole of its medium. */
static void homogeneous_is_the_dipole(void **state)
{
    op_dataset_spec s = small_spec("homogeneous", 5, 4, 7, 0.5, 0.4);
    s.media[0] = s.media[1] = op_medium_lookup("KETCHUP");
    op_dataset d;
    generate(&s, &d);
    for (int c = 0; c < 3; c++) {
        op_dipole dp;
        op_dipole_init(&dp, s.media[0]->sigma_s[c], s.media[0]->sigma_a[c], s.media[0]->eta);
        for (int dy = -3; dy <= 3; dy++)
            for (int dx = -3; dx <= 3; dx++) {
                double want = op_dipole_pixel(&dp, abs(dx) * 1.0, abs(dy) * 1.0, 1.0, 1.0,
                                              (abs(dx) > abs(dy) ? abs(dx) : abs(dy)) < 3 ? 10 : 4);
                float got = d.rd[c][(2 * 5 + 3) * 49 + (dy + 3) * 7 + (dx + 3)];
                assert_true(fabs(got - want) <= 1e-6 * want + 1e-12);
            }
    }
    op_dataset_free(&d);
}

/* Rd(x_i, x_o) == Rd(x_o, x_i) bit for bit, x_o taken in the periodic tiling. */
static void check_reciprocal_exact(const op_dataset *d)
{
    int W = d->width, H = d->height, K = d->kernel, h = K / 2;
    for (int c = 0; c < 3; c++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++)
                for (int dy = -h; dy <= h; dy++)
                    for (int dx = -h; dx <= h; dx++) {
                        int xo = ((x + dx) % W + W) % W, yo = ((y + dy) % H + H) % H;
                        float a = d->rd[c][((size_t)y * W + x) * K * K + (dy + h) * K + dx + h];
                        float b = d->rd[c][((size_t)yo * W + xo) * K * K + (h - dy) * K + h - dx];
                        if (memcmp(&a, &b, sizeof a) != 0)
                            fail_msg("channel %d (%d,%d)+(%d,%d): %.9g != %.9g", c, x, y, dx, dy,
                                     (double)a, (double)b);
                    }
}

static void check_energy(const op_dataset *d)
{
    int cols = d->kernel * d->kernel;
    for (int c = 0; c < 3; c++)
        for (uint64_t r = 0; r < op_dataset_rows(d); r++) {
            double sum = 0;
            for (int j = 0; j < cols; j++) {
                float v = d->rd[c][r * (uint64_t)cols + (uint64_t)j];
                assert_true(isfinite(v) && v >= 0);
                sum += v;
            }
            assert_true(sum >= 0 && sum <= 1);
        }
}

static void reciprocity_and_energy(void **state)
{
    const char *names[] = {"chess4x4", "chess8x8", "veined-marble", "marble-closeup"};
    for (int i = 0; i < 4; i++) {
        op_dataset_spec s = small_spec(names[i], 13, 11, 9, 1.3, 1.1);
        op_dataset d;
        generate(&s, &d);
        check_reciprocal_exact(&d);
        check_energy(&d);
        op_dataset_free(&d);
    }
}

/* Same result for any thread count. */
static void threads_do_not_matter(void **state)
{
    op_dataset_spec s = small_spec("veined-marble", 21, 17, 11, 2.0, 1.6);
    op_dataset a, b;
    s.threads = 1;
    generate(&s, &a);
    s.threads = 3;
    generate(&s, &b);
    size_t n = (size_t)21 * 17 * 121 * sizeof(float);
    for (int c = 0; c < 3; c++)
        assert_memory_equal(a.rd[c], b.rd[c], n);
    assert_int_equal(op_dataset_crc(&a), op_dataset_crc(&b));
    op_dataset_free(&a);
    op_dataset_free(&b);
}

/* A response that crosses a square boundary differs from the same response in either medium
 * alone (at the board's one index, its base medium's). 8 x 8 pixels of 1 mm, 4 x 4 squares of
 * 2 x 2 pixels. */
static void heterogeneity_shows(void **state)
{
    op_dataset_spec s = small_spec("chess4x4", 8, 8, 7, 0.8, 0.8);
    op_dataset chess, ha, hb;
    generate(&s, &chess);
    op_dataset_spec sa = small_spec("homogeneous", 8, 8, 7, 0.8, 0.8);
    sa.eta = s.media[0]->eta;
    sa.media[0] = sa.media[1] = s.media[0];
    generate(&sa, &ha);
    sa.media[0] = sa.media[1] = s.media[1];
    generate(&sa, &hb);
    /* Pixel (0, 0) is in medium 0; offset (+3, 0) ends in pixel (3, 0), medium 1. */
    int col = (0 + 3) * 7 + (3 + 3);
    for (int c = 0; c < 3; c++) {
        double v = chess.rd[c][col], a = ha.rd[c][col], b = hb.rd[c][col];
        assert_true(fabs(v - a) > 0.05 * fmax(v, a));
        assert_true(fabs(v - b) > 0.05 * fmax(v, b));
    }
    /* Rows differ across the board too: the albedo of a medium-0 and a medium-1 pixel. */
    double r0 = 0, r1 = 0;
    for (int j = 0; j < 49; j++) {
        r0 += chess.rd[1][0 * 49 + j];
        r1 += chess.rd[1][2 * 49 + j];
    }
    assert_true(fabs(r0 - r1) > 0.1);
    op_dataset_free(&chess);
    op_dataset_free(&ha);
    op_dataset_free(&hb);
}

/* The file: raw method, the documented layout, crc over the RD sections. */
static void writes_a_raw_material(void **state)
{
    op_dataset_spec s = small_spec("chess8x8", 9, 7, 5, 0.9, 0.7);
    op_dataset d;
    generate(&s, &d);
    const char *path = op_test_tmp_path("diffusion.opm");
    op_error err = {0};
    op_status st = op_dataset_write(&d, path, &err);
    OP_ASSERT_OK(st, err);
    op_material *m;
    st = op_material_open(path, &m, &err);
    OP_ASSERT_OK(st, err);
    const op_material_info *i = op_material_get_info(m);
    assert_int_equal(i->method, OP_METHOD_RAW);
    assert_int_equal(i->width, 9);
    assert_int_equal(i->height, 7);
    assert_int_equal(i->kernel, 5);
    assert_int_equal(i->channels, 3);
    assert_string_equal(i->name, "Chess8x8");
    assert_true(strstr(i->generator, "diffusion") != NULL);
    assert_int_equal(i->dataset_crc, op_dataset_crc(&d));
    assert_true(fabs(i->size_x_cm - 0.9) < 1e-12);
    for (int c = 0; c < 3; c++)
        for (int y = 0; y < 7; y++)
            for (int x = 0; x < 9; x++)
                for (int dy = -2; dy <= 2; dy++)
                    for (int dx = -2; dx <= 2; dx++)
                        assert_true(op_material_eval(m, c, x, y, dx, dy) ==
                                    d.rd[c][(y * 9 + x) * 25 + (dy + 2) * 5 + dx + 2]);
    assert_null(op_material_section(m, "SE.R", NULL));
    op_material_close(m);
    op_dataset_free(&d);
}

/* The whole file's bytes. */
static unsigned char *slurp(const char *path, long *n)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    *n = ftell(f);
    rewind(f);
    unsigned char *b = malloc((size_t)*n);
    assert_non_null(b);
    assert_int_equal(fread(b, 1, (size_t)*n, f), (size_t)*n);
    fclose(f);
    return b;
}

/* op_dataset_generate_file, generating and writing in blocks of rows (here 2 blocks, the
 * second partial), writes the bytes op_dataset_write writes of the whole dataset, for either
 * generator and any thread count; a writer given too few rows refuses to commit and leaves
 * nothing. */
static void file_written_in_blocks_is_the_same(void **state)
{
    for (int mc = 0; mc < 2; mc++) {
        /* rows per block: 64 MiB / (K^2 * 12 bytes, x2 with standard errors) */
        int k = mc ? 21 : 29, side = mc ? 80 : 82;
        op_dataset_spec s = small_spec(mc ? "jade" : "chess4x4", side, side, k, 1.0, 1.0);
        uint64_t per_block = OP_DATASET_BLOCK_BYTES / ((uint64_t)k * k * 12 * (mc ? 2 : 1));
        assert_true(per_block < (uint64_t)side * side && 2 * per_block > (uint64_t)side * side);
        s.generator = mc ? OP_GEN_MONTECARLO : OP_GEN_DIFFUSION;
        s.photons = 1;
        op_dataset d;
        generate(&s, &d);
        const char *whole = op_test_tmp_path("whole.opm");
        op_error err = {0};
        OP_ASSERT_OK(op_dataset_write(&d, whole, &err), err);
        long n0, n1;
        unsigned char *a = slurp(whole, &n0);
        for (int threads = 1; threads <= 3; threads += 2) {
            s.threads = threads;
            const char *blocks = op_test_tmp_path("blocks.opm");
            OP_ASSERT_OK(op_dataset_generate_file(&s, blocks, NULL, &err), err);
            unsigned char *b = slurp(blocks, &n1);
            assert_int_equal(n0, n1);
            assert_memory_equal(a, b, (size_t)n0);
            free(b);
            unlink(blocks);
        }
        free(a);
        unlink(whole);

        op_dataset_writer *w;
        const char *part = op_test_tmp_path("part.opm");
        OP_ASSERT_OK(op_dataset_writer_open(part, &d, mc, &w, &err), err);
        d.nrows = 5;
        OP_ASSERT_OK(op_dataset_writer_add(w, &d, &err), err);
        assert_int_equal(op_dataset_writer_commit(w, &err), OP_ERR_INTERNAL);
        assert_int_not_equal(access(part, F_OK), 0);
        op_dataset_free(&d);
    }
}

static int run_cmd(const char **args, int n)
{
    char *argv[32];
    for (int i = 0; i < n; i++)
        argv[i] = (char *)args[i];
    argv[n] = NULL;
    return op_cmd_dataset(n, argv);
}

/* Bad input: a clear message, exit code 2, nothing written. */
static void bad_input(void **state)
{
    const char *out = op_test_tmp_path("bad.opm");
    const char *cases[][6] = {
        {"dataset", "chess4x4", "--kernel", "8", "--pixels", "4x4"},
        {"dataset", "chess4x4", "--kernel", "0", "--pixels", "4x4"},
        {"dataset", "chess4x4", "--kernel", "-3", "--pixels", "4x4"},
        {"dataset", "chess4x4", "--pixels", "0x4", "--kernel", "3"},
        {"dataset", "chess4x4", "--pixels", "-4x4", "--kernel", "3"},
        {"dataset", "chess4x4", "--size-cm", "0x1", "--kernel", "3"},
        {"dataset", "chess4x4", "--size-cm", "1x-2", "--kernel", "3"},
        {"dataset", "chess4x4", "--media", "marble,plutonium", "--kernel", "3"},
        {"dataset", "homogeneous", "--medium", "unobtainium", "--kernel", "3"},
        {"dataset", "nosuchthing", "--pixels", "4x4", "--kernel", "3"},
        {"dataset", "chess4x4", "--generator", "magic", "--kernel", "3"},
        {"dataset", "chess4x4", "--photons", "0", "--kernel", "3"},
        {"dataset", "chess4x4", "--kernel", "3x", "--pixels", "4x4"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        const char *args[10];
        for (int k = 0; k < 6; k++)
            args[k] = cases[i][k];
        args[6] = "-o";
        args[7] = out;
        assert_int_equal(run_cmd(args, 8), 2);
        assert_int_not_equal(access(out, F_OK), 0);
    }
    const char *no_out[] = {"dataset", "chess4x4", "--kernel", "3"};
    assert_int_equal(run_cmd(no_out, 4), 2);
    const char *help[] = {"dataset", "--help"};
    assert_int_equal(run_cmd(help, 2), 0);
    /* And a good one, case-insensitive names. */
    const char *good[] = {"dataset", "Chess4x4", "--pixels", "6x5", "--kernel", "3",
                          "--media", "SKIN1,marble", "-t", "2", "-o", out};
    assert_int_equal(run_cmd(good, 12), 0);
    op_material *m;
    op_error err = {0};
    op_status st = op_material_open(out, &m, &err);
    OP_ASSERT_OK(st, err);
    assert_int_equal(op_material_get_info(m)->width, 6);
    assert_int_equal(op_material_get_info(m)->height, 5);
    op_material_close(m);
    unlink(out);
}

int main(void)
{
    op_log_set_level(OP_LOG_WARN);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(dipole_sums_to_closed_form),
        cmocka_unit_test(homogeneous_is_the_dipole),
        cmocka_unit_test(reciprocity_and_energy),
        cmocka_unit_test(threads_do_not_matter),
        cmocka_unit_test(heterogeneity_shows),
        cmocka_unit_test(writes_a_raw_material),
        cmocka_unit_test(file_written_in_blocks_is_the_same),
        cmocka_unit_test(bad_input),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
