/* measured_points.h - the irradiance points and pair values of a measured (tabulated) material:
 * points at the centres of its pixels (or of an even subdivision of them), so that the offset
 * between two points of a flat part is a whole number of pixels and the exitance sum is the
 * material's own discrete convolution (docs/subsurface-rendering.md, "Measured materials").
 *
 * Sites are laid per triangle in its material pixel coordinates (texture coordinates times the
 * material's size in pixels, or the box projection), with an exact (integer) inside test and a
 * tie rule that gives a sample on an edge shared by two triangles to exactly one of them: a
 * mesh whose coordinates are continuous gets every sample once. The pair value of source i and
 * receiver j is the kernel at the whole-pixel offset floor(f_i + u) - floor(f_i): f_i is i's
 * material coordinate, u the offset x_j - x_i along i's frame in physical pixels (sss/prepass.c,
 * centred_task). */
#ifndef OP_SSS_MEASURED_POINTS_H
#define OP_SSS_MEASURED_POINTS_H

#include "opaline.h"

/* The sample step in material pixels for a density (points per pixel area): 1/round(sqrt(d))
 * for d >= 1 (the centres of an s x s subdivision of every pixel), else round(1/sqrt(d)). */
double op_sss_measured_step(double density);

/* One sample inside a triangle: barycentrics (of vertices 1 and 2), its material coordinates
 * x, y = (k + 0.5) step (unwrapped), and its index among the triangle's samples in the
 * rasterizer's order. */
typedef struct op_sss_site {
    double b1, b2, x, y;
    long long index;
} op_sss_site;

/* Calls visit(user, site) for every sample point (kx + 1/2, ky + 1/2) step (kx, ky integers)
 * inside the triangle whose vertices have material coordinates xy[0..2] (in pixels), in a fixed
 * order; returns how many. A degenerate triangle has none. xy is not changed. */
long long op_sss_measured_raster(double xy[3][2], double step,
                                 void (*visit)(void *user, const op_sss_site *s), void *user);

/* As op_sss_measured_raster, for the samples (kx, ky) with clip[0] <= kx <= clip[1] and
 * clip[2] <= ky <= clip[3] only (the same sites, indices included, in the same order); returns
 * how many it visits. */
long long op_sss_measured_raster_clip(double xy[3][2], double step, const long long clip[4],
                                      void (*visit)(void *user, const op_sss_site *s),
                                      void *user);

/* How many samples op_sss_measured_raster visits, in time proportional to the triangle's rows. */
long long op_sss_measured_count(double xy[3][2], double step);

#endif
