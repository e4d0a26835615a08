/* medium.h - a homogeneous participating medium: absorption and scattering coefficients per
 * scene unit (RGB) and a phase function; its transmittance and free-flight distance sampling.
 * Distances are drawn by one channel's extinction (the path's "hero" channel); the sampling
 * density of every channel is returned so that the integrator can weight a path by the
 * densities averaged over the channels (spectral MIS, as Mitsuba 3's volpathmis and pbrt-v4
 * do), which keeps chromatic media from blowing up. */
#ifndef OP_MEDIUM_H
#define OP_MEDIUM_H

#include "math/vec.h"
#include "medium/phase.h"

typedef struct op_pmedium {
    op_v3 sigma_a, sigma_s, sigma_t; /* per scene unit; sigma_t = sigma_a + sigma_s */
    op_phase phase;
    char label[160]; /* "file:line" of its <medium>, for messages */
} op_pmedium;

/* exp(-sigma_t d) per channel (d may be infinite: 0 where sigma_t > 0, 1 where it is 0). */
op_v3 op_pmedium_transmittance(const op_pmedium *m, float d);

/* Samples a free-flight distance along a segment of length tmax (may be infinite) by channel
 * c's extinction from u in [0, 1). Returns 1 with *t < tmax when the path scatters there, with
 * *f = sigma_s T(t) and *pdf per channel sigma_t T(t) (the density channel k's sampling would
 * have had); else 0 with *t = tmax, *f = T(tmax) and *pdf per channel T(tmax) (the probability
 * of passing). f / pdf_c is the one-channel estimate. */
int op_pmedium_sample_distance(const op_pmedium *m, int c, float tmax, float u, float *t,
                               op_v3 *f, op_v3 *pdf);

#endif
