/* transform.c - see transform.h. */
#include "math/transform.h"

#include <math.h>
#include <string.h>

#define OP_PI 3.14159265358979323846

op_matrix4 op_matrix4_identity(void)
{
    op_matrix4 r;
    memset(&r, 0, sizeof r);
    for (int i = 0; i < 4; i++)
        r.m[i][i] = 1.0;
    return r;
}

op_matrix4 op_matrix4_mul(const op_matrix4 *a, const op_matrix4 *b)
{
    op_matrix4 r;
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            double s = 0.0;
            for (int k = 0; k < 4; k++)
                s += a->m[i][k] * b->m[k][j];
            r.m[i][j] = s;
        }
    return r;
}

op_matrix4 op_matrix4_transpose(const op_matrix4 *a)
{
    op_matrix4 r;
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            r.m[i][j] = a->m[j][i];
    return r;
}

op_matrix4 op_matrix4_translate(double x, double y, double z)
{
    op_matrix4 r = op_matrix4_identity();
    r.m[0][3] = x;
    r.m[1][3] = y;
    r.m[2][3] = z;
    return r;
}

op_matrix4 op_matrix4_scale(double x, double y, double z)
{
    op_matrix4 r = op_matrix4_identity();
    r.m[0][0] = x;
    r.m[1][1] = y;
    r.m[2][2] = z;
    return r;
}

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross3(const double a[3], const double b[3], double out[3])
{
    double r[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    memcpy(out, r, sizeof r);
}

static int normalize3(double v[3])
{
    double len = sqrt(dot3(v, v));
    if (!(len > 0.0) || !isfinite(len))
        return 0;
    for (int i = 0; i < 3; i++)
        v[i] /= len;
    return 1;
}

op_matrix4 op_matrix4_rotate(const double axis[3], double angle_deg)
{
    double a[3] = {axis[0], axis[1], axis[2]};
    if (!normalize3(a))
        return op_matrix4_identity();
    double t = angle_deg * (OP_PI / 180.0), s = sin(t), c = cos(t);
    op_matrix4 r = op_matrix4_identity();
    r.m[0][0] = a[0] * a[0] + (1.0 - a[0] * a[0]) * c;
    r.m[0][1] = a[0] * a[1] * (1.0 - c) - a[2] * s;
    r.m[0][2] = a[0] * a[2] * (1.0 - c) + a[1] * s;
    r.m[1][0] = a[0] * a[1] * (1.0 - c) + a[2] * s;
    r.m[1][1] = a[1] * a[1] + (1.0 - a[1] * a[1]) * c;
    r.m[1][2] = a[1] * a[2] * (1.0 - c) - a[0] * s;
    r.m[2][0] = a[0] * a[2] * (1.0 - c) - a[1] * s;
    r.m[2][1] = a[1] * a[2] * (1.0 - c) + a[0] * s;
    r.m[2][2] = a[2] * a[2] + (1.0 - a[2] * a[2]) * c;
    return r;
}

int op_matrix4_lookat(const double origin[3], const double target[3], const double up[3],
                      op_matrix4 *out)
{
    *out = op_matrix4_identity();
    double dir[3] = {target[0] - origin[0], target[1] - origin[1], target[2] - origin[2]};
    if (!normalize3(dir))
        return 0;
    double u[3] = {0, 0, 0};
    if (up) {
        /* scaled by a power of two (exactly) so that a tiny or huge up neither underflows nor
         * overflows below */
        double big = fmax(fabs(up[0]), fmax(fabs(up[1]), fabs(up[2])));
        if (!(big > 0.0) || !isfinite(big))
            return 0;
        int e;
        frexp(big, &e);
        for (int i = 0; i < 3; i++)
            u[i] = ldexp(up[i], -e);
    } else {
        /* Mitsuba's coordinateSystem(dir, up, tmp): tmp is perpendicular to dir, up = tmp x dir. */
        double tmp[3];
        if (fabs(dir[0]) > fabs(dir[1])) {
            double inv = 1.0 / sqrt(dir[0] * dir[0] + dir[2] * dir[2]);
            tmp[0] = dir[2] * inv, tmp[1] = 0.0, tmp[2] = -dir[0] * inv;
        } else {
            double inv = 1.0 / sqrt(dir[1] * dir[1] + dir[2] * dir[2]);
            tmp[0] = 0.0, tmp[1] = dir[2] * inv, tmp[2] = -dir[1] * inv;
        }
        cross3(tmp, dir, u);
    }
    double left[3], newup[3];
    cross3(u, dir, left);
    /* |u x dir| = |u| sin(angle between them) */
    if (!(dot3(left, left) > 1e-18 * dot3(u, u)) || !normalize3(left))
        return 0;
    cross3(dir, left, newup);
    for (int i = 0; i < 3; i++) {
        out->m[i][0] = left[i];
        out->m[i][1] = newup[i];
        out->m[i][2] = dir[i];
        out->m[i][3] = origin[i];
    }
    return 1;
}

int op_matrix4_is_finite(const op_matrix4 *a)
{
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            if (!isfinite(a->m[i][j]))
                return 0;
    return 1;
}

int op_matrix4_inverse(const op_matrix4 *a, op_matrix4 *out)
{
    double w[4][8];
    *out = op_matrix4_identity();
    if (!op_matrix4_is_finite(a))
        return 0;
    double scale = 0.0;
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            w[i][j] = a->m[i][j];
            w[i][j + 4] = i == j;
            if (j < 3 || i == 3) /* a translation, however far, does not make it singular */
                scale = fmax(scale, fabs(a->m[i][j]));
        }
    if (scale == 0.0)
        return 0;
    for (int col = 0; col < 4; col++) {
        int piv = col;
        for (int r = col + 1; r < 4; r++)
            if (fabs(w[r][col]) > fabs(w[piv][col]))
                piv = r;
        if (fabs(w[piv][col]) <= 1e-14 * scale)
            return 0;
        if (piv != col)
            for (int j = 0; j < 8; j++) {
                double t = w[col][j];
                w[col][j] = w[piv][j];
                w[piv][j] = t;
            }
        double inv = 1.0 / w[col][col];
        for (int j = 0; j < 8; j++)
            w[col][j] *= inv;
        for (int r = 0; r < 4; r++)
            if (r != col && w[r][col] != 0.0) {
                double f = w[r][col];
                for (int j = 0; j < 8; j++)
                    w[r][j] -= f * w[col][j];
            }
    }
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            out->m[i][j] = w[i][j + 4];
    return op_matrix4_is_finite(out);
}

void op_matrix4_point(const op_matrix4 *a, const double p[3], double out[3])
{
    double r[4];
    for (int i = 0; i < 4; i++)
        r[i] = a->m[i][0] * p[0] + a->m[i][1] * p[1] + a->m[i][2] * p[2] + a->m[i][3];
    if (r[3] != 1.0 && r[3] != 0.0)
        for (int i = 0; i < 3; i++)
            r[i] /= r[3];
    memcpy(out, r, 3 * sizeof(double));
}

void op_matrix4_vector(const op_matrix4 *a, const double v[3], double out[3])
{
    double r[3];
    for (int i = 0; i < 3; i++)
        r[i] = a->m[i][0] * v[0] + a->m[i][1] * v[1] + a->m[i][2] * v[2];
    memcpy(out, r, sizeof r);
}

void op_matrix4_normal(const op_matrix4 *inv, const double n[3], double out[3])
{
    double r[3];
    for (int i = 0; i < 3; i++)
        r[i] = inv->m[0][i] * n[0] + inv->m[1][i] * n[1] + inv->m[2][i] * n[2];
    memcpy(out, r, sizeof r);
}
