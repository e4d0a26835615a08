/* phase.h - phase functions of participating media: isotropic, Henyey-Greenstein and Rayleigh
 * (3 (1 + cos^2 theta) / (16 pi): scattering by particles much smaller than the wavelength, whose
 * wavelength dependence is the medium's coefficients'). Directions follow the BSDF convention:
 * wi points back along the arriving ray (away from the scattering point), wo is where light
 * leaves; cos theta = -dot(wi, wo) is the deflection cosine, so g > 0 scatters forward. */
#ifndef OP_PHASE_H
#define OP_PHASE_H

#include "math/vec.h"

typedef enum op_phase_type { OP_PHASE_ISOTROPIC, OP_PHASE_HG, OP_PHASE_RAYLEIGH } op_phase_type;

typedef struct op_phase {
    op_phase_type type;
    float g; /* HG mean cosine, in (-1, 1); 0 for the others */
} op_phase;

/* The phase function's value for wi -> wo (both unit), which is also its sampling density
 * (per steradian). */
float op_phase_eval(const op_phase *p, op_v3 wi, op_v3 wo);
/* Samples wo from wi with u1, u2 in [0, 1) exactly by the phase function's density; returns that
 * density (the sample's weight is 1). */
float op_phase_sample(const op_phase *p, op_v3 wi, float u1, float u2, op_v3 *wo);

#endif
