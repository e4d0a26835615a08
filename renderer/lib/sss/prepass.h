/* prepass.h - the irradiance-point integrator for measured heterogeneous materials.
 *
 * Before the camera pass, points are laid over every translucent shape (area-uniform, about
 * `density` per material pixel area, capped), the irradiance E_i at each is estimated with the
 * path tracer, and the exitance at each point j is gathered from the points i within the
 * material's kernel footprint: M_j = sum_i E_i A_i Rd(pixel(i), offset(i -> j)) / A_pixel (the
 * dipole: over a tree of the points, near pairs exact and far clusters aggregated, sss/tree.h).
 * The camera pass interpolates M between the points near a hit; the radiance leaving is M / pi.
 *
 * The work follows what the camera needs: a first pass traces one camera segment (through masks
 * and smooth bounces) per pixel corner of the whole film (a crop window does not narrow it, so
 * a cropped render's pixels are the full render's) and marks as receivers the points within the
 * interpolation radius plus a pixel footprint of each translucent hit. Points are laid only on
 * shapes that some camera segment reaches, exitance is computed only at the marked points
 * (receivers), irradiance only at the points whose kernel footprint holds a receiver
 * (sources). A receiver's M is bit-identical to the one the full computation gives, because
 * point layout, irradiance streams and summation order do not depend on the marking. Where a
 * path finds no exitance (op_sss_lookup returns 0: parts seen only after diffuse bounces, or
 * sub-pixel slivers the corner rays missed) the surface acts as the irradiance pass's diffuse
 * stand-in of mean albedo.
 * docs/subsurface-rendering.md describes the scheme, its mappings and its limits. Everything
 * depends on point indices only, so the result is the same for any thread count. */
#ifndef OP_SSS_PREPASS_H
#define OP_SSS_PREPASS_H

#include <stdatomic.h>

#include "geometry/isect.h"
#include "math/rng.h"

typedef struct op_sss_prepass op_sss_prepass;

/* The light transport the pre-pass needs, supplied by its caller (render.c passes the path
 * tracer's, integrator.h's op_path_transport): the pre-pass lays points, marks and sums, and
 * traces nothing itself. irradiance: a one-sample estimate of pi times the radiance a white
 * Lambertian at (p, ng, ns) of translucent shape sss (its subsurface index) reflects, behind the
 * shape's surface bsdf where it has one (what crosses the boundary). camera_hits: follows a
 * camera ray's segment as the path tracer would and calls hit for every translucent shape whose
 * exitance the path tracer would use on it (where, how far along the path, at what cosine): the
 * first, and those seen in a smooth sheen's reflection. Both draw only from rng. */
typedef int (*op_sss_cam_fn)(void *user, const op_isect *it, float dist, float cosine);
typedef struct op_sss_transport {
    op_v3 (*irradiance)(const op_scene *scene, int sss, op_v3 p, op_v3 ng, op_v3 ns,
                        op_rng *rng);
    void (*camera_hits)(const op_scene *scene, op_v3 org, op_v3 dir, float tmin, float tmax,
                        int max_bounces, op_rng *rng, op_sss_cam_fn hit, void *user);
} op_sss_transport;

/* What earlier pre-passes of the same key (sss/cache_file.h) computed for one translucent shape:
 * per point whether its irradiance E (OP_SSS_HAS_E) and its exitance M (OP_SSS_HAS_M) are
 * known, and their values (3 floats per point, meaningful where flagged). n is the shape's
 * point count, 0 when nothing is known (then has, e and m are NULL). */
typedef struct op_sss_saved {
    int n;
    unsigned char *has;
    float *e, *m;
} op_sss_saved;

enum { OP_SSS_HAS_E = 1, OP_SSS_HAS_M = 2 };

/* The saved results of every translucent shape (index = subsurface index). A build given a
 * store reuses what it holds and adds what it computed; the counts say what it did. */
typedef struct op_sss_store {
    int nshapes;
    op_sss_saved *shapes;
    long long reused_e, reused_m; /* sources and receivers of this view taken from the store */
    long long new_e, new_m;       /* irradiance and exitance values computed and added */
} op_sss_store;

typedef struct op_sss_prepass_options {
    int threads;
    uint64_t seed;
    atomic_int *cancel;
    op_progress_fn progress;
    void *progress_user;
    int everywhere; /* 1: every point of every translucent shape, no camera pass */
    op_sss_store *store; /* NULL, or results to reuse, extended with what the build computes */
    const op_sss_transport *transport; /* required */
} op_sss_prepass_options;

/* What a build computed, summed over the translucent shapes. */
typedef struct op_sss_stats {
    long long points;    /* irradiance points laid (on shapes a camera segment reaches) */
    long long sources;   /* points whose irradiance was computed */
    long long receivers; /* points whose exitance was computed */
    long long sources_reused, receivers_reused; /* taken from the store instead */
    int shapes_reached;  /* translucent shapes a camera segment reaches */
    int shapes_capped;   /* of those, shapes with fewer points than the image needs
                            (maxPoints; each warned) */
    double seconds;      /* the build's wall time */
} op_sss_stats;

/* Runs the pre-pass over the translucent shapes of scene (see above for which parts). */
op_status op_sss_prepass_run(const op_scene *scene, const op_sss_prepass_options *opt,
                             op_sss_prepass **out, op_error *err);
void op_sss_prepass_free(op_sss_prepass *c);

/* Exitance M at surface point p (shading normal n) of the shape with subsurface index sss,
 * interpolated between the points near p. Returns 0 (and *m black) when some of those points
 * have no computed exitance, or when no point is near p (the part of a windowed shape that was
 * not laid); then the caller uses the diffuse stand-in. */
int op_sss_lookup(const op_sss_prepass *c, int sss, op_v3 p, op_v3 n, op_v3 *m);
/* op_sss_lookup's M, black where it has none. */
op_v3 op_sss_exitance(const op_sss_prepass *c, int sss, op_v3 p, op_v3 n);

/* How many irradiance points a translucent shape got (for tests and logs). */
int op_sss_prepass_points(const op_sss_prepass *c, int sss);
void op_sss_prepass_stats(const op_sss_prepass *c, op_sss_stats *st);

#endif
