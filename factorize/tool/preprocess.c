/* preprocess.c - see preprocess.h. */
#include "preprocess.h"

#include <math.h>
#include <string.h>

void op_prep_scan(const float *src, uint64_t n, op_prep_counts *counts)
{
    counts->nonfinite = counts->negative = 0;
    counts->first_nonfinite = -1;
    for (uint64_t i = 0; i < n; i++) {
        float v = src[i];
        if (!isfinite(v)) {
            if (counts->first_nonfinite < 0)
                counts->first_nonfinite = (int64_t)i;
            counts->nonfinite++;
        } else if (v < 0.0f) {
            counts->negative++;
        }
    }
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
        /* Dividing by the maximum keeps every value in [0, 1] exactly. */
        float mx = max[r];
        int s = (int)shift[r];
        for (int j = 0; j < cols - s; j++)
            out[j] = fminf(op_prep_clean(in[j + s]) / mx, 1.0f);
        for (int j = cols - s; j < cols; j++)
            out[j] = fminf(op_prep_clean(in[j + s - cols]) / mx, 1.0f);
    }
}

void op_prep_log(float *v, uint64_t n, double a, double b)
{
    /* ln(v/a + b) = log1p(v/a + (b - 1)), exact near 0 when b == 1. */
    float inv_a = (float)(1.0 / a), bm1 = (float)(b - 1.0);
    for (uint64_t i = 0; i < n; i++)
        v[i] = log1pf(v[i] * inv_a + bm1);
}
