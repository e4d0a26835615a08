/* fit.h - what `opaline-factor factor` (factor_cmd.c) shares with the fitting step of each
 * method (fit_<name>.c, registered in fit_table.c): the arguments, the dataset as read, one
 * method's entry, and the helpers the fits share (fit.c). */
#ifndef OP_FACTOR_FIT_H
#define OP_FACTOR_FIT_H

#include "opaline.h"
#include "opaline_material.h"
#include "opaline_material_write.h"
#include "preprocess.h"
#include "report.h"
#include "rsvd.h"

/* What the command was asked to do. -1 in an option means "not given" until the method's
 * defaults() has run. */
typedef struct factor_args {
    const char *input, *output, *report, *albedo_png, *name;
    op_method method;
    int terms, degree, shift, sanitize;
    int threads; /* preprocessing threads (0: all cores) */
    int clusters, km, iters; /* kcta's C and K_m; kcta's or nmf's iterations (-1: default) */
    double homog_exp;        /* nmf: the remainder is Rd / H^homog_exp */
    double log_a, log_b;
    op_rsvd_options svd;
    int block_rows; /* svd from a dataset streamed in blocks of this many rows: > 0 given, 0
                       never, -1 when the dataset is larger than half the physical memory */
} factor_args;

/* The dataset as read: its META and one read-only rows x cols matrix per channel. */
typedef struct dataset {
    op_material *file;
    op_material_info info;
    int64_t rows;
    int cols;
    const float *rd[3];
    int64_t block_rows; /* > 0: read in passes of this many rows, pages released after each */
} dataset;

/* One fit: the inputs, the META the material is written with (its terms already within the
 * rank bound), the open writer the sections go to, and what the fit reports. */
typedef struct fit_job {
    const factor_args *a;
    const dataset *ds;
    const op_material_info *info;
    op_material_writer *w;
    op_factor_report *rep;
    double prep_seconds; /* the part of the fit spent preprocessing */
} fit_job;

/* The options that only some methods take: a method names those it takes in its entry. */
enum {
    FIT_OPT_CLUSTERS = 1,   /* -C and --km */
    FIT_OPT_ITERS = 2,      /* --iters */
    FIT_OPT_HOMOG = 4,      /* --homog-exp */
    FIT_OPT_BLOCK_ROWS = 8, /* --block-rows: the method can read the dataset in passes */
};

/* One factorization method, as the factor command runs it. */
typedef struct fit_method {
    op_method method;
    unsigned options; /* FIT_OPT_* */
    int albedo;       /* stores the row sums of its reconstruction (op_write_albedo) */
    int counts_values; /* its fit counts the dataset's non-finite and negative values itself
                          (in its first pass over the data) when the dataset is in memory:
                          the command does not scan them first (op_fit_counted) */
    const char *terms_help; /* what -T counts, for the usage text: "" or e.g. "rank " */
    /* Fills in a's defaults for what was not given (-1) and checks the method's options
     * (OP_ERR_INPUT naming the option). */
    op_status (*defaults)(factor_args *a, op_error *err);
    /* Sets the method's own META fields of info (info->terms is set) from a and the dataset's
     * size, warning about what it lowers; OP_ERR_INPUT when the options cannot fit ds. NULL
     * when the method has none. */
    op_status (*describe)(const factor_args *a, const dataset *ds, op_material_info *info,
                          op_error *err);
    /* Fits the dataset and writes the method's sections (op_write_<name>_*) to job->w. */
    op_status (*fit)(fit_job *job, op_error *err);
} fit_method;

/* malloc of bytes (at least 1), or NULL when out of memory or bytes exceeds size_t. */
void *op_fit_alloc(uint64_t bytes);
/* Allocates one rows x cols float matrix of ds into *mat. */
op_status op_fit_matrix(const dataset *ds, float **mat, op_error *err);
/* The error for channel c's non-finite values without --sanitize: n counts them and names the
 * first (op_prep_scan). */
op_status op_fit_nonfinite_error(const factor_args *a, const dataset *ds, int c,
                                 const op_prep_counts *n, op_error *err);
/* Adds what a fit counted (non-finite values, counted as 0, and negative ones) to rep and logs
 * it; without --sanitize, non-finite values are an error naming the first (the channels are
 * scanned again to find it). */
op_status op_fit_counted(const factor_args *a, const dataset *ds, uint64_t nonfinite,
                         uint64_t negative, op_factor_report *rep, op_error *err);
/* The error for channel c's own count of nonfinite > 0 values without --sanitize:
 * op_fit_counted's, which names the first (or, should it find none, one naming the channel). */
op_status op_fit_channel_nonfinite(const factor_args *a, const dataset *ds, int c,
                                   uint64_t nonfinite, uint64_t negative, op_factor_report *rep,
                                   op_error *err);
/* Logs the non-finite and negative values rep counts. */
void op_fit_log_counts(const factor_args *a, const op_factor_report *rep);
/* Writes channel c of ds, rows shifted and normalized (paper section 4.1) when a->shift, into
 * mat (rows x cols). The per-row shifts and maxima go to *shift and *max, owned by the caller
 * (both NULL when not shifted).
 * For a method with counts_values: unless ds is streamed (ds->block_rows, counted by the
 * command), the same pass counts the channel's values into *nonfinite and *negative
 * (op_prep_fetch); non-finite ones without --sanitize then fail with OP_ERR_INPUT, err unset,
 * for op_fit_channel_nonfinite to name the first. */
op_status op_fit_prepare_channel(const factor_args *a, const dataset *ds, int c, float *mat,
                                 uint32_t **shift, float **max, uint64_t *nonfinite,
                                 uint64_t *negative, op_error *err);

#endif
