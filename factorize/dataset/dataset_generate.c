/* dataset_generate.c - runs the generator a dataset spec names (see dataset_generate.h). Apart
 * from dataset.c, whose spec and storage the generators use. */
#include "dataset_generate.h"

#include <stdio.h>
#include <string.h>

#include "dataset_diffusion.h"

op_status op_dataset_generate(const op_dataset_spec *spec, op_dataset *out,
                              op_mc_stats *mc_stats, op_error *err)
{
    memset(out, 0, sizeof *out);
    op_status st = op_dataset_spec_check(spec, err);
    if (st != OP_OK)
        return st;
    op_layout layout;
    st = op_dataset_layout(spec, &layout, err);
    if (st != OP_OK)
        return st;
    layout.eta = spec->eta;
    char etas[48];
    double e0 = op_layout_eta(&layout, 0), e1 = op_layout_eta(&layout, 1);
    if (e0 == e1)
        snprintf(etas, sizeof etas, "%.2g", e0);
    else
        snprintf(etas, sizeof etas, "%.2g,%.2g", e0, e1);
    st = op_dataset_alloc(out, spec->width, spec->height, spec->kernel,
                          spec->generator == OP_GEN_MONTECARLO, err);
    if (st == OP_OK) {
        out->size_x_cm = spec->size_x_cm;
        out->size_y_cm = spec->size_y_cm;
        snprintf(out->name, sizeof out->name, "%s", spec->name);
        if (spec->generator == OP_GEN_MONTECARLO) {
            op_mc_options o = {.photons = spec->photons, .seed = spec->seed,
                               .threads = spec->threads, .progress = spec->progress,
                               .progress_user = spec->progress_user};
            op_mc_stats stats;
            st = op_mc_generate(&layout, &o, out, mc_stats ? mc_stats : &stats, err);
            snprintf(out->generator, sizeof out->generator,
                     "montecarlo photons=%llu seed=%llu media=%s,%s eta=%s",
                     (unsigned long long)spec->photons, (unsigned long long)spec->seed,
                     spec->media[0]->name, spec->media[1]->name, etas);
        } else {
            st = op_diffusion_generate(&layout, spec->threads, spec->progress,
                                       spec->progress_user, out, err);
            snprintf(out->generator, sizeof out->generator,
                     "diffusion dipole-segment media=%s,%s eta=%s", spec->media[0]->name,
                     spec->media[1]->name, etas);
        }
    }
    if (st == OP_OK && op_dataset_check(out, err) != OP_OK) {
        op_error_prefix(err, "%s generator broke an energy invariant (a bug): ",
                        spec->generator == OP_GEN_MONTECARLO ? "montecarlo" : "diffusion");
        st = OP_ERR_INTERNAL;
        if (err)
            err->status = st;
    }
    if (st != OP_OK)
        op_dataset_free(out);
    op_layout_free(&layout);
    return st;
}
