/* fit_tucker.c - the tucker method's entry in the method table: defaults and the fit (tucker.c;
 * its layout: libopaline/method_tucker.c). */
#include "fit_table.h"
#include "tucker.h"

#include <math.h>
#include <stdlib.h>

static op_status tucker_defaults(factor_args *a, op_error *err)
{
    (void)err;
    a->terms = a->terms < 0 ? 15 : a->terms;
    a->degree = a->degree < 0 ? 7 : a->degree;
    return OP_OK;
}

/* The factors of tucker.c as sections; the colour fit's conditioning goes to the report. */
static op_status tucker_fit(fit_job *job, op_error *err)
{
    const factor_args *a = job->a;
    const dataset *ds = job->ds;
    op_factor_report *rep = job->rep;
    op_tucker_result t;
    op_status st = op_tucker_factor(ds->rd, ds->info.channels, ds->rows, ds->cols,
                                    job->info->terms, a->degree, a->shift, &a->svd, a->threads,
                                    &t, err);
    if (st != OP_OK)
        return st;
    rep->has_fit = 1;
    rep->fit_condition = t.fit.cond_max;
    rep->fit_coef_max = t.fit.coef_max;
    rep->fit_storage_error = t.fit.data_sq > 0 ? sqrt(t.fit.storage_sq / t.fit.data_sq) : 0.0;
    if (rep->fit_storage_error > 1e-4)
        op_log(OP_LOG_WARN, "tucker: storing the colour fit as float32 changes it by %.2g "
               "(relative), more than 1e-4", rep->fit_storage_error);
    if (!(rep->fit_condition < 1e10))
        op_log(OP_LOG_WARN, "tucker: a colour fit is ill-conditioned (condition %.3g)",
               rep->fit_condition);
    st = op_write_tucker(job->w, job->info, t.u, t.v, t.range, t.beta, t.shift, t.max, err);
    op_tucker_free(&t);
    return st;
}

const fit_method op_fit_tucker = {
    .method = OP_METHOD_TUCKER,
    .options = 0,
    .albedo = 1,
    .terms_help = "",
    .defaults = tucker_defaults,
    .describe = NULL,
    .fit = tucker_fit,
};
