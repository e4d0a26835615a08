/* dataset_generate.h - a dataset from its spec: the generator the spec names, run in blocks of
 * rows and checked. */
#ifndef OP_DATASET_GENERATE_H
#define OP_DATASET_GENERATE_H

#include "dataset.h"
#include "dataset_montecarlo.h"

/* The memory op_dataset_generate_file holds for the values of a block (Rd and standard
 * errors, all channels), whatever the dataset's size (at least one row). */
#define OP_DATASET_BLOCK_BYTES ((uint64_t)64 << 20)

/* Checks spec, runs its generator into out (allocated here; freed again on failure) and checks
 * the energy invariants of the result. With the Monte Carlo generator, fills *mc_stats when it
 * is not NULL. */
op_status op_dataset_generate(const op_dataset_spec *spec, op_dataset *out,
                              op_mc_stats *mc_stats, op_error *err);
/* The same dataset written to path as a raw material (op_dataset_writer), generated and written
 * in blocks of rows: memory stays within OP_DATASET_BLOCK_BYTES plus the generator's tables,
 * and the file's bytes are those of op_dataset_write on op_dataset_generate's result. */
op_status op_dataset_generate_file(const op_dataset_spec *spec, const char *path,
                                   op_mc_stats *mc_stats, op_error *err);

#endif
