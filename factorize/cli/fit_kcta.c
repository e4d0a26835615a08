/* fit_kcta.c - the kcta method's entry in the method table: defaults, option checks, and the
 * fit (kcta.c; its layout: libopaline/method_kcta.c). */
#include "fit_table.h"
#include "kcta.h"

#include <math.h>
#include <stdlib.h>

/* The kcta method, channel by channel: preprocess (shift and normalize, no log transform: the
 * clusters are linear subspaces), then K-CTA (kcta.h). */
static op_status kcta_fit(fit_job *job, op_error *err)
{
    const factor_args *a = job->a;
    const dataset *ds = job->ds;
    int terms = job->info->terms, clusters = job->info->clusters;
    double *prep_seconds = &job->prep_seconds;
    int64_t rows = ds->rows;
    int cols = ds->cols;
    float *mat = NULL;
    op_status st = op_fit_matrix(ds, &mat, err);
    if (st != OP_OK)
        return st;
    op_kcta_options opt = op_kcta_defaults();
    opt.clusters = clusters;
    opt.km = a->km;
    opt.terms = terms;
    opt.max_iters = a->iters;
    opt.svd = a->svd;
    opt.threads = a->threads;
    opt.svd.threads = a->threads;
    int wide = clusters > 65536 ? 4 : 2;
    op_progress *prog = op_progress_begin(
        "kcta", (uint64_t)ds->info.channels * (uint64_t)(1 + opt.max_iters), NULL, NULL);
    uint64_t nonfinite = 0, negative = 0;
    for (int c = 0; c < ds->info.channels && st == OP_OK; c++) {
        uint32_t *shift = NULL;
        float *max = NULL;
        double t0 = op_monotonic_seconds();
        uint64_t nf = 0, neg = 0;
        st = op_fit_prepare_channel(a, ds, c, mat, &shift, &max, &nf, &neg, err);
        nonfinite += nf;
        negative += neg;
        if (nf && !a->sanitize)
            st = op_fit_channel_nonfinite(a, ds, c, nf, neg, job->rep, err);
        if (st != OP_OK)
            break;
        double t1 = op_monotonic_seconds();
        *prep_seconds += t1 - t0;
        op_kcta_model md;
        st = op_kcta_factor(mat, rows, cols, &opt, &md, prog, err);
        if (st != OP_OK) {
            op_error_prefix(err, "channel %d: ", c);
            free(shift);
            free(max);
            break;
        }
        double norm = md.norm2;
        op_log(OP_LOG_INFO, "kcta channel %d: %d iteration(s)%s, %d empty cluster(s) split, "
               "relative error %.4g of the preprocessed matrix (%.3f s)", c, md.iterations,
               md.restored ? " (one more raised the error and was undone)" : "", md.splits,
               norm > 0 ? sqrt(md.history[md.nhistory - 1] / norm) : 0.0, op_monotonic_seconds() - t1);
        uint64_t nidx = (uint64_t)rows * (uint64_t)md.km;
        void *idx = op_fit_alloc(nidx * (uint64_t)wide);
        if (!idx) {
            op_kcta_free(&md);
            free(shift);
            free(max);
            st = op_error_set(err, OP_ERR_NOMEM, "out of memory");
            break;
        }
        for (uint64_t q = 0; q < nidx; q++) {
            if (wide == 2)
                ((uint16_t *)idx)[q] = (uint16_t)md.idx[q];
            else
                ((uint32_t *)idx)[q] = md.idx[q];
        }
        st = op_write_kcta_channel(job->w, job->info, c, md.km, wide, md.basis, idx, md.coef,
                                   shift, max, err);
        op_kcta_free(&md);
        free(idx);
        free(shift);
        free(max);
    }
    op_progress_end(prog);
    free(mat);
    if (st == OP_OK && !ds->block_rows)
        st = op_fit_counted(a, ds, nonfinite, negative, job->rep, err);
    return st == OP_OK ? op_write_kcta_params(job->w, a->km, wide, err) : st;
}

static op_status kcta_defaults(factor_args *a, op_error *err)
{
    op_kcta_options k = op_kcta_defaults();
    a->terms = a->terms < 0 ? k.terms : a->terms;
    a->degree = 0;
    a->clusters = a->clusters < 0 ? k.clusters : a->clusters;
    a->km = a->km < 0 ? k.km : a->km;
    a->iters = a->iters < 0 ? k.max_iters : a->iters;
    if (a->km > a->clusters)
        return op_error_set(err, OP_ERR_INPUT, "--km %d exceeds the %d clusters (-C)", a->km,
                            a->clusters);
    if (a->iters > OP_KCTA_MAX_HISTORY)
        return op_error_set(err, OP_ERR_INPUT, "kcta takes at most %d iterations",
                            OP_KCTA_MAX_HISTORY);
    return OP_OK;
}

/* -C is lowered to the rows; --km must then still fit. */
static op_status kcta_describe(const factor_args *a, const dataset *ds, op_material_info *info,
                               op_error *err)
{
    int clusters = a->clusters;
    if (clusters > ds->rows) {
        op_log(OP_LOG_WARN, "-C %d exceeds the %lld rows; using %lld", clusters,
               (long long)ds->rows, (long long)ds->rows);
        clusters = (int)ds->rows;
    }
    if (a->km > clusters)
        return op_error_set(err, OP_ERR_INPUT, "--km %d exceeds the %d clusters", a->km,
                            clusters);
    info->clusters = clusters;
    return OP_OK;
}

const fit_method op_fit_kcta = {
    .method = OP_METHOD_KCTA,
    .options = FIT_OPT_CLUSTERS | FIT_OPT_ITERS,
    .albedo = 1,
    .counts_values = 1,
    .terms_help = "rank per cluster ",
    .defaults = kcta_defaults,
    .describe = kcta_describe,
    .fit = kcta_fit,
};
