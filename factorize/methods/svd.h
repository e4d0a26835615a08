/* svd.h - the log-transformed truncated SVD of Onel, Kurt and Ozturk, one channel at a time.
 *
 * A channel (rows x cols, row-major float32) is preprocessed (preprocess.h: cleaned, each row
 * shifted and normalized when asked), log transformed as R''' = ln(R'/A + B), and factored by
 * the rank-T truncated SVD of rsvd.h. The transform is checked afterwards on up to 4096 sampled
 * rows: an A and B under which the transformed values are not finite, underflow, exceed 60 in
 * magnitude or map back worse than 1e-3 (relative) are refused, as they lose the data.
 *
 * In memory, the first pass of the SVD preprocesses the rows into a work matrix and counts the
 * channel's values (op_rsvd_fill); streamed, the channel is read in passes of a number of rows
 * and every pass of the SVD preprocesses its rows again (op_rsvd_rows), so that the channel is
 * never whole in memory. */
#ifndef OP_FACTOR_SVD_H
#define OP_FACTOR_SVD_H

#include <stdint.h>

#include "opaline.h"
#include "opaline_material.h"
#include "rsvd.h"

typedef struct op_svd_options {
    int terms;           /* T, 1 <= T <= min(rows, cols) */
    int shifted;         /* shift and normalize the rows (Kurt et al. 2013, section 4.1) */
    double log_a, log_b; /* the transform's A > 0 and B > 0 */
    int sanitize;        /* non-finite values count as 0 (else, in memory, they stop the fit) */
    int threads;         /* threads of the preprocessing (<= 0: all cores) */
    op_rsvd_options svd; /* in memory its threads are replaced by `threads` */
} op_svd_options;

/* One channel's factors, laid out as the file's sections (op_write_svd_channel). */
typedef struct op_svd_channel {
    float *us;       /* rows x T: left singular vectors times the singular values */
    float *v;        /* cols x T: right singular vectors */
    uint32_t *shift; /* rows, NULL when not shifted */
    float *max;      /* rows, NULL when not shifted */
    uint64_t nonfinite, negative; /* in memory: the channel's values counted (streamed: 0) */
    double prep_seconds; /* streamed: the time spent finding the peaks and checking the
                            transform, before the SVD (in memory: 0, as the SVD's first pass
                            preprocesses) */
} op_svd_channel;

/* Factors channel `channel` (for messages) src, rows x cols, in memory: mat (rows x cols) is the
 * work matrix, holding the transformed channel afterwards. Non-finite values without
 * opt->sanitize fail with OP_ERR_INPUT and err unset (res->nonfinite counts them; op_prep_scan
 * names the first). On failure res holds nothing to free (but its counts). progress advances
 * by op_rsvd_progress_units + 1. */
op_status op_svd_factor(const float *src, int64_t rows, int cols, int channel,
                        const op_svd_options *opt, float *mat, op_svd_channel *res,
                        op_progress *progress, op_error *err);
/* The same, streamed: src, lying in file's sections, is read in passes of block_rows rows whose
 * pages are released after each (op_material_release); opt->svd is used as it is (its products
 * run on OpenBLAS's threads). Values are not counted. */
op_status op_svd_factor_streamed(const float *src, int64_t rows, int cols, int channel,
                                 int64_t block_rows, const op_material *file,
                                 const op_svd_options *opt, op_svd_channel *res,
                                 op_progress *progress, op_error *err);
/* Frees res's arrays (accepts a zeroed res). */
void op_svd_free(op_svd_channel *res);

#endif
