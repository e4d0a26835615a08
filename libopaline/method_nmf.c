/* method_nmf.c - the non-negative matrix factorization baseline of Peers et al. 2006: a
 * homogeneous approximation (radial profile times row albedo) times a non-negative
 * factorization of the remainder.
 *
 * With T = info.terms, n = K*K columns, per channel c (tag suffix R, G, B or Y), every value
 * finite and >= 0:
 *   "PROF.c"   n float32: the radial profile p_j (sums to 1)
 *   "SCALE.c"  rows float32: each row's albedo s_i (at most OP_MATERIAL_MAX_ALBEDO)
 *   "W.c"      rows x T float32        "H.c"   n x T float32
 *   "ALBEDO"   optional, channels x rows float32 (row sums of the reconstruction)
 * Rd(row, col) = SCALE[row] * PROF[col] * (W[row] . H[col]); never negative by construction.
 * docs/formats.md is the specification. */
#include "material_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PROF_TAG "PROF."
#define SCALE_TAG "SCALE."
#define W_TAG "W."
#define H_TAG "H."

typedef struct nmf_state {
    int terms, cols;
    int64_t rows;
    const float *prof[3], *scale[3], *w[3], *h[3];
} nmf_state;

/* Rejects factors whose reconstruction could overflow a float. */
static op_status check_range(const op_material *m, const nmf_state *s, int c, op_error *err)
{
    const int T = s->terms;
    double hmax[4096], pmax = 0;
    op_column_abs_max(s->h[c], s->cols, T, hmax); /* H >= 0: its column maxima */
    for (int j = 0; j < s->cols; j++)
        pmax = fmax(pmax, s->prof[c][j]);
    for (int64_t r = 0; r < s->rows; r++) {
        double bound = 0;
        for (int t = 0; t < T; t++)
            bound += (double)s->w[c][(size_t)r * T + t] * hmax[t];
        if (!(bound < 1e36) || !(bound * pmax < 1e36) || !(bound * pmax * s->scale[c][r] < 1e36))
            return op_error_set(err, OP_ERR_FORMAT, "%s: channel %d row %lld: factors too large "
                                "(reconstruction would overflow)", m->path, c, (long long)r);
    }
    return OP_OK;
}

static op_status nmf_prepare(op_material *m, op_error *err)
{
    const op_material_info *in = &m->info;
    if (in->terms < 1 || in->terms > 4096)
        return op_error_set(err, OP_ERR_FORMAT, "%s: nmf needs 1 to 4096 terms, META says %d",
                            m->path, in->terms);
    nmf_state *s = calloc(1, sizeof *s);
    if (!s)
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", m->path);
    s->terms = in->terms;
    s->cols = op_material_cols(m);
    s->rows = op_material_rows(m);
    uint64_t rows = (uint64_t)s->rows, n = (uint64_t)s->cols, T = (uint64_t)s->terms;
    op_status st = OP_OK;
    for (int c = 0; c < in->channels && st == OP_OK; c++) {
        st = op_material_channel_floats(m, PROF_TAG, c, n, 1, &s->prof[c], err);
        if (st == OP_OK)
            st = op_material_channel_floats(m, SCALE_TAG, c, rows, 1, &s->scale[c], err);
        if (st == OP_OK) {
            char tag[16];
            op_channel_tag(tag, sizeof tag, SCALE_TAG, in, c);
            st = op_material_check_albedo(m, tag, s->scale[c], rows, err);
        }
        if (st == OP_OK)
            st = op_material_channel_floats(m, W_TAG, c, rows * T, 1, &s->w[c], err);
        if (st == OP_OK)
            st = op_material_channel_floats(m, H_TAG, c, n * T, 1, &s->h[c], err);
        if (st == OP_OK)
            st = check_range(m, s, c, err);
    }
    return op_method_keep_state(m, s, st);
}

static inline float entry(const nmf_state *s, int c, int64_t row, int col)
{
    const int T = s->terms;
    const float *w = s->w[c] + (size_t)row * T, *h = s->h[c] + (size_t)col * T;
    float x = 0.0f;
    for (int t = 0; t < T; t++)
        x += w[t] * h[t];
    return s->scale[c][row] * s->prof[c][col] * x;
}

static float nmf_eval(const op_material *m, int channel, int64_t row, int col)
{
    return entry(m->state, channel, row, col);
}

static void nmf_eval_row(const op_material *m, int channel, int64_t row, float *out)
{
    const nmf_state *s = m->state;
    for (int j = 0; j < s->cols; j++)
        out[j] = entry(s, channel, row, j);
}

op_status op_write_nmf_channel(op_material_writer *w, const op_material_info *info, int c,
                               const float *prof, const float *scale, const float *wf,
                               const float *h, op_error *err)
{
    uint64_t rows = (uint64_t)info->width * (uint64_t)info->height, T = (uint64_t)info->terms;
    uint64_t n = (uint64_t)info->kernel * (uint64_t)info->kernel;
    op_status st = op_material_write_channel(w, info, PROF_TAG, c, prof, n * sizeof *prof, err);
    if (st == OP_OK)
        st = op_material_write_channel(w, info, SCALE_TAG, c, scale, rows * sizeof *scale, err);
    if (st == OP_OK)
        st = op_material_write_channel(w, info, W_TAG, c, wf, rows * T * sizeof *wf, err);
    if (st == OP_OK)
        st = op_material_write_channel(w, info, H_TAG, c, h, n * T * sizeof *h, err);
    return st;
}

const op_method_ops op_method_nmf_ops = {
    .prepare = nmf_prepare,
    .eval = nmf_eval,
    .eval_row = nmf_eval_row,
    .destroy = op_method_free_state,
};
