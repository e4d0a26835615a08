/* shape.h - triangle meshes in world space: the procedural shapes (sphere, rectangle, cube,
 * disk) tessellated, and loaded mesh files placed by a transform. Every shape becomes one
 * op_trimesh that the acceleration structure shares without copying, except instances: a mesh
 * file used by several plain shapes is kept once in object space and each shape places it with
 * an op_placement. */
#ifndef OP_SHAPE_H
#define OP_SHAPE_H

#include <stdint.h>

#include "math/vec.h"
#include "scene/scene_desc.h"

typedef struct op_trimesh {
    int nverts, ntris;
    float *pos;      /* 3 * nverts floats + 4 padding floats (Embree reads 16 bytes per vertex) */
    float *nrm;      /* 3 * nverts unit normals, or NULL (flat shading) */
    float *uv;       /* 2 * nverts, or NULL */
    uint32_t *idx;   /* 3 * ntris + 1 padding */
    float *area_cdf; /* ntris running sums of triangle areas (filled by op_trimesh_finish) */
    float area;
    op_v3 bmin, bmax; /* the bounds of all vertices (filled by op_trimesh_finish) */
} op_trimesh;

/* Allocates a mesh of the given size (normals and uvs only when asked); zeroed. */
op_status op_trimesh_alloc(op_trimesh *m, int nverts, int ntris, int with_normals, int with_uv,
                           op_error *err);
void op_trimesh_free(op_trimesh *m);
/* The bytes m's arrays hold. */
long long op_trimesh_bytes(const op_trimesh *m);
/* Transforms positions and normals by to_world (flipping the winding when it mirrors), flips
 * normals and winding when flip is set, then computes the bounds and the area table. Fails on
 * non-finite or degenerate (zero total area) results; m stays the caller's to free either way. */
op_status op_trimesh_finish(op_trimesh *m, const op_matrix4 *to_world, int flip, op_error *err);

/* The corner positions of triangle t. */
static inline void op_trimesh_tri(const op_trimesh *m, int t, op_v3 *a, op_v3 *b, op_v3 *c)
{
    const uint32_t *i = m->idx + 3 * (size_t)t;
    const float *p = m->pos;
    *a = v3(p[3 * i[0]], p[3 * i[0] + 1], p[3 * i[0] + 2]);
    *b = v3(p[3 * i[1]], p[3 * i[1] + 1], p[3 * i[1] + 2]);
    *c = v3(p[3 * i[2]], p[3 * i[2] + 1], p[3 * i[2] + 2]);
}

/* Where an instanced shape's object-space mesh (shared with other shapes) lies in the world:
 * the shape's toWorld, and flipNormals. Positions and normals computed through it equal, up to
 * float rounding, those of a world-space copy made by op_trimesh_finish. */
typedef struct op_placement {
    float m[12]; /* object to world, row-major 3 x 4 */
    float n[9];  /* normals: the inverse transpose of m's 3 x 3, row-major */
    int flip;    /* flipNormals: shading normals turn over */
    int swap;    /* the world winding is the reverse of the mesh's (mirroring xor flip) */
} op_placement;

/* Fills pl from to_world and flip; fails when to_world is singular or not finite. */
op_status op_placement_make(const op_matrix4 *to_world, int flip, op_placement *pl, op_error *err);
/* The bounds of mesh m (finished) placed by pl; NaN when a corner is not finite. */
void op_placement_bounds(const op_placement *pl, const op_trimesh *m, op_v3 *lo, op_v3 *hi);
static inline op_v3 op_place_point(const op_placement *pl, op_v3 p)
{
    const float *m = pl->m;
    return v3(m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3],
              m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
              m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]);
}
/* A normal's world direction, not normalized and not flipped. */
static inline op_v3 op_place_normal(const op_placement *pl, op_v3 n)
{
    const float *a = pl->n;
    return v3(a[0] * n.x + a[1] * n.y + a[2] * n.z, a[3] * n.x + a[4] * n.y + a[5] * n.z,
              a[6] * n.x + a[7] * n.y + a[8] * n.z);
}

/* Picks a triangle with probability proportional to its area; u in [0, 1). */
int op_trimesh_pick(const op_trimesh *m, float u);

/* Procedural shapes in object space (Mitsuba's conventions): a sphere of radius 1 about the
 * origin with u = phi / 2pi and v = theta / pi; the rectangle [-1,1]^2 in z = 0 with normal +z;
 * the cube [-1,1]^3; the unit disk in z = 0 with normal +z; the open tube of radius 1 from
 * z = 0 to z = 1 (no caps) with outward normals, u = phi / 2pi and v = z. */
op_status op_shape_sphere(op_trimesh *m, int segments, op_error *err);
op_status op_shape_rectangle(op_trimesh *m, op_error *err);
op_status op_shape_cube(op_trimesh *m, op_error *err);
op_status op_shape_disk(op_trimesh *m, int segments, op_error *err);
op_status op_shape_cylinder(op_trimesh *m, int segments, op_error *err);
/* The object-to-world placement (before toWorld) of Mitsuba's cylinder from p0 to p1 of the
 * given radius: the unit tube's z axis along p1 - p0, in the frame Mitsuba builds around it.
 * Fails when p0 = p1 or the radius is not positive and finite. */
op_status op_cylinder_placement(const double p0[3], const double p1[3], double radius,
                                op_matrix4 *out, op_error *err);

/* A loaded mesh file kept in object space so that several shapes can share one load. */
typedef struct op_mesh_cache op_mesh_cache;
op_mesh_cache *op_mesh_cache_new(void);
void op_mesh_cache_free(op_mesh_cache *c);
/* Fills m with a copy (in object space, for op_trimesh_finish to place) of the mesh file at path,
 * read as kind ("obj", "ply" or "serialized", whose mesh shape_index is taken; loaded at most
 * once per cache and option set). face_normals drops vertex normals; flip_tex flips v. */
op_status op_mesh_cache_get(op_mesh_cache *c, const char *path, const char *kind,
                            uint32_t shape_index, int face_normals, int flip_tex, op_trimesh *m,
                            op_error *err);

#endif
