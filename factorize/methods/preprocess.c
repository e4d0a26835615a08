/* preprocess.c - see preprocess.h. */
#include "preprocess.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Counts of src[i0 .. i1): branch-free, so that it vectorizes; the first non-finite value is
 * looked for only when there is one. */
static void scan_range(const float *src, uint64_t i0, uint64_t i1, op_prep_counts *counts)
{
    uint64_t nonfinite = 0, negative = 0;
    for (uint64_t i = i0; i < i1; i++) {
        uint32_t bits;
        memcpy(&bits, &src[i], sizeof bits);
        nonfinite += op_prep_is_nonfinite(bits);
        negative += op_prep_is_negative(bits);
    }
    counts->first_nonfinite = -1;
    for (uint64_t i = i0; nonfinite && i < i1; i++)
        if (!isfinite(src[i])) {
            counts->first_nonfinite = (int64_t)i;
            break;
        }
    counts->nonfinite = nonfinite;
    counts->negative = negative;
}

typedef struct scan_job {
    const float *src;
    uint64_t n, per;
    op_prep_counts *parts;
} scan_job;

static void scan_task(void *user, int task, int thread)
{
    const scan_job *j = user;
    uint64_t i0 = (uint64_t)task * j->per, i1 = i0 + j->per < j->n ? i0 + j->per : j->n;
    (void)thread;
    scan_range(j->src, i0, i1, &j->parts[task]);
}

void op_prep_scan(const float *src, uint64_t n, op_prep_counts *counts)
{
    /* Blocks of 16 MiB on every core, merged in order. */
    scan_job j = {src, n, (uint64_t)1 << 22, NULL};
    while (n / j.per >= (1u << 16))
        j.per *= 2;
    int tasks = (int)((n + j.per - 1) / j.per);
    if (tasks < 2 || !(j.parts = malloc((size_t)tasks * sizeof *j.parts)) ||
        op_parallel_for(0, tasks, scan_task, &j, NULL, NULL) != OP_OK) {
        free(j.parts);
        scan_range(src, 0, n, counts);
        return;
    }
    counts->nonfinite = counts->negative = 0;
    counts->first_nonfinite = -1;
    for (int t = 0; t < tasks; t++) {
        counts->nonfinite += j.parts[t].nonfinite;
        counts->negative += j.parts[t].negative;
        if (counts->first_nonfinite < 0)
            counts->first_nonfinite = j.parts[t].first_nonfinite;
    }
    free(j.parts);
}

void op_prep_find_peaks(const float *src, int64_t rows, int cols, uint32_t *shift, float *max)
{
    for (int64_t r = 0; r < rows; r++) {
        const float *row = src + r * cols;
        float best = 0.0f;
        uint32_t at = 0;
        for (int j = 0; j < cols; j++) {
            float v = op_prep_clean(row[j]);
            if (v > best) {
                best = v;
                at = (uint32_t)j;
            }
        }
        shift[r] = at;
        max[r] = best;
    }
}

static inline float at_most_one(float v)
{
    return v < 1.0f ? v : 1.0f;
}

void op_prep_apply(const float *src, int64_t rows, int cols, const uint32_t *shift,
                   const float *max, float *dst)
{
    for (int64_t r = 0; r < rows; r++) {
        const float *in = src + r * cols;
        float *out = dst + r * cols;
        if (!shift) {
            for (int j = 0; j < cols; j++)
                out[j] = op_prep_clean(in[j]);
            continue;
        }
        if (max[r] <= 0.0f) {
            memset(out, 0, (size_t)cols * sizeof *out);
            continue;
        }
        /* Dividing by the maximum keeps every value in [0, 1] exactly (min() only guards
         * rounding; a ternary, not fminf, so it compiles to one instruction). */
        float mx = max[r];
        int s = (int)shift[r];
        for (int j = 0; j < cols - s; j++)
            out[j] = at_most_one(op_prep_clean(in[j + s]) / mx);
        for (int j = cols - s; j < cols; j++)
            out[j] = at_most_one(op_prep_clean(in[j + s - cols]) / mx);
    }
}

/* ln(1 + x) for x > -1 within about 1e-15 (relative; NaN at x = -1, where ln is -infinity: the
 * svd's check refuses either), branch-free and without calls so that loops over it vectorize:
 * ln(u) for u = 1 + x = 2^k m, m in [sqrt(1/2), sqrt(2)), ln m = 2 atanh(s) with
 * s = (m - 1) / (m + 1), |s| < 0.172, by its series to s^15; less the rounding of u over u. */
static inline double log1p_vec(double x)
{
    double u = 1.0 + x, c = (u - 1.0) - x;
    int64_t bits;
    memcpy(&bits, &u, sizeof bits);
    int64_t mant = bits & 0x000fffffffffffffll, up = mant > 0x6a09e667f3bcdll; /* m >= sqrt 2 */
    int64_t mbits = mant | ((1023 - up) << 52), kbits = 0x4330000000000000ll + (bits >> 52) + up;
    double m, kd;
    memcpy(&m, &mbits, sizeof m);
    memcpy(&kd, &kbits, sizeof kd);
    kd -= 0x1p52 + 1023.0; /* the exponent k */
    double f = m - 1.0, s = f / (2.0 + f), s2 = s * s;
    double p = 1.0 / 15.0;
    p = p * s2 + 1.0 / 13.0;
    p = p * s2 + 1.0 / 11.0;
    p = p * s2 + 1.0 / 9.0;
    p = p * s2 + 1.0 / 7.0;
    p = p * s2 + 1.0 / 5.0;
    p = p * s2 + 1.0 / 3.0;
    double r = kd * 0.6931471805599453 + (2.0 * s + 2.0 * s * s2 * p - c / u);
    return r;
}

OP_VECTOR_CLONES
void op_prep_log(float *v, uint64_t n, double a, double b)
{
    float inv_a = (float)(1.0 / a), bm1 = (float)(b - 1.0);
    for (uint64_t i = 0; i < n; i++)
        v[i] = (float)log1p_vec((double)(v[i] * inv_a + bm1));
}

/* The bits of op_prep_clean(v) as the pool's threads compute it (they flush denormals to 0),
 * from the bits of v: cleaned values are non-negative, so their bits order as they do. */
static inline int32_t clean_bits(uint32_t bits)
{
    return bits >= 0x00800000u && bits < 0x7f800000u ? (int32_t)bits : 0;
}

/* op_prep_apply's value at_most_one(op_prep_clean(v) / mx) as the pool's threads compute it,
 * with integer selects (which vectorize; floating compares, which may trap, do not). */
static inline float scaled_bits(float v, float mx)
{
    float q = op_prep_clean_pool(v) / mx;
    int32_t qb;
    memcpy(&qb, &q, sizeof qb);
    qb = qb < 0x3f800000 ? qb : 0x3f800000; /* q >= 0: at most 1 */
    memcpy(&q, &qb, sizeof q);
    return q;
}

/* One row of op_prep_apply with a positive maximum mx and shift s, on a pool thread. */
static void shift_row(const float *in, int n, int s, float mx, float *out)
{
    for (int j = 0; j < n - s; j++)
        out[j] = scaled_bits(in[j + s], mx);
    for (int j = n - s; j < n; j++)
        out[j] = scaled_bits(in[j + s - n], mx);
}

OP_VECTOR_CLONES
op_status op_prep_fetch(void *user, int64_t r0, int64_t count, float *dst, op_error *err)
{
    op_prep_source *p = user;
    int n = p->cols;
    uint64_t nonfinite = 0, negative = 0;
    int64_t first_bad = -1;
    for (int64_t r = r0; r < r0 + count; r++) {
        const float *in = p->src + r * n;
        float *out = dst + (r - r0) * n;
        /* one pass over the row for scan_range's counts and op_prep_find_peaks's maximum */
        uint32_t bad = 0, neg = 0;
        int32_t top = 0;
        for (int j = 0; j < n; j++) {
            uint32_t bits;
            memcpy(&bits, &in[j], sizeof bits);
            bad += op_prep_is_nonfinite(bits);
            neg += op_prep_is_negative(bits);
            int32_t c = clean_bits(bits);
            top = c > top ? c : top;
        }
        nonfinite += bad;
        negative += neg;
        if (bad && first_bad < 0)
            first_bad = r;
        if (p->shift) {
            int at = 0;
            while (top > 0 && at < n) { /* the first column holding the maximum */
                uint32_t bits;
                memcpy(&bits, &in[at], sizeof bits);
                if (clean_bits(bits) == top)
                    break;
                at++;
            }
            p->shift[r] = top > 0 ? (uint32_t)at : 0;
            memcpy(&p->max[r], &top, sizeof top);
        }
        if (p->shift && top > 0)
            shift_row(in, n, (int)p->shift[r], p->max[r], out);
        else
            op_prep_apply(in, 1, n, p->shift ? p->shift + r : NULL, p->max ? p->max + r : NULL,
                          out);
        if (p->log_a > 0)
            op_prep_log(out, (uint64_t)n, p->log_a, p->log_b);
    }
    atomic_fetch_add(&p->nonfinite, nonfinite);
    atomic_fetch_add(&p->negative, negative);
    if (nonfinite && !p->sanitize)
        return op_error_set(err, OP_ERR_INPUT, "row %lld holds a non-finite value",
                            (long long)first_bad);
    return OP_OK;
}

typedef struct prep_job {
    const float *src;
    int64_t rows;
    int cols;
    uint32_t *shift;
    float *max;
    double log_a, log_b;
    float *dst;
    int64_t rows_per_task;
    int find_peaks;
} prep_job;

static void prep_task(void *user, int task, int thread)
{
    const prep_job *j = user;
    int64_t r0 = (int64_t)task * j->rows_per_task;
    int64_t n = j->rows - r0 < j->rows_per_task ? j->rows - r0 : j->rows_per_task;
    size_t at = (size_t)r0 * (size_t)j->cols;
    (void)thread;
    if (j->shift && j->find_peaks)
        op_prep_find_peaks(j->src + at, n, j->cols, j->shift + r0, j->max + r0);
    op_prep_apply(j->src + at, n, j->cols, j->shift ? j->shift + r0 : NULL,
                  j->max ? j->max + r0 : NULL, j->dst + at);
    if (j->log_a > 0)
        op_prep_log(j->dst + at, (uint64_t)n * (uint64_t)j->cols, j->log_a, j->log_b);
}

static op_status prep_rows(const float *src, int64_t rows, int cols, uint32_t *shift, float *max,
                           int find_peaks, double log_a, double log_b, int threads, float *dst,
                           op_error *err)
{
    /* Blocks of about 256 KiB: large enough to amortize a task, small enough to balance. */
    int64_t per = (int64_t)(65536 / (cols > 0 ? cols : 1));
    prep_job j = {src, rows, cols, shift, max, log_a, log_b, dst, per > 0 ? per : 1, find_peaks};
    int64_t tasks = (rows + j.rows_per_task - 1) / j.rows_per_task;
    while (tasks > 1 << 30) {
        j.rows_per_task *= 2;
        tasks = (rows + j.rows_per_task - 1) / j.rows_per_task;
    }
    return op_parallel_for(threads, (int)tasks, prep_task, &j, NULL, err);
}

op_status op_prep_rows(const float *src, int64_t rows, int cols, uint32_t *shift, float *max,
                       double log_a, double log_b, int threads, float *dst, op_error *err)
{
    return prep_rows(src, rows, cols, shift, max, 1, log_a, log_b, threads, dst, err);
}

op_status op_prep_rows_given_peaks(const float *src, int64_t rows, int cols,
                                   const uint32_t *shift, const float *max, double log_a,
                                   double log_b, int threads, float *dst, op_error *err)
{
    /* prep_task writes shift and max only when it finds the peaks */
    return prep_rows(src, rows, cols, (uint32_t *)shift, (float *)max, 0, log_a, log_b, threads,
                     dst, err);
}
