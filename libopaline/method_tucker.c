/* method_tucker.c - Tucker factorization of the channel mean with per-row polynomial colour
 * regression (Kurt, Ozturk and Peers 2013).
 *
 * With T = info.terms, P = info.degree, n = K*K columns, C = info.channels:
 *   "U"      rows x T float32: f_j(x_i) g_j      "V"   n x T float32: h_j(d)
 *   "RANGE"  rows x 2 float32: (center, scale) of each row's polynomial argument
 *   "BETA"   C x rows x (P + 1) float32: Chebyshev coefficients per channel and row
 *   "SHIFT"  rows u32 and "MAX" rows float32, only when info.shifted
 *   "ALBEDO" optional, C x rows float32: the row sums of the reconstruction
 * Rd_c(row, col) = max * sum_p BETA[c][row][p] T_p((U[row] . V[j] - center) * scale),
 * clamped at 0, with j = (col - shift) mod n. docs/formats.md is the specification. */
#include "material_internal.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define U_TAG "U"
#define V_TAG "V"
#define RANGE_TAG "RANGE"
#define BETA_TAG "BETA"

typedef struct tucker_state {
    int terms, degree, cols;
    int64_t rows;
    const float *u, *v, *range, *beta, *max;
    const uint32_t *shift;
    float *vt; /* V transposed (terms x cols), for eval_row's column chunks */
} tucker_state;

/* Rejects factors whose reconstruction could overflow a float anywhere: |U[r] . V[j]| <= b_r,
 * |T_p(t)| <= max(1, 2|t|)^p and Clenshaw's partial sums stay within (P + 1) times that. */
static op_status check_range(const op_material *m, const tucker_state *s, op_error *err)
{
    int T = s->terms, np = s->degree + 1;
    double vmax[4096];
    op_column_abs_max(s->v, s->cols, T, vmax);
    double limit = log(FLT_MAX) - 4.0;
    for (int64_t r = 0; r < s->rows; r++) {
        double bound = 0;
        for (int t = 0; t < T; t++)
            bound += fabs(s->u[(size_t)r * T + t]) * vmax[t];
        double tau = (bound + fabs(s->range[2 * r])) * fabs(s->range[2 * r + 1]);
        double mx = s->max ? s->max[r] : 1.0;
        double coef = 0;
        for (int c = 0; c < m->info.channels; c++)
            for (int p = 0; p < np; p++)
                coef = fmax(coef, fabs(s->beta[((size_t)c * s->rows + r) * np + p]));
        double lg = log(fmax(mx, 1.0)) + log((double)np * np) + log(fmax(coef, 1e-300)) +
                    s->degree * log(fmax(1.0, 2.0 * tau));
        if (bound > 1e30 || !(lg < limit))
            return op_error_set(err, OP_ERR_FORMAT, "%s: row %lld: factors too large "
                                "(reconstruction would overflow)", m->path, (long long)r);
    }
    return OP_OK;
}

static op_status tucker_prepare(op_material *m, op_error *err)
{
    const op_material_info *in = &m->info;
    if (in->terms < 1 || in->terms > 4096 || in->degree < 0 || in->degree > 64)
        return op_error_set(err, OP_ERR_FORMAT, "%s: tucker needs 1 to 4096 terms and degree 0 "
                            "to 64, META says %d and %d", m->path, in->terms, in->degree);
    tucker_state *s = calloc(1, sizeof *s);
    if (!s)
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", m->path);
    s->terms = in->terms;
    s->degree = in->degree;
    s->cols = op_material_cols(m);
    s->rows = op_material_rows(m);
    uint64_t rows = (uint64_t)s->rows, T = (uint64_t)s->terms;
    op_status st = op_material_float_section(m, U_TAG, rows * T, 0, &s->u, err);
    if (st == OP_OK)
        st = op_material_float_section(m, V_TAG, (uint64_t)s->cols * T, 0, &s->v, err);
    if (st == OP_OK)
        st = op_material_float_section(m, RANGE_TAG, rows * 2, 0, &s->range, err);
    if (st == OP_OK)
        st = op_material_float_section(m, BETA_TAG,
                                       (uint64_t)in->channels * rows * (uint64_t)(s->degree + 1),
                                       0, &s->beta, err);
    if (st == OP_OK && in->shifted)
        st = op_material_shift_sections(m, -1, &s->shift, &s->max, err);
    if (st == OP_OK)
        st = check_range(m, s, err);
    if (st == OP_OK && !(s->vt = op_transpose(s->v, s->cols, s->terms)))
        st = op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", m->path);
    if (st != OP_OK)
        free(s->vt);
    return op_method_keep_state(m, s, st);
}

/* One entry of the shifted, normalized matrix for channel c, clamped at 0. */
static inline float entry(const tucker_state *s, int c, int64_t row, const float *v)
{
    const int T = s->terms, P = s->degree;
    const float *u = s->u + row * T;
    float x = 0.0f;
    for (int t = 0; t < T; t++)
        x += u[t] * v[t];
    float t = (x - s->range[2 * row]) * s->range[2 * row + 1];
    const float *beta = s->beta + ((size_t)c * s->rows + row) * (size_t)(P + 1);
    float b1 = 0.0f, b2 = 0.0f;
    for (int p = P; p >= 1; p--) {
        float b0 = 2.0f * t * b1 - b2 + beta[p];
        b2 = b1;
        b1 = b0;
    }
    float y = t * b1 - b2 + beta[0];
    return y > 0.0f ? y : 0.0f;
}

static float tucker_eval(const op_material *m, int channel, int64_t row, int col)
{
    const tucker_state *s = m->state;
    if (!s->shift)
        return entry(s, channel, row, s->v + (size_t)col * s->terms);
    int j = col - (int)s->shift[row];
    if (j < 0)
        j += s->cols;
    return s->max[row] * entry(s, channel, row, s->v + (size_t)j * s->terms);
}

/* The row in chunks of OP_EVAL_CHUNK columns, vectorized across the columns with V transposed:
 * each entry is computed with exactly entry()'s operations in the same order, so eval_row and
 * eval agree bit for bit. */
static void tucker_eval_row(const op_material *m, int channel, int64_t row, float *out)
{
    const tucker_state *s = m->state;
    const int T = s->terms, n = s->cols, P = s->degree;
    const float *u = s->u + row * T;
    const float center = s->range[2 * row], scale = s->range[2 * row + 1];
    const float *beta = s->beta + ((size_t)channel * s->rows + row) * (size_t)(P + 1);
    const int sh = s->shift ? (int)s->shift[row] : 0;
    const float mx = s->shift ? s->max[row] : 1.0f;
    float x[OP_EVAL_CHUNK], b1[OP_EVAL_CHUNK], b2[OP_EVAL_CHUNK];
    for (int j0 = 0; j0 < n; j0 += OP_EVAL_CHUNK) {
        const int len = n - j0 < OP_EVAL_CHUNK ? n - j0 : OP_EVAL_CHUNK;
        for (int k = 0; k < len; k++)
            x[k] = 0.0f;
        for (int t = 0; t < T; t++) {
            const float *v = s->vt + (size_t)t * n + j0, ut = u[t];
            for (int k = 0; k < len; k++)
                x[k] += ut * v[k];
        }
        for (int k = 0; k < len; k++) {
            x[k] = (x[k] - center) * scale;
            b1[k] = b2[k] = 0.0f;
        }
        for (int p = P; p >= 1; p--) {
            const float bp = beta[p];
            for (int k = 0; k < len; k++) {
                float b0 = 2.0f * x[k] * b1[k] - b2[k] + bp;
                b2[k] = b1[k];
                b1[k] = b0;
            }
        }
        for (int k = 0; k < len; k++) {
            float y = x[k] * b1[k] - b2[k] + beta[0];
            x[k] = mx * (y > 0.0f ? y : 0.0f); /* mx is 1 when not shifted: exact */
        }
        op_store_shifted(out, n, j0 + sh, x, len);
    }
}

static void tucker_destroy(op_material *m)
{
    tucker_state *s = m->state;
    if (s)
        free(s->vt);
    op_method_free_state(m);
}

op_status op_write_tucker(op_material_writer *w, const op_material_info *info, const float *u,
                          const float *v, const float *range, const float *beta,
                          const uint32_t *shift, const float *max, op_error *err)
{
    uint64_t rows = (uint64_t)info->width * (uint64_t)info->height, T = (uint64_t)info->terms;
    uint64_t n = (uint64_t)info->kernel * (uint64_t)info->kernel;
    uint64_t nbeta = (uint64_t)info->channels * rows * ((uint64_t)info->degree + 1);
    op_status st = op_material_writer_add(w, U_TAG, u, rows * T * sizeof *u, err);
    if (st == OP_OK)
        st = op_material_writer_add(w, V_TAG, v, n * T * sizeof *v, err);
    if (st == OP_OK)
        st = op_material_writer_add(w, RANGE_TAG, range, rows * 2 * sizeof *range, err);
    if (st == OP_OK)
        st = op_material_writer_add(w, BETA_TAG, beta, nbeta * sizeof *beta, err);
    return st == OP_OK ? op_material_write_shift(w, info, -1, shift, max, err) : st;
}

const op_method_ops op_method_tucker_ops = {
    .prepare = tucker_prepare,
    .eval = tucker_eval,
    .eval_row = tucker_eval_row,
    .destroy = tucker_destroy,
};
