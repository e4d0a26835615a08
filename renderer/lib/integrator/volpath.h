/* volpath.h - the volumetric path tracer (Mitsuba's volpath, volpath_simple and Mitsuba 3's
 * volpath): paths through homogeneous media (medium/medium.h) between surfaces, free-flight
 * distances sampled per channel with spectral MIS, next-event estimation at surfaces and in
 * media with the transmittance of media and index-matched boundaries along shadow rays,
 * combined with BSDF and phase sampling by the power heuristic, and Russian roulette on the
 * throughput alone (a path of throughput >= 1 is never stopped, so albedo-0.99 media keep
 * their thousands of scattering events). Media are entered and left where a path crosses a
 * shape that has an interior or exterior medium (its side given by the shading normal). */
#ifndef OP_VOLPATH_H
#define OP_VOLPATH_H

#include "camera/sampler.h"
#include "scene/render_scene.h"

/* Radiance along the ray (org, dir), t in (tmin, tmax), which starts in the sensor's medium;
 * *alpha gets 1 when the ray met geometry or scattered. The scene has no translucent
 * (<subsurface>) shapes. */
op_v3 op_volpath_li(const op_scene *s, op_v3 org, op_v3 dir, float tmin, float tmax,
                    op_path_sampler *ps, float *alpha);

#endif
