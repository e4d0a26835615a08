/* svd.c - the svd method's factorization of a channel (svd.h): preprocessing, log transform,
 * truncated SVD (rsvd.c), and the check of the transform. */
#include "svd.h"
#include "preprocess.h"

#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>

/* malloc of bytes (at least 1), or NULL when out of memory or bytes exceeds size_t. */
static void *alloc_bytes(uint64_t bytes)
{
    return bytes > (uint64_t)SIZE_MAX ? NULL : malloc(bytes ? (size_t)bytes : 1);
}

/* The rows of the transformed channel: from mat (rows x cols) when it is in memory, else
 * preprocessed from src one block at a time (op_row_source), the pages of file released after. */
typedef struct svd_rows {
    const op_svd_options *opt;
    const float *src;
    int64_t rows;
    int cols;
    const op_material *file;
    const float *mat;
    const uint32_t *shift;
    const float *max;
} svd_rows;

static op_status fetch_rows(void *user, int64_t r0, int64_t count, float *dst, op_error *err)
{
    const svd_rows *s = user;
    const float *src = s->src + r0 * s->cols;
    op_status st = op_prep_rows_given_peaks(src, count, s->cols, s->shift ? s->shift + r0 : NULL,
                                            s->max ? s->max + r0 : NULL, s->opt->log_a,
                                            s->opt->log_b, s->opt->threads, dst, err);
    op_material_release(s->file, src, (size_t)count * (size_t)s->cols * sizeof *src);
    return st;
}

/* Row r of the transformed matrix into *row: in mat, or fetched into buf (cols floats). */
static op_status svd_row(const svd_rows *s, int64_t r, float *buf, const float **row,
                         op_error *err)
{
    *row = s->mat ? s->mat + r * s->cols : buf;
    return s->mat ? OP_OK : fetch_rows((void *)s, r, 1, buf, err);
}

/* Refuses an A and B that make ln(R'/A + B) lose channel c's data: the transformed matrix
 * (rows x cols, float) must be finite, map back to the preprocessed values within 1e-3
 * (relative, over up to 4096 sampled rows), and stay within [1e-15, 60] in magnitude, so that
 * the float SVD neither underflows nor the reconstruction A e^x overflows its checks. */
static op_status check_log_transform(const svd_rows *t, int c, op_error *err)
{
    const op_svd_options *o = t->opt;
    const uint32_t *shift = t->shift;
    const float *max = t->max;
    int64_t rows = t->rows, step = rows > 4096 ? rows / 4096 : 1, done = 0;
    int n = t->cols;
    double err2 = 0, ref2 = 0, xmax = 0;
    int finite = 1;
    float *buf = t->mat ? NULL : malloc((size_t)n * sizeof *buf);
    if (!t->mat && !buf)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    for (int64_t r = 0; r < rows; r += step) {
        const float *row;
        op_status st = svd_row(t, r, buf, &row, err);
        if (st != OP_OK) {
            free(buf);
            return st;
        }
        int s = shift ? (int)shift[r] : 0;
        double mx = max ? max[r] : 1.0;
        for (int j = 0; j < n; j++) {
            int col = j + s < n ? j + s : j + s - n;
            double v = mx > 0 ? op_prep_clean(t->src[r * n + col]) / mx : 0.0;
            double x = row[j];
            finite &= isfinite(x);
            double back = o->log_a * expm1(x) + o->log_a * (1.0 - o->log_b);
            err2 += (back - v) * (back - v);
            ref2 += v * v;
            xmax = fmax(xmax, fabs(x));
        }
        if (!t->mat) { /* streaming: a row is less than a page, but each read maps the pages
                          around it (fault-around): release up to the next sampled row, or the
                          samples would map the whole channel */
            int64_t end = r + step < rows ? r + step : rows;
            op_material_release(t->file, t->src + done * n,
                                (size_t)(end - done) * (size_t)n * sizeof(float));
            done = end;
        }
    }
    const char *why = !finite                         ? "some values are infinite"
                      : ref2 > 0 && xmax < 1e-15       ? "its values underflow single precision"
                      : xmax > 60                      ? "its values are too large"
                      : ref2 > 0 && err2 > 1e-6 * ref2 ? "it does not map back within 1e-3"
                                                       : NULL;
    free(buf);
    if (why)
        return op_error_set(err, OP_ERR_INPUT, "--log-a %g --log-b %g: the transform ln(R/A + B) "
                            "loses channel %d's data (%s); choose A near the data's scale (the "
                            "default is 100) and B = 1", o->log_a, o->log_b, c, why);
    return OP_OK;
}

/* The per-row shifts and maxima of res when opt->shifted (else both stay NULL). */
static op_status alloc_peaks(const op_svd_options *opt, int64_t rows, op_svd_channel *res,
                             op_error *err)
{
    if (!opt->shifted)
        return OP_OK;
    res->shift = alloc_bytes((uint64_t)rows * sizeof *res->shift);
    res->max = alloc_bytes((uint64_t)rows * sizeof *res->max);
    return res->shift && res->max ? OP_OK : op_error_set(err, OP_ERR_NOMEM, "out of memory");
}

/* The factors us (rows x T) and v (cols x T) of res. */
static op_status alloc_factors(const op_svd_options *opt, int64_t rows, int cols,
                               op_svd_channel *res, op_error *err)
{
    res->us = alloc_bytes((uint64_t)rows * (uint64_t)opt->terms * sizeof *res->us);
    res->v = alloc_bytes((uint64_t)cols * (uint64_t)opt->terms * sizeof *res->v);
    return res->us && res->v ? OP_OK : op_error_set(err, OP_ERR_NOMEM, "out of memory");
}

/* In memory: the SVD with the preprocessing, the log transform and the count of the values
 * fused into its first pass over the channel (op_rsvd_fill of op_prep_fetch into mat), then the
 * check of the transform. */
static op_status factor_fused(const float *src, int64_t rows, int cols, int c,
                              const op_svd_options *opt, float *mat, op_svd_channel *res,
                              op_progress *prog, op_error *err)
{
    op_status st = alloc_peaks(opt, rows, res, err);
    if (st != OP_OK)
        return st;
    op_prep_source p = {.src = src, .rows = rows, .cols = cols, .shift = res->shift,
                        .max = res->max, .log_a = opt->log_a, .log_b = opt->log_b,
                        .sanitize = opt->sanitize};
    atomic_init(&p.nonfinite, 0);
    atomic_init(&p.negative, 0);
    op_row_source rs = {op_prep_fetch, &p, 1};
    op_rsvd_options ro = opt->svd;
    ro.threads = opt->threads;
    st = op_rsvd_fill(&rs, mat, rows, cols, opt->terms, &ro, res->us, res->v, NULL, prog, err);
    res->nonfinite = atomic_load(&p.nonfinite);
    res->negative = atomic_load(&p.negative);
    if (res->nonfinite && !opt->sanitize)
        return OP_ERR_INPUT;
    if (st == OP_OK || st == OP_ERR_NUMERIC) { /* a refused transform explains a failure */
        op_error check_err = {0};
        svd_rows t = {opt, src, rows, cols, NULL, mat, res->shift, res->max};
        op_status check = check_log_transform(&t, c, &check_err);
        if (check != OP_OK) {
            if (err)
                *err = check_err;
            return check;
        }
    }
    return st == OP_OK ? st : op_error_prefix(err, "channel %d: ", c);
}

op_status op_svd_factor(const float *src, int64_t rows, int cols, int channel,
                        const op_svd_options *opt, float *mat, op_svd_channel *res,
                        op_progress *progress, op_error *err)
{
    *res = (op_svd_channel){0};
    double t0 = op_monotonic_seconds();
    op_status st = alloc_factors(opt, rows, cols, res, err);
    if (st == OP_OK)
        st = factor_fused(src, rows, cols, channel, opt, mat, res, progress, err);
    op_progress_advance(progress, 1);
    op_log(OP_LOG_DEBUG, "channel %d: preprocessing and SVD of %lld x %d to rank %d %.3f s",
           channel, (long long)rows, cols, opt->terms, op_monotonic_seconds() - t0);
    if (st != OP_OK) {
        uint64_t nonfinite = res->nonfinite, negative = res->negative;
        op_svd_free(res);
        res->nonfinite = nonfinite;
        res->negative = negative;
    }
    return st;
}

op_status op_svd_factor_streamed(const float *src, int64_t rows, int cols, int channel,
                                 int64_t block_rows, const op_material *file,
                                 const op_svd_options *opt, op_svd_channel *res,
                                 op_progress *progress, op_error *err)
{
    *res = (op_svd_channel){0};
    double t0 = op_monotonic_seconds();
    /* the per-row peaks, in passes whose pages are released after */
    op_status st = alloc_peaks(opt, rows, res, err);
    for (int64_t r0 = 0; st == OP_OK && res->shift && r0 < rows; r0 += block_rows) {
        int64_t nb = rows - r0 < block_rows ? rows - r0 : block_rows;
        const float *p = src + r0 * cols;
        op_prep_find_peaks(p, nb, cols, res->shift + r0, res->max + r0);
        op_material_release(file, p, (size_t)nb * (size_t)cols * sizeof *p);
    }
    svd_rows t = {opt, src, rows, cols, file, NULL, res->shift, res->max};
    if (st == OP_OK)
        st = check_log_transform(&t, channel, err);
    /* its sampled rows (and the pages the kernel mapped around them) */
    op_material_release(file, src, (size_t)rows * (size_t)cols * sizeof *src);
    if (st != OP_OK) {
        op_svd_free(res);
        return st;
    }
    op_progress_advance(progress, 1);
    double t1 = op_monotonic_seconds();
    res->prep_seconds = t1 - t0;
    st = alloc_factors(opt, rows, cols, res, err);
    op_row_source rs = {fetch_rows, &t, block_rows};
    if (st == OP_OK)
        st = op_rsvd_rows(&rs, rows, cols, opt->terms, &opt->svd, res->us, res->v, NULL,
                          progress, err);
    op_log(OP_LOG_DEBUG, "channel %d: preprocessing %.3f s, SVD of %lld x %d to rank %d %.3f s",
           channel, t1 - t0, (long long)rows, cols, opt->terms, op_monotonic_seconds() - t1);
    if (st != OP_OK) {
        op_error_prefix(err, "channel %d: ", channel);
        op_svd_free(res);
    }
    return st;
}

void op_svd_free(op_svd_channel *res)
{
    free(res->us);
    free(res->v);
    free(res->shift);
    free(res->max);
    *res = (op_svd_channel){0};
}
