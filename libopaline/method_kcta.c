/* method_kcta.c - K-clustered tensor approximation (Tsai and Shih 2012) of each channel's
 * preprocessed matrix, clustered along the rows.
 *
 * With C = info.clusters, T = info.terms (rank per cluster), n = K*K columns:
 *   "KCTA"     2 u32: K_m (clusters per row, 1 to min(C, 64)) and the index width in bytes
 *              (2 or 4)
 * and per channel c (tag suffix R, G, B or Y):
 *   "BASIS.c"  C x n x T float32: cluster bases, each n x T row-major (orthonormal columns)
 *   "KIDX.c"   rows x K_m indices (u16 or u32 as "KCTA" says), each < C, distinct in a row
 *   "KCOEF.c"  rows x K_m x T float32: each row's coefficients on its clusters
 *   "SHIFT.c", "MAX.c" as for svd, only when info.shifted
 *   "ALBEDO"   optional, channels x rows float32 (row sums of the reconstruction)
 * Rd(row, col) = max * max(0, sum_k KCOEF[row][k] . BASIS[KIDX[row][k]][j]), with
 * j = (col - shift) mod n. docs/formats.md is the specification. */
#include "material_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PARAMS_TAG "KCTA"
#define BASIS_TAG "BASIS."
#define KIDX_TAG "KIDX."
#define KCOEF_TAG "KCOEF."

typedef struct kcta_state {
    int clusters, km, terms, cols, ibytes;
    int64_t rows;
    const float *basis[3], *coef[3], *max[3];
    const void *idx[3];
    const uint32_t *shift[3];
} kcta_state;

static inline uint32_t cluster_of(const kcta_state *s, int c, int64_t row, int k)
{
    size_t q = (size_t)row * s->km + k;
    return s->ibytes == 2 ? ((const uint16_t *)s->idx[c])[q] : ((const uint32_t *)s->idx[c])[q];
}

/* Checks the index section of channel c: size, range, distinct clusters within each row. */
static op_status load_indices(const op_material *m, kcta_state *s, int c, op_error *err)
{
    char tag[16];
    uint64_t count = (uint64_t)s->rows * (uint64_t)s->km;
    op_channel_tag(tag, sizeof tag, KIDX_TAG, &m->info, c);
    op_status st = op_material_sized_section(m, tag, count * (uint64_t)s->ibytes, &s->idx[c], err);
    if (st != OP_OK)
        return st;
    for (int64_t r = 0; r < s->rows; r++)
        for (int k = 0; k < s->km; k++) {
            uint32_t v = cluster_of(s, c, r, k);
            if (v >= (uint32_t)s->clusters)
                return op_error_set(err, OP_ERR_FORMAT, "%s: section '%s' row %lld names cluster "
                                    "%u of %d", m->path, tag, (long long)r, v, s->clusters);
            for (int k2 = 0; k2 < k; k2++)
                if (cluster_of(s, c, r, k2) == v)
                    return op_error_set(err, OP_ERR_FORMAT, "%s: section '%s' row %lld names "
                                        "cluster %u twice", m->path, tag, (long long)r, v);
        }
    return OP_OK;
}

/* Rejects factors whose reconstruction could overflow a float: the sum is bounded by
 * sum_k sum_t |coef| * max_j |basis[cluster][j][t]|. */
static op_status check_range(const op_material *m, const kcta_state *s, int c, op_error *err)
{
    const int T = s->terms, n = s->cols;
    double *bmax = calloc((size_t)s->clusters * T, sizeof *bmax);
    if (!bmax)
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", m->path);
    for (int q = 0; q < s->clusters; q++)
        op_column_abs_max(s->basis[c] + (size_t)q * n * T, n, T, bmax + (size_t)q * T);
    op_status st = OP_OK;
    for (int64_t r = 0; r < s->rows && st == OP_OK; r++) {
        double bound = 0;
        for (int k = 0; k < s->km; k++) {
            const float *y = s->coef[c] + ((size_t)r * s->km + k) * T;
            const double *b = bmax + (size_t)cluster_of(s, c, r, k) * T;
            for (int t = 0; t < T; t++)
                bound += fabs(y[t]) * b[t];
        }
        double scale = s->max[c] ? s->max[c][r] : 1.0;
        if (!(bound < 1e36) || !(bound * scale < 1e36))
            st = op_error_set(err, OP_ERR_FORMAT, "%s: channel %d row %lld: factors too large "
                              "(reconstruction would overflow)", m->path, c, (long long)r);
    }
    free(bmax);
    return st;
}

static op_status kcta_prepare(op_material *m, op_error *err)
{
    const op_material_info *in = &m->info;
    if (in->terms < 1 || in->terms > 4096 || in->clusters < 1 || in->clusters > 65536 ||
        (int64_t)in->clusters * in->terms > 65536)
        return op_error_set(err, OP_ERR_FORMAT, "%s: kcta needs 1 to 4096 terms, 1 to 65536 "
                            "clusters and clusters * terms <= 65536, META says %d and %d",
                            m->path, in->terms, in->clusters);
    kcta_state *s = calloc(1, sizeof *s);
    if (!s)
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", m->path);
    s->clusters = in->clusters;
    s->terms = in->terms;
    s->cols = op_material_cols(m);
    s->rows = op_material_rows(m);
    const void *p = NULL;
    op_status st = op_material_sized_section(m, PARAMS_TAG, 2 * sizeof(uint32_t), &p, err);
    const uint32_t *par = p;
    if (st == OP_OK && (par[0] < 1 || par[0] > 64 || par[0] > (uint32_t)s->clusters ||
                        (par[1] != 2 && par[1] != 4) || (par[1] == 2 && s->clusters > 65536)))
        st = op_error_set(err, OP_ERR_FORMAT, "%s: section '" PARAMS_TAG "' says K_m = %u and index width "
                          "%u (need 1 <= K_m <= min(64, %d) and width 2 or 4)", m->path, par[0],
                          par[1], s->clusters);
    if (st == OP_OK) {
        s->km = (int)par[0];
        s->ibytes = (int)par[1];
    }
    uint64_t rows = (uint64_t)s->rows, T = (uint64_t)s->terms;
    for (int c = 0; c < in->channels && st == OP_OK; c++) {
        st = op_material_channel_floats(m, BASIS_TAG, c,
                                        (uint64_t)s->clusters * (uint64_t)s->cols * T, 0,
                                        &s->basis[c], err);
        if (st == OP_OK)
            st = op_material_channel_floats(m, KCOEF_TAG, c, rows * (uint64_t)s->km * T, 0,
                                            &s->coef[c], err);
        if (st == OP_OK)
            st = load_indices(m, s, c, err);
        if (st == OP_OK && in->shifted)
            st = op_material_shift_sections(m, c, &s->shift[c], &s->max[c], err);
        if (st == OP_OK)
            st = check_range(m, s, c, err);
    }
    return op_method_keep_state(m, s, st);
}

/* The reconstruction of entry j of the shifted, normalized row, clamped at 0. */
static inline float entry(const kcta_state *s, int c, int64_t row, int j)
{
    const int T = s->terms;
    float x = 0.0f;
    for (int k = 0; k < s->km; k++) {
        const float *y = s->coef[c] + ((size_t)row * s->km + k) * T;
        const float *b = s->basis[c] + ((size_t)cluster_of(s, c, row, k) * s->cols + j) * T;
        for (int t = 0; t < T; t++)
            x += y[t] * b[t];
    }
    return x > 0.0f ? x : 0.0f;
}

static float kcta_eval(const op_material *m, int channel, int64_t row, int col)
{
    const kcta_state *s = m->state;
    if (!s->shift[channel])
        return entry(s, channel, row, col);
    int j = col - (int)s->shift[channel][row];
    if (j < 0)
        j += s->cols;
    return s->max[channel][row] * entry(s, channel, row, j);
}

/* The row in chunks of OP_EVAL_CHUNK columns, vectorized across the columns: each entry is
 * computed with exactly entry()'s operations (one sum over k, then t, in the same order), so
 * eval_row and eval agree bit for bit. */
OP_VECTOR_CLONES
static void kcta_eval_row(const op_material *m, int channel, int64_t row, float *out)
{
    const kcta_state *s = m->state;
    const int T = s->terms, n = s->cols;
    const int sh = s->shift[channel] ? (int)s->shift[channel][row] : 0;
    const float mx = s->shift[channel] ? s->max[channel][row] : 1.0f;
    float x[OP_EVAL_CHUNK];
    for (int j0 = 0; j0 < n; j0 += OP_EVAL_CHUNK) {
        const int len = n - j0 < OP_EVAL_CHUNK ? n - j0 : OP_EVAL_CHUNK;
        for (int q = 0; q < len; q++)
            x[q] = 0.0f;
        for (int k = 0; k < s->km; k++) {
            const float *y = s->coef[channel] + ((size_t)row * s->km + k) * T;
            const float *b = s->basis[channel] +
                             ((size_t)cluster_of(s, channel, row, k) * n + j0) * T;
            for (int t = 0; t < T; t++) {
                const float yt = y[t];
                for (int q = 0; q < len; q++)
                    x[q] += yt * b[(size_t)q * T + t];
            }
        }
        for (int q = 0; q < len; q++)
            x[q] = mx * (x[q] > 0.0f ? x[q] : 0.0f); /* mx is 1 when not shifted: exact */
        op_store_shifted(out, n, j0 + sh, x, len);
    }
}

op_status op_write_kcta_channel(op_material_writer *w, const op_material_info *info, int c,
                                int km, int index_bytes, const float *basis, const void *idx,
                                const float *coef, const uint32_t *shift, const float *max,
                                op_error *err)
{
    uint64_t rows = (uint64_t)info->width * (uint64_t)info->height, T = (uint64_t)info->terms;
    uint64_t n = (uint64_t)info->kernel * (uint64_t)info->kernel;
    uint64_t nidx = rows * (uint64_t)km;
    op_status st = op_material_write_channel(w, info, BASIS_TAG, c, basis,
                                             (uint64_t)info->clusters * n * T * sizeof *basis,
                                             err);
    if (st == OP_OK)
        st = op_material_write_channel(w, info, KIDX_TAG, c, idx, nidx * (uint64_t)index_bytes,
                                       err);
    if (st == OP_OK)
        st = op_material_write_channel(w, info, KCOEF_TAG, c, coef, nidx * T * sizeof *coef, err);
    return st == OP_OK ? op_material_write_shift(w, info, c, shift, max, err) : st;
}

op_status op_write_kcta_params(op_material_writer *w, int km, int index_bytes, op_error *err)
{
    uint32_t par[2] = {(uint32_t)km, (uint32_t)index_bytes};
    return op_material_writer_add(w, PARAMS_TAG, par, sizeof par, err);
}

const op_method_ops op_method_kcta_ops = {
    .prepare = kcta_prepare,
    .eval = kcta_eval,
    .eval_row = kcta_eval_row,
    .destroy = op_method_free_state,
};
