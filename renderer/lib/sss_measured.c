/* sss_measured.c - sample points at material pixel centres (see sss_measured.h). */
#include "sss_measured.h"

#include <math.h>

__extension__ typedef __int128 wide;

double op_sss_measured_step(double density)
{
    if (!(density > 0.0))
        return 1.0;
    double s = sqrt(density);
    return s >= 1.0 ? 1.0 / fmax(1.0, round(s)) : fmax(1.0, round(1.0 / s));
}

/* Fixed point: coordinates in sample units (k at integers) times 2^16. */
enum { FIX_BITS = 16 };

static wide edge(const long long a[2], const long long b[2], const long long p[2])
{
    return (wide)(b[0] - a[0]) * (p[1] - a[1]) - (wide)(b[1] - a[1]) * (p[0] - a[0]);
}

/* Whether the edge a -> b of a counter-clockwise triangle owns the samples on it. */
static int owns(const long long a[2], const long long b[2])
{
    long long dx = b[0] - a[0], dy = b[1] - a[1];
    return dy < 0 || (dy == 0 && dx > 0);
}

long long op_sss_measured_raster(double xy[3][2], double step,
                                 void (*visit)(void *user, const op_sss_site *s), void *user)
{
    long long v[3][2];
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (int i = 0; i < 3; i++)
        for (int a = 0; a < 2; a++) {
            double g = xy[i][a] / step - 0.5;
            if (!(fabs(g) < 0x1p45))
                return 0; /* not finite, or beyond what the fixed point holds */
            v[i][a] = llround(g * (double)(1 << FIX_BITS));
            lo[a] = fmin(lo[a], g);
            hi[a] = fmax(hi[a], g);
        }
    wide area2 = edge(v[0], v[1], v[2]);
    if (area2 == 0)
        return 0;
    int i0 = 0, i1 = 1, i2 = 2;
    if (area2 < 0) { /* counter-clockwise from here on */
        i1 = 2;
        i2 = 1;
        area2 = -area2;
    }
    const long long *A = v[i0], *B = v[i1], *C = v[i2];
    int oab = owns(A, B), obc = owns(B, C), oca = owns(C, A);
    long long count = 0;
    double inv = 1.0 / (double)area2;
    for (long long ky = (long long)ceil(lo[1]) - 1; ky <= (long long)floor(hi[1]) + 1; ky++)
        for (long long kx = (long long)ceil(lo[0]) - 1; kx <= (long long)floor(hi[0]) + 1; kx++) {
            long long p[2] = {kx * (1LL << FIX_BITS), ky * (1LL << FIX_BITS)};
            wide ea = edge(B, C, p), eb = edge(C, A, p), ec = edge(A, B, p);
            if (ea < 0 || eb < 0 || ec < 0 || (ea == 0 && !obc) || (eb == 0 && !oca) ||
                (ec == 0 && !oab))
                continue;
            /* barycentrics of the triangle's own vertices 1 and 2 */
            double w[3];
            w[i0] = (double)ea * inv;
            w[i1] = (double)eb * inv;
            w[i2] = (double)ec * inv;
            op_sss_site s = {w[1], w[2], ((double)kx + 0.5) * step, ((double)ky + 0.5) * step};
            count++;
            if (visit)
                visit(user, &s);
        }
    return count;
}
