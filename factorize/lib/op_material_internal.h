/* op_material_internal.h - what the material container shares with the method modules. */
#ifndef OP_MATERIAL_INTERNAL_H
#define OP_MATERIAL_INTERNAL_H

#include "opaline.h"

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
    const unsigned char *base; /* the mapped file */
    uint64_t size;
    char path[1024];
    uint32_t nsections;
    const unsigned char *table;
    const float *albedo;    /* the "ALBEDO" section (channels x rows), or NULL */
};

/* Helpers for method modules. */
int64_t op_material_rows(const op_material *m);
int op_material_cols(const op_material *m);
/* The tag of a per-channel section: prefix + "R"/"G"/"B", or + "Y" for one channel. */
void op_channel_tag(char *tag, size_t n, const char *prefix, const op_material_info *info, int c);
/* Finds a section that must hold exactly `count` little-endian float32 values, all finite and,
 * when nonneg is set, >= 0. */
op_status op_material_float_section(const op_material *m, const char *tag, uint64_t count,
                                    int nonneg, const float **out, op_error *err);

/* Opens a file's container and META only (header, section table, checksums, dimensions) without
 * the method's checks: sections may be read with op_material_section, but eval, eval_row and
 * albedo must not be called. The factorizer reads datasets this way, so that NaN or negative
 * noise in a dataset gets its own clear report. Close with op_material_close. */
op_status op_material_open_container(const char *path, op_material **out, op_error *err);

extern const op_method_ops op_method_raw_ops;
extern const op_method_ops op_method_svd_ops;
extern const op_method_ops op_method_tucker_ops;
extern const op_method_ops op_method_kcta_ops;
extern const op_method_ops op_method_nmf_ops;

#endif
