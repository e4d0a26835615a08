/*
 * opaline_material.h - reading and evaluating factored heterogeneous subsurface-scattering
 * materials (".opm" files): what a renderer needs. Writing them is opaline_material_write.h's.
 *
 *  - A material is read-only once open and may be evaluated from any number of threads.
 *  - Units: a material's physical size is in centimetres; Rd values are dimensionless (the
 *    fraction of the power entering through one incident pixel that leaves through one exit
 *    pixel). docs/formats.md is the one place that defines them.
 * Errors and the other conventions: opaline.h.
 */
#ifndef OPALINE_MATERIAL_H
#define OPALINE_MATERIAL_H

#include <stddef.h>
#include <stdint.h>

#include "opaline.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The methods, one X(ID, name) each, in enum order: the one list behind the op_method enum
 * (OP_METHOD_<ID>), the names (op_method_name) and libopaline's evaluation table (the
 * op_method_<name>_ops of libopaline/method_<name>.c). Adding a method is a line here and its
 * module. */
#define OP_METHOD_LIST(X)                                                                        \
    X(RAW, raw)       /* the dataset itself: the reference */                                    \
    X(SVD, svd)       /* log-transformed truncated SVD per channel (Onel, Kurt, Ozturk) */       \
    X(TUCKER, tucker) /* Tucker of the channel mean + per-row polynomial colour regression */    \
    X(KCTA, kcta)     /* K-clustered tensor approximation (Tsai and Shih 2012) */                \
    X(NMF, nmf)       /* non-negative matrix factorization baseline (Peers et al. 2006) */

#define OP_METHOD_ENUM_(id, name) OP_METHOD_##id,
typedef enum op_method { OP_METHOD_LIST(OP_METHOD_ENUM_) OP_METHOD_COUNT } op_method;
#undef OP_METHOD_ENUM_

/* The method's name ("svd"), or "unknown" for a value out of range. */
const char *op_method_name(op_method m);
/* Returns OP_METHOD_COUNT for an unknown name. */
op_method op_method_from_name(const char *name);

/* What a material is. Rows are incident pixels (row index y * width + x), columns are kernel
 * offsets (column index (dy + kernel/2) * kernel + (dx + kernel/2)). */
typedef struct op_material_info {
    op_method method;
    int width, height;         /* incident pixels */
    int kernel;                /* odd kernel side K: offsets range over [-K/2, K/2] */
    int channels;              /* 1 or 3 (R, G, B) */
    double size_x_cm, size_y_cm; /* physical size of the sample */
    int terms;                 /* T (svd, tucker, kcta, nmf), 0 for raw */
    int degree;                /* P (tucker), 0 otherwise */
    int clusters;              /* C (kcta), 0 otherwise */
    int shifted;               /* rows were shifted and normalized (paper section 4.1) */
    double log_a, log_b;       /* svd: R''' = ln(R'/A + B) */
    uint32_t dataset_crc;      /* CRC-32 of the source dataset's Rd values */
    char name[128];            /* e.g. "Chess4x4" */
    char generator[128];       /* how the source data was made, free text */
    char tool_version[32];
} op_material_info;

typedef struct op_material op_material;

/* Opens and fully validates a material file (header, section table, checksums, dimensions,
 * method-specific invariants). A truncated, corrupt or hostile file gives OP_ERR_FORMAT. */
op_status op_material_open(const char *path, op_material **out, op_error *err);
void op_material_close(op_material *m);
const op_material_info *op_material_get_info(const op_material *m);
/* Bytes the material occupies on disk. */
uint64_t op_material_file_size(const op_material *m);

/* Rd for `channel` at incident pixel (x, y) and offset (dx, dy); 0 outside the kernel.
 * Coordinates must be in range (checked only by assertions). Never negative or NaN. */
float op_material_eval(const op_material *m, int channel, int x, int y, int dx, int dy);
/* The whole kernel row of incident pixel (x, y): K*K values in column order. */
void op_material_eval_row(const op_material *m, int channel, int x, int y, float *out);
/* Albedo map: for every channel and incident pixel the row sum, as channels*width*height
 * floats, channel-major. */
op_status op_material_albedo_map(const op_material *m, float *out, op_error *err);

/* A named section's bytes (e.g. "RD.R" of a raw material), or NULL when absent. Sections are
 * aligned to 64 bytes in the file and in memory. */
const void *op_material_section(const op_material *m, const char *tag, uint64_t *bytes);
/* The checksum stored for a section (verified when the file was opened), or 0 when absent. */
uint32_t op_material_section_crc(const op_material *m, const char *tag);
/* The tag of a per-channel section: prefix + "R"/"G"/"B", or + "Y" for one channel. */
void op_channel_tag(char *tag, size_t n, const char *prefix, const op_material_info *info, int c);
/* The prefix of a raw material's (a dataset's) per-channel Rd sections (op_channel_tag). */
#define OP_RAW_SECTION "RD."
/* Rows (incident pixels, width * height) and columns (kernel offsets, K * K) of a material. */
int64_t op_material_rows(const op_material *m);
int op_material_cols(const op_material *m);

/* Opens a file's container and META only (header, section table, checksums, dimensions) without
 * the method's checks: sections may be read with op_material_section, but eval, eval_row and
 * albedo must not be called. The factorizer reads datasets this way, so that NaN or negative
 * noise in a dataset gets its own clear report. Close with op_material_close. */
op_status op_material_open_container(const char *path, op_material **out, op_error *err);
/* op_material_open_container for a file larger than memory, read in passes: each section's
 * pages are dropped from memory once its checksum is verified (in pieces, so the resident size
 * stays bounded), and readers drop the rows they are done with by op_material_release. */
op_status op_material_open_streaming(const char *path, op_material **out, op_error *err);
/* op_file_release on m's file: [p, p + n) lies within one of its sections. */
void op_material_release(const op_material *m, const void *p, size_t n);

#ifdef __cplusplus
}
#endif
#endif
