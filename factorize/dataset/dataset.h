/* dataset.h - synthetic measured-like subsurface datasets: what one is, how it is specified and
 * how it is written.
 *
 * A dataset holds, for each colour channel, W x H incident pixels x_i and for each a K x K
 * kernel of exit pixels x_o = x_i + d, d in [-K/2, K/2]^2: the fraction of the power entering
 * through pixel x_i (uniformly over its area; Monte Carlo: diffuse incidence) that leaves
 * through pixel x_o.
 * Row r = y * W + x, column (dy + K/2) * K + (dx + K/2). Lengths are in mm inside the
 * generators; the sample's physical size is in cm (as in the material file). The sample tiles
 * the plane periodically, so an exit pixel beyond the edge is the matching pixel of the
 * neighbouring tile (see docs/datasets.md).
 */
#ifndef OP_FACTOR_DATASET_H
#define OP_FACTOR_DATASET_H

#include "dataset_layout.h"
#include "opaline.h"

#include <stdint.h>

typedef enum op_generator { OP_GEN_DIFFUSION, OP_GEN_MONTECARLO } op_generator;

typedef enum op_dataset_kind {
    OP_DS_CHESS4X4, OP_DS_CHESS8X8, OP_DS_MARBLE_CLOSEUP, OP_DS_VEINED_MARBLE, OP_DS_HOMOGENEOUS,
    /* the preset library's materials (docs/presets.md) */
    OP_DS_CARRARA_MARBLE, OP_DS_JADE, OP_DS_LAYERED_WAX, OP_DS_SOAP, OP_DS_SKIN
} op_dataset_kind;

typedef struct op_dataset_spec {
    op_dataset_kind kind;
    char name[64];              /* the material's display name, e.g. "Chess4x4" */
    int width, height, kernel;  /* incident pixels, odd kernel side */
    double size_x_cm, size_y_cm;
    const op_medium *media[2];  /* [0] base medium, [1] second medium (chess, veins) */
    double eta;                 /* > 0: one index of refraction for the whole sample (a recipe
                                   reproducing older values); 0: each medium's own */
    op_generator generator;
    uint64_t photons;           /* Monte Carlo photons per incident pixel and channel */
    uint64_t seed;              /* Monte Carlo seed (and the veins' noise) */
    int threads;                /* worker threads, >= 1 */
    op_progress_fn progress;    /* NULL: op_progress's stderr report */
    void *progress_user;
} op_dataset_spec;

/* Fills spec with the defaults of a dataset NAME (chess4x4, chess8x8, marble-closeup,
 * veined-marble, homogeneous, carrara-marble, jade, layered-wax, soap, skin;
 * case-insensitive). OP_ERR_INPUT for an unknown name. */
op_status op_dataset_spec_defaults(const char *name, op_dataset_spec *spec, op_error *err);
/* Checks sizes, kernel and media; OP_ERR_INPUT with a message naming the bad value. */
op_status op_dataset_spec_check(const op_dataset_spec *spec, op_error *err);
/* The sample's medium map for spec (caller frees with op_layout_free). */
op_status op_dataset_layout(const op_dataset_spec *spec, op_layout *l, op_error *err);

typedef struct op_dataset {
    int width, height, kernel;
    double size_x_cm, size_y_cm;
    uint64_t row0, nrows;       /* the rows rd and se hold: all (0, width * height), or a block
                                   of a dataset generated or written in pieces */
    float *rd[3];               /* nrows * kernel^2 values per channel */
    float *se[3];               /* standard errors of rd (Monte Carlo), else NULL */
    char name[128];
    char generator[128];        /* free text: generator and its parameters */
} op_dataset;

/* Allocates a zeroed dataset (with standard-error arrays when with_se). */
op_status op_dataset_alloc(op_dataset *d, int w, int h, int k, int with_se, op_error *err);
/* Allocates room for a block of rows rows (row0 0) of a w x h x k dataset. */
op_status op_dataset_alloc_block(op_dataset *d, int w, int h, int k, int with_se, uint64_t rows,
                                 op_error *err);
void op_dataset_free(op_dataset *d);
static inline uint64_t op_dataset_rows(const op_dataset *d)
{
    return (uint64_t)d->width * (uint64_t)d->height;
}
/* Checks the energy invariants of the rows d holds: every value finite and >= 0, every row sum
 * <= 1 (to float rounding). OP_ERR_INPUT naming channel, pixel and value otherwise. */
op_status op_dataset_check(const op_dataset *d, op_error *err);
/* CRC-32 of the Rd values d holds (little-endian float32), channels in order R, G, B. */
uint32_t op_dataset_crc(const op_dataset *d);

/* Writing a dataset as a raw material (sections RD.R RD.G RD.B, plus SE.* when with_se) through
 * op_material_writer, in blocks of rows given in order: the destination appears whole at commit
 * or not at all. The META's dataset_crc is that of all rows, known at commit. */
typedef struct op_dataset_writer op_dataset_writer;
/* d gives the dimensions, name and generator (its rows are not written). */
op_status op_dataset_writer_open(const char *path, const op_dataset *d, int with_se,
                                 op_dataset_writer **out, op_error *err);
/* Writes the rows block holds, which must start where the previous block ended. */
op_status op_dataset_writer_add(op_dataset_writer *w, const op_dataset *block, op_error *err);
/* Refuses a dataset with rows missing; frees w whatever the result. */
op_status op_dataset_writer_commit(op_dataset_writer *w, op_error *err);
void op_dataset_writer_abort(op_dataset_writer *w);
/* The whole of d, in one block. */
op_status op_dataset_write(const op_dataset *d, const char *path, op_error *err);

#endif
