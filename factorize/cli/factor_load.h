/* factor_load.h - the dataset of `opaline-factor factor`: opened, its sections found and, unless
 * the method counts them itself in its first pass, its values checked. */
#ifndef OP_FACTOR_LOAD_H
#define OP_FACTOR_LOAD_H

#include "fit.h"
#include "opaline.h"
#include "report.h"

/* Opens a->input into ds (whole, or streamed in passes of rows when it is larger than half the
 * physical memory or --block-rows asks: ds->block_rows) and finds its channels. Non-finite
 * values are an error naming the first, unless a->sanitize (they then count as 0); rep gets
 * the counts and the dataset's CRC. ds->file, when set, is the caller's to close, failure or
 * not. */
op_status op_factor_load(const factor_args *a, dataset *ds, op_factor_report *rep, op_error *err);

#endif
