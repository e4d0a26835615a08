/* factor_test_util.h - what the factorizer's tests share: small raw datasets written with
 * op_material_writer, running `opaline-factor factor` in-process with its stderr captured, and
 * comparing a material with its dataset. Header-only (static functions), included by the
 * test_factor_*.c programs. */
#ifndef OP_FACTOR_TEST_UTIL_H
#define OP_FACTOR_TEST_UTIL_H

#include "test_support.h"

#include "commands.h"
#include "opaline_image.h"
#include "opaline_material.h"
#include "opaline_material_write.h"

#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* A dataset: channels x rows x cols values, row = y * w + x, col = (dy + K/2) * K + dx + K/2. */
typedef struct ds_spec {
    int w, h, k, channels;
    float *v; /* owned */
} ds_spec;

static inline ds_spec ds_new(int w, int h, int k, int channels)
{
    ds_spec d = {w, h, k, channels, NULL};
    d.v = calloc((size_t)channels * (size_t)w * h * k * k, sizeof *d.v);
    assert_non_null(d.v);
    return d;
}

static inline float *ds_at(ds_spec *d, int c, int64_t row, int col)
{
    return d->v + ((size_t)c * d->w * d->h + (size_t)row) * (size_t)(d->k * d->k) + col;
}

/* A deterministic uniform deviate in [0, 1). */
static inline double ds_uniform(uint64_t *s)
{
    return (double)(op_splitmix64(s) >> 11) * 0x1.0p-53;
}

/* A smooth kernel-like profile: a Gaussian of width s around the kernel centre. */
static inline float ds_profile(const ds_spec *d, int col, double s)
{
    int h = d->k / 2, dy = col / d->k - h, dx = col % d->k - h;
    return (float)exp(-(dx * dx + dy * dy) / (2.0 * s * s));
}

/* A realistic small dataset: per-pixel Gaussian kernels whose width and brightness vary over a
 * 2 x 2 checkerboard, different per channel; wobble > 0 also varies the width smoothly within
 * the cells (by the factor 1 + wobble * sin(0.7 x + 0.3 y)). */
static inline ds_spec ds_chess(int w, int h, int k, double wobble)
{
    ds_spec d = ds_new(w, h, k, 3);
    for (int c = 0; c < 3; c++)
        for (int64_t r = 0; r < (int64_t)w * h; r++) {
            int x = (int)(r % w), y = (int)(r / w), cell = (2 * x / w + 2 * y / h) % 2;
            double s = cell ? 1.0 + 0.3 * c : 2.0 - 0.2 * c, amp = cell ? 0.05 : 0.02 * (c + 1);
            if (wobble > 0)
                s *= 1.0 + wobble * sin(0.7 * x + 0.3 * y);
            for (int j = 0; j < k * k; j++)
                *ds_at(&d, c, r, j) = (float)(amp * ds_profile(&d, j, s));
        }
    return d;
}

/* Writes the dataset as a raw material; returns its path (a fresh copy to free). */
static inline char *ds_write(const ds_spec *d)
{
    op_material_info info = {0};
    info.method = OP_METHOD_RAW;
    info.width = d->w;
    info.height = d->h;
    info.kernel = d->k;
    info.channels = d->channels;
    info.size_x_cm = info.size_y_cm = 1.0;
    snprintf(info.name, sizeof info.name, "test");
    char *path = strdup(op_test_tmp_path("ds.opm"));
    op_error err = {0};
    op_material_writer *w;
    OP_ASSERT_OK(op_material_writer_open(path, &info, &w, &err), err);
    size_t n = (size_t)d->w * d->h * d->k * d->k;
    for (int c = 0; c < d->channels; c++) {
        char tag[8];
        snprintf(tag, sizeof tag, "RD.%c", d->channels == 1 ? 'Y' : "RGB"[c]);
        OP_ASSERT_OK(op_material_writer_add(w, tag, d->v + c * n, n * sizeof(float), &err), err);
    }
    OP_ASSERT_OK(op_material_writer_commit(w, &err), err);
    return path;
}

/* Runs `opaline-factor factor IN -o OUT ARGS...` (args NULL-terminated); returns its exit code,
 * with what it wrote to stderr in errtext. */
static inline int run_factor(const char *in, const char *out, char *errtext, size_t errcap,
                             const char *const *args)
{
    char *argv[64];
    int argc = 0;
    argv[argc++] = (char *)"factor";
    argv[argc++] = (char *)in;
    argv[argc++] = (char *)"-o";
    argv[argc++] = (char *)out;
    for (int i = 0; args && args[i]; i++)
        argv[argc++] = (char *)args[i];
    argv[argc] = NULL;
    const char *cap = op_test_tmp_path("stderr.txt");
    fflush(stderr);
    int saved = dup(2);
    int fd = open(cap, O_WRONLY | O_CREAT | O_TRUNC, 0600);
    assert_true(saved >= 0 && fd >= 0);
    dup2(fd, 2);
    close(fd);
    int rc = op_cmd_factor(argc, argv);
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    FILE *f = fopen(cap, "r");
    size_t n = f ? fread(errtext, 1, errcap - 1, f) : 0;
    errtext[n] = '\0';
    if (f)
        fclose(f);
    remove(cap);
    if (n)
        fprintf(stderr, "%s", errtext);
    return rc;
}

/* Opens a material (which validates it), checks every value is finite and >= 0, and returns
 * ||dataset - material||_F / ||dataset||_F over all channels (non-finite dataset values count
 * as 0); *max_abs gets the largest absolute error when not NULL. */
static inline double ds_compare(const ds_spec *d, const char *path, double *max_abs)
{
    op_material *m;
    op_error err = {0};
    OP_ASSERT_OK(op_material_open(path, &m, &err), err);
    int cols = d->k * d->k;
    float *row = malloc((size_t)cols * sizeof *row);
    double se = 0, sr = 0, mx = 0;
    for (int c = 0; c < d->channels; c++)
        for (int64_t r = 0; r < (int64_t)d->w * d->h; r++) {
            op_material_eval_row(m, c, (int)(r % d->w), (int)(r / d->w), row);
            for (int j = 0; j < cols; j++) {
                assert_true(isfinite(row[j]) && row[j] >= 0.0f);
                double ref = *ds_at((ds_spec *)d, c, r, j);
                ref = isfinite(ref) ? ref : 0.0;
                se += (ref - row[j]) * (ref - row[j]);
                sr += ref * ref;
                mx = fmax(mx, fabs(ref - row[j]));
            }
        }
    free(row);
    op_material_close(m);
    if (max_abs)
        *max_abs = mx;
    return sr > 0 ? sqrt(se / sr) : sqrt(se);
}

/* Checks op_material_eval against eval_row, and the albedo map against row sums. */
static inline void check_eval_paths(const char *path)
{
    op_material *m;
    op_error err = {0};
    OP_ASSERT_OK(op_material_open(path, &m, &err), err);
    const op_material_info *in = op_material_get_info(m);
    int k = in->kernel, h = k / 2, cols = k * k;
    int64_t rows = (int64_t)in->width * in->height;
    float *row = malloc((size_t)cols * sizeof *row);
    float *albedo = malloc((size_t)rows * in->channels * sizeof *albedo);
    OP_ASSERT_OK(op_material_albedo_map(m, albedo, &err), err);
    for (int c = 0; c < in->channels; c++)
        for (int64_t r = 0; r < rows; r++) {
            int x = (int)(r % in->width), y = (int)(r / in->width);
            op_material_eval_row(m, c, x, y, row);
            double sum = 0;
            for (int j = 0; j < cols; j++) {
                float e = op_material_eval(m, c, x, y, j % k - h, j / k - h);
                if (e != row[j])
                    fail_msg("channel %d row %lld column %d: eval %g, eval_row %g", c,
                             (long long)r, j, (double)e, (double)row[j]);
                sum += row[j];
            }
            assert_float_equal(albedo[c * rows + r], sum, 1e-5 * fmax(1.0, fabs(sum)));
        }
    free(row);
    free(albedo);
    op_material_close(m);
}

/* Opens a material that must be valid (close with op_material_close). */
static inline op_material *open_valid(const char *path)
{
    op_material *m;
    op_error err = {0};
    OP_ASSERT_OK(op_material_open(path, &m, &err), err);
    return m;
}

/* Checks that path is a readable image of w x h pixels. */
static inline void check_image_size(const char *path, int w, int h)
{
    op_image img = {0};
    op_error err = {0};
    OP_ASSERT_OK(op_image_read(path, &img, &err), err);
    assert_int_equal(img.width, w);
    assert_int_equal(img.height, h);
    op_image_free(&img);
}

/* The bytes of a file, NUL-terminated (a fresh buffer to free); its length in *n if not NULL. */
static inline char *slurp_bytes(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    assert_int_equal(fseek(f, 0, SEEK_END), 0);
    long len = ftell(f);
    assert_true(len >= 0);
    rewind(f);
    char *buf = malloc((size_t)len + 1);
    assert_non_null(buf);
    assert_int_equal(fread(buf, 1, (size_t)len, f), (size_t)len);
    buf[len] = '\0';
    fclose(f);
    if (n)
        *n = (size_t)len;
    return buf;
}

/* The contents of a text file (a fresh string to free). */
static inline char *slurp(const char *path)
{
    return slurp_bytes(path, NULL);
}

/* Checks that the small text file at path contains text. */
static inline void check_file_contains(const char *path, const char *text)
{
    char *buf = slurp(path);
    if (!strstr(buf, text))
        fail_msg("%s does not contain '%s'", path, text);
    free(buf);
}

/* in holds d with a NaN at channel 1 (G), row 5, column 7 and an infinity elsewhere: the
 * factor command with args refuses it naming the NaN and writes nothing; with san (the same
 * and --sanitize, report at report) it replaces both by 0 and reports them. */
static inline void check_nonfinite_handled(const ds_spec *d, const char *in, const char *out,
                                           const char *report, const char *const *args,
                                           const char *const *san)
{
    char errtext[8192];
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, args), 2);
    assert_non_null(strstr(errtext, "RD.G"));
    assert_non_null(strstr(errtext, "row 5, column 7"));
    assert_non_null(strstr(errtext, "NaN"));
    assert_int_equal(access(out, F_OK), -1); /* nothing written */
    assert_int_equal(run_factor(in, out, errtext, sizeof errtext, san), 0);
    assert_non_null(strstr(errtext, "replaced 2 non-finite"));
    check_file_contains(report, "\"nonfinite_replaced\": 2,");
    assert_true(ds_compare(d, out, NULL) < 0.05);
}

#endif
