/* preprocess.h - the row preprocessing of Kurt et al. 2013, section 4.1, and the value
 * transforms the factorization methods apply before factoring.
 *
 * A dataset channel is a row-major rows x cols float32 matrix Rd'(x_i, d): one row per
 * incident pixel, one column per kernel offset. Shifting moves each row's maximum to column 0
 * (circularly) and divides the row by it, so that similar values line up in the same columns:
 *     shifted[r][j] = src[r][(j + shift[r]) mod cols] / max[r]
 * and reconstruction is src[r][col] = max[r] * shifted[r][(col - shift[r]) mod cols]. */
#ifndef OP_FACTOR_PREPROCESS_H
#define OP_FACTOR_PREPROCESS_H

#include <stdint.h>
#include <string.h>

#include "opaline.h"

/* What a scan of the input values found. */
typedef struct op_prep_counts {
    uint64_t nonfinite;       /* NaN or infinite values (treated as 0) */
    uint64_t negative;        /* negative values, i.e. noise (treated as 0) */
    int64_t first_nonfinite;  /* index of the first one, -1 if none */
} op_prep_counts;

/* op_prep_scan's two counts for one value, from its bits alone (branch-free, so that loops
 * vectorize; and the pool's threads flush denormals, which would make a negative denormal
 * compare as 0): 1 when it is NaN or infinite, and 1 when it is negative, finite and not 0. */
static inline uint32_t op_prep_is_nonfinite(uint32_t bits)
{
    return (bits & 0x7f800000u) == 0x7f800000u;
}

static inline uint32_t op_prep_is_negative(uint32_t bits)
{
    return (op_prep_is_nonfinite(bits) ^ 1u) & (bits >> 31) & ((bits & 0x7fffffffu) != 0);
}

/* Counts non-finite and negative values of src[0 .. n). */
void op_prep_scan(const float *src, uint64_t n, op_prep_counts *counts);

/* The value the factorizations see for an input value: non-finite and negative become 0. */
static inline float op_prep_clean(float v)
{
    return v > 0.0f && v <= 3.4028234663852886e38f ? v : 0.0f;
}

/* op_prep_clean as op_parallel_for's tasks compute it (their threads treat denormals as 0),
 * with integer selects only, so that loops over it vectorize. */
static inline float op_prep_clean_pool(float v)
{
    uint32_t bits;
    memcpy(&bits, &v, sizeof bits);
    bits = bits >= 0x00800000u && bits < 0x7f800000u ? bits : 0u;
    memcpy(&v, &bits, sizeof v);
    return v;
}

/* For every row of src (rows x cols, row-major): shift[r] = the first column holding the row's
 * largest cleaned value, max[r] = that value (0 for a row with no positive value, whose shift
 * is then 0). */
void op_prep_find_peaks(const float *src, int64_t rows, int cols, uint32_t *shift, float *max);

/* dst = the shifted, normalized matrix of the cleaned src (rows of zero maximum stay 0). With
 * shift and max NULL, dst is the cleaned src itself. dst and src must not overlap. */
void op_prep_apply(const float *src, int64_t rows, int cols, const uint32_t *shift,
                   const float *max, float *dst);

/* The whole preprocessing of a channel on `threads` threads (<= 0: all cores), one block of
 * rows per task so that each row is read once: op_prep_find_peaks (when shift and max are not
 * NULL), op_prep_apply, then op_prep_log when log_a > 0. The result is the same as those steps
 * in sequence, for any thread count. Fails only when threads cannot be started. */
op_status op_prep_rows(const float *src, int64_t rows, int cols, uint32_t *shift, float *max,
                       double log_a, double log_b, int threads, float *dst, op_error *err);
/* op_prep_rows with the peaks already found (shift and max given, or both NULL): for a matrix
 * preprocessed one block of rows at a time; each row's result is op_prep_rows's. */
op_status op_prep_rows_given_peaks(const float *src, int64_t rows, int cols,
                                   const uint32_t *shift, const float *max, double log_a,
                                   double log_b, int threads, float *dst, op_error *err);

/* A matrix preprocessed while it is read (the svd method's fused first pass): op_prep_fetch, an
 * op_row_source fetch (rsvd.h), writes rows [r0, r0 + count) of op_prep_rows's result for src
 * and counts the rows' values as op_prep_scan does. Calls for disjoint rows may run at once.
 * Non-finite values count as 0 when sanitize is set; else a block holding one fails with
 * OP_ERR_INPUT (op_prep_scan of src then names the first). */
typedef struct op_prep_source {
    const float *src;
    int64_t rows;
    int cols;
    uint32_t *shift; /* rows, filled in; NULL: not shifted (max NULL too) */
    float *max;
    double log_a, log_b; /* log_a <= 0: no log transform */
    int sanitize;
    _Atomic uint64_t nonfinite, negative; /* counted so far */
} op_prep_source;

op_status op_prep_fetch(void *user, int64_t r0, int64_t count, float *dst, op_error *err);

/* The svd method's value transform, in place: v = ln(v / a + b), with a > 0, b > 0, v >= 0. */
void op_prep_log(float *v, uint64_t n, double a, double b);

#endif
