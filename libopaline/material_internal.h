/* material_internal.h - what the material container shares with the method modules. */
#ifndef OP_MATERIAL_INTERNAL_H
#define OP_MATERIAL_INTERNAL_H

#include "opaline.h"
#include "opaline_material.h"
#include "opaline_material_write.h"

#include <string.h>

/* One evaluation method. prepare() checks the method's sections against m->info (sizes,
 * finiteness, ranges) and builds m->state; after it succeeds eval and eval_row must never fail
 * or return a negative or non-finite value for in-range arguments. The albedo map is the
 * container's: the stored "ALBEDO" section when the file has one, else the sums of eval_row. */
typedef struct op_method_ops {
    op_status (*prepare)(op_material *m, op_error *err);
    float (*eval)(const op_material *m, int channel, int64_t row, int col);
    void (*eval_row)(const op_material *m, int channel, int64_t row, float *out);
    void (*destroy)(op_material *m);
} op_method_ops;

struct op_material {
    op_material_info info;
    const op_method_ops *ops;
    void *state;            /* owned by the method */
    op_file_view file;      /* the whole file */
    const unsigned char *base; /* file.data */
    uint64_t size;             /* file.size */
    char path[1024];
    uint32_t nsections;
    const unsigned char *table;
    const float *albedo;    /* the "ALBEDO" section (channels x rows), or NULL */
    int streaming;          /* op_material_open_streaming: pages released once checked */
};

/* The largest albedo (the sum of a row of Rd: the fraction of the light entering one incident
 * pixel that leaves the sample) a raw material may hold: physically at most 1, and noisy
 * measurements may exceed that a little, so up to 1.5 is accepted (docs/formats.md). A
 * factored material approximates its data and may overshoot: its stored albedos, per-row
 * maxima and NMF row scales get a warning above OP_MATERIAL_MAX_ALBEDO and are refused above
 * OP_MATERIAL_ABSURD_ALBEDO, which no approximation of physical data comes near. */
#define OP_MATERIAL_MAX_ALBEDO 1.5
#define OP_MATERIAL_ABSURD_ALBEDO 1e6

/* Helpers for method modules. */
/* Finds a section that must hold exactly `bytes` bytes; *out is set only on success. */
op_status op_material_sized_section(const op_material *m, const char *tag, uint64_t bytes,
                                    const void **out, op_error *err);
/* Finds a section that must hold exactly `count` little-endian float32 values, all finite and,
 * when nonneg is set, >= 0. */
op_status op_material_float_section(const op_material *m, const char *tag, uint64_t count,
                                    int nonneg, const float **out, op_error *err);
/* Checks a factored material's section of per-row albedos or Rd values (rows or channels x
 * rows float32, already checked by op_material_float_section) against
 * OP_MATERIAL_ABSURD_ALBEDO (refused) and OP_MATERIAL_MAX_ALBEDO (one warning), naming the
 * first row at fault. */
op_status op_material_check_albedo(const op_material *m, const char *tag, const float *v,
                                   uint64_t count, op_error *err);
/* op_material_float_section for channel c's section prefix + "R"/"G"/"B" (or "Y"). */
op_status op_material_channel_floats(const op_material *m, const char *prefix, int c,
                                     uint64_t count, int nonneg, const float **out,
                                     op_error *err);
/* Finds the per-row shift and maximum sections of a shifted material (paper section 4.1):
 * "SHIFT.c" (rows u32, each < cols) and "MAX.c" (rows float32, finite, >= 0, checked by
 * op_material_check_albedo) of channel c, or
 * the channel-less "SHIFT" and "MAX" when c < 0. *shift and *max are set only when valid. */
op_status op_material_shift_sections(const op_material *m, int c, const uint32_t **shift,
                                     const float **max, op_error *err);
/* Writing, the other half of each method's layout (opaline_material_write.h's op_write_*): channel
 * c's section prefix + "R"/"G"/"B" (or "Y") of `bytes` bytes. */
op_status op_material_write_channel(op_material_writer *w, const op_material_info *info,
                                    const char *prefix, int c, const void *data, uint64_t bytes,
                                    op_error *err);
/* Writes the per-row shift and maximum sections op_material_shift_sections reads (channel c's,
 * or the channel-less ones when c < 0), when info->shifted; nothing otherwise. */
op_status op_material_write_shift(op_material_writer *w, const op_material_info *info, int c,
                                  const uint32_t *shift, const float *max, op_error *err);
/* out[t] = max over j < n of |v[j * T + t]| for t < T, v being n x T row-major: the factor
 * bound the methods' overflow checks start from. */
void op_column_abs_max(const float *v, int n, int T, double *out);
/* The transpose (T x n, row-major, from malloc) of v (n x T, row-major), or NULL when out of
 * memory: eval_row works through a row in chunks of OP_EVAL_CHUNK columns, vectorized across
 * the columns of the transposed factor. */
float *op_transpose(const float *v, int n, int T);
#define OP_EVAL_CHUNK 256
/* out[(col + k) mod n] = v[k] for k < len, col < 2n, len <= n: a chunk of a shifted row. */
static inline void op_store_shifted(float *out, int n, int col, const float *v, int len)
{
    if (col >= n)
        col -= n;
    int first = n - col < len ? n - col : len;
    memcpy(out + col, v, (size_t)first * sizeof *v);
    memcpy(out, v + first, (size_t)(len - first) * sizeof *v);
}
/* Ends a prepare() whose state is one block from malloc: keeps it as m->state when st is OP_OK,
 * else frees it; returns st. */
op_status op_method_keep_state(op_material *m, void *state, op_status st);
/* A destroy() for methods whose state is one block from malloc. */
void op_method_free_state(op_material *m);



/* Frees a material whose method state is gone (or was never made): its mapping and itself. */
void op_material_free_container(op_material *m);

/* Each method's evaluation, op_method_<name>_ops of method_<name>.c (OP_METHOD_LIST). */
#define OP_METHOD_OPS_(id, name) extern const op_method_ops op_method_##name##_ops;
OP_METHOD_LIST(OP_METHOD_OPS_)
#undef OP_METHOD_OPS_

#endif
