/* integrator.h - radiance estimates: the path tracer (next-event estimation with multiple
 * importance sampling, Russian roulette), Mitsuba's direct lighting (emitterSamples samples of
 * every emitter and bsdfSamples BSDF samples combined by MIS, no indirect light), the
 * debug views (normals, uv, albedo), and the irradiance estimate the subsurface pass uses.
 * Translucent shapes: a camera path that reaches one takes the pre-pass's exitance M/pi there
 * and ends; with a surface bsdf (render_scene.h: op_sss_desc's boundary) it takes the exitance
 * through the boundary, M t(cos) exit_norm / pi, and goes on with the boundary's reflection
 * lobe. During the irradiance pass, and where the pre-pass has no exitance (parts no camera
 * segment reaches, see sss/prepass.h), they act as diffuse surfaces of the material's mean
 * albedo (under the boundary's interface as a plastic where there is one).
 * Masked surfaces (bsdf.h): camera, indirect and debug rays pass through them with probability
 * 1 - opacity (not a bounce), shadow rays are attenuated by 1 - opacity; an emitter's own
 * emission is seen by rays that reach its front, whether they then pass through or not. */
#ifndef OP_INTEGRATOR_H
#define OP_INTEGRATOR_H

#include "geometry/isect.h"
#include "math/rng.h"
#include "camera/sampler.h"
#include "sss/prepass.h"

typedef struct op_trace_ctx {
    const op_scene *scene;
    const op_sss_prepass *sss; /* NULL during the irradiance pass */
} op_trace_ctx;

/* Radiance along the ray (org, dir) with t in (tmin, tmax), its random numbers drawn from ps
 * in the dimension layout of sampler.h; *alpha gets 1 when the ray hit geometry, 0 when it
 * escaped. */
op_v3 op_li(const op_trace_ctx *ctx, op_v3 org, op_v3 dir, float tmin, float tmax,
            op_path_sampler *ps, float *alpha);
/* Follows the camera segment of a path from the camera ray (org, dir, tmin, tmax) the way the
 * path tracer would: through passable surfaces (every one that a ray may pass is passed) and
 * along smooth (delta) bounces, at most max_bounces of them, drawing choices from rng. Calls
 * hit(user, it, dist, cosine) (dist: the path's length to it; cosine: |cos| between the last
 * segment and the surface) for every translucent shape it meets whose exitance the path tracer
 * would use there (within maxDepth); a translucent shape with a smooth sheen (a surface bsdf
 * whose reflection is a delta lobe) does not end the segment: it goes on along the reflection,
 * a bounce like any other. Stops when hit returns 0. */
void op_camera_sss_hits(const op_scene *scene, op_v3 org, op_v3 dir, float tmin, float tmax,
                        int max_bounces, op_rng *rng, op_sss_cam_fn hit, void *user);
/* One-sample estimate of the irradiance at surface point p (normals ng, ns) of translucent shape
 * sss (-1: none): pi times the radiance a white Lambertian surface would reflect there, with
 * direct and indirect light (translucent shapes acting as their stand-ins); where shape sss has
 * a surface bsdf, the irradiance that crosses it (each direction weighted by t(cos)). */
op_v3 op_irradiance(const op_scene *scene, int sss, op_v3 p, op_v3 ng, op_v3 ns, op_rng *rng);
/* The light transport the subsurface pre-pass asks for: op_irradiance and op_camera_sss_hits. */
extern const op_sss_transport op_path_transport;

#endif
