/* dipole_kernel.h - the classical dipole as the radial profile of the hierarchical exitance sum
 * (sss/tree.h): the point spacing its profile needs, the exact near profile (Rd averaged over
 * the disk a point stands for, tabulated finely), the closed-form far profile with its
 * derivatives, and when a cluster may stand in for its points. docs/subsurface-rendering.md
 * gives the figures and why. */
#ifndef OP_SSS_DIPOLE_KERNEL_H
#define OP_SSS_DIPOLE_KERNEL_H

#include "sss/dipole_profile.h"
#include "sss/tree.h"

typedef struct op_sss_dipole_kernel {
    op_sss_dipole d;   /* coefficients per scene unit */
    float step;        /* the near table's step */
    int ntab;
    float *tab;        /* ntab x 3: Rd averaged over a point's disk, centred i x step away */
    double far0, far_scale; /* the far table: entry i at r = far0 exp(i / far_scale) */
    int nfar;
    float *far;        /* nfar x 3 channels x (Rd, Rd', Rd'') */
    op_sss_radial radial; /* the profile for op_sss_tree_*, pointing at this kernel */
} op_sss_dipole_kernel;

/* The spacing of irradiance points (at density 1) that resolves the profile: a sixth of the
 * shortest characteristic length over the channels, each channel's being its diffusion length
 * 1/sigma_tr or an eighth of its 0.1 % radius, whichever is shorter. */
double op_sss_dipole_spacing(const op_sss_dipole *d);

/* Sets up the kernel for points that each stand for `area` (a disk of that area) laid
 * `spacing` apart. k must stay where it is while k->radial is used. */
op_status op_sss_dipole_kernel_init(op_sss_dipole_kernel *k, const op_sss_dipole *d,
                                    double area, double spacing, op_error *err);
void op_sss_dipole_kernel_free(op_sss_dipole_kernel *k);

#endif
