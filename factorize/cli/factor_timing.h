/* factor_timing.h - how fast a new material evaluates, for the factor report. */
#ifndef OP_FACTOR_TIMING_H
#define OP_FACTOR_TIMING_H

#include "opaline.h"
#include "opaline_material.h"
#include "report.h"

/* Times op_material_eval of m at pseudo-random arguments, coherent (64 offsets per incident
 * pixel, as a renderer gathers a kernel) and random (every argument independent), each the
 * median of 3 passes of 65536 calls, and op_material_albedo_map of m: rep's eval_ns,
 * eval_random_ns and albedo_map_seconds. */
op_status op_factor_time_eval(const op_material *m, op_factor_report *rep, op_error *err);

#endif
