/* dataset_generate.c - runs the generator a dataset spec names, block by block (see
 * dataset_generate.h). Apart from dataset.c, whose spec and storage the generators use. */
#include "dataset_generate.h"

#include <stdio.h>
#include <string.h>

#include "dataset_diffusion.h"

/* Generates spec's rows into block (allocated for its capacity of nrows rows, with standard
 * errors for Monte Carlo), block after block, each checked and, with a writer, written. */
static op_status generate(const op_dataset_spec *spec, op_dataset *block,
                          op_dataset_writer *writer, op_mc_stats *mc_stats, op_error *err)
{
    op_layout layout;
    op_status st = op_dataset_layout(spec, &layout, err);
    if (st != OP_OK)
        return st;
    layout.eta = spec->eta;
    int mc = spec->generator == OP_GEN_MONTECARLO;
    uint64_t rows = op_dataset_rows(block), capacity = block->nrows;
    op_progress *progress = op_progress_begin(mc ? "montecarlo" : "diffusion", (mc ? 3 : 1) * rows,
                                              spec->progress, spec->progress_user);
    op_mc_options o = {.photons = spec->photons, .seed = spec->seed, .threads = spec->threads,
                       .progress = progress};
    op_mc_stats stats;
    op_diffusion *diffusion = NULL;
    if (!mc)
        st = op_diffusion_begin(&layout, spec->kernel, &diffusion, err);
    for (uint64_t r0 = 0; r0 < rows && st == OP_OK; r0 += capacity) {
        block->row0 = r0;
        block->nrows = rows - r0 < capacity ? rows - r0 : capacity;
        if (mc)
            st = op_mc_generate(&layout, &o, block, mc_stats ? mc_stats : &stats, err);
        else
            st = op_diffusion_fill(diffusion, spec->threads, progress, block, err);
        if (st == OP_OK && op_dataset_check(block, err) != OP_OK) {
            op_error_prefix(err, "%s generator broke an energy invariant (a bug): ",
                            mc ? "montecarlo" : "diffusion");
            st = OP_ERR_INTERNAL;
            if (err)
                err->status = st;
        }
        if (st == OP_OK && writer)
            st = op_dataset_writer_add(writer, block, err);
    }
    op_progress_end(progress);
    op_diffusion_end(diffusion);
    op_layout_free(&layout);
    return st;
}

/* The block's dataset fields (size, name, generator text) from spec. */
static void describe(const op_dataset_spec *spec, op_dataset *d)
{
    d->size_x_cm = spec->size_x_cm;
    d->size_y_cm = spec->size_y_cm;
    snprintf(d->name, sizeof d->name, "%s", spec->name);
    const op_medium *a = spec->media[0], *b = spec->media[1];
    /* diffusion gives the sample the base medium's index (dataset_diffusion.h) */
    double e0 = spec->eta ? spec->eta : a->eta, e1 = spec->eta ? spec->eta : b->eta;
    if (spec->generator != OP_GEN_MONTECARLO)
        e1 = e0;
    char etas[48];
    if (e0 == e1)
        snprintf(etas, sizeof etas, "%.2g", e0);
    else
        snprintf(etas, sizeof etas, "%.2g,%.2g", e0, e1);
    if (spec->generator == OP_GEN_MONTECARLO)
        snprintf(d->generator, sizeof d->generator,
                 "montecarlo photons=%llu seed=%llu media=%s,%s eta=%s",
                 (unsigned long long)spec->photons, (unsigned long long)spec->seed, a->name,
                 b->name, etas);
    else
        snprintf(d->generator, sizeof d->generator, "diffusion dipole-segment media=%s,%s eta=%s",
                 a->name, b->name, etas);
}

op_status op_dataset_generate(const op_dataset_spec *spec, op_dataset *out,
                              op_mc_stats *mc_stats, op_error *err)
{
    memset(out, 0, sizeof *out);
    op_status st = op_dataset_spec_check(spec, err);
    if (st == OP_OK)
        st = op_dataset_alloc(out, spec->width, spec->height, spec->kernel,
                              spec->generator == OP_GEN_MONTECARLO, err);
    if (st != OP_OK)
        return st;
    describe(spec, out);
    st = generate(spec, out, NULL, mc_stats, err);
    out->row0 = 0;
    out->nrows = op_dataset_rows(out);
    if (st != OP_OK)
        op_dataset_free(out);
    return st;
}

op_status op_dataset_generate_file(const op_dataset_spec *spec, const char *path,
                                   op_mc_stats *mc_stats, op_error *err)
{
    op_status st = op_dataset_spec_check(spec, err);
    if (st != OP_OK)
        return st;
    int mc = spec->generator == OP_GEN_MONTECARLO;
    uint64_t row_bytes = (uint64_t)spec->kernel * (uint64_t)spec->kernel * 4 * 3 * (mc ? 2 : 1);
    uint64_t rows = (uint64_t)spec->width * (uint64_t)spec->height;
    uint64_t capacity = OP_DATASET_BLOCK_BYTES / row_bytes;
    capacity = capacity < 1 ? 1 : capacity > rows ? rows : capacity;
    op_dataset block;
    st = op_dataset_alloc_block(&block, spec->width, spec->height, spec->kernel, mc, capacity,
                                err);
    if (st != OP_OK)
        return st;
    describe(spec, &block);
    op_dataset_writer *w;
    st = op_dataset_writer_open(path, &block, mc, &w, err);
    if (st == OP_OK) {
        st = generate(spec, &block, w, mc_stats, err);
        if (st == OP_OK)
            st = op_dataset_writer_commit(w, err);
        else
            op_dataset_writer_abort(w);
    }
    op_dataset_free(&block);
    return st;
}
