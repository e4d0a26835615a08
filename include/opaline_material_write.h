/*
 * opaline_material_write.h - writing materials: the container's writer and each method's
 * section layout. For the programs that make materials (the factorizer); a renderer only reads
 * them (opaline_material.h).
 */
#ifndef OPALINE_MATERIAL_WRITE_H
#define OPALINE_MATERIAL_WRITE_H

#include <stddef.h>
#include <stdint.h>

#include "opaline.h"
#include "opaline_material.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Writing: open, add each section once, commit. Section tags are 1 to 8 printable characters;
 * "META" is written by the library from info. The file is an op_output: it appears whole at
 * path on commit, or not at all. */
typedef struct op_material_writer op_material_writer;

op_status op_material_writer_open(const char *path, const op_material_info *info,
                                  op_material_writer **out, op_error *err);
op_status op_material_writer_add(op_material_writer *w, const char *tag, const void *data,
                                 uint64_t bytes, op_error *err);
/* A section written in pieces: reserve gives it its place and size (the sections after it go
 * beyond), fill appends its next n bytes (its checksum follows along), in any interleaving with
 * other reserved sections; commit refuses a section not filled to its size. */
op_status op_material_writer_reserve(op_material_writer *w, const char *tag, uint64_t bytes,
                                     op_error *err);
op_status op_material_writer_fill(op_material_writer *w, const char *tag, const void *data,
                                  size_t n, op_error *err);
/* Rewrites META from info, which must give text of the same length (fixed-width fields such as
 * dataset_crc may change: a checksum known only once the data is written). */
op_status op_material_writer_set_info(op_material_writer *w, const op_material_info *info,
                                      op_error *err);
/* Completes the file under its temporary name (section table and header) without putting it in
 * place, and gives that name in *tmp_path, valid until commit or abort: the file can be read
 * back with op_material_open to verify it. Sections may still be added after. */
op_status op_material_writer_finish(op_material_writer *w, const char **tmp_path, op_error *err);
/* Writes the section table and puts the file in place; frees w whatever the result. */
op_status op_material_writer_commit(op_material_writer *w, op_error *err);
/* Removes the temporary file and frees w. Accepts NULL. */
void op_material_writer_abort(op_material_writer *w);

/* Each method's section layout has one home, libopaline/method_<name>.c, which writes the
 * sections (these functions) and reads them back (op_material_open); docs/formats.md is the
 * specification. info is the META w was opened with; every array holds the count info implies
 * (rows = width * height, n = kernel * kernel, T = terms, C = clusters), row-major. shift (rows
 * u32) and max (rows float32) are each row's shift and maximum, required exactly when
 * info->shifted. Call them in the order given for a method: the file's layout follows it. */
/* raw: channel c's Rd values, rows x n. */
op_status op_write_raw_channel(op_material_writer *w, const op_material_info *info, int c,
                               const float *rd, op_error *err);
/* svd: channel c's U (rows x T, scaled by the singular values) and V (n x T). */
op_status op_write_svd_channel(op_material_writer *w, const op_material_info *info, int c,
                               const float *u, const float *v, const uint32_t *shift,
                               const float *max, op_error *err);
/* tucker: U (rows x T), V (n x T), RANGE (rows x 2), BETA (channels x rows x (degree + 1)). */
op_status op_write_tucker(op_material_writer *w, const op_material_info *info, const float *u,
                          const float *v, const float *range, const float *beta,
                          const uint32_t *shift, const float *max, op_error *err);
/* kcta, per channel: BASIS (C x n x T), KIDX (rows x km indices of index_bytes, 2 or 4, each),
 * KCOEF (rows x km x T); after the channels op_write_kcta_params. */
op_status op_write_kcta_channel(op_material_writer *w, const op_material_info *info, int c,
                                int km, int index_bytes, const float *basis, const void *idx,
                                const float *coef, const uint32_t *shift, const float *max,
                                op_error *err);
op_status op_write_kcta_params(op_material_writer *w, int km, int index_bytes, op_error *err);
/* nmf: channel c's PROF (n), SCALE (rows), W (rows x T) and H (n x T). */
op_status op_write_nmf_channel(op_material_writer *w, const op_material_info *info, int c,
                               const float *prof, const float *scale, const float *wf,
                               const float *h, op_error *err);
/* Any factored method, last: the row sums of the reconstruction (channels x rows), which
 * op_material_albedo_map then copies. */
op_status op_write_albedo(op_material_writer *w, const op_material_info *info,
                          const float *albedo, op_error *err);

#ifdef __cplusplus
}
#endif
#endif
