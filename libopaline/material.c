/* material.c - a material: its container (material_file.c) with its method's evaluation
 * (method_<name>.c, through the op_method_ops of material_internal.h) behind the public
 * op_material API. The only module that knows every method: its table comes from
 * OP_METHOD_LIST. */
#include "material_internal.h"

#include <stdlib.h>
#include <string.h>

/* The row sums of a factored material's reconstruction (channels x rows float32). */
#define ALBEDO_TAG "ALBEDO"

#define METHOD_OPS(id, name) [OP_METHOD_##id] = &op_method_##name##_ops,
static const op_method_ops *const method_table[OP_METHOD_COUNT] = {OP_METHOD_LIST(METHOD_OPS)};
#undef METHOD_OPS

static const op_method_ops *method_ops(op_method m)
{
    return (unsigned)m < OP_METHOD_COUNT ? method_table[m] : NULL;
}

op_status op_material_open(const char *path, op_material **out, op_error *err)
{
    op_material *m;
    op_status st = op_material_open_container(path, &m, err);
    if (st != OP_OK)
        return st;
    if (!(m->ops = method_ops(m->info.method)))
        st = op_error_set(err, OP_ERR_FORMAT, "%s: method '%s' is not supported by this build",
                          path, op_method_name(m->info.method));
    if (st == OP_OK && (st = m->ops->prepare(m, err)) != OP_OK)
        m->ops = NULL; /* prepare cleans up after itself on failure */
    /* Factorizers store the row sums of their reconstruction, so the albedo map is a copy. */
    if (st == OP_OK && op_material_section(m, ALBEDO_TAG, NULL)) {
        uint64_t n = (uint64_t)op_material_rows(m) * (uint64_t)m->info.channels;
        st = op_material_float_section(m, ALBEDO_TAG, n, 1, &m->albedo, err);
        if (st == OP_OK)
            st = op_material_check_albedo(m, ALBEDO_TAG, m->albedo, n, err);
    }
    if (st != OP_OK) {
        op_material_close(m);
        return st;
    }
    *out = m;
    return OP_OK;
}

void op_material_close(op_material *m)
{
    if (!m)
        return;
    if (m->ops && m->ops->destroy)
        m->ops->destroy(m);
    op_material_free_container(m);
}

float op_material_eval(const op_material *m, int channel, int x, int y, int dx, int dy)
{
    int h = m->info.kernel / 2;
    if (dx < -h || dx > h || dy < -h || dy > h)
        return 0.0f;
    int64_t row = (int64_t)y * m->info.width + x;
    return m->ops->eval(m, channel, row, (dy + h) * m->info.kernel + (dx + h));
}

void op_material_eval_row(const op_material *m, int channel, int x, int y, float *out)
{
    m->ops->eval_row(m, channel, (int64_t)y * m->info.width + x, out);
}

op_status op_material_albedo_map(const op_material *m, float *out, op_error *err)
{
    int64_t rows = op_material_rows(m);
    if (m->albedo) {
        memcpy(out, m->albedo, (size_t)rows * (size_t)m->info.channels * sizeof *out);
        return OP_OK;
    }
    int cols = op_material_cols(m);
    float *row = malloc((size_t)cols * sizeof *row);
    if (!row)
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", m->path);
    for (int c = 0; c < m->info.channels; c++) {
        for (int64_t r = 0; r < rows; r++) {
            m->ops->eval_row(m, c, r, row);
            double s = 0;
            for (int j = 0; j < cols; j++)
                s += row[j];
            out[c * rows + r] = (float)s;
        }
    }
    free(row);
    return OP_OK;
}

op_status op_write_albedo(op_material_writer *w, const op_material_info *info,
                          const float *albedo, op_error *err)
{
    uint64_t count = (uint64_t)info->width * (uint64_t)info->height * (uint64_t)info->channels;
    return op_material_writer_add(w, ALBEDO_TAG, albedo, count * sizeof *albedo, err);
}
