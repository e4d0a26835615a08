/* fit.c - the helpers the methods' fits share (fit.h): allocation and a channel's
 * preprocessing. */
#include "fit.h"
#include "preprocess.h"

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

op_status op_fit_prepare_channel(const factor_args *a, const dataset *ds, int c, int with_log,
                                 float *mat, uint32_t **shift, float **max, op_error *err)
{
    int64_t rows = ds->rows;
    *shift = NULL;
    *max = NULL;
    if (a->shift) {
        *shift = op_fit_alloc((uint64_t)rows * sizeof **shift);
        *max = op_fit_alloc((uint64_t)rows * sizeof **max);
        if (!*shift || !*max) {
            free(*shift);
            free(*max);
            *shift = NULL;
            *max = NULL;
            return op_error_set(err, OP_ERR_NOMEM, "out of memory");
        }
    }
    op_status st = op_prep_rows(ds->rd[c], rows, ds->cols, *shift, *max, with_log ? a->log_a : 0,
                                a->log_b, a->threads, mat, err);
    if (st != OP_OK) {
        free(*shift);
        free(*max);
        *shift = NULL;
        *max = NULL;
    }
    return st;
}
