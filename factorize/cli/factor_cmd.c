/* factor_cmd.c - `opaline-factor factor`: the steps in order, each timed into the report: read
 * the arguments (factor_args.c) and the dataset (factor_load.c), run the method's entry of the
 * method table (fit_table.h) into a new material, read it back to measure its errors
 * (factor_measure.c) and speed (factor_timing.c), then put the material, the report and the
 * albedo thumbnail (albedo_png.c) in place together. */
#include "albedo_png.h"
#include "commands.h"
#include "factor_args.h"
#include "factor_load.h"
#include "factor_measure.h"
#include "factor_timing.h"
#include "fit_table.h"
#include "opaline.h"
#include "opaline_material.h"
#include "opaline_material_write.h"
#include "report.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

/* Every output writable and none of them another or the dataset, before any work. */
static op_status check_outputs(const factor_args *a, op_error *err)
{
    const char *outputs[3] = {a->output}, *inputs[1] = {a->input};
    int noutputs = 1;
    if (a->report)
        outputs[noutputs++] = a->report;
    if (a->albedo_png)
        outputs[noutputs++] = a->albedo_png;
    return op_output_check(outputs, noutputs, inputs, 1, err);
}

/* The META of the material fm makes of ds: the dataset's, with the method's fields (-T lowered
 * to the rank bound) and the dataset's CRC. */
static op_status describe_material(const factor_args *a, const dataset *ds, const fit_method *fm,
                                   uint32_t dataset_crc, op_material_info *info, op_error *err)
{
    int64_t mn = ds->rows < ds->cols ? ds->rows : ds->cols;
    int terms = a->terms;
    if (terms > mn) {
        op_log(OP_LOG_WARN, "-T %d exceeds the rank bound min(rows, columns) = %lld; using %lld",
               terms, (long long)mn, (long long)mn);
        terms = (int)mn;
    }
    *info = ds->info;
    info->method = a->method;
    info->terms = terms;
    info->degree = a->degree;
    info->clusters = 0;
    info->shifted = a->shift;
    info->log_a = info->log_b = 0.0;
    info->dataset_crc = dataset_crc;
    op_status st = fm->describe ? fm->describe(a, ds, info, err) : OP_OK;
    if (st != OP_OK)
        return st;
    if (a->name)
        snprintf(info->name, sizeof info->name, "%s", a->name);
    for (char *p = info->name; *p; p++) /* META is one key=value per line */
        if (*p == '\n' || *p == '\r')
            *p = ' ';
    return OP_OK;
}

/* What the report says the material is, from its META (rep->size_bytes already set). */
static void describe_report(const factor_args *a, const dataset *ds,
                            const op_material_info *info, op_factor_report *rep)
{
    snprintf(rep->name, sizeof rep->name, "%s", info->name);
    snprintf(rep->method, sizeof rep->method, "%s", op_method_name(a->method));
    snprintf(rep->input, sizeof rep->input, "%s", a->input);
    snprintf(rep->output, sizeof rep->output, "%s", a->output);
    rep->width = info->width;
    rep->height = info->height;
    rep->kernel = info->kernel;
    rep->channels = info->channels;
    rep->terms = info->terms;
    rep->degree = info->degree;
    rep->shifted = info->shifted;
    rep->log_a = info->log_a;
    rep->log_b = info->log_b;
    rep->original_bytes =
        (uint64_t)ds->rows * (uint64_t)ds->cols * (uint64_t)ds->info.channels * 4u;
    rep->compression_ratio = (double)rep->original_bytes / (double)rep->size_bytes;
}

static int fail(op_status st, const op_error *err)
{
    op_log(OP_LOG_ERROR, "%s", err->message);
    return op_exit_code(st);
}

int op_cmd_factor(int argc, char **argv)
{
    for (int i = 1; i < argc; i++)
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            op_factor_usage(stdout);
            return 0;
        }
    op_error err = {0};
    factor_args a;
    op_status st = op_factor_parse_args(argc, argv, &a, &err);
    if (st != OP_OK) {
        op_factor_usage(stderr);
        return fail(st, &err);
    }
    if ((st = check_outputs(&a, &err)) != OP_OK)
        return fail(st, &err);
    double t0 = op_monotonic_seconds(), t = t0;
    op_factor_report rep = {0};
    dataset ds = {0};
    float *albedo = NULL;
    op_material_writer *writer = NULL;
    op_output *report = NULL;
    st = op_factor_load(&a, &ds, &rep, &err);
    if (st != OP_OK)
        goto done;
    op_report_stage(&rep, "load", op_monotonic_seconds() - t);

    const fit_method *fm = op_fit_find(a.method);
    op_material_info info;
    if ((st = describe_material(&a, &ds, fm, rep.dataset_crc, &info, &err)) != OP_OK)
        goto done;
    /* Opened before the work, so that an output that cannot be written fails at once. */
    if ((st = op_material_writer_open(a.output, &info, &writer, &err)) != OP_OK)
        goto done;
    t = op_monotonic_seconds();
    fit_job job = {.a = &a, .ds = &ds, .info = &info, .w = writer, .rep = &rep};
    if ((st = fm->fit(&job, &err)) != OP_OK)
        goto done;
    if (job.prep_seconds > 0)
        op_report_stage(&rep, "preprocess", job.prep_seconds);
    op_report_stage(&rep, "factor", op_monotonic_seconds() - t - job.prep_seconds);

    /* The fit wrote its sections; complete the file without the albedo map and read it back
     * (still under its temporary name) to measure it and the errors; then add the map. Every
     * output is put in place only at the end, the material last: an interruption or a failure
     * before leaves the old files. */
    t = op_monotonic_seconds();
    uint64_t albedo_count = (uint64_t)ds.rows * (uint64_t)ds.info.channels;
    albedo = op_fit_alloc(albedo_count * sizeof *albedo);
    if (!albedo) {
        st = op_error_set(&err, OP_ERR_NOMEM, "out of memory");
        goto done;
    }
    const char *pending;
    if ((st = op_material_writer_finish(writer, &pending, &err)) != OP_OK)
        goto done;
    op_report_stage(&rep, "write", op_monotonic_seconds() - t);
    t = op_monotonic_seconds();
    st = op_factor_measure(pending, &ds, a.threads, &rep, albedo, &err);
    if (st != OP_OK)
        goto done;
    op_report_stage(&rep, "evaluate", op_monotonic_seconds() - t);
    t = op_monotonic_seconds();
    if (fm->albedo && ((st = op_write_albedo(writer, &info, albedo, &err)) != OP_OK ||
                       (st = op_material_writer_finish(writer, &pending, &err)) != OP_OK))
        goto done;
    op_report_stage(&rep, "finish", op_monotonic_seconds() - t);

    op_material *out;
    if ((st = op_material_open(pending, &out, &err)) != OP_OK) {
        op_error_prefix(&err, "reading back the new material: ");
        goto done;
    }
    rep.size_bytes = op_material_file_size(out);
    st = op_factor_time_eval(out, &rep, &err);
    op_material_close(out);
    if (st != OP_OK)
        goto done;
    describe_report(&a, &ds, &info, &rep);
    rep.total_seconds = op_monotonic_seconds() - t0;
    rep.peak_memory_bytes = op_peak_memory_bytes();
    op_report_print(&rep, stdout);
    if (fflush(stdout) != 0 || ferror(stdout)) {
        st = op_error_set(&err, OP_ERR_IO, "stdout: cannot write the report: %s",
                          strerror(errno ? errno : EIO));
        goto done;
    }
    /* The png, the report and the material are put in place together, or none of them. */
    op_output_group_begin();
    if (a.report && (st = op_report_write_json(&rep, a.report, &report, &err)) != OP_OK)
        goto done;
    if (a.albedo_png && (st = op_albedo_png_write(a.albedo_png, &ds, albedo, &err)) != OP_OK)
        goto done;
    if (report) {
        st = op_output_commit(report, &err);
        report = NULL;
        if (st != OP_OK)
            goto done;
    }
    st = op_material_writer_commit(writer, &err);
    writer = NULL;
    if (st == OP_OK)
        st = op_output_group_commit(&err);

done:
    op_output_group_abort(); /* what a failure left pending; nothing after a commit */
    op_output_abort(report);
    op_material_writer_abort(writer);
    free(albedo);
    op_material_close(ds.file);
    return st == OP_OK ? 0 : fail(st, &err);
}
