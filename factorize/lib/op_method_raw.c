/* op_method_raw.c - the unfactored dataset: one float32 K*K kernel per incident pixel and
 * channel, sections "RD.R", "RD.G", "RD.B" (or "RD.Y"). The renderer's reference. */
#include "op_material_internal.h"

#include <stdlib.h>
#include <string.h>

typedef struct raw_state {
    const float *rd[3];
} raw_state;

static op_status raw_prepare(op_material *m, op_error *err)
{
    raw_state *s = calloc(1, sizeof *s);
    if (!s)
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", m->path);
    uint64_t count = (uint64_t)op_material_rows(m) * (uint64_t)op_material_cols(m);
    op_status st = OP_OK;
    for (int c = 0; c < m->info.channels && st == OP_OK; c++)
        st = op_material_channel_floats(m, "RD.", c, count, 1, &s->rd[c], err);
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

const op_method_ops op_method_raw_ops = {
    .prepare = raw_prepare,
    .eval = raw_eval,
    .eval_row = raw_eval_row,
    .destroy = op_method_free_state,
};
