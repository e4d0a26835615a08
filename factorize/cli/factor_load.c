/* factor_load.c - reading the dataset of `opaline-factor factor` (factor_load.h). */
#include "factor_load.h"
#include "fit_table.h"
#include "opaline.h"
#include "opaline_material.h"
#include "preprocess.h"

#include <string.h>
#include <unistd.h>

/* Rows per pass over the dataset for a: 0 when it is read whole. */
static int64_t stream_rows(const factor_args *a, uint64_t file_bytes, int cols)
{
    if (a->block_rows >= 0 || !(op_fit_find(a->method)->options & FIT_OPT_BLOCK_ROWS) ||
        a->svd.exact)
        return a->block_rows > 0 ? a->block_rows : 0;
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    if (pages <= 0 || page <= 0 || file_bytes <= (uint64_t)pages * (uint64_t)page / 2)
        return 0;
    int64_t rows = ((int64_t)64 << 20) / ((int64_t)cols * (int64_t)sizeof(float));
    return rows > 0 ? rows : 1;
}

/* op_prep_scan of channel c; streaming, in passes whose pages are released after. */
static void scan_channel(const dataset *ds, int c, op_prep_counts *n)
{
    uint64_t count = (uint64_t)ds->rows * (uint64_t)ds->cols;
    if (!ds->block_rows) {
        op_prep_scan(ds->rd[c], count, n);
        return;
    }
    uint64_t per = (uint64_t)ds->block_rows * (uint64_t)ds->cols;
    memset(n, 0, sizeof *n);
    n->first_nonfinite = -1;
    for (uint64_t at = 0; at < count; at += per) {
        uint64_t len = count - at < per ? count - at : per;
        op_prep_counts part;
        op_prep_scan(ds->rd[c] + at, len, &part);
        if (n->first_nonfinite < 0 && part.first_nonfinite >= 0)
            n->first_nonfinite = (int64_t)at + part.first_nonfinite;
        n->nonfinite += part.nonfinite;
        n->negative += part.negative;
        op_material_release(ds->file, ds->rd[c] + at, len * sizeof(float));
    }
}

op_status op_factor_load(const factor_args *a, dataset *ds, op_factor_report *rep, op_error *err)
{
    uint64_t file_bytes = 0;
    int fd;
    op_status st = op_file_open(a->input, &fd, &file_bytes, err);
    if (st != OP_OK)
        return st;
    close(fd);
    /* Whether to stream is decided from the file's size, before it is read: a whole read of a
     * file larger than memory is what streaming avoids. */
    int stream = stream_rows(a, file_bytes, 1) > 0;
    st = stream ? op_material_open_streaming(a->input, &ds->file, err)
                : op_material_open_container(a->input, &ds->file, err);
    if (st != OP_OK)
        return st;
    ds->info = *op_material_get_info(ds->file);
    if (ds->info.method != OP_METHOD_RAW)
        return op_error_set(err, OP_ERR_INPUT, "%s: is a %s material, not a dataset (method raw)",
                            a->input, op_method_name(ds->info.method));
    ds->rows = op_material_rows(ds->file);
    ds->cols = op_material_cols(ds->file);
    ds->block_rows = stream ? stream_rows(a, file_bytes, ds->cols) : 0;
    if (ds->block_rows)
        op_log(OP_LOG_INFO, "%s: read in passes of %lld rows (%.1f MiB), never whole in memory",
               a->input, (long long)ds->block_rows,
               (double)ds->block_rows * ds->cols * sizeof(float) / 1048576.0);
    uint64_t count = (uint64_t)ds->rows * (uint64_t)ds->cols;
    uint32_t crc = 0;
    /* a method that counts the values in its first pass over them spares a pass here */
    int counted = op_fit_find(a->method)->counts_values && !ds->block_rows;
    for (int c = 0; c < ds->info.channels; c++) {
        char tag[16];
        uint64_t bytes = 0;
        op_channel_tag(tag, sizeof tag, OP_RAW_SECTION, &ds->info, c);
        ds->rd[c] = op_material_section(ds->file, tag, &bytes);
        if (!ds->rd[c])
            return op_error_set(err, OP_ERR_FORMAT, "%s: section '%s' is missing", a->input, tag);
        if (bytes != count * sizeof(float))
            return op_error_set(err, OP_ERR_FORMAT, "%s: section '%s' holds %llu bytes, expected "
                                "%llu", a->input, tag, (unsigned long long)bytes,
                                (unsigned long long)(count * sizeof(float)));
        /* The dataset's CRC from its sections' verified ones: no second pass over the data. */
        crc = op_crc32_combine(crc, op_material_section_crc(ds->file, tag), bytes);
        if (counted)
            continue;
        op_prep_counts n;
        scan_channel(ds, c, &n);
        if (n.nonfinite && !a->sanitize)
            return op_fit_nonfinite_error(a, ds, c, &n, err);
        rep->nonfinite_replaced += n.nonfinite;
        rep->negative_values += n.negative;
    }
    if (!counted)
        op_fit_log_counts(a, rep);
    rep->dataset_crc = crc;
    return OP_OK;
}
