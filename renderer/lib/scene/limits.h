/* limits.h - the scene limits (opaline_render.h's op_scene_limits: defaults, --limit
 * NAME=VALUE) and the one check of them that several parts of the scene share. */
#ifndef OP_SCENE_LIMITS_H
#define OP_SCENE_LIMITS_H

#include "math/vec.h"
#include "scene/scene_desc.h"

/* Refuses (OP_ERR_INPUT naming node) a position of node's object, `what`, farther from the
 * origin than the coordinate limit, or not finite: single precision cannot place it. */
op_status op_limit_position(const op_scene_limits *limits, const op_node *node, const char *what,
                            op_v3 p, op_error *err);

/* The load-memory bytes per stored triangle: the peak of --check on a PLY grid of 2 million
 * triangles, 281 MB (the mapped file, the mesh as read and as placed, Embree's BVH). */
#define OP_LOAD_BYTES_PER_TRIANGLE 144

/* What a scene stores, counted as it is described or built against the triangles and
 * load-memory limits. */
typedef struct op_limit_tally {
    long long triangles; /* stored (a shared prototype once) */
    long long bytes;     /* the estimated memory of what is loaded */
} op_limit_tally;

/* Adds bytes, what the part the caller read (named by what, e.g. "its images") is estimated
 * to take, and refuses the total over load-memory (callers name the element). */
op_status op_limit_add_bytes(const op_scene_limits *limits, op_limit_tally *t, long long bytes,
                             const char *what, op_error *err);
/* Adds the n triangles of one mesh (and their OP_LOAD_BYTES_PER_TRIANGLE each), refused over
 * the triangles or load-memory limit (callers name the shape). */
op_status op_limit_add_triangles(const op_scene_limits *limits, op_limit_tally *t, long long n,
                                 op_error *err);

#endif
