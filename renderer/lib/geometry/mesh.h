/* mesh.h - triangle meshes loaded from Wavefront OBJ, Stanford PLY and Mitsuba serialized
 * files.
 *
 * A mesh is indexed: every vertex has a position and, when the file gives them, a normal and
 * a texture coordinate; triangles are triples of vertex indices. Loaders return the file's
 * data as is (polygons fan-triangulated); options such as Mitsuba's flipTexCoords and
 * faceNormals are the scene builder's to apply with the helpers below. A truncated, corrupt
 * or hostile file gives OP_ERR_FORMAT naming the file and the line (text) or element index
 * (binary) at fault, never a crash. */
#ifndef OP_MESH_H
#define OP_MESH_H

#include <stdint.h>

#include "opaline.h"

typedef struct op_mesh {
    uint32_t nverts, ntris;
    float *positions;  /* 3 * nverts */
    float *normals;    /* 3 * nverts, or NULL */
    float *uvs;        /* 2 * nverts, or NULL */
    uint32_t *indices; /* 3 * ntris, each < nverts */
} op_mesh;

/* Wavefront OBJ: v, vt, vn and f (v, v/vt, v//vn, v/vt/vn; negative indices count back from
 * the last vertex read; polygons are fan-triangulated); every object and group is merged into
 * one mesh; other statements (o, g, s, usemtl, mtllib, l, p, ...) are ignored. A corner is one
 * mesh vertex per distinct (v, vt, vn). Normals are kept only when every corner has one; uvs
 * when any corner has one (the others get (0, 0)). */
op_status op_mesh_load_obj(const char *path, op_mesh *out, op_error *err);
/* Stanford PLY, ascii or binary (either byte order): vertex x y z, optional nx ny nz and
 * u v (or s t, texture_u texture_v, texture_s texture_t) of any numeric type, and face
 * vertex_indices (or vertex_index) lists of any integer types; other elements and properties
 * are skipped. */
op_status op_mesh_load_ply(const char *path, op_mesh *out, op_error *err);
/* The vertex and face counts a PLY file's header declares (0 for an element it lacks), read
 * without loading the file; the loader's errors for a bad header. */
op_status op_mesh_ply_counts(const char *path, uint64_t *vertices, uint64_t *faces,
                             op_error *err);
/* Mitsuba's serialized format, versions 3 and 4 (single or double precision; vertex colours
 * are skipped): the mesh shape_index of the file (the first needs no offset dictionary, the
 * others are found through it). Errors name the file and the shape index. */
op_status op_mesh_load_serialized(const char *path, uint32_t shape_index, op_mesh *out,
                                  op_error *err);
/* The vertex and triangle counts of mesh shape_index of a serialized file, read from its
 * header without inflating its arrays; the loader's errors for a bad header. */
op_status op_mesh_serialized_counts(const char *path, uint32_t shape_index, uint64_t *vertices,
                                    uint64_t *triangles, op_error *err);
/* Chooses the loader by the file name's extension (.obj, .ply or .serialized, any case; a
 * serialized file's first mesh). */
op_status op_mesh_load(const char *path, op_mesh *out, op_error *err);
/* Frees the arrays and zeroes *m. Accepts NULL and zeroed meshes. */
void op_mesh_free(op_mesh *m);

/* v -> 1 - v for every texture coordinate (Mitsuba's flipTexCoords); no-op without uvs. */
void op_mesh_flip_v(op_mesh *m);
/* Replaces the normals by area-weighted averages of the adjacent triangles' normals (vertices
 * touching only degenerate triangles get (0, 0, 1)). */
op_status op_mesh_compute_normals(op_mesh *m, op_error *err);
/* Frees the normals so that shading uses the geometric (face) normals. */
void op_mesh_drop_normals(op_mesh *m);
/* Axis-aligned bounds of the positions; (0,0,0) both when there are none. */
void op_mesh_bounds(const op_mesh *m, float lo[3], float hi[3]);

#endif
