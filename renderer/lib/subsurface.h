/* subsurface.h - the irradiance-point integrator for measured heterogeneous materials.
 *
 * Before the camera pass, points are laid over every translucent shape (area-uniform, about
 * `density` per material pixel area, capped), the irradiance E_i at each is estimated with the
 * path tracer, and the exitance at each point j is gathered from the points i within the
 * material's kernel footprint: M_j = sum_i E_i A_i Rd(pixel(i), offset(i -> j)) / A_pixel.
 * The camera pass interpolates M between the points near a hit; the radiance leaving is M / pi.
 * docs/subsurface-rendering.md describes the scheme, its mappings and its limits. Everything
 * depends on point indices only, so the result is the same for any thread count. */
#ifndef OP_SUBSURFACE_H
#define OP_SUBSURFACE_H

#include "integrator.h"

typedef struct op_sss_build_options {
    int threads;
    uint64_t seed;
    atomic_int *cancel;
    op_progress_fn progress;
    void *progress_user;
} op_sss_build_options;

/* Builds the cache for every translucent shape of scene. */
op_status op_sss_cache_build(const op_scene *scene, const op_sss_build_options *opt,
                             op_sss_cache **out, op_error *err);
void op_sss_cache_free(op_sss_cache *c);

/* Exitance M at surface point p (shading normal n) of the shape with subsurface index sss. */
op_v3 op_sss_exitance(const op_sss_cache *c, int sss, op_v3 p, op_v3 n);

/* How many irradiance points a translucent shape got (for tests and logs). */
int op_sss_cache_points(const op_sss_cache *c, int sss);

/* The long material names of the Blender/Mitsuba plugin (Onel, Kurt, Ozturk), e.g.
 * "SVD S10 Div100 Add1 for Rd Chess4x4 v1(277x277x39x39)": "<METHOD> <params> for Rd <Name> ...",
 * where each param is letters followed by a number. Returns 1 when name has that form, writing
 * the preset name (METHOD, the params other than Div and Add, and Name joined by '_', e.g.
 * "SVD_S10_Chess4x4", "TUCKER_T15_P7_Chess4x4") to out, the method to *method, and Div (A) and
 * Add (B) to *a and *b (0 when absent); returns 0 otherwise (out untouched). */
int op_sss_parse_long_name(const char *name, char *out, size_t n, op_method *method, double *a,
                           double *b);

#endif
