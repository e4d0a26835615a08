/* volume_grid.h - the volumes of heterogeneous media: a grid of 1 or 3 channels read from
 * Mitsuba's binary .vol file, or a constant, looked up at world points by trilinear
 * interpolation in either of Mitsuba's two conventions (docs/scene-format.md, Participating
 * media).
 *
 * The .vol file: "VOL", version byte 3, then little-endian int32 encoding (1 float32, 3 uint8
 * mapped to [0, 1]), int32 x, y, z resolutions and channel count (1 or 3), six float32 (the
 * bounding box's min and max corners), then the values, channels interleaved, x fastest,
 * then y, then z. */
#ifndef OP_VOLUME_GRID_H
#define OP_VOLUME_GRID_H

#include <stddef.h>

#include "math/transform.h"
#include "math/vec.h"
#include "opaline.h"

/* Where a grid's values sit in the unit cube its placement maps the world to. */
typedef enum op_volume_layout {
    OP_VOLUME_CELLS,   /* Mitsuba 3: at the centres of res^3 equal cells, clamped at the faces */
    OP_VOLUME_VERTICES /* Mitsuba 0.6: at the vertices of a grid whose corners are the cube's;
                        * 0 where a lookup's cell is not wholly inside the grid */
} op_volume_layout;

typedef struct op_volume op_volume;

/* How a grid in the cell layout is looked up (Mitsuba 3's filter_type and wrap_mode); the vertex
 * layout is always trilinear and 0 beyond its last cells. */
typedef enum op_volume_filter {
    OP_VOLUME_TRILINEAR, /* blends the 8 cells around the point */
    OP_VOLUME_NEAREST    /* the value of the cell the point lies in */
} op_volume_filter;
typedef enum op_volume_wrap {
    OP_VOLUME_CLAMP,  /* beyond a face: the cells at that face */
    OP_VOLUME_REPEAT, /* the grid tiles space */
    OP_VOLUME_MIRROR  /* the grid tiles space, every other copy mirrored */
} op_volume_wrap;

/* The largest magnitude a grid value may have (docs/limits.md): interpolating and scaling it
 * stay finite. */
#define OP_VOLUME_MAX_VALUE 1e30

/* Reads the .vol file at path. A file that is not one (bad magic, version or encoding, zero or
 * negative sizes, a channel count other than 1 or 3, data shorter than its header says, a value
 * that is not finite or beyond OP_VOLUME_MAX_VALUE in magnitude) is an OP_ERR_INPUT naming path
 * and the fault. */
op_status op_volume_read(const char *path, op_volume **out, op_error *err);
/* The same for a file's bytes already in memory; name is what messages call it. */
op_status op_volume_parse(const void *data, size_t size, const char *name, op_volume **out,
                          op_error *err);
/* A volume of one value everywhere (or in its unit cube when placed bounded); NULL when out of
 * memory. */
op_volume *op_volume_constant(op_v3 value);
void op_volume_free(op_volume *v);

/* 1 or 3 (a constant counts as 3). */
int op_volume_channels(const op_volume *v);
/* The bounding box the .vol file gives (a constant's is the unit cube). */
void op_volume_file_bbox(const op_volume *v, double min[3], double max[3]);
/* Each channel's smallest and largest value (for a 1-channel grid all three are that one). */
op_v3 op_volume_min(const op_volume *v);
op_v3 op_volume_max(const op_volume *v);

/* Places v in the world: world_to_unit maps world points into the unit cube [0, 1]^3 that the
 * grid spans, with the given layout; bounded: v is 0 outside that cube (else a grid is
 * clamped there and a constant extends everywhere). Unplaced: identity, cells, unbounded.
 * Returns 0 when world_to_unit is not finite. */
int op_volume_place(op_volume *v, const op_matrix4 *world_to_unit, op_volume_layout layout,
                    int bounded);
/* Sets how v is looked up in the cell layout (unplaced: trilinear, clamped). */
void op_volume_set_lookup(op_volume *v, op_volume_filter filter, op_volume_wrap wrap);
/* Whether v is bounded; then *t0, *t1 (t0 <= t1) is the part of the ray org + t dir, t >= 0,
 * inside its cube (empty: returns 1 with *t0 > *t1). */
int op_volume_ray_span(const op_volume *v, op_v3 org, op_v3 dir, float *t0, float *t1);

/* v at world point p (a 1-channel grid's value in all three channels). */
op_v3 op_volume_eval(const op_volume *v, op_v3 p);

/* A grid's bricks are blocks of OP_VOLUME_BRICK^3 voxels, each with the largest value of any
 * channel over its voxels and a margin of two around them (more than the neighbours that
 * trilinear lookups inside the brick blend in, in either layout). A grid that wraps other than by
 * clamping is bounded, by its largest value, only where its cube is. */
#define OP_VOLUME_BRICK 8

/* A walk along a ray through the bricks it crosses (3-D DDA), in order of t. */
typedef struct op_volume_walk {
    const op_volume *v;
    float t;          /* where the walk is */
    float grid_start; /* where the ray enters the grid's cube */
    float grid_end;   /* where it leaves it */
    float span_end;   /* the end of the whole span */
    int stage;        /* 0: before the cube, 1: bricks, 2: after the cube, 3: done */
    int idx[3], step[3];
    float so[3], sd[3]; /* the ray in brick-grid units: so + t sd */
} op_volume_walk;

/* Starts a walk over the span [t0, t1) of the ray org + t dir (dir need not be unit; t1 may be
 * infinite). */
void op_volume_walk_start(op_volume_walk *w, const op_volume *v, op_v3 org, op_v3 dir, float t0,
                          float t1);
/* The next piece [*a, *b) of the span (pieces come in order and cover it) with *bound >= every
 * channel of v at every point of it; 0 once the span is covered. Parts outside the grid's cube, and
 * constant volumes, get the largest value v has anywhere. */
int op_volume_walk_next(op_volume_walk *w, float *a, float *b, float *bound);

#endif
