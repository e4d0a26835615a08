/* phase.c - isotropic, Henyey-Greenstein and Rayleigh phase functions (see phase.h). */
#include "medium/phase.h"

#include <math.h>

#define INV_4PI (0.25f * OP_INV_PI)

/* Henyey-Greenstein's density for deflection cosine c. */
static float hg(float g, float c)
{
    float d = 1.0f + g * g - 2.0f * g * c;
    return INV_4PI * (1.0f - g * g) / (d * sqrtf(d));
}

/* Rayleigh's density for deflection cosine c: 3 (1 + c^2) / (16 pi). */
static float rayleigh(float c)
{
    return 3.0f / (16.0f * OP_PI) * (1.0f + c * c);
}

/* The deflection cosine c whose Rayleigh cumulative distribution (c^3 + 3 c + 4) / 8 is u: the
 * one real root of c^3 + 3 c + 4 - 8 u (Cardano), c = A - 1 / A with A = cbrt(z + sqrt(z^2 + 1))
 * and z = 4 u - 2, taken for |z| (the root is odd in z) so that nothing cancels. */
static float rayleigh_cosine(float u)
{
    float z = 4.0f * u - 2.0f, az = fabsf(z);
    float a = cbrtf(az + sqrtf(az * az + 1.0f));
    float c = a - 1.0f / a;
    return z < 0.0f ? -c : c;
}

float op_phase_eval(const op_phase *p, op_v3 wi, op_v3 wo)
{
    if (p->type == OP_PHASE_ISOTROPIC)
        return INV_4PI;
    float c = -v3_dot(wi, wo);
    return p->type == OP_PHASE_RAYLEIGH ? rayleigh(c) : hg(p->g, c);
}

float op_phase_sample(const op_phase *p, op_v3 wi, float u1, float u2, op_v3 *wo)
{
    float c, pdf;
    float g = p->type == OP_PHASE_HG ? p->g : 0.0f;
    if (p->type == OP_PHASE_RAYLEIGH) {
        c = fminf(fmaxf(rayleigh_cosine(u1), -1.0f), 1.0f);
        pdf = rayleigh(c);
    } else if (fabsf(g) < 1e-3f) {
        c = 1.0f - 2.0f * u1;
        pdf = INV_4PI;
    } else {
        /* the inverse of HG's cumulative distribution in the deflection cosine */
        float q = (1.0f - g * g) / (1.0f - g + 2.0f * g * u1);
        c = fminf(fmaxf((1.0f + g * g - q * q) / (2.0f * g), -1.0f), 1.0f);
        pdf = hg(g, c);
    }
    float s = sqrtf(fmaxf(0.0f, 1.0f - c * c)), phi = 2.0f * OP_PI * u2;
    op_frame f = op_frame_from_normal(v3_neg(wi));
    *wo = v3_norm(op_frame_to_world(&f, v3(s * cosf(phi), s * sinf(phi), c)));
    return pdf;
}
