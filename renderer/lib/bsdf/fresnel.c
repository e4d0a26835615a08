/* fresnel.c - the dielectric Fresnel reflectance (see fresnel.h). */
#include "bsdf/fresnel.h"

#include <math.h>

float op_fresnel_dielectric(float cos_i, float eta, float *cos_t)
{
    float e = cos_i >= 0.0f ? eta : 1.0f / eta;
    float ci = fabsf(cos_i);
    float sin2_t = (1.0f - ci * ci) / (e * e);
    if (sin2_t >= 1.0f) {
        *cos_t = 0.0f;
        return 1.0f;
    }
    float ct = sqrtf(1.0f - sin2_t);
    float rs = (ci - e * ct) / (ci + e * ct);
    float rp = (e * ci - ct) / (e * ci + ct);
    *cos_t = ct;
    return 0.5f * (rs * rs + rp * rp);
}

float op_fresnel_dielectric_pair(float cos_out, float cos_in, float eta)
{
    float rs = (cos_out - eta * cos_in) / (cos_out + eta * cos_in);
    float rp = (eta * cos_out - cos_in) / (eta * cos_out + cos_in);
    return 0.5f * (rs * rs + rp * rp);
}
