/* factor_measure.h - how close a new material is to its dataset: every row read back through
 * libopaline and compared. */
#ifndef OP_FACTOR_MEASURE_H
#define OP_FACTOR_MEASURE_H

#include "fit.h"
#include "opaline.h"
#include "report.h"

/* Opens the material at path and compares every row with ds on `threads` threads (0: all
 * cores), in fixed blocks of rows merged in order, so that the figures do not depend on the
 * thread count; fills the error figures of rep and the albedo map (channels x rows floats,
 * each row's sum). A streamed ds has each block's pages released after. */
op_status op_factor_measure(const char *path, const dataset *ds, int threads,
                            op_factor_report *rep, float *albedo, op_error *err);

#endif
