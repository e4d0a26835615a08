/* mesh.c - mesh helpers shared by the loaders and the scene builder; it calls no loader. */
#include "geometry/mesh.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void op_mesh_free(op_mesh *m)
{
    if (!m)
        return;
    free(m->positions);
    free(m->normals);
    free(m->uvs);
    free(m->indices);
    memset(m, 0, sizeof *m);
}

void op_mesh_flip_v(op_mesh *m)
{
    if (!m->uvs)
        return;
    for (uint32_t i = 0; i < m->nverts; i++)
        m->uvs[2 * (size_t)i + 1] = 1.0f - m->uvs[2 * (size_t)i + 1];
}

op_status op_mesh_compute_normals(op_mesh *m, op_error *err)
{
    double *acc = calloc((size_t)m->nverts * 3 + 1, sizeof(double));
    if (!acc)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory computing normals");
    for (uint32_t t = 0; t < m->ntris; t++) {
        const uint32_t *idx = &m->indices[3 * (size_t)t];
        const float *p0 = &m->positions[3 * (size_t)idx[0]], *p1 = &m->positions[3 * (size_t)idx[1]],
                    *p2 = &m->positions[3 * (size_t)idx[2]];
        double e1[3], e2[3], n[3];
        for (int k = 0; k < 3; k++) {
            e1[k] = (double)p1[k] - p0[k];
            e2[k] = (double)p2[k] - p0[k];
        }
        /* |e1 x e2| is twice the area: summing unnormalized crosses weights by area. */
        n[0] = e1[1] * e2[2] - e1[2] * e2[1];
        n[1] = e1[2] * e2[0] - e1[0] * e2[2];
        n[2] = e1[0] * e2[1] - e1[1] * e2[0];
        for (int c = 0; c < 3; c++)
            for (int k = 0; k < 3; k++)
                acc[3 * (size_t)idx[c] + k] += n[k];
    }
    float *normals = m->normals ? m->normals : malloc((size_t)m->nverts * 3 * sizeof(float) + 1);
    if (!normals) {
        free(acc);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory computing normals");
    }
    for (uint32_t i = 0; i < m->nverts; i++) {
        double *a = &acc[3 * (size_t)i];
        double len = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
        float *n = &normals[3 * (size_t)i];
        if (len > 0 && isfinite(len)) {
            n[0] = (float)(a[0] / len);
            n[1] = (float)(a[1] / len);
            n[2] = (float)(a[2] / len);
        } else {
            n[0] = 0.0f, n[1] = 0.0f, n[2] = 1.0f;
        }
    }
    m->normals = normals;
    free(acc);
    return OP_OK;
}

void op_mesh_drop_normals(op_mesh *m)
{
    free(m->normals);
    m->normals = NULL;
}

void op_mesh_bounds(const op_mesh *m, float lo[3], float hi[3])
{
    for (int k = 0; k < 3; k++)
        lo[k] = hi[k] = 0.0f;
    for (uint32_t i = 0; i < m->nverts; i++)
        for (int k = 0; k < 3; k++) {
            float v = m->positions[3 * (size_t)i + k];
            if (i == 0 || v < lo[k])
                lo[k] = v;
            if (i == 0 || v > hi[k])
                hi[k] = v;
        }
}
