/* shape.c - world-space triangle meshes and the procedural shapes (see shape.h). */
#include "geometry/shape.h"

#include <stdlib.h>
#include <string.h>

op_status op_trimesh_alloc(op_trimesh *m, int nverts, int ntris, int with_normals, int with_uv,
                           op_error *err)
{
    memset(m, 0, sizeof *m);
    if (nverts < 3 || ntris < 1 || nverts > (1 << 28) || ntris > (1 << 28))
        return op_error_set(err, OP_ERR_INPUT, "mesh with %d vertices and %d triangles", nverts,
                            ntris);
    m->nverts = nverts;
    m->ntris = ntris;
    m->pos = calloc(3 * (size_t)nverts + 4, sizeof(float));
    m->idx = calloc(3 * (size_t)ntris + 1, sizeof(uint32_t));
    m->area_cdf = calloc((size_t)ntris, sizeof(float));
    if (with_normals)
        m->nrm = calloc(3 * (size_t)nverts, sizeof(float));
    if (with_uv)
        m->uv = calloc(2 * (size_t)nverts, sizeof(float));
    if (!m->pos || !m->idx || !m->area_cdf || (with_normals && !m->nrm) || (with_uv && !m->uv)) {
        op_trimesh_free(m);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for a mesh of %d triangles", ntris);
    }
    return OP_OK;
}

void op_trimesh_free(op_trimesh *m)
{
    free(m->pos);
    free(m->nrm);
    free(m->uv);
    free(m->idx);
    free(m->area_cdf);
    memset(m, 0, sizeof *m);
}

long long op_trimesh_bytes(const op_trimesh *m)
{
    long long v = m->nverts, t = m->ntris;
    return (long long)sizeof(float) * (3 * v + 4 + (m->nrm ? 3 * v : 0) + (m->uv ? 2 * v : 0) + t) +
           (long long)sizeof(uint32_t) * (3 * t + 1);
}

static double det3(const op_matrix4 *a)
{
    const double(*m)[4] = a->m;
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
           m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

op_status op_trimesh_finish(op_trimesh *m, const op_matrix4 *to_world, int flip, op_error *err)
{
    op_matrix4 inv;
    if (!op_matrix4_is_finite(to_world) || !op_matrix4_inverse(to_world, &inv))
        return op_error_set(err, OP_ERR_INPUT, "toWorld is singular or not finite");
    int mirror = det3(to_world) < 0.0;
    op_v3 lo = v3s(INFINITY), hi = v3s(-INFINITY);
    for (int i = 0; i < m->nverts; i++) {
        double p[3] = {m->pos[3 * i], m->pos[3 * i + 1], m->pos[3 * i + 2]};
        op_matrix4_point(to_world, p, p);
        for (int k = 0; k < 3; k++)
            m->pos[3 * i + k] = (float)p[k];
        op_v3 q = v3(m->pos[3 * i], m->pos[3 * i + 1], m->pos[3 * i + 2]);
        if (!isfinite(q.x) || !isfinite(q.y) || !isfinite(q.z))
            return op_error_set(err, OP_ERR_INPUT, "vertex %d is not finite (%g, %g, %g) in "
                                "world space", i, p[0], p[1], p[2]);
        lo = v3(fminf(lo.x, q.x), fminf(lo.y, q.y), fminf(lo.z, q.z));
        hi = v3(fmaxf(hi.x, q.x), fmaxf(hi.y, q.y), fmaxf(hi.z, q.z));
        if (m->nrm) {
            double n[3] = {m->nrm[3 * i], m->nrm[3 * i + 1], m->nrm[3 * i + 2]};
            op_matrix4_normal(&inv, n, n);
            op_v3 nn = v3_norm(v3_from_d(n));
            if (flip)
                nn = v3_neg(nn);
            m->nrm[3 * i] = nn.x;
            m->nrm[3 * i + 1] = nn.y;
            m->nrm[3 * i + 2] = nn.z;
        }
    }
    if (mirror != flip)
        for (int t = 0; t < m->ntris; t++) {
            uint32_t tmp = m->idx[3 * t + 1];
            m->idx[3 * t + 1] = m->idx[3 * t + 2];
            m->idx[3 * t + 2] = tmp;
        }
    double sum = 0.0;
    for (int t = 0; t < m->ntris; t++) {
        for (int k = 0; k < 3; k++)
            if (m->idx[3 * t + k] >= (uint32_t)m->nverts)
                return op_error_set(err, OP_ERR_INPUT, "triangle %d refers to vertex %u of %d", t,
                                    m->idx[3 * t + k], m->nverts);
        op_v3 a, b, c;
        op_trimesh_tri(m, t, &a, &b, &c);
        double area = 0.5 * v3_len(v3_cross(v3_sub(b, a), v3_sub(c, a)));
        if (!isfinite(area))
            return op_error_set(err, OP_ERR_INPUT, "triangle %d is not finite", t);
        sum += area;
        m->area_cdf[t] = (float)sum;
    }
    if (!(sum > 0.0) || !((float)sum > 0.0f))
        return op_error_set(err, OP_ERR_INPUT, "the mesh has zero area");
    m->area = (float)sum;
    m->bmin = lo;
    m->bmax = hi;
    return OP_OK;
}

op_status op_placement_make(const op_matrix4 *to_world, int flip, op_placement *pl, op_error *err)
{
    op_matrix4 inv;
    if (!op_matrix4_is_finite(to_world) || !op_matrix4_inverse(to_world, &inv))
        return op_error_set(err, OP_ERR_INPUT, "toWorld is singular or not finite");
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 4; c++)
            pl->m[4 * r + c] = (float)to_world->m[r][c];
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            pl->n[3 * r + c] = (float)inv.m[c][r];
    pl->flip = flip != 0;
    pl->swap = (det3(to_world) < 0.0) != (flip != 0);
    return OP_OK;
}

void op_placement_bounds(const op_placement *pl, const op_trimesh *m, op_v3 *lo, op_v3 *hi)
{
    *lo = v3s(INFINITY);
    *hi = v3s(-INFINITY);
    for (int k = 0; k < 8; k++) {
        op_v3 c = v3(k & 1 ? m->bmax.x : m->bmin.x, k & 2 ? m->bmax.y : m->bmin.y,
                     k & 4 ? m->bmax.z : m->bmin.z);
        op_v3 p = op_place_point(pl, c);
        if (!isfinite(p.x) || !isfinite(p.y) || !isfinite(p.z)) {
            *lo = *hi = v3s(NAN); /* fails every comparison */
            return;
        }
        *lo = v3(fminf(lo->x, p.x), fminf(lo->y, p.y), fminf(lo->z, p.z));
        *hi = v3(fmaxf(hi->x, p.x), fmaxf(hi->y, p.y), fmaxf(hi->z, p.z));
    }
}

int op_trimesh_pick(const op_trimesh *m, float u)
{
    float target = u * m->area;
    int lo = 0, hi = m->ntris - 1;
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        if (m->area_cdf[mid] <= target)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

op_status op_shape_sphere(op_trimesh *m, int segments, op_error *err)
{
    int nu = segments, nv = segments / 2;
    op_status st = op_trimesh_alloc(m, (nu + 1) * (nv + 1), 2 * nu * (nv - 1), 1, 1, err);
    if (st)
        return st;
    for (int j = 0; j <= nv; j++)
        for (int i = 0; i <= nu; i++) {
            int k = j * (nu + 1) + i;
            double theta = M_PI * j / nv, phi = 2.0 * M_PI * i / nu;
            float x = (float)(sin(theta) * cos(phi)), y = (float)(sin(theta) * sin(phi)),
                  z = (float)cos(theta);
            m->pos[3 * k] = m->nrm[3 * k] = x;
            m->pos[3 * k + 1] = m->nrm[3 * k + 1] = y;
            m->pos[3 * k + 2] = m->nrm[3 * k + 2] = z;
            m->uv[2 * k] = (float)i / nu;
            m->uv[2 * k + 1] = (float)j / nv;
        }
    int t = 0;
    for (int j = 0; j < nv; j++)
        for (int i = 0; i < nu; i++) {
            uint32_t a = j * (nu + 1) + i, b = a + 1, c = a + nu + 1, d = c + 1;
            /* outward winding: theta grows downward from +z, phi counter-clockwise */
            if (j != 0) {
                m->idx[3 * t] = a;
                m->idx[3 * t + 1] = c;
                m->idx[3 * t + 2] = b;
                t++;
            }
            if (j != nv - 1) {
                m->idx[3 * t] = b;
                m->idx[3 * t + 1] = c;
                m->idx[3 * t + 2] = d;
                t++;
            }
        }
    return OP_OK;
}

op_status op_shape_rectangle(op_trimesh *m, op_error *err)
{
    op_status st = op_trimesh_alloc(m, 4, 2, 1, 1, err);
    if (st)
        return st;
    static const float p[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (int k = 0; k < 4; k++) {
        m->pos[3 * k] = p[k][0];
        m->pos[3 * k + 1] = p[k][1];
        m->nrm[3 * k + 2] = 1.0f;
        m->uv[2 * k] = 0.5f * (p[k][0] + 1.0f);
        m->uv[2 * k + 1] = 0.5f * (p[k][1] + 1.0f);
    }
    static const uint32_t idx[6] = {0, 1, 2, 0, 2, 3};
    memcpy(m->idx, idx, sizeof idx);
    return OP_OK;
}

op_status op_shape_cube(op_trimesh *m, op_error *err)
{
    op_status st = op_trimesh_alloc(m, 24, 12, 1, 1, err);
    if (st)
        return st;
    /* each face: normal axis n, sign s; corners in (u, v) order counter-clockwise seen from outside */
    for (int f = 0; f < 6; f++) {
        int axis = f / 2;
        float s = (f % 2) ? -1.0f : 1.0f;
        int ua = (axis + 1) % 3, va = (axis + 2) % 3;
        static const float cu[4] = {-1, 1, 1, -1}, cv[4] = {-1, -1, 1, 1};
        for (int k = 0; k < 4; k++) {
            int vi = 4 * f + k;
            float p[3];
            p[axis] = s;
            p[ua] = cu[k] * s; /* mirror u on the negative face to keep the winding outward */
            p[va] = cv[k];
            for (int c = 0; c < 3; c++) {
                m->pos[3 * vi + c] = p[c];
                m->nrm[3 * vi + c] = c == axis ? s : 0.0f;
            }
            m->uv[2 * vi] = 0.5f * (cu[k] + 1.0f);
            m->uv[2 * vi + 1] = 0.5f * (cv[k] + 1.0f);
        }
        uint32_t b = 4 * f;
        uint32_t tri[6] = {b, b + 1, b + 2, b, b + 2, b + 3};
        memcpy(m->idx + 6 * f, tri, sizeof tri);
    }
    return OP_OK;
}

op_status op_shape_disk(op_trimesh *m, int segments, op_error *err)
{
    op_status st = op_trimesh_alloc(m, segments + 2, segments, 1, 1, err);
    if (st)
        return st;
    m->nrm[2] = 1.0f;
    for (int i = 0; i <= segments; i++) {
        int k = i + 1;
        double phi = 2.0 * M_PI * i / segments;
        m->pos[3 * k] = (float)cos(phi);
        m->pos[3 * k + 1] = (float)sin(phi);
        m->nrm[3 * k + 2] = 1.0f;
        m->uv[2 * k] = 1.0f;
        m->uv[2 * k + 1] = (float)i / segments;
    }
    for (int t = 0; t < segments; t++) {
        m->idx[3 * t] = 0;
        m->idx[3 * t + 1] = t + 1;
        m->idx[3 * t + 2] = t + 2;
    }
    return OP_OK;
}

op_status op_shape_cylinder(op_trimesh *m, int segments, op_error *err)
{
    op_status st = op_trimesh_alloc(m, 2 * (segments + 1), 2 * segments, 1, 1, err);
    if (st)
        return st;
    for (int i = 0; i <= segments; i++) {
        double phi = 2.0 * M_PI * i / segments;
        float c = (float)cos(phi), s = (float)sin(phi);
        for (int j = 0; j < 2; j++) {
            int k = 2 * i + j;
            m->pos[3 * k] = m->nrm[3 * k] = c;
            m->pos[3 * k + 1] = m->nrm[3 * k + 1] = s;
            m->pos[3 * k + 2] = (float)j;
            m->uv[2 * k] = (float)i / segments;
            m->uv[2 * k + 1] = (float)j;
        }
    }
    for (int i = 0; i < segments; i++) {
        uint32_t a = 2 * i, b = a + 1, c = a + 2, d = a + 3; /* a, c at z = 0; b, d at z = 1 */
        uint32_t tri[6] = {a, c, d, a, d, b};                /* counter-clockwise from outside */
        memcpy(m->idx + 6 * i, tri, sizeof tri);
    }
    return OP_OK;
}

op_status op_cylinder_placement(const double p0[3], const double p1[3], double radius,
                                op_matrix4 *out, op_error *err)
{
    double d[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
    double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (!(len > 0.0) || !isfinite(len) || !(radius > 0.0) || !isfinite(radius))
        return op_error_set(err, OP_ERR_INPUT, "a cylinder needs p0 != p1 and a radius > 0, all "
                            "finite (length %g, radius %g)", len, radius);
    double n[3] = {d[0] / len, d[1] / len, d[2] / len}, s[3], t[3];
    /* Mitsuba's coordinateSystem(n): t first, then s = t x n */
    if (fabs(n[0]) > fabs(n[1])) {
        double inv = 1.0 / sqrt(n[0] * n[0] + n[2] * n[2]);
        t[0] = n[2] * inv, t[1] = 0.0, t[2] = -n[0] * inv;
    } else {
        double inv = 1.0 / sqrt(n[1] * n[1] + n[2] * n[2]);
        t[0] = 0.0, t[1] = n[2] * inv, t[2] = -n[1] * inv;
    }
    s[0] = t[1] * n[2] - t[2] * n[1];
    s[1] = t[2] * n[0] - t[0] * n[2];
    s[2] = t[0] * n[1] - t[1] * n[0];
    *out = op_matrix4_identity();
    for (int r = 0; r < 3; r++) {
        out->m[r][0] = s[r] * radius;
        out->m[r][1] = t[r] * radius;
        out->m[r][2] = n[r] * len;
        out->m[r][3] = p0[r];
    }
    return OP_OK;
}
