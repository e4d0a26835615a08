/* shape_points.h - what the parts of the subsurface pre-pass share (prepass.c, the layout of its
 * irradiance points layout.c, the scatter scatter.c, the lookups lookup.c): a translucent
 * shape's points and pre-pass state (its grids: grid.h), and the camera segments' hits. Private
 * to sss/. */
#ifndef OP_SSS_SHAPE_POINTS_H
#define OP_SSS_SHAPE_POINTS_H

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "scene/render_scene.h"
#include "sss/dipole_kernel.h"
#include "sss/grid.h"
#include "sss/tree.h"

typedef struct sss_point {
    op_v3 p, ng, n;   /* position, geometric and shading normal */
    op_v3 tu, tv;     /* unit tangents along the material's x (columns) and y (rows) */
    float fx, fy;     /* continuous material pixel coordinates, in [0, W) x [0, H) */
    op_v3 e;          /* irradiance */
    op_v3 m;          /* exitance */
    float a;          /* centred: the surface area it stands for */
    op_v3 gu, gv;     /* centred: tu and tv over the pixel size (a world offset d is dot(d,
                         gu), dot(d, gv) material pixels at the material's physical size) */
} sss_point;

/* A point as the exitance lookups read it once it is within reach (its position is apart). */
typedef struct look_pt {
    float nx, ny, nz;
    op_v3 m;     /* exitance */
    int32_t recv; /* 1: the view needs its exitance (m is computed) */
} look_pt;

/* The exitance lookups' view of a shape, made once its exitance is known: the points of its
 * lookup grid in the grid's items' order (positions, which every lookup screens, apart from the
 * rest), and per occupied cell the runs of those points in the 3 x 3 x 3 cells around it (by z,
 * then y, then x; neighbouring cells' points merged). */
typedef struct look_set {
    op_v3 *pos;
    look_pt *pts;
    uint32_t *at;   /* per slot of the grid's cells: its first run and how many */
    uint32_t *runs; /* 2 per run: [first, last) items */
} look_set;

typedef struct sss_shape {
    const op_sss_desc *desc;
    const op_sss_plan_entry *plan;
    int width, height, kernel, channels;
    float px, py, a_pix, a_i, spacing;
    float radius; /* gather radius: the kernel footprint */
    float h;      /* the interp grid's cell: 2 point spacings */
    float hr;     /* the lookup's interpolation radius: h, or 2 sqrt(3) x the receiver
                     spacing where the receivers are thinned */
    unsigned char *rep; /* hier, NULL or per point: it may be a receiver (one per cell of the
                           receiver spacing and normal class); NULL: every point may */
    sss_grid look;      /* hier with rep: the grid of the rep points, of cell hr */
    sss_grid ballg;     /* hier: the grid of the points, of the profile's ball as cell */
    int n;
    sss_point *pts;
    look_set lk;    /* after the pre-pass: the lookups' (of the grid look with rep, else
                       interp) */
    int nfull;    /* the points of the whole layout (n unless windowed) */
    int *gid;     /* windowed (n points of a layout of nfull, those near the view): per
                     point its index in the whole layout (ascending for a measured layout, in
                     Morton order for the dipole's); NULL: the identity */
    sss_grid gather, interp;
    struct gather_set *gset; /* the scatter's view of the points, cell by cell */
    float *acc; /* scatter pass: one 3 * n accumulator per chunk of sources */
    int nchunks;
    int hier;     /* 1: exitance from the hierarchical sum (the dipole), 0: the scatter */
    int centred;  /* measured: points at material pixel (sub-)centres (sss/measured_points.h), pair
                     values at whole-pixel offsets, each point's own area */
    op_sss_tree tree;        /* hier: the tree over the points */
    op_sss_dipole_kernel dk; /* hier: the profile it sums */
    unsigned char *near_recv; /* hier: per point: a computed receiver lies within the
                                 profile's ball (its normalization is needed) */
    int reached;           /* some camera segment reaches the shape: points are laid */
    int capped;            /* coarsened where the image shows it (and warned) */
    int coarse;            /* a windowed measured shape laid near the view at its layout's
                              level `coarse` (4^coarse times fewer points, nfull of them): its
                              exitance depends on the view, so the store does not keep it */
    unsigned char *recv;   /* per point: the view needs its exitance (a receiver) */
    int32_t *rmap;         /* per point: its index among the receivers whose exitance is
                              computed (those the store lacks), or -1 */
    int *src;              /* the sources whose irradiance is computed (those the store
                              lacks), ascending */
    int nsrc, nrecv;       /* how many are computed */
    int reused_src, reused_recv; /* the sources and receivers of this view taken from the store */
    int unsaved;           /* a windowed shape too large for the store's entry: computed only */
    int levels;            /* a windowed dipole laid in levels around the view (lay_levels): its
                              exitance depends on the view's regions, so the store lends it
                              irradiance only */
} sss_shape;

/* Point i's index in the shape's whole layout (what the irradiance's random stream, the
 * scatter's chunks and the pre-pass cache go by). */
static inline int point_index(const sss_shape *ss, int i)
{
    return ss->gid ? ss->gid[i] : i;
}

/* One translucent hit of a camera segment: the shape, the point, and the length one radian of
 * ray angle spans there (path length / |cos|). */
typedef struct cam_hit {
    op_v3 p;
    float span;
    float cosine; /* |cos| at the hit, at least 0.05 (as span takes it) */
    int sss;
} cam_hit;

typedef struct cam_row {
    cam_hit *h;
    int n, cap;
} cam_row;

#endif
