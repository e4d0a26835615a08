/* dataset_montecarlo.h - generator 1: Monte Carlo photon transport, the reference physics.
 *
 * Per channel and incident pixel, `photons` photons enter at points uniform over the pixel (a
 * pencil beam one pixel wide) into a semi-infinite slab whose medium varies with (x, y) as the layout says (tiled periodically).
 * Free paths by delta (Woodcock) tracking against the larger extinction of the two media;
 * isotropic scattering with the reduced coefficients; survival weighting (weight *= albedo at
 * each real collision) with Russian roulette below weight 0.1; the flat boundary (relative index
 * of the medium where the photon crosses it, op_layout_eta) reflects with the unpolarized
 * Fresnel probability, else the photon leaves and its weight is tallied in the exit pixel. Where
 * the two media differ in index, the sides between their pixels are interfaces too: a photon
 * reaching one is reflected (Fresnel, total internal reflection) or refracted (Snell). Incidence
 * is diffuse by default: directions cosine-weighted outside, kept with the Fresnel transmittance
 * and refracted, which makes the measurement reciprocal: T(n_i) Rd(x_i, x_o) = T(n_o) Rd(x_o, x_i)
 * in expectation, T(n) the transmittance of diffuse light from air into index n, since exit is
 * collected over all directions (one index: Rd(x_i, x_o) = Rd(x_o, x_i); docs/datasets.md);
 * OP_MC_NORMAL is the classical normal-incidence pencil beam (the dipole's own setting), which is
 * not reciprocal across media. Either way the power reflected at entry is not part of the power
 * that enters. Each (channel, pixel) has its own random stream
 * (xoshiro256+ seeded by splitmix64 from seed, channel and pixel), and is traced by one thread
 * in photon order, so the result is bit-identical for any thread count.
 */
#ifndef OP_FACTOR_DATASET_MONTECARLO_H
#define OP_FACTOR_DATASET_MONTECARLO_H

#include "dataset.h"

typedef enum op_mc_incidence { OP_MC_DIFFUSE = 0, OP_MC_NORMAL } op_mc_incidence;

typedef struct op_mc_options {
    uint64_t photons;           /* per channel and incident pixel, >= 1 */
    uint64_t seed;
    int threads;                /* >= 1 */
    op_progress *progress;      /* advanced by one per channel and row; NULL: no report */
    op_mc_incidence incidence;  /* OP_MC_DIFFUSE (0, the default) or OP_MC_NORMAL */
} op_mc_options;

typedef struct op_mc_stats {
    uint64_t steps;             /* free-path samples (real and null collisions, boundary hits) */
    uint64_t photons;           /* photons traced, all channels */
    uint64_t lost;              /* photons stopped after OP_MC_MAX_STEPS (counted as absorbed) */
    double seconds;             /* wall time of the tracing */
    double steps_per_second;
    double total_reflectance[3];/* mean over pixels of all escaping power, inside the kernel
                                 * or not */
    double mean_albedo[3];      /* mean row sum (escaping within the kernel) */
    double mean_rel_se;         /* mean over rows and channels of SE(row sum) / row sum */
    double max_rel_se;
    double rel_se_sum;          /* the sum and count behind mean_rel_se, over the blocks so far */
    uint64_t rel_se_count;
} op_mc_stats;

#define OP_MC_MAX_STEPS 10000000u

/* Fills out->rd and out->se for the rows out holds (out allocated with standard errors for the
 * layout's size, whole or a block) and adds their figures to stats; the block of row 0 starts
 * stats afresh. Each row's values depend on the row alone (its own random streams). */
op_status op_mc_generate(const op_layout *l, const op_mc_options *o, op_dataset *out,
                         op_mc_stats *stats, op_error *err);

#endif
