/* meter.h - Mitsuba's irradiancemeter: a sensor that is the child of a shape and measures the
 * mean irradiance over that shape's surface (W/m^2 for radiance in W/(m^2 sr)): rays start at
 * points uniform by area and leave in cosine-weighted directions on the side the surface's
 * geometric normal points to (the front, which flipNormals turns over); a ray's radiance times
 * OP_METER_WEIGHT estimates that irradiance, so a meter under a uniform radiance L reads pi L.
 * A film of more than one pixel splits the unit square of position samples into its pixels,
 * each the mean over its part of the surface, as Mitsuba does: on a rectangle the square maps
 * linearly onto it (pixels are patches of the rectangle), on other shapes through the choice of
 * triangle by area. */
#ifndef OP_METER_H
#define OP_METER_H

#include "geometry/shape.h"

/* The factor on a meter ray's radiance: pi, the cosine-weighted hemisphere's integral of cos. */
#define OP_METER_WEIGHT 3.14159265358979323846f

/* The ray from the point of mesh (world space, finished) that the position sample (su, sv) in
 * [0, 1)^2 picks in the cosine-weighted direction of (du, dv) about the triangle's front normal;
 * *tmin skips the surface itself (Mitsuba's ray epsilon, relative to the point's magnitude). The
 * point: for a rectangle (mesh as op_shape_rectangle makes it, then transformed), the local point
 * (2 su - 1, 2 sv - 1); else su picks the triangle by area and, rescaled, with sv its
 * barycentrics. */
void op_meter_ray(const op_trimesh *mesh, int rectangle, float su, float sv, float du, float dv,
                  op_v3 *org, op_v3 *dir, float *tmin);

#endif
