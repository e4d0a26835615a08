/* material_sections.c - how the method modules read and check a material's sections (see
 * material_internal.h). It uses the container's section lookup and nothing else of
 * material_file.c, which in turn reaches the methods only through their op_method_ops. */
#include "material_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The per-row shift and maximum of a shifted material (paper section 4.1): "SHIFT" and "MAX",
 * or per channel "SHIFT.c" and "MAX.c". */
#define SHIFT_TAG "SHIFT"
#define MAX_TAG "MAX"

op_status op_material_sized_section(const op_material *m, const char *tag, uint64_t bytes,
                                    const void **out, op_error *err)
{
    uint64_t have = 0;
    const void *p = op_material_section(m, tag, &have);
    if (!p)
        return op_error_set(err, OP_ERR_FORMAT, "%s: section '%s' is missing", m->path, tag);
    if (have != bytes)
        return op_error_set(err, OP_ERR_FORMAT,
                            "%s: section '%s' holds %llu bytes, expected %llu", m->path, tag,
                            (unsigned long long)have, (unsigned long long)bytes);
    *out = p;
    return OP_OK;
}

op_status op_material_float_section(const op_material *m, const char *tag, uint64_t count,
                                    int nonneg, const float **out, op_error *err)
{
    const void *p = NULL;
    op_status st = op_material_sized_section(m, tag, count * sizeof(float), &p, err);
    if (st != OP_OK)
        return st;
    const float *v = p;
    for (uint64_t i = 0; i < count; i++) {
        if (!isfinite(v[i]) || (nonneg && v[i] < 0.0f))
            return op_error_set(err, OP_ERR_FORMAT, "%s: section '%s' value %llu is %g", m->path,
                                tag, (unsigned long long)i, (double)v[i]);
    }
    *out = v;
    return OP_OK;
}

op_status op_material_check_albedo(const op_material *m, const char *tag, const float *v,
                                   uint64_t count, op_error *err)
{
    uint64_t rows = (uint64_t)op_material_rows(m), w = (uint64_t)m->info.width;
    uint64_t first_high = count;
    for (uint64_t i = 0; i < count; i++) {
        if (v[i] <= OP_MATERIAL_MAX_ALBEDO)
            continue;
        if (first_high == count)
            first_high = i;
        if (v[i] > OP_MATERIAL_ABSURD_ALBEDO) {
            first_high = i;
            break;
        }
    }
    if (first_high == count)
        return OP_OK;
    uint64_t i = first_high, r = i % rows;
    char channel[32] = "", where[192];
    if (count > rows) /* channels x rows */
        snprintf(channel, sizeof channel, "channel %llu, ", (unsigned long long)(i / rows));
    snprintf(where, sizeof where, "section '%s' value %llu (%srow %llu: incident pixel x %llu, "
             "y %llu) is %g", tag, (unsigned long long)i, channel, (unsigned long long)r,
             (unsigned long long)(r % w), (unsigned long long)(r / w), (double)v[i]);
    if (v[i] > OP_MATERIAL_ABSURD_ALBEDO)
        return op_error_set(err, OP_ERR_FORMAT, "%s: %s, but an albedo cannot exceed 1 (a "
                            "factored material is refused above %g): physically impossible "
                            "data", m->path, where, OP_MATERIAL_ABSURD_ALBEDO);
    op_log(OP_LOG_WARN, "%s: %s, but an albedo cannot exceed 1: the material will render too "
           "bright there (a poor approximation, or data that was not physical)", m->path, where);
    return OP_OK;
}

op_status op_material_channel_floats(const op_material *m, const char *prefix, int c,
                                     uint64_t count, int nonneg, const float **out,
                                     op_error *err)
{
    char tag[16];
    op_channel_tag(tag, sizeof tag, prefix, &m->info, c);
    return op_material_float_section(m, tag, count, nonneg, out, err);
}

op_status op_material_shift_sections(const op_material *m, int c, const uint32_t **shift,
                                     const float **max, op_error *err)
{
    char tag[16];
    int64_t rows = op_material_rows(m);
    int cols = op_material_cols(m);
    const void *p = NULL;
    if (c < 0)
        snprintf(tag, sizeof tag, SHIFT_TAG);
    else
        op_channel_tag(tag, sizeof tag, SHIFT_TAG ".", &m->info, c);
    op_status st = op_material_sized_section(m, tag, (uint64_t)rows * sizeof(uint32_t), &p, err);
    if (st != OP_OK)
        return st;
    const uint32_t *sh = p;
    for (int64_t r = 0; r < rows; r++)
        if (sh[r] >= (uint32_t)cols)
            return op_error_set(err, OP_ERR_FORMAT, "%s: section '%s' row %lld shifts by %u >= %d",
                                m->path, tag, (long long)r, sh[r], cols);
    *shift = sh;
    if (c < 0)
        snprintf(tag, sizeof tag, MAX_TAG);
    else
        op_channel_tag(tag, sizeof tag, MAX_TAG ".", &m->info, c);
    const float *mx = NULL;
    st = op_material_float_section(m, tag, (uint64_t)rows, 1, &mx, err);
    if (st == OP_OK && (st = op_material_check_albedo(m, tag, mx, (uint64_t)rows, err)) == OP_OK)
        *max = mx;
    return st;
}

op_status op_material_write_channel(op_material_writer *w, const op_material_info *info,
                                    const char *prefix, int c, const void *data, uint64_t bytes,
                                    op_error *err)
{
    char tag[16];
    op_channel_tag(tag, sizeof tag, prefix, info, c);
    return op_material_writer_add(w, tag, data, bytes, err);
}

op_status op_material_write_shift(op_material_writer *w, const op_material_info *info, int c,
                                  const uint32_t *shift, const float *max, op_error *err)
{
    if (!info->shifted)
        return OP_OK;
    if (!shift || !max)
        return op_error_set(err, OP_ERR_INTERNAL, "a shifted material without its row shifts");
    uint64_t rows = (uint64_t)info->width * (uint64_t)info->height;
    if (c < 0) {
        op_status st = op_material_writer_add(w, SHIFT_TAG, shift, rows * sizeof *shift, err);
        return st != OP_OK ? st : op_material_writer_add(w, MAX_TAG, max, rows * sizeof *max, err);
    }
    op_status st = op_material_write_channel(w, info, SHIFT_TAG ".", c, shift,
                                             rows * sizeof *shift, err);
    return st != OP_OK ? st
                       : op_material_write_channel(w, info, MAX_TAG ".", c, max,
                                                   rows * sizeof *max, err);
}

float *op_transpose(const float *v, int n, int T)
{
    float *vt = malloc((size_t)n * (size_t)T * sizeof *vt + 1);
    if (vt)
        for (int j = 0; j < n; j++)
            for (int t = 0; t < T; t++)
                vt[(size_t)t * n + j] = v[(size_t)j * T + t];
    return vt;
}

void op_column_abs_max(const float *v, int n, int T, double *out)
{
    for (int t = 0; t < T; t++)
        out[t] = 0;
    for (int j = 0; j < n; j++)
        for (int t = 0; t < T; t++)
            out[t] = fmax(out[t], fabs(v[(size_t)j * T + t]));
}

op_status op_method_keep_state(op_material *m, void *state, op_status st)
{
    if (st == OP_OK)
        m->state = state;
    else
        free(state);
    return st;
}

void op_method_free_state(op_material *m)
{
    free(m->state);
    m->state = NULL;
}

