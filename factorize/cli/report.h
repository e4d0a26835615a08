/* report.h - the factor report: how close a material is to its dataset, how large it is and
 * what producing it cost. Printed after every run and written as JSON (docs/formats.md lists
 * the keys). */
#ifndef OP_FACTOR_REPORT_H
#define OP_FACTOR_REPORT_H

#include "opaline.h"

#define OP_REPORT_MAX_STAGES 8

typedef struct op_factor_report {
    char name[128], method[16], input[1024], output[1024];
    int width, height, kernel, channels, terms, degree, shifted;
    double log_a, log_b;
    uint32_t dataset_crc;
    /* Errors against the dataset over every channel, row and column (non-finite dataset values
     * count as the 0 they were replaced by). */
    double rmse;          /* sqrt(mean((R - R^)^2)) */
    double relative_rmse; /* ||R - R^||_F / ||R||_F (0 when R is 0) */
    double psnr;          /* 20 log10(max |R| / rmse) dB; infinite when exact (written as null) */
    double max_error;     /* max |R - R^| */
    uint64_t size_bytes;  /* the material file */
    uint64_t original_bytes; /* the dataset's Rd values: rows * K^2 * channels * 4 */
    double compression_ratio; /* original_bytes / size_bytes */
    uint64_t nonfinite_replaced, negative_values;
    int nstages;
    char stage_name[OP_REPORT_MAX_STAGES][16];
    double stage_seconds[OP_REPORT_MAX_STAGES];
    double total_seconds;
    uint64_t peak_memory_bytes; /* peak resident set size of this process image (VmHWM) */
    double eval_ns;        /* mean time of one op_material_eval on the written material, 64
                              offsets per incident pixel (a renderer's access pattern) */
    double eval_random_ns; /* the same with every argument random (cache misses dominate) */
    double albedo_map_seconds;  /* time of op_material_albedo_map on it */
    /* The colour regression's conditioning (tucker only, has_fit 0 otherwise): the largest
     * condition number of a kept fit, the largest coefficient, and the relative RMS change that
     * storing the coefficients as float32 makes (||stored - double fit|| / ||data||). */
    int has_fit;
    double fit_condition, fit_coef_max, fit_storage_error;
} op_factor_report;

/* Records a stage's duration (ignored beyond OP_REPORT_MAX_STAGES). */
void op_report_stage(op_factor_report *r, const char *name, double seconds);
/* Peak resident set size of this process in bytes. */
uint64_t op_peak_memory_bytes(void);
/* Accumulates error statistics row by row: call add for every (reference, approximation) row,
 * then finish. */
typedef struct op_error_accum {
    double sum_sq_err, sum_sq_ref, max_err, max_ref;
    uint64_t count;
} op_error_accum;
void op_error_accum_add(op_error_accum *acc, const float *ref, const float *approx, int n);
/* Adds the statistics of part (rows accumulated separately, e.g. by another thread) to acc. */
void op_error_accum_merge(op_error_accum *acc, const op_error_accum *part);
void op_error_accum_finish(const op_error_accum *acc, op_factor_report *r);
/* Human-readable report to f. */
void op_report_print(const op_factor_report *r, FILE *f);
/* Writes the JSON report into a new op_output on path, returned in *pending for the caller to
 * commit (or abort); NULL on failure. */
op_status op_report_write_json(const op_factor_report *r, const char *path, op_output **pending,
                               op_error *err);

#endif
