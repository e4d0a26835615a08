/* measured_points.c - sample points at material pixel centres (see measured_points.h). */
#include "sss/measured_points.h"

#include <limits.h>
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

/* A triangle set up for rasterizing: its vertices in fixed point, counter-clockwise (A, B, C
 * are vertices i0, i1, i2), which edges own the samples on them, and the rows and columns of
 * samples its bounding box may hold. */
typedef struct raster {
    long long v[3][2];
    int i0, i1, i2, oab, obc, oca;
    wide area2;
    long long x0, x1, y0, y1;
} raster;

static int raster_setup(double xy[3][2], double step, raster *r)
{
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (int i = 0; i < 3; i++)
        for (int a = 0; a < 2; a++) {
            double g = xy[i][a] / step - 0.5;
            if (!(fabs(g) < 0x1p45))
                return 0; /* not finite, or beyond what the fixed point holds */
            r->v[i][a] = llround(g * (double)(1 << FIX_BITS));
            lo[a] = fmin(lo[a], g);
            hi[a] = fmax(hi[a], g);
        }
    r->area2 = edge(r->v[0], r->v[1], r->v[2]);
    if (r->area2 == 0)
        return 0;
    r->i0 = 0;
    r->i1 = 1;
    r->i2 = 2;
    if (r->area2 < 0) { /* counter-clockwise from here on */
        r->i1 = 2;
        r->i2 = 1;
        r->area2 = -r->area2;
    }
    const long long *A = r->v[r->i0], *B = r->v[r->i1], *C = r->v[r->i2];
    r->oab = owns(A, B);
    r->obc = owns(B, C);
    r->oca = owns(C, A);
    r->x0 = (long long)ceil(lo[0]) - 1;
    r->x1 = (long long)floor(hi[0]) + 1;
    r->y0 = (long long)ceil(lo[1]) - 1;
    r->y1 = (long long)floor(hi[1]) + 1;
    return 1;
}

/* Whether sample (kx, ky) is inside, with its edge functions (of the edges opposite A, B, C). */
static int raster_inside(const raster *r, long long kx, long long ky, wide e[3])
{
    const long long *A = r->v[r->i0], *B = r->v[r->i1], *C = r->v[r->i2];
    long long p[2] = {kx * (1LL << FIX_BITS), ky * (1LL << FIX_BITS)};
    e[0] = edge(B, C, p);
    e[1] = edge(C, A, p);
    e[2] = edge(A, B, p);
    return !(e[0] < 0 || e[1] < 0 || e[2] < 0 || (e[0] == 0 && !r->obc) ||
             (e[1] == 0 && !r->oca) || (e[2] == 0 && !r->oab));
}

static wide floor_div(wide a, wide b)
{
    wide q = a / b;
    return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q;
}

/* The samples of row ky inside: [*lo, *hi] (empty when *lo > *hi). The interval follows from
 * the edge functions, linear in kx, and is checked at its ends with the exact test (a row of a
 * convex region is one interval). */
static void raster_row(const raster *r, long long ky, long long *lo, long long *hi)
{
    long long l = r->x0, h = r->x1;
    const long long *P[3] = {r->v[r->i1], r->v[r->i2], r->v[r->i0]};
    const long long *Q[3] = {r->v[r->i2], r->v[r->i0], r->v[r->i1]};
    wide F = (wide)1 << FIX_BITS;
    for (int k = 0; k < 3 && l <= h; k++) {
        /* edge(P, Q, (kx F, ky F)) = c - d kx >= 0 */
        wide d = (wide)(Q[k][1] - P[k][1]) * F;
        wide c = (wide)(Q[k][0] - P[k][0]) * (ky * F - P[k][1]) +
                 (wide)(Q[k][1] - P[k][1]) * P[k][0];
        if (d > 0) {
            wide m = floor_div(c, d);
            if (m < h)
                h = (long long)(m < l - 1 ? l - 1 : m);
        } else if (d < 0) {
            wide m = -floor_div(c, -d); /* kx >= -c / |d| */
            if (m > l)
                l = (long long)(m > h + 1 ? h + 1 : m);
        } else if (c < 0) {
            h = l - 1;
        }
    }
    wide e[3];
    if (l <= h) { /* the ties and rounding: settle the ends exactly */
        while (l > r->x0 && raster_inside(r, l - 1, ky, e))
            l--;
        while (l <= h && !raster_inside(r, l, ky, e))
            l++;
        while (h < r->x1 && raster_inside(r, h + 1, ky, e))
            h++;
        while (h >= l && !raster_inside(r, h, ky, e))
            h--;
    }
    *lo = l;
    *hi = h;
}

long long op_sss_measured_count(double xy[3][2], double step)
{
    raster r;
    if (!raster_setup(xy, step, &r))
        return 0;
    long long n = 0;
    for (long long ky = r.y0; ky <= r.y1; ky++) {
        long long lo, hi;
        raster_row(&r, ky, &lo, &hi);
        n += hi >= lo ? hi - lo + 1 : 0;
    }
    return n;
}

long long op_sss_measured_raster_clip(double xy[3][2], double step, const long long clip[4],
                                      void (*visit)(void *user, const op_sss_site *s),
                                      void *user)
{
    raster r;
    if (!raster_setup(xy, step, &r))
        return 0;
    long long count = 0, before = 0; /* visited; the triangle's samples in earlier rows */
    double inv = 1.0 / (double)r.area2;
    long long y1 = r.y1 < clip[3] ? r.y1 : clip[3];
    for (long long ky = r.y0; ky <= y1; ky++) {
        long long lo, hi;
        raster_row(&r, ky, &lo, &hi);
        if (hi < lo)
            continue;
        long long first = lo, a = lo > clip[0] ? lo : clip[0], b = hi < clip[1] ? hi : clip[1];
        before += hi - lo + 1;
        if (ky < clip[2])
            continue;
        for (long long kx = a; kx <= b; kx++) {
            wide e[3];
            if (!raster_inside(&r, kx, ky, e))
                continue; /* not reached: the row is one interval */
            /* barycentrics of the triangle's own vertices 1 and 2 */
            double w[3];
            w[r.i0] = (double)e[0] * inv;
            w[r.i1] = (double)e[1] * inv;
            w[r.i2] = (double)e[2] * inv;
            op_sss_site s = {w[1], w[2], ((double)kx + 0.5) * step, ((double)ky + 0.5) * step,
                             before - (hi - lo + 1) + (kx - first)};
            count++;
            if (visit)
                visit(user, &s);
        }
    }
    return count;
}

long long op_sss_measured_raster(double xy[3][2], double step,
                                 void (*visit)(void *user, const op_sss_site *s), void *user)
{
    static const long long all[4] = {LLONG_MIN, LLONG_MAX, LLONG_MIN, LLONG_MAX};
    return op_sss_measured_raster_clip(xy, step, all, visit, user);
}
