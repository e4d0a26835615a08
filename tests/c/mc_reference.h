/* mc_reference.h - the subsurface renderer against the Monte Carlo generator's own volumetric
 * transport, the measurement that tests/c/test_render_mc_reference.c checks and that
 * bench/bench_sss_reference.c tabulates. For a medium of the table and one colour channel c, a
 * "grey" medium (channel c's coefficients in all three channels, so the three channels of one
 * dataset are three independent Monte Carlo estimates) is traced by op_mc_generate (normal
 * incidence, the dipole's setting) into a 1 x 1 pixel raw material of kernel K: one Rd row per
 * channel, the same row at every position. On a homogeneous slab (millimetre scene) lit by a
 * hard-edged spot (a disk of radius a = 2 L, L the channel's diffusion length) or by uniform
 * light:
 *  (a) the exact answer the rows give: the exitance M(x) = integral over the disk of E(y)
 *      Rd~((x - y) / pixel) / pixel^2, Rd~ the row interpolated bilinearly between its offsets
 *      (zero beyond the kernel), the disk integrated in polar coordinates; its standard error from
 *      the rows' own (sum of (dM/dRd_k)^2 se_k^2); under uniform light the row sum;
 *  (b) the renderer's exitance with that dataset as a `raw` material (op_sss_prepass_run as a
 *      render runs it, camera-marked, then op_sss_lookup);
 *  (c) the renderer's dipole for the same grey medium, and (d) the dipole's closed form
 *      (dipole_reference.h) integrated over the disk, which tells the renderer's error from the
 *      model's (full cases only).
 * Exitance is averaged over rings of 32 directions at 1, 2 and 4 L outside the disk's edge; the
 * total is the ring integral out to the kernel's reach against P_in x row sum. Runs inside a
 * cmocka test: a failing step fails it. */
#ifndef OP_MC_REFERENCE_H
#define OP_MC_REFERENCE_H

#include <stdint.h>

typedef struct mcref_case {
    const char *medium;
    int channel;        /* the medium's channel made grey */
    uint64_t photons;   /* per channel of the grey dataset */
    double pix_per_L;   /* material pixels per diffusion length */
    int full;           /* 1: kernel reaching 2a + 4.5 L, total and dipole; 0: the fast test */
} mcref_case;

typedef struct mcref_result {
    double L, pix, a, D, p_in, eta, sp, sa;
    int K, points;
    double mc_total[3], rowsum[3], rowse[3], mc_seconds, raw_seconds;
    double ref[3][4], se[3][4], got[3][4]; /* per replica: 1, 2, 4 L, total */
    double uni_got[3];
    double dip[4], dip_uni, dip_seconds;   /* full only: (c), channel 0 of grey */
    double cf[4], cf_uni;                  /* full only: (d) */
} mcref_result;

/* Measures case k into r. */
void mcref_run(const mcref_case *k, mcref_result *r);

#endif
