/* fit_svd.c - the svd method's entry in the method table: defaults, option checks, and the fit
 * (svd.c; its layout: libopaline/method_svd.c). */
#include "fit_table.h"
#include "svd.h"

#include <stdlib.h>

/* The svd method, channel by channel (svd.h): in memory, the first pass of the SVD
 * preprocesses the dataset's rows into the matrix; streamed, every pass preprocesses them. */
static op_status svd_fit(fit_job *job, op_error *err)
{
    const factor_args *a = job->a;
    const dataset *ds = job->ds;
    float *mat = NULL;
    op_status st = ds->block_rows ? OP_OK : op_fit_matrix(ds, &mat, err);
    if (st != OP_OK)
        return st;
    op_svd_options opt = {.terms = job->info->terms, .shifted = a->shift, .log_a = a->log_a,
                          .log_b = a->log_b, .sanitize = a->sanitize, .threads = a->threads,
                          .svd = a->svd};
    op_progress *prog = op_progress_begin(
        "svd", (uint64_t)ds->info.channels *
                   (1 + op_rsvd_progress_units(ds->rows, ds->cols, opt.terms, &a->svd)), NULL,
        NULL);
    uint64_t nonfinite = 0, negative = 0;
    for (int c = 0; c < ds->info.channels && st == OP_OK; c++) {
        op_svd_channel f;
        if (ds->block_rows) {
            st = op_svd_factor_streamed(ds->rd[c], ds->rows, ds->cols, c, ds->block_rows,
                                        ds->file, &opt, &f, prog, err);
            job->prep_seconds += f.prep_seconds;
        } else {
            st = op_svd_factor(ds->rd[c], ds->rows, ds->cols, c, &opt, mat, &f, prog, err);
            nonfinite += f.nonfinite;
            negative += f.negative;
            if (f.nonfinite && !a->sanitize)
                st = op_fit_channel_nonfinite(a, ds, c, f.nonfinite, f.negative, job->rep, err);
        }
        if (st == OP_OK)
            st = op_write_svd_channel(job->w, job->info, c, f.us, f.v, f.shift, f.max, err);
        op_svd_free(&f);
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
