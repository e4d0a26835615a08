/* method_svd.c - the log-transformed truncated SVD of Onel, Kurt and Ozturk.
 *
 * Per channel c (tag suffix R, G, B or Y), with T = info.terms and n = K*K columns:
 *   "U.c"     rows x T float32, row-major: the left singular vectors scaled by the values
 *   "V.c"     n x T float32, row-major: the right singular vectors
 *   "SHIFT.c" rows u32 and "MAX.c" rows float32, only when info.shifted: the column of each
 *             row's maximum and the maximum itself (paper section 4.1)
 *   "ALBEDO"  optional, channels x rows float32: the row sums of the reconstruction, written
 *             by the factorizer so the albedo map needs no summation
 * Rd(row, col) = max * (A * exp(U[row] . V[j]) - A * B), clamped at 0, where
 * j = (col - shift) mod n. docs/formats.md is the specification. */
#include "material_internal.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

#define U_TAG "U."
#define V_TAG "V."

typedef struct svd_state {
    int terms, cols;
    int stride;               /* floats per row of rowdata, a multiple of 16 */
    float a, c;               /* Rd' = a * expm1(x) + c, c = A * (1 - B) */
    const float *u[3], *v[3]; /* per channel, in the file */
    float *vt[3];             /* V transposed (terms x cols), for eval_row's column chunks */
    const uint32_t *shift[3]; /* NULL when not shifted */
    const float *max[3];      /* NULL when not shifted */
    /* Per channel and row, one cache-line-aligned record: U[row] (terms floats), then the
     * maximum and the shift (as a float holding a whole number), so that one evaluation
     * touches one record instead of three sections. */
    float *rowdata[3];
} svd_state;

/* Builds the interleaved row records of channel c. */
static op_status build_rows(const op_material *m, svd_state *s, int c, op_error *err)
{
    int64_t rows = op_material_rows(m);
    /* Whole 2 MiB pages, offered to the kernel as huge pages: random rows then cost one cache
     * miss and no TLB miss. */
    size_t huge = (size_t)2 << 20;
    size_t bytes = ((size_t)rows * (size_t)s->stride * sizeof(float) + huge - 1) / huge * huge;
    float *d = aligned_alloc(huge, bytes);
    if (!d)
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", m->path);
#ifdef MADV_HUGEPAGE
    madvise(d, bytes, MADV_HUGEPAGE); /* advisory: failure only costs speed */
#endif
    memset(d, 0, bytes);
    for (int64_t r = 0; r < rows; r++) {
        float *rec = d + r * s->stride;
        memcpy(rec, s->u[c] + r * s->terms, (size_t)s->terms * sizeof *rec);
        rec[s->terms] = s->max[c] ? s->max[c][r] : 1.0f;
        rec[s->terms + 1] = s->shift[c] ? (float)s->shift[c][r] : 0.0f;
    }
    s->rowdata[c] = d;
    return OP_OK;
}

static void free_state(svd_state *s)
{
    if (!s)
        return;
    for (int c = 0; c < 3; c++) {
        free(s->rowdata[c]);
        free(s->vt[c]);
    }
    free(s);
}

/* Rejects factors whose reconstruction could overflow a float: |U[r] . V[j]| is bounded by
 * sum_t |U[r][t]| * max_j |V[j][t]|. */
static op_status check_range(const op_material *m, const svd_state *s, int c, op_error *err)
{
    int T = s->terms;
    double vmax[4096];
    op_column_abs_max(s->v[c], s->cols, T, vmax);
    double limit = log(FLT_MAX) - 1.0 - log(fmax(s->a, 1.0));
    int64_t rows = op_material_rows(m);
    for (int64_t r = 0; r < rows; r++) {
        double bound = 0;
        for (int t = 0; t < T; t++)
            bound += fabs(s->u[c][(size_t)r * T + t]) * vmax[t];
        double scale = s->max[c] ? s->max[c][r] : 1.0;
        if (bound + (scale > 1.0 ? log(scale) : 0.0) > limit)
            return op_error_set(err, OP_ERR_FORMAT,
                                "%s: channel %d row %lld: factors too large (reconstruction would "
                                "overflow)", m->path, c, (long long)r);
    }
    return OP_OK;
}

static op_status svd_prepare(op_material *m, op_error *err)
{
    const op_material_info *in = &m->info;
    if (in->terms < 1 || in->terms > 4096)
        return op_error_set(err, OP_ERR_FORMAT, "%s: svd needs 1 to 4096 terms, META says %d",
                            m->path, in->terms);
    if (!(in->log_a > 0) || !(in->log_b > 0) || in->log_a > 1e30 || in->log_b > 1e30)
        return op_error_set(err, OP_ERR_FORMAT,
                            "%s: svd needs log_a > 0 and log_b > 0, META says %g and %g", m->path,
                            in->log_a, in->log_b);
    svd_state *s = calloc(1, sizeof *s);
    if (!s)
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", m->path);
    s->terms = in->terms;
    s->stride = (in->terms + 2 + 15) / 16 * 16;
    s->cols = op_material_cols(m);
    s->a = (float)in->log_a;
    s->c = (float)(in->log_a * (1.0 - in->log_b));
    int64_t rows = op_material_rows(m);
    op_status st = OP_OK;
    for (int c = 0; c < in->channels && st == OP_OK; c++) {
        st = op_material_channel_floats(m, U_TAG, c, (uint64_t)rows * (uint64_t)s->terms, 0,
                                        &s->u[c], err);
        if (st == OP_OK)
            st = op_material_channel_floats(m, V_TAG, c, (uint64_t)s->cols * (uint64_t)s->terms,
                                            0, &s->v[c], err);
        if (st == OP_OK && in->shifted)
            st = op_material_shift_sections(m, c, &s->shift[c], &s->max[c], err);
        if (st == OP_OK)
            st = check_range(m, s, c, err);
        if (st == OP_OK)
            st = build_rows(m, s, c, err);
        if (st == OP_OK && !(s->vt[c] = op_transpose(s->v[c], s->cols, s->terms)))
            st = op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", m->path);
    }
    if (st != OP_OK) {
        free_state(s);
        return st;
    }
    m->state = s;
    return OP_OK;
}

/* e^x - 1 for -87 <= x <= 88 (the factors' range check keeps x below; callers clamp x at -87,
 * whose e^x - 1 is -1 to float, to keep 2^k a normal number) in single precision, relative to
 * the exact value within 2 ulp also for tiny x (the test's bound); branch-free and without
 * calls so that eval_row's loop over columns vectorizes. 2^k is built from the bits of the
 * rounding of x / ln 2 (ln 2 in two parts, the first exact in k ln 2); e^r - 1, |r| <= ln(2) / 2,
 * by its Taylor series to r^7 (truncation below 2e-8 relative); e^x - 1 = (2^k - 1) +
 * 2^k (e^r - 1), exact in its first term. eval and eval_row both use it, so they agree bit for
 * bit. */
static inline float expm1_vec(float x)
{
    const float shifter = 0x1.8p23f, log2e = 0x1.715476p0f;
    const float ln2_hi = 0x1.63p-1f, ln2_lo = -0x1.bd0106p-13f;
    float kd = x * log2e + shifter;
    uint32_t kbits;
    memcpy(&kbits, &kd, sizeof kbits);
    kd -= shifter;
    float r = (x - kd * ln2_hi) - kd * ln2_lo;
    float p = 1.0f / 5040.0f;
    p = p * r + 1.0f / 720.0f;
    p = p * r + 1.0f / 120.0f;
    p = p * r + 1.0f / 24.0f;
    p = p * r + 1.0f / 6.0f;
    p = p * r + 0.5f;
    p = p * r * r + r; /* e^r - 1 */
    uint32_t sbits = (kbits + 127u) << 23;
    float scale;
    memcpy(&scale, &sbits, sizeof scale);
    return (scale - 1.0f) + scale * p;
}

/* The reconstruction of one entry of the shifted, normalized matrix, clamped at 0. */
static inline float entry(const svd_state *s, const float *u, const float *v)
{
    /* Four partial sums: a short dependency chain matters more than the flops here. */
    float x0 = 0.0f, x1 = 0.0f, x2 = 0.0f, x3 = 0.0f;
    int t = 0;
    for (; t + 4 <= s->terms; t += 4) {
        x0 += u[t] * v[t];
        x1 += u[t + 1] * v[t + 1];
        x2 += u[t + 2] * v[t + 2];
        x3 += u[t + 3] * v[t + 3];
    }
    for (; t < s->terms; t++)
        x0 += u[t] * v[t];
    float x = (x0 + x1) + (x2 + x3);
    x = x > -87.0f ? x : -87.0f;
    float r = s->a * expm1_vec(x) + s->c;
    return r > 0.0f ? r : 0.0f;
}

static float svd_eval(const op_material *m, int channel, int64_t row, int col)
{
    const svd_state *s = m->state;
    const int T = s->terms;
    const float *rec = s->rowdata[channel] + row * s->stride;
    int j = col - (int)rec[T + 1];
    if (j < 0)
        j += s->cols;
    return rec[T] * entry(s, rec, s->v[channel] + (size_t)j * T);
}

/* The row in chunks of OP_EVAL_CHUNK columns, vectorized across the columns with V transposed:
 * each entry is computed with exactly entry()'s operations (four partial sums over t, in the
 * same order), so eval_row and eval agree bit for bit. */
OP_VECTOR_CLONES
static void svd_eval_row(const op_material *m, int channel, int64_t row, float *out)
{
    const svd_state *s = m->state;
    const int T = s->terms, n = s->cols;
    const float *u = s->u[channel] + row * T, *vt = s->vt[channel];
    const int sh = s->shift[channel] ? (int)s->shift[channel][row] : 0;
    const float mx = s->shift[channel] ? s->max[channel][row] : 1.0f;
    const float a = s->a, c = s->c;
    float x0[OP_EVAL_CHUNK], x1[OP_EVAL_CHUNK], x2[OP_EVAL_CHUNK], x3[OP_EVAL_CHUNK];
    for (int j0 = 0; j0 < n; j0 += OP_EVAL_CHUNK) {
        const int len = n - j0 < OP_EVAL_CHUNK ? n - j0 : OP_EVAL_CHUNK;
        for (int k = 0; k < len; k++)
            x0[k] = x1[k] = x2[k] = x3[k] = 0.0f;
        int t = 0;
        for (; t + 4 <= T; t += 4) {
            const float *v0 = vt + (size_t)t * n + j0, *v1 = v0 + n, *v2 = v1 + n, *v3 = v2 + n;
            const float u0 = u[t], u1 = u[t + 1], u2 = u[t + 2], u3 = u[t + 3];
            for (int k = 0; k < len; k++) {
                x0[k] += u0 * v0[k];
                x1[k] += u1 * v1[k];
                x2[k] += u2 * v2[k];
                x3[k] += u3 * v3[k];
            }
        }
        for (; t < T; t++) {
            const float *v0 = vt + (size_t)t * n + j0, u0 = u[t];
            for (int k = 0; k < len; k++)
                x0[k] += u0 * v0[k];
        }
        for (int k = 0; k < len; k++) {
            float x = (x0[k] + x1[k]) + (x2[k] + x3[k]);
            x0[k] = x > -87.0f ? x : -87.0f;
        }
        /* two loops: GCC 12 vectorizes each, not the two in one */
        for (int k = 0; k < len; k++) {
            float r = a * expm1_vec(x0[k]) + c;
            x0[k] = mx * (r > 0.0f ? r : 0.0f); /* mx is 1 when not shifted: exact */
        }
        op_store_shifted(out, n, j0 + sh, x0, len);
    }
}

static void svd_destroy(op_material *m)
{
    free_state(m->state);
    m->state = NULL;
}

op_status op_write_svd_channel(op_material_writer *w, const op_material_info *info, int c,
                               const float *u, const float *v, const uint32_t *shift,
                               const float *max, op_error *err)
{
    uint64_t rows = (uint64_t)info->width * (uint64_t)info->height, T = (uint64_t)info->terms;
    uint64_t n = (uint64_t)info->kernel * (uint64_t)info->kernel;
    op_status st = op_material_write_channel(w, info, U_TAG, c, u, rows * T * sizeof *u, err);
    if (st == OP_OK)
        st = op_material_write_channel(w, info, V_TAG, c, v, n * T * sizeof *v, err);
    return st == OP_OK ? op_material_write_shift(w, info, c, shift, max, err) : st;
}

const op_method_ops op_method_svd_ops = {
    .prepare = svd_prepare,
    .eval = svd_eval,
    .eval_row = svd_eval_row,
    .destroy = svd_destroy,
};
