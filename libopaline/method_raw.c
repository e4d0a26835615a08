/* method_raw.c - the unfactored dataset: one float32 K*K kernel per incident pixel and
 * channel, sections "RD.R", "RD.G", "RD.B" (or "RD.Y"). The renderer's reference.
 *
 * Every value must be finite and >= 0, and every row (the light leaving through the whole
 * kernel for one incident pixel: that pixel's albedo) must sum to at most
 * OP_MATERIAL_MAX_ALBEDO; docs/formats.md explains the tolerance. */
#include "material_internal.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct raw_state {
    const float *rd[3];
} raw_state;

/* Checks channel c's section in one pass: sizes, finite and non-negative values, row sums. */
static op_status check_channel(const op_material *m, int c, const float **out, op_error *err)
{
    char tag[16];
    op_channel_tag(tag, sizeof tag, OP_RAW_SECTION, &m->info, c);
    int64_t rows = op_material_rows(m);
    int cols = op_material_cols(m), w = m->info.width, k = m->info.kernel;
    const void *p = NULL;
    op_status st = op_material_sized_section(m, tag, (uint64_t)rows * (uint64_t)cols *
                                             sizeof(float), &p, err);
    if (st != OP_OK)
        return st;
    const float *rd = p;
    for (int64_t r = 0; r < rows; r++) {
        const float *row = rd + r * cols;
        /* Eight partial sums and a flag: a tight loop, since this reads the whole file. */
        double part[8] = {0};
        int ok = 1, j = 0;
        for (; j + 8 <= cols; j += 8)
            for (int q = 0; q < 8; q++) {
                float v = row[j + q];
                part[q] += v;
                ok &= (v >= 0.0f) & (v <= FLT_MAX);
            }
        for (; j < cols; j++) {
            part[0] += row[j];
            ok &= (row[j] >= 0.0f) & (row[j] <= FLT_MAX);
        }
        double sum = ((part[0] + part[1]) + (part[2] + part[3])) +
                     ((part[4] + part[5]) + (part[6] + part[7]));
        if (ok && sum <= OP_MATERIAL_MAX_ALBEDO)
            continue;
        int bad = 0, top = 0;
        while (row[bad] >= 0.0f && row[bad] <= FLT_MAX && bad + 1 < cols)
            bad++;
        for (j = 1; j < cols; j++)
            if (row[j] > row[top])
                top = j;
        if (!ok)
            return op_error_set(err, OP_ERR_FORMAT, "%s: section '%s' value %lld (row %lld: "
                                "incident pixel x %lld, y %lld; column %d: offset dx %d, dy %d) "
                                "is %g: Rd must be finite and >= 0", m->path, tag,
                                (long long)(r * cols + bad), (long long)r, (long long)(r % w),
                                (long long)(r / w), bad, bad % k - k / 2, bad / k - k / 2,
                                (double)row[bad]);
        return op_error_set(err, OP_ERR_FORMAT, "%s: section '%s' row %lld (incident pixel x "
                            "%lld, y %lld) sums to %g (largest value %g in column %d), but the "
                            "albedo of a pixel cannot exceed 1 (at most %g is accepted as "
                            "measurement noise): physically impossible data", m->path, tag,
                            (long long)r, (long long)(r % w), (long long)(r / w), sum,
                            (double)row[top], top, OP_MATERIAL_MAX_ALBEDO);
    }
    *out = rd;
    return OP_OK;
}

static op_status raw_prepare(op_material *m, op_error *err)
{
    raw_state *s = calloc(1, sizeof *s);
    if (!s)
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", m->path);
    op_status st = OP_OK;
    for (int c = 0; c < m->info.channels && st == OP_OK; c++)
        st = check_channel(m, c, &s->rd[c], err);
    return op_method_keep_state(m, s, st);
}

static float raw_eval(const op_material *m, int channel, int64_t row, int col)
{
    const raw_state *s = m->state;
    return s->rd[channel][row * op_material_cols(m) + col];
}

static void raw_eval_row(const op_material *m, int channel, int64_t row, float *out)
{
    const raw_state *s = m->state;
    int cols = op_material_cols(m);
    memcpy(out, s->rd[channel] + row * cols, (size_t)cols * sizeof *out);
}

op_status op_write_raw_channel(op_material_writer *w, const op_material_info *info, int c,
                               const float *rd, op_error *err)
{
    uint64_t count = (uint64_t)info->width * (uint64_t)info->height * (uint64_t)info->kernel *
                     (uint64_t)info->kernel;
    return op_material_write_channel(w, info, OP_RAW_SECTION, c, rd, count * sizeof *rd, err);
}

const op_method_ops op_method_raw_ops = {
    .prepare = raw_prepare,
    .eval = raw_eval,
    .eval_row = raw_eval_row,
    .destroy = op_method_free_state,
};
