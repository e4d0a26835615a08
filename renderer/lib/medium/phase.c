/* phase.c - isotropic and Henyey-Greenstein phase functions (see phase.h). */
#include "medium/phase.h"

#include <math.h>

#define INV_4PI (0.25f * OP_INV_PI)

/* Henyey-Greenstein's density for deflection cosine c. */
static float hg(float g, float c)
{
    float d = 1.0f + g * g - 2.0f * g * c;
    return INV_4PI * (1.0f - g * g) / (d * sqrtf(d));
}

float op_phase_eval(const op_phase *p, op_v3 wi, op_v3 wo)
{
    if (p->type == OP_PHASE_ISOTROPIC)
        return INV_4PI;
    return hg(p->g, -v3_dot(wi, wo));
}

float op_phase_sample(const op_phase *p, op_v3 wi, float u1, float u2, op_v3 *wo)
{
    float c;
    float g = p->type == OP_PHASE_HG ? p->g : 0.0f;
    if (fabsf(g) < 1e-3f) {
        c = 1.0f - 2.0f * u1;
    } else {
        /* the inverse of HG's cumulative distribution in the deflection cosine */
        float q = (1.0f - g * g) / (1.0f - g + 2.0f * g * u1);
        c = (1.0f + g * g - q * q) / (2.0f * g);
    }
    c = fminf(fmaxf(c, -1.0f), 1.0f);
    float s = sqrtf(fmaxf(0.0f, 1.0f - c * c)), phi = 2.0f * OP_PI * u2;
    op_frame f = op_frame_from_normal(v3_neg(wi));
    *wo = v3_norm(op_frame_to_world(&f, v3(s * cosf(phi), s * sinf(phi), c)));
    return fabsf(g) < 1e-3f ? INV_4PI : hg(g, c);
}
