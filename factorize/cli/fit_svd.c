/* fit_svd.c - the svd method's entry in the method table: defaults, option checks, and the fit
 * (preprocess, log transform, truncated SVD of rsvd.c; its layout: libopaline/method_svd.c). */
#include "fit_table.h"
#include "preprocess.h"

#include <math.h>
#include <stdlib.h>

/* Rows of the transformed matrix of channel c, for the SVD: from mat (rows x cols) when it is
 * in memory, else preprocessed from the dataset one block at a time (op_row_source). */
typedef struct svd_rows {
    const factor_args *a;
    const dataset *ds;
    int c;
    const float *mat;
    const uint32_t *shift;
    const float *max;
} svd_rows;

static op_status fetch_rows(void *user, int64_t r0, int64_t count, float *dst, op_error *err)
{
    const svd_rows *s = user;
    const dataset *ds = s->ds;
    const float *src = ds->rd[s->c] + r0 * ds->cols;
    op_status st = op_prep_rows_given_peaks(src, count, ds->cols, s->shift ? s->shift + r0 : NULL,
                                            s->max ? s->max + r0 : NULL, s->a->log_a,
                                            s->a->log_b, s->a->threads, dst, err);
    op_material_release(ds->file, src, (size_t)count * (size_t)ds->cols * sizeof *src);
    return st;
}

/* Row r of the transformed matrix into *row: in mat, or fetched into buf (cols floats). */
static op_status svd_row(const svd_rows *s, int64_t r, float *buf, const float **row,
                         op_error *err)
{
    *row = s->mat ? s->mat + r * s->ds->cols : buf;
    return s->mat ? OP_OK : fetch_rows((void *)s, r, 1, buf, err);
}

/* Refuses --log-a/--log-b that make ln(R'/A + B) lose channel c's data: the transformed matrix
 * (rows x cols, float) must be finite, map back to the preprocessed values within 1e-3
 * (relative, over up to 4096 sampled rows), and stay within [1e-15, 60] in magnitude, so that
 * the float SVD neither underflows nor the reconstruction A e^x overflows its checks. */
static op_status check_log_transform(const factor_args *a, const svd_rows *t, op_error *err)
{
    const dataset *ds = t->ds;
    const uint32_t *shift = t->shift;
    const float *max = t->max;
    int c = t->c;
    int64_t rows = ds->rows, step = rows > 4096 ? rows / 4096 : 1, done = 0;
    int n = ds->cols;
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
            double v = mx > 0 ? op_prep_clean(ds->rd[c][r * n + col]) / mx : 0.0;
            double x = row[j];
            finite &= isfinite(x);
            double back = a->log_a * expm1(x) + a->log_a * (1.0 - a->log_b);
            err2 += (back - v) * (back - v);
            ref2 += v * v;
            xmax = fmax(xmax, fabs(x));
        }
        if (!t->mat) { /* streaming: a row is less than a page, but each read maps the pages
                          around it (fault-around): release up to the next sampled row, or the
                          samples would map the whole channel */
            int64_t end = r + step < rows ? r + step : rows;
            op_material_release(ds->file, ds->rd[c] + done * n,
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
                            "default is 100) and B = 1", a->log_a, a->log_b, c, why);
    return OP_OK;
}

/* Streaming: channel c's per-row shifts and maxima (when a->shift; else both NULL), found in
 * passes of ds->block_rows rows whose pages are released after. */
static op_status stream_peaks(const factor_args *a, const dataset *ds, int c, uint32_t **shift,
                              float **max, op_error *err)
{
    op_status st = op_fit_alloc_peaks(a, ds, shift, max, err);
    if (st != OP_OK || !a->shift)
        return st;
    for (int64_t r0 = 0; r0 < ds->rows; r0 += ds->block_rows) {
        int64_t nb = ds->rows - r0 < ds->block_rows ? ds->rows - r0 : ds->block_rows;
        const float *src = ds->rd[c] + r0 * ds->cols;
        op_prep_find_peaks(src, nb, ds->cols, *shift + r0, *max + r0);
        op_material_release(ds->file, src, (size_t)nb * (size_t)ds->cols * sizeof *src);
    }
    return OP_OK;
}

/* Channel c of the in-memory svd method: its SVD with the preprocessing, the log transform and
 * the count of its values fused into the first pass over it (op_rsvd_fill of op_prep_fetch into
 * mat), then the check of the transform. The per-row shifts and maxima go to *shift and *max,
 * the counts to *nonfinite and *negative (non-finite values without --sanitize stop the fit:
 * OP_ERR_INPUT, for op_fit_counted to name the first). */
static op_status svd_channel_fused(const factor_args *a, const dataset *ds, int c, int terms,
                                   float *mat, uint32_t **shift, float **max, float *us,
                                   float *v, op_progress *prog, uint64_t *nonfinite,
                                   uint64_t *negative, op_error *err)
{
    op_status st = op_fit_alloc_peaks(a, ds, shift, max, err);
    if (st != OP_OK)
        return st;
    op_prep_source p = {.src = ds->rd[c], .rows = ds->rows, .cols = ds->cols, .shift = *shift,
                        .max = *max, .log_a = a->log_a, .log_b = a->log_b,
                        .sanitize = a->sanitize};
    atomic_init(&p.nonfinite, 0);
    atomic_init(&p.negative, 0);
    op_row_source src = {op_prep_fetch, &p, 1};
    op_rsvd_options opt = a->svd;
    opt.threads = a->threads;
    st = op_rsvd_fill(&src, mat, ds->rows, ds->cols, terms, &opt, us, v, NULL, prog, err);
    *nonfinite = atomic_load(&p.nonfinite);
    *negative = atomic_load(&p.negative);
    if (*nonfinite && !a->sanitize)
        return OP_ERR_INPUT;
    if (st == OP_OK || st == OP_ERR_NUMERIC) { /* a refused transform explains a failure */
        op_error check_err = {0};
        svd_rows t = {a, ds, c, mat, *shift, *max};
        op_status check = check_log_transform(a, &t, &check_err);
        if (check != OP_OK) {
            if (err)
                *err = check_err;
            return check;
        }
    }
    return st == OP_OK ? st : op_error_prefix(err, "channel %d: ", c);
}

/* The svd method, channel by channel: preprocess, log transform, truncated SVD (in memory: the
 * first pass of the SVD preprocesses the dataset's rows into the matrix; streaming: every pass
 * preprocesses them). */
static op_status svd_fit(fit_job *job, op_error *err)
{
    const factor_args *a = job->a;
    const dataset *ds = job->ds;
    int terms = job->info->terms;
    double *prep_seconds = &job->prep_seconds;
    int64_t rows = ds->rows;
    int cols = ds->cols;
    float *mat = NULL;
    op_status st = ds->block_rows ? OP_OK : op_fit_matrix(ds, &mat, err);
    if (st != OP_OK)
        return st;
    op_progress *prog = op_progress_begin(
        "svd", (uint64_t)ds->info.channels *
                   (1 + op_rsvd_progress_units(rows, cols, terms, &a->svd)), NULL, NULL);
    uint64_t nonfinite = 0, negative = 0;
    for (int c = 0; c < ds->info.channels && st == OP_OK; c++) {
        uint32_t *shift = NULL;
        float *max = NULL;
        double t0 = op_monotonic_seconds();
        if (!ds->block_rows) {
            float *us = op_fit_alloc((uint64_t)rows * (uint64_t)terms * sizeof *us);
            float *v = op_fit_alloc((uint64_t)cols * (uint64_t)terms * sizeof *v);
            uint64_t nf = 0, neg = 0;
            st = !us || !v ? op_error_set(err, OP_ERR_NOMEM, "out of memory")
                           : svd_channel_fused(a, ds, c, terms, mat, &shift, &max, us, v, prog,
                                               &nf, &neg, err);
            nonfinite += nf;
            negative += neg;
            if (nf && !a->sanitize)
                st = op_fit_channel_nonfinite(a, ds, c, nf, neg, job->rep, err);
            op_progress_advance(prog, 1);
            op_log(OP_LOG_DEBUG, "channel %d: preprocessing and SVD of %lld x %d to rank %d "
                   "%.3f s", c, (long long)rows, cols, terms, op_monotonic_seconds() - t0);
            if (st == OP_OK)
                st = op_write_svd_channel(job->w, job->info, c, us, v, shift, max, err);
            free(us);
            free(v);
            free(shift);
            free(max);
            continue;
        }
        st = stream_peaks(a, ds, c, &shift, &max, err);
        svd_rows t = {a, ds, c, mat, shift, max};
        if (st == OP_OK)
            st = check_log_transform(a, &t, err);
        /* its sampled rows (and the pages the kernel mapped around them) */
        op_material_release(ds->file, ds->rd[c], (size_t)rows * (size_t)cols * sizeof *ds->rd[c]);
        if (st != OP_OK) {
            free(shift);
            free(max);
        }
        if (st != OP_OK)
            break;
        op_progress_advance(prog, 1);
        double t1 = op_monotonic_seconds();
        *prep_seconds += t1 - t0;
        float *us = op_fit_alloc((uint64_t)rows * (uint64_t)terms * sizeof *us);
        float *v = op_fit_alloc((uint64_t)cols * (uint64_t)terms * sizeof *v);
        if (!us || !v)
            st = op_error_set(err, OP_ERR_NOMEM, "out of memory");
        op_row_source src = {fetch_rows, &t, ds->block_rows};
        if (st == OP_OK)
            st = op_rsvd_rows(&src, rows, cols, terms, &a->svd, us, v, NULL, prog, err);
        op_log(OP_LOG_DEBUG, "channel %d: preprocessing %.3f s, SVD of %lld x %d to rank %d "
               "%.3f s", c, t1 - t0, (long long)rows, cols, terms, op_monotonic_seconds() - t1);
        if (st != OP_OK) {
            op_error_prefix(err, "channel %d: ", c);
            free(us);
            free(v);
            free(shift);
            free(max);
            break;
        }
        st = op_write_svd_channel(job->w, job->info, c, us, v, shift, max, err);
        free(us);
        free(v);
        free(shift);
        free(max);
    }
    op_progress_end(prog);
    free(mat);
    if (st == OP_OK && !ds->block_rows)
        st = op_fit_counted(a, ds, nonfinite, negative, job->rep, err);
    return st;
}

static op_status svd_defaults(factor_args *a, op_error *err)
{
    a->terms = a->terms < 0 ? 10 : a->terms;
    a->degree = 0;
    if (a->block_rows > 0 && a->svd.exact)
        return op_error_set(err, OP_ERR_INPUT, "--block-rows needs the randomized SVD, not "
                            "--exact-svd");
    return OP_OK;
}

static op_status svd_describe(const factor_args *a, const dataset *ds, op_material_info *info,
                              op_error *err)
{
    (void)ds;
    (void)err;
    info->log_a = a->log_a;
    info->log_b = a->log_b;
    return OP_OK;
}

const fit_method op_fit_svd = {
    .method = OP_METHOD_SVD,
    .options = FIT_OPT_BLOCK_ROWS,
    .albedo = 1,
    .counts_values = 1,
    .terms_help = "",
    .defaults = svd_defaults,
    .describe = svd_describe,
    .fit = svd_fit,
};
