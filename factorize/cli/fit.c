/* fit.c - the helpers the methods' fits share (fit.h): allocation, a channel's preprocessing,
 * and what a fit's own count of the dataset's values means for the command. */
#include "fit.h"
#include "preprocess.h"

#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>

void *op_fit_alloc(uint64_t bytes)
{
    return bytes > (uint64_t)SIZE_MAX ? NULL : malloc(bytes ? (size_t)bytes : 1);
}

op_status op_fit_matrix(const dataset *ds, float **mat, op_error *err)
{
    *mat = op_fit_alloc((uint64_t)ds->rows * (uint64_t)ds->cols * sizeof **mat);
    if (!*mat)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for a %lld x %d matrix",
                            (long long)ds->rows, ds->cols);
    return OP_OK;
}

/* Allocates the per-row shifts and maxima of ds into *shift and *max when a->shift; else sets
 * both NULL. */
static op_status alloc_peaks(const factor_args *a, const dataset *ds, uint32_t **shift,
                             float **max, op_error *err)
{
    *shift = NULL;
    *max = NULL;
    if (!a->shift)
        return OP_OK;
    *shift = op_fit_alloc((uint64_t)ds->rows * sizeof **shift);
    *max = op_fit_alloc((uint64_t)ds->rows * sizeof **max);
    if (!*shift || !*max) {
        free(*shift);
        free(*max);
        *shift = NULL;
        *max = NULL;
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    }
    return OP_OK;
}

op_status op_fit_nonfinite_error(const factor_args *a, const dataset *ds, int c,
                                 const op_prep_counts *n, op_error *err)
{
    char tag[16];
    op_channel_tag(tag, sizeof tag, "RD.", &ds->info, c);
    int64_t i = n->first_nonfinite;
    float v = ds->rd[c][i];
    return op_error_set(err, OP_ERR_INPUT,
                        "%s: section '%s' value %lld (row %lld, column %lld) is %s; %llu values "
                        "are not finite (--sanitize replaces them by 0)",
                        a->input, tag, (long long)i, (long long)(i / ds->cols),
                        (long long)(i % ds->cols), isnan(v) ? "NaN" : "infinite",
                        (unsigned long long)n->nonfinite);
}

void op_fit_log_counts(const factor_args *a, const op_factor_report *rep)
{
    if (rep->nonfinite_replaced)
        op_log(OP_LOG_WARN, "%s: replaced %llu non-finite values by 0 (--sanitize)", a->input,
               (unsigned long long)rep->nonfinite_replaced);
    if (rep->negative_values)
        op_log(OP_LOG_INFO, "%s: %llu negative values (noise) are factored as 0", a->input,
               (unsigned long long)rep->negative_values);
}

op_status op_fit_channel_nonfinite(const factor_args *a, const dataset *ds, int c,
                                   uint64_t nonfinite, uint64_t negative, op_factor_report *rep,
                                   op_error *err)
{
    op_status st = op_fit_counted(a, ds, nonfinite, negative, rep, err);
    if (st == OP_OK) /* not found again: cannot happen to a read-only mapping */
        st = op_error_set(err, OP_ERR_INPUT, "%s: channel %d holds non-finite values", a->input,
                          c);
    return st;
}

op_status op_fit_counted(const factor_args *a, const dataset *ds, uint64_t nonfinite,
                         uint64_t negative, op_factor_report *rep, op_error *err)
{
    for (int c = 0; nonfinite && !a->sanitize && c < ds->info.channels; c++) {
        op_prep_counts n; /* the first channel holding one names it */
        op_prep_scan(ds->rd[c], (uint64_t)ds->rows * (uint64_t)ds->cols, &n);
        if (n.nonfinite)
            return op_fit_nonfinite_error(a, ds, c, &n, err);
    }
    rep->nonfinite_replaced += nonfinite;
    rep->negative_values += negative;
    op_fit_log_counts(a, rep);
    return OP_OK;
}

typedef struct prep_counted {
    op_prep_source src;
    float *mat;
    int64_t rows_per_task;
} prep_counted;

static void prep_counted_task(void *user, int task, int thread)
{
    prep_counted *p = user;
    int64_t r0 = (int64_t)task * p->rows_per_task;
    int64_t n = p->src.rows - r0 < p->rows_per_task ? p->src.rows - r0 : p->rows_per_task;
    (void)thread;
    /* a non-finite value shows in the counts, which the caller checks */
    op_prep_fetch(&p->src, r0, n, p->mat + r0 * p->src.cols, NULL);
}

op_status op_fit_prepare_channel(const factor_args *a, const dataset *ds, int c, float *mat,
                                 uint32_t **shift, float **max, uint64_t *nonfinite,
                                 uint64_t *negative, op_error *err)
{
    op_status st = alloc_peaks(a, ds, shift, max, err);
    if (st != OP_OK)
        return st;
    if (ds->block_rows) /* the command counted the values */
        st = op_prep_rows(ds->rd[c], ds->rows, ds->cols, *shift, *max, 0, a->log_b,
                          a->threads, mat, err);
    else {
        /* Blocks of about 256 KiB, as op_prep_rows's. */
        int64_t per = (int64_t)(65536 / (ds->cols > 0 ? ds->cols : 1));
        prep_counted p = {.src = {.src = ds->rd[c], .rows = ds->rows, .cols = ds->cols,
                                  .shift = *shift, .max = *max, .log_a = 0,
                                  .log_b = a->log_b, .sanitize = a->sanitize},
                          .mat = mat, .rows_per_task = per > 0 ? per : 1};
        atomic_init(&p.src.nonfinite, 0);
        atomic_init(&p.src.negative, 0);
        int64_t tasks = (ds->rows + p.rows_per_task - 1) / p.rows_per_task;
        while (tasks > 1 << 30) {
            p.rows_per_task *= 2;
            tasks = (ds->rows + p.rows_per_task - 1) / p.rows_per_task;
        }
        st = op_parallel_for(a->threads, (int)tasks, prep_counted_task, &p, NULL, err);
        *nonfinite = atomic_load(&p.src.nonfinite);
        *negative = atomic_load(&p.src.negative);
        if (st == OP_OK && *nonfinite && !a->sanitize)
            st = OP_ERR_INPUT;
    }
    if (st != OP_OK) {
        free(*shift);
        free(*max);
        *shift = NULL;
        *max = NULL;
    }
    return st;
}
