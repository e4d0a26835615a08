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
    float *rd[3];               /* width * height * kernel^2 values per channel */
    float *se[3];               /* standard errors of rd (Monte Carlo), else NULL */
    char name[128];
    char generator[128];        /* free text: generator and its parameters */
} op_dataset;

/* Allocates a zeroed dataset (with standard-error arrays when with_se). */
op_status op_dataset_alloc(op_dataset *d, int w, int h, int k, int with_se, op_error *err);
void op_dataset_free(op_dataset *d);
static inline uint64_t op_dataset_rows(const op_dataset *d)
{
    return (uint64_t)d->width * (uint64_t)d->height;
}
/* Checks the energy invariants: every value finite and >= 0, every row sum <= 1 (to float
 * rounding). OP_ERR_INPUT naming channel, pixel and value otherwise. */
op_status op_dataset_check(const op_dataset *d, op_error *err);
/* CRC-32 of the Rd values (little-endian float32), channels in order R, G, B. */
uint32_t op_dataset_crc(const op_dataset *d);
/* Writes d as a raw material (sections RD.R RD.G RD.B, plus SE.* when present) through
 * op_material_writer: the destination appears whole or not at all. */
op_status op_dataset_write(const op_dataset *d, const char *path, op_error *err);

#endif
