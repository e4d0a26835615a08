/* fit_raw.c - the raw method's entry in the method table: the cleaned dataset itself (its
 * layout: libopaline/method_raw.c). */
#include "fit_table.h"
#include "preprocess.h"

#include <stdlib.h>

static op_status raw_defaults(factor_args *a, op_error *err)
{
    (void)err;
    a->terms = a->degree = 0;
    a->shift = 0;
    return OP_OK;
}

static op_status raw_fit(fit_job *job, op_error *err)
{
    const dataset *ds = job->ds;
    uint64_t count = (uint64_t)ds->rows * (uint64_t)ds->cols;
    float *v = op_fit_alloc(count * sizeof *v);
    if (!v)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    op_status st = OP_OK;
    for (int c = 0; c < ds->info.channels && st == OP_OK; c++) {
        for (uint64_t i = 0; i < count; i++)
            v[i] = op_prep_clean(ds->rd[c][i]);
        st = op_write_raw_channel(job->w, job->info, c, v, err);
    }
    free(v);
    return st;
}

const fit_method op_fit_raw = {
    .method = OP_METHOD_RAW,
    .options = 0,
    .albedo = 0,
    .terms_help = "",
    .defaults = raw_defaults,
    .describe = NULL,
    .fit = raw_fit,
};
