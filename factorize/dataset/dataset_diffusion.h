/* dataset_diffusion.h - generator 2: a fast deterministic diffusion approximation.
 *
 * Assumptions: each (x_i, x_o) pair sees a semi-infinite homogeneous medium whose coefficients
 * are the path-length average of sigma_s' and sigma_a along the straight segment x_i -> x_o
 * (sampled at max(|dx|, |dy|) + 1 evenly spaced points, each in the pixel that holds it);
 * the classical dipole of Jensen et al. 2001 (multiple scattering only, no single scattering)
 * gives Rd for that medium; Rd is integrated over both pixels (uniform entry over x_i, exit
 * anywhere in x_o). The whole sample has one relative index: the layout's one eta, else the base
 * medium's (op_layout_eta(l, 0)). A dipole has no interface inside the sample to refract at, and
 * with two indices reciprocity would ask T(n_i) Rd(x_i, x_o) = T(n_o) Rd(x_o, x_i) (T the diffuse
 * transmittance into index n, docs/datasets.md), which no dipole supplies; so media of different
 * index are given the base medium's, with a warning. The segment average is symmetric in its
 * two ends, so Rd(x_i, x_o) == Rd(x_o, x_i) exactly (bit for bit), which is reciprocity for one
 * index.
 */
#ifndef OP_FACTOR_DATASET_DIFFUSION_H
#define OP_FACTOR_DATASET_DIFFUSION_H

#include "dataset.h"

typedef struct op_dipole {
    double alpha;     /* reduced albedo sigma_s' / sigma_t' */
    double sigma_tr;  /* effective transport coefficient, 1/mm */
    double z_r, z_v;  /* real and virtual source depths, mm */
} op_dipole;

/* The dipole of a medium (coefficients in 1/mm, sigma_s + sigma_a > 0) under relative index eta. */
void op_dipole_init(op_dipole *d, double sigma_s, double sigma_a, double eta);
/* Rd(r): exitance at distance r (mm) per unit power entering, in 1/mm^2. */
double op_dipole_rd(const op_dipole *d, double r);
/* Closed-form total diffuse reflectance, the integral of Rd over the plane. */
double op_dipole_total(double sigma_s, double sigma_a, double eta);
/* Rd averaged over entry points in a px x py (mm) pixel and integrated over exit points in the
 * pixel whose centre is (cx, cy) mm away; n Gauss-Legendre points per half axis (1..16). */
double op_dipole_pixel(const op_dipole *d, double cx, double cy, double px, double py, int n);

/* The generator's tables for a layout and kernel (every value an entry can take, the sample
 * points of each offset, the map padded periodically): made once, then any block of rows is
 * filled from them. */
typedef struct op_diffusion op_diffusion;
op_status op_diffusion_begin(const op_layout *l, int kernel, op_diffusion **out, op_error *err);
/* Fills block->rd for its rows (block sized for the layout and kernel), in parallel over
 * `threads`, advancing progress (may be NULL) by one per row. Each row's values depend on the
 * row alone: the same for any blocks and thread count. */
op_status op_diffusion_fill(const op_diffusion *d, int threads, op_progress *progress,
                            op_dataset *block, op_error *err);
void op_diffusion_end(op_diffusion *d);

#endif
