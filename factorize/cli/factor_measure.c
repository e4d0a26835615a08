/* factor_measure.c - a new material's errors against its dataset (factor_measure.h). */
#include "factor_measure.h"
#include "opaline.h"
#include "opaline_material.h"

#include <math.h>
#include <stdlib.h>

/* One read-back, in tasks of rows of one channel. */
typedef struct eval_job {
    const op_material *m;
    const dataset *ds;
    int64_t rows_per_task;
    int tasks_per_channel;
    float *rowbuf;         /* one row of cols floats per thread */
    op_error_accum *parts; /* per task */
    float *albedo;
    op_progress *prog;
} eval_job;

/* Evaluates one block of rows of one channel against the dataset (one op_parallel_for task). */
static void eval_task(void *user, int task, int thread)
{
    const eval_job *j = user;
    const dataset *ds = j->ds;
    int c = task / j->tasks_per_channel, w = ds->info.width;
    int64_t r0 = (int64_t)(task % j->tasks_per_channel) * j->rows_per_task;
    int64_t r1 = r0 + j->rows_per_task < ds->rows ? r0 + j->rows_per_task : ds->rows;
    float *row = j->rowbuf + (size_t)thread * (size_t)ds->cols;
    for (int64_t r = r0; r < r1; r++) {
        op_material_eval_row(j->m, c, (int)(r % w), (int)(r / w), row);
        op_error_accum_add(&j->parts[task], ds->rd[c] + r * ds->cols, row, ds->cols);
        double sum = 0;
        for (int k = 0; k < ds->cols; k++)
            sum += row[k];
        j->albedo[c * ds->rows + r] = (float)sum;
    }
    if (ds->block_rows)
        op_material_release(ds->file, ds->rd[c] + r0 * ds->cols,
                            (size_t)(r1 - r0) * (size_t)ds->cols * sizeof(float));
    op_progress_advance(j->prog, (uint64_t)(r1 - r0));
}

op_status op_factor_measure(const char *path, const dataset *ds, int threads,
                            op_factor_report *rep, float *albedo, op_error *err)
{
    op_material *m;
    op_status st = op_material_open(path, &m, err);
    if (st != OP_OK)
        return op_error_prefix(err, "reading back the new material: ");
    /* Fixed blocks of rows, merged in order: the figures do not depend on the thread count. */
    eval_job j = {.m = m, .ds = ds, .albedo = albedo};
    j.rows_per_task = 1 + (int64_t)(262144 / ds->cols);
    j.tasks_per_channel = (int)((ds->rows + j.rows_per_task - 1) / j.rows_per_task);
    int tasks = j.tasks_per_channel * ds->info.channels;
    int nthreads = op_parallel_threads(threads);
    j.rowbuf = malloc((size_t)nthreads * (size_t)ds->cols * sizeof *j.rowbuf);
    j.parts = calloc((size_t)tasks, sizeof *j.parts);
    if (!j.rowbuf || !j.parts)
        st = op_error_set(err, OP_ERR_NOMEM, "out of memory");
    j.prog = op_progress_begin("evaluate", (uint64_t)ds->info.channels * (uint64_t)ds->rows,
                               NULL, NULL);
    if (st == OP_OK)
        st = op_parallel_for(nthreads, tasks, eval_task, &j, NULL, err);
    op_progress_end(j.prog);
    op_error_accum acc = {0};
    for (int t = 0; st == OP_OK && t < tasks; t++)
        op_error_accum_merge(&acc, &j.parts[t]);
    op_error_accum_finish(&acc, rep);
    free(j.rowbuf);
    free(j.parts);
    op_material_close(m);
    for (int64_t i = 0; st == OP_OK && i < ds->rows * ds->info.channels; i++)
        if (!isfinite(albedo[i]))
            return op_error_set(err, OP_ERR_NUMERIC, "albedo of row %lld is not finite",
                                (long long)(i % ds->rows));
    return st;
}
