/* meter.c - the irradiancemeter's rays (see meter.h). */
#include "camera/meter.h"

#include <math.h>

void op_meter_ray(const op_trimesh *mesh, int rectangle, float su, float sv, float du, float dv,
                  op_v3 *org, op_v3 *dir, float *tmin)
{
    if (rectangle) {
        op_v3 a, b, c;
        op_trimesh_tri(mesh, 0, &a, &b, &c); /* its front, whatever the winding */
        const float *q = mesh->pos; /* vertices 0, 1, 3: the local corners (-1, -1), (1, -1), (-1, 1) */
        op_v3 p0 = v3(q[0], q[1], q[2]), p1 = v3(q[3], q[4], q[5]), p3 = v3(q[9], q[10], q[11]);
        op_v3 p = v3_add(p0, v3_add(v3_scale(v3_sub(p1, p0), su), v3_scale(v3_sub(p3, p0), sv)));
        op_v3 n = v3_norm(v3_cross(v3_sub(b, a), v3_sub(c, a)));
        op_frame f = op_frame_from_normal(n);
        *dir = v3_norm(op_frame_to_world(&f, op_sample_cosine(du, dv)));
        *org = p;
        *tmin = 1e-4f * fmaxf(1.0f, fmaxf(fabsf(p.x), fmaxf(fabsf(p.y), fabsf(p.z))));
        return;
    }
    int t = op_trimesh_pick(mesh, su);
    float lo = t > 0 ? mesh->area_cdf[t - 1] : 0.0f, hi = mesh->area_cdf[t];
    float ru = hi > lo ? (su * mesh->area - lo) / (hi - lo) : 0.5f; /* su within the triangle */
    ru = fminf(fmaxf(ru, 0.0f), 0x1.fffffep-1f);
    float b1, b2;
    op_sample_triangle(ru, sv, &b1, &b2);
    op_v3 a, b, c;
    op_trimesh_tri(mesh, t, &a, &b, &c);
    op_v3 p = v3_add(v3_add(v3_scale(a, 1.0f - b1 - b2), v3_scale(b, b1)), v3_scale(c, b2));
    op_v3 n = v3_norm(v3_cross(v3_sub(b, a), v3_sub(c, a)));
    op_frame f = op_frame_from_normal(n);
    *dir = v3_norm(op_frame_to_world(&f, op_sample_cosine(du, dv)));
    *org = p;
    *tmin = 1e-4f * fmaxf(1.0f, fmaxf(fabsf(p.x), fmaxf(fabsf(p.y), fabsf(p.z))));
}
