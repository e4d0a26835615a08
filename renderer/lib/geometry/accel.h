/* accel.h - the ray-tracing acceleration structure: one Embree 3 device and scene over the
 * scene's triangle meshes (shared buffers, no copies; robust traversal, high build quality).
 * Instanced shapes (an object-space mesh and a placement) become Embree instances: every mesh
 * they share is built once, into its own Embree scene. Geometry ids (and instance ids) equal
 * shape indices. Safe to query from any number of threads once built. */
#ifndef OP_ACCEL_H
#define OP_ACCEL_H

#include "geometry/shape.h"

typedef struct op_accel op_accel;

typedef struct op_ray_hit {
    float t;
    int shape, prim;
    float b1, b2; /* barycentrics of corners 1 and 2 */
    op_v3 ng;     /* unnormalized geometric normal in world space (its sign is not meaningful
                     for instances) */
} op_ray_hit;

/* One shape for the accel: a world-space mesh (place NULL), or an object-space mesh placed by
 * place (shapes whose mesh pointers are equal share its BVH). */
typedef struct op_accel_shape {
    const op_trimesh *mesh;
    const op_placement *place;
    int proto; /* with place: mesh's number among the distinct placed meshes, 0 .. n - 1 (the
                  same for every shape placing it) */
} op_accel_shape;

/* Builds over shapes[0..n); the meshes and placements must outlive the accel unchanged. Each
 * placed mesh's structure is built once, for the first shape that places it. */
op_status op_accel_build(const op_accel_shape *shapes, int n, op_accel **out, op_error *err);
void op_accel_free(op_accel *a);
/* Bytes Embree holds for the built structure (its memory monitor's net count). */
long long op_accel_bytes(const op_accel *a);

/* Nearest hit with t in (tmin, tmax); returns 0 when none, also for a ray Embree cannot take
 * (a component beyond 1e18 or not finite, tmin < 0 or NaN, tmax NaN). */
int op_accel_intersect(const op_accel *a, op_v3 org, op_v3 dir, float tmin, float tmax,
                       op_ray_hit *hit);
/* Whether anything lies on the ray with t in (tmin, tmax); 1 for a ray Embree cannot take. */
int op_accel_occluded(const op_accel *a, op_v3 org, op_v3 dir, float tmin, float tmax);

#endif
