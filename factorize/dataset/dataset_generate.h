/* dataset_generate.h - a dataset from its spec: the generator the spec names, run and checked. */
#ifndef OP_DATASET_GENERATE_H
#define OP_DATASET_GENERATE_H

#include "dataset.h"
#include "dataset_montecarlo.h"

/* Checks spec, runs its generator into out (allocated here; freed again on failure) and checks
 * the energy invariants of the result. With the Monte Carlo generator, fills *mc_stats when it
 * is not NULL. */
op_status op_dataset_generate(const op_dataset_spec *spec, op_dataset *out,
                              op_mc_stats *mc_stats, op_error *err);

#endif
