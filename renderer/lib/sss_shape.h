/* sss_shape.h - what the subsurface pre-pass (subsurface.c) and the layout of its irradiance
 * points (sss_layout.c) share: a translucent shape's points and pre-pass state, the hashed
 * grids and cell sets over space, and the camera segments' hits. Private to those modules. */
#ifndef OP_SSS_SHAPE_H
#define OP_SSS_SHAPE_H

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "render_scene.h"
#include "sss_dipole.h"
#include "sss_tree.h"

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

/* A uniform grid hashed into buckets, stored compressed (bucket starts + point indices). */
typedef struct sss_grid {
    float cell;
    op_v3 origin;
    uint32_t mask;
    uint32_t *start; /* mask + 2 entries */
    uint32_t *items;
    int32_t *coord;  /* 3 per point: its cell */
} sss_grid;

typedef struct sss_shape {
    const op_sss_desc *desc;
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
    int nfull;    /* the points of the whole layout (n unless windowed) */
    int *gid;     /* windowed (n points of a layout of nfull, those near the view): per
                     point its index in the whole layout (ascending for a measured layout, in
                     Morton order for the dipole's); NULL: the identity */
    sss_grid gather, interp;
    struct gather_set *gset; /* the scatter's view of the points, cell by cell */
    float *acc; /* scatter pass: one 3 * n accumulator per chunk of sources */
    int nchunks;
    int hier;     /* 1: exitance from the hierarchical sum (the dipole), 0: the scatter */
    int centred;  /* measured: points at material pixel (sub-)centres (sss_measured.h), pair
                     values at whole-pixel offsets, each point's own area */
    op_sss_tree tree;        /* hier: the tree over the points */
    op_sss_dipole_kernel dk; /* hier: the profile it sums */
    unsigned char *near_recv; /* hier: per point: a computed receiver lies within the
                                 profile's ball (its normalization is needed) */
    int reached;           /* some camera segment reaches the shape: points are laid */
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

static inline uint32_t cell_hash(int32_t x, int32_t y, int32_t z, uint32_t mask)
{
    return ((uint32_t)x * 73856093u ^ (uint32_t)y * 19349663u ^ (uint32_t)z * 83492791u) & mask;
}

static inline void cell_of(const sss_grid *g, op_v3 p, int32_t c[3])
{
    c[0] = (int32_t)floorf((p.x - g->origin.x) / g->cell);
    c[1] = (int32_t)floorf((p.y - g->origin.y) / g->cell);
    c[2] = (int32_t)floorf((p.z - g->origin.z) / g->cell);
}

/* One translucent hit of a camera segment: the shape, the point, and the length one radian of
 * ray angle spans there (path length / |cos|). */
typedef struct cam_hit {
    op_v3 p;
    float span;
    int sss;
} cam_hit;

typedef struct cam_row {
    cam_hit *h;
    int n, cap;
} cam_row;

/* A set of grid cells, by exact coordinates (open addressing): a windowed shape's window. */
typedef struct cell_set {
    sss_grid cells; /* only cell and origin */
    uint32_t size, count; /* size a power of 2, or 0 */
    int32_t *tab;   /* 3 per slot; INT32_MIN in x: empty */
    op_v3 lo, hi;   /* hit_window: the bounds of its cells */
} cell_set;

static inline uint32_t cell_slot(const cell_set *cs, const int32_t c[3])
{
    uint32_t b = cell_hash(c[0], c[1], c[2], cs->size - 1);
    while (cs->tab[3 * (size_t)b] != INT32_MIN &&
           (cs->tab[3 * (size_t)b] != c[0] || cs->tab[3 * (size_t)b + 1] != c[1] ||
            cs->tab[3 * (size_t)b + 2] != c[2]))
        b = (b + 1) & (cs->size - 1);
    return b;
}

static inline int cell_set_has(const cell_set *cs, const int32_t c[3])
{
    return cs->size && cs->tab[3 * (size_t)cell_slot(cs, c)] != INT32_MIN;
}

/* Adds cell c; 0 when out of memory. */
static inline int cell_set_add(cell_set *cs, const int32_t c[3])
{
    if (2 * (cs->count + 1) > cs->size) {
        uint32_t size = cs->size ? 2 * cs->size : 1024;
        cell_set old = *cs;
        if (size > (1u << 30) || !(cs->tab = malloc(3 * (size_t)size * sizeof *cs->tab))) {
            cs->tab = old.tab;
            return 0;
        }
        cs->size = size;
        for (uint32_t b = 0; b < size; b++)
            cs->tab[3 * (size_t)b] = INT32_MIN;
        for (uint32_t b = 0; b < old.size; b++)
            if (old.tab[3 * (size_t)b] != INT32_MIN)
                memcpy(cs->tab + 3 * (size_t)cell_slot(cs, old.tab + 3 * (size_t)b),
                       old.tab + 3 * (size_t)b, 3 * sizeof *cs->tab);
        free(old.tab);
    }
    uint32_t b = cell_slot(cs, c);
    if (cs->tab[3 * (size_t)b] == INT32_MIN) {
        memcpy(cs->tab + 3 * (size_t)b, c, 3 * sizeof *c);
        cs->count++;
    }
    return 1;
}

#endif
