/* medium.h - participating media: absorption and scattering coefficients per scene unit (RGB),
 * constant (homogeneous) or given by volumes (heterogeneous: extinction and albedo grids), and
 * a phase function; transmittance along a ray and free-flight distance sampling.
 * Distances are drawn by one channel's extinction (the path's "hero" channel); the sampling
 * density of every channel is returned so that the integrator can weight a path by the
 * densities averaged over the channels (spectral MIS, as Mitsuba 3's volpathmis and pbrt-v4
 * do), which keeps chromatic media from blowing up. Heterogeneous media are tracked brick by
 * brick (volume_grid.h) against each brick's majorant (its largest extinction, all channels;
 * empty bricks skipped): distances by delta tracking, transmittance by ratio tracking, both
 * unbiased; they draw all but the first number from the caller's random stream. */
#ifndef OP_MEDIUM_H
#define OP_MEDIUM_H

#include "math/rng.h"
#include "math/vec.h"
#include "medium/phase.h"
#include "medium/volume_grid.h"

typedef struct op_pmedium {
    op_v3 sigma_a, sigma_s, sigma_t; /* homogeneous: per scene unit; sigma_t = sigma_a + sigma_s */
    op_phase phase;
    op_volume *extinction, *albedo; /* heterogeneous (both set, owned): sigma_t = scale *
                                     * extinction, sigma_s = albedo * sigma_t; else NULL */
    float scale, majorant;          /* heterogeneous: majorant >= every channel's sigma_t
                                     * (bricks' majorants are capped by it) */
    char label[160];                /* "file:line" of its <medium>, for messages */
} op_pmedium;

/* Frees a heterogeneous medium's volumes (nothing for a homogeneous one). */
void op_pmedium_free(op_pmedium *m);

/* The transmittance of the segment org + t dir, t in [0, d] (dir unit, d may be infinite),
 * per channel: homogeneous exp(-sigma_t d) exactly (0 where d is infinite and sigma_t > 0),
 * heterogeneous an unbiased estimate by ratio tracking drawing from rng. */
op_v3 op_pmedium_transmittance(const op_pmedium *m, op_v3 org, op_v3 dir, float d, op_rng *rng);

/* Samples a free-flight distance along the segment org + t dir, t in [0, tmax) (tmax may be
 * infinite) by channel c's extinction from u in [0, 1) (and, heterogeneous, rng). Returns 1
 * with *t < tmax when the path scatters there, else 0 with *t = tmax. *f and *pdf are, up to
 * one common positive factor, the segment's contribution (homogeneous: sigma_s T(t) when it
 * scatters, else T(tmax)) and per channel the density channel k's sampling would have had
 * (sigma_t T(t), or T(tmax) the probability of passing); heterogeneous media give them
 * relative to channel c's density (the contribution of the null-collision path over it).
 * f / pdf_c is the one-channel estimate. */
int op_pmedium_sample_distance(const op_pmedium *m, int c, op_v3 org, op_v3 dir, float tmax,
                               float u, op_rng *rng, float *t, op_v3 *f, op_v3 *pdf);

#endif
