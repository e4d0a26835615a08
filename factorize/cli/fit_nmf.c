/* fit_nmf.c - the nmf method's entry in the method table: defaults, option checks, and the fit
 * (nmf.c; its layout: libopaline/method_nmf.c). */
#include "fit_table.h"
#include "nmf.h"

#include <math.h>
#include <stdlib.h>

/* The nmf method, channel by channel: the homogeneous approximation, the remainder, HALS. */
static op_status nmf_fit(fit_job *job, op_error *err)
{
    const factor_args *a = job->a;
    const dataset *ds = job->ds;
    int terms = job->info->terms;
    double *prep_seconds = &job->prep_seconds;
    int64_t rows = ds->rows;
    int cols = ds->cols;
    float *q = NULL;
    op_status st = op_fit_matrix(ds, &q, err);
    if (st != OP_OK)
        return st;
    op_nmf_options opt = op_nmf_defaults();
    opt.rank = terms;
    opt.max_iter = a->iters;
    opt.svd = a->svd;
    op_progress *prog = op_progress_begin(
        "nmf", (uint64_t)ds->info.channels * (uint64_t)opt.max_iter, NULL, NULL);
    for (int c = 0; c < ds->info.channels && st == OP_OK; c++) {
        double t0 = op_monotonic_seconds();
        float *prof = op_fit_alloc((uint64_t)cols * sizeof *prof);
        float *scale = op_fit_alloc((uint64_t)rows * sizeof *scale);
        float *w = op_fit_alloc((uint64_t)rows * (uint64_t)terms * sizeof *w);
        float *h = op_fit_alloc((uint64_t)cols * (uint64_t)terms * sizeof *h);
        if (!prof || !scale || !w || !h) {
            free(prof);
            free(scale);
            free(w);
            free(h);
            st = op_error_set(err, OP_ERR_NOMEM, "out of memory");
            break;
        }
        op_nmf_homogeneous(ds->rd[c], rows, ds->info.kernel, a->homog_exp, prof, scale);
        op_nmf_remainder(ds->rd[c], rows, cols, prof, scale, q);
        double t1 = op_monotonic_seconds();
        *prep_seconds += t1 - t0;
        op_nmf_stats ns;
        st = op_nmf_hals(q, rows, cols, &opt, w, h, &ns, prog, err);
        if (st == OP_OK)
            op_log(OP_LOG_INFO, "nmf channel %d: %d HALS iteration(s), %s; remainder relative "
                   "error %.4g (NNDSVD start %.4g) (%.3f s)", c, ns.iterations,
                   ns.converged ? "converged" : "stopped at --iters",
                   ns.norm > 0 ? sqrt(ns.objective / ns.norm) : 0.0,
                   ns.norm > 0 ? sqrt(ns.initial / ns.norm) : 0.0, op_monotonic_seconds() - t1);
        else
            op_error_prefix(err, "channel %d: ", c);
        if (st == OP_OK)
            st = op_write_nmf_channel(job->w, job->info, c, prof, scale, w, h, err);
        free(prof);
        free(scale);
        free(w);
        free(h);
    }
    op_progress_end(prog);
    free(q);
    return st;
}

static op_status nmf_defaults(factor_args *a, op_error *err)
{
    (void)err;
    op_nmf_options n = op_nmf_defaults();
    a->terms = a->terms < 0 ? n.rank : a->terms;
    a->degree = 0;
    a->iters = a->iters < 0 ? n.max_iter : a->iters;
    a->homog_exp = a->homog_exp < 0 ? 1.0 : a->homog_exp;
    a->shift = 0; /* the homogeneous approximation takes the place of shifting */
    return OP_OK;
}

const fit_method op_fit_nmf = {
    .method = OP_METHOD_NMF,
    .options = FIT_OPT_ITERS | FIT_OPT_HOMOG,
    .albedo = 1,
    .terms_help = "rank ",
    .defaults = nmf_defaults,
    .describe = NULL,
    .fit = nmf_fit,
};
