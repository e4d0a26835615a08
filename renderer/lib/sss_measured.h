/* sss_measured.h - the irradiance points and pair values of a measured (tabulated) material:
 * points at the centres of its pixels (or of an even subdivision of them), so that the offset
 * between two points of a flat part is a whole number of pixels and the exitance sum is the
 * material's own discrete convolution (docs/subsurface-rendering.md, "Measured materials").
 *
 * Sites are laid per triangle in its material pixel coordinates (texture coordinates times the
 * material's size in pixels, or the box projection), with an exact (integer) inside test and a
 * tie rule that gives a sample on an edge shared by two triangles to exactly one of them: a
 * mesh whose coordinates are continuous gets every sample once. */
#ifndef OP_SSS_MEASURED_H
#define OP_SSS_MEASURED_H

#include <math.h>

#include "opaline.h"

/* The sample step in material pixels for a density (points per pixel area): 1/round(sqrt(d))
 * for d >= 1 (the centres of an s x s subdivision of every pixel), else round(1/sqrt(d)). */
double op_sss_measured_step(double density);

/* One sample inside a triangle: barycentrics (of vertices 1 and 2) and its material
 * coordinates x, y = (k + 0.5) step (unwrapped). */
typedef struct op_sss_site {
    double b1, b2, x, y;
} op_sss_site;

/* Calls visit(user, site) for every sample point (kx + 1/2, ky + 1/2) step (kx, ky integers)
 * inside the triangle whose vertices have material coordinates xy[0..2] (in pixels), in a fixed
 * order; returns how many. A degenerate triangle has none. xy is not changed. */
long long op_sss_measured_raster(double xy[3][2], double step,
                                 void (*visit)(void *user, const op_sss_site *s), void *user);

/* The kernel offset (dx, dy) in whole pixels from a source at material coordinates (fx, fy)
 * (a sample centre) to a receiver d = (ux, uy) pixels away in the source's frame: the pixel the
 * receiver falls in minus the source's. Returns 0 outside the kernel [-K/2, K/2]^2. */
static inline int op_sss_measured_offset(float fx, float fy, float ux, float uy, int kernel,
                                         int *dx, int *dy)
{
    int half = kernel / 2;
    float bx = floorf(fx), by = floorf(fy);
    float ox = floorf(fx + ux) - bx, oy = floorf(fy + uy) - by;
    if (!(ox >= (float)-half && ox <= (float)half && oy >= (float)-half && oy <= (float)half))
        return 0;
    *dx = (int)ox;
    *dy = (int)oy;
    return 1;
}

#endif
