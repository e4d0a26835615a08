/* medium.c - homogeneous media (see medium.h). */
#include "medium/medium.h"

#include <math.h>

/* exp(-s d) for one channel, with 0 * infinity taken as 0. */
static float tr1(float s, float d)
{
    return s > 0.0f ? expf(-s * d) : 1.0f;
}

op_v3 op_pmedium_transmittance(const op_pmedium *m, float d)
{
    return v3(tr1(m->sigma_t.x, d), tr1(m->sigma_t.y, d), tr1(m->sigma_t.z, d));
}

int op_pmedium_sample_distance(const op_pmedium *m, int c, float tmax, float u, float *t,
                               op_v3 *f, op_v3 *pdf)
{
    float sc = v3_get(m->sigma_t, c);
    float d = sc > 0.0f ? -log1pf(-u) / sc : INFINITY;
    int scattered = d < tmax;
    *t = scattered ? d : tmax;
    op_v3 tr = op_pmedium_transmittance(m, *t);
    *f = scattered ? v3_mul(m->sigma_s, tr) : tr;
    *pdf = scattered ? v3_mul(m->sigma_t, tr) : tr;
    return scattered;
}
