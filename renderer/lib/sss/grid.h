/* grid.h - uniform grids over space for the subsurface pre-pass: a grid's cells
 * (sss_cells), sets of cells by their exact coordinates (cell_set: a windowed shape's window),
 * and grids of points stored cell by cell (sss_grid: the points near a position, contiguous per
 * cell and per row of cells). */
#ifndef OP_SSS_GRID_H
#define OP_SSS_GRID_H

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "opaline.h"
#include "math/vec.h"

/* The cells of side `cell` whose corner (0, 0, 0) is `origin`. */
typedef struct sss_cells {
    float cell;
    op_v3 origin;
} sss_cells;

static inline void cell_of(const sss_cells *g, op_v3 p, int32_t c[3])
{
    c[0] = (int32_t)floorf((p.x - g->origin.x) / g->cell);
    c[1] = (int32_t)floorf((p.y - g->origin.y) / g->cell);
    c[2] = (int32_t)floorf((p.z - g->origin.z) / g->cell);
}

static inline uint32_t cell_hash(int32_t x, int32_t y, int32_t z, uint32_t mask)
{
    return ((uint32_t)x * 73856093u ^ (uint32_t)y * 19349663u ^ (uint32_t)z * 83492791u) & mask;
}

/* A set of cells, by exact coordinates (open addressing). */
typedef struct cell_set {
    sss_cells cells;
    uint32_t size, count; /* size a power of 2, or 0 */
    int32_t *tab;   /* 3 per slot; INT32_MIN in x: empty */
    op_v3 lo, hi;   /* hit_window: the bounds of its cells */
} cell_set;

/* The slot of cell c: where it is, or the empty slot where it would go. The set is not empty. */
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
int cell_set_add(cell_set *cs, const int32_t c[3]);

/* Points in a grid: the items (point indices) ordered by cell, z then y then x (a row of cells
 * along x is contiguous), and within a cell by ascending index. */
typedef struct sss_grid {
    sss_cells cells;
    cell_set occ;          /* the occupied cells */
    uint32_t *start, *end; /* per slot of occ: its items are [start[slot], end[slot]) */
    uint32_t *items;
    int32_t *coord;        /* 3 per point: its cell */
} sss_grid;

/* Builds the grid of the points p[i * stride] (bytes), i < n, with only[i] set (every point
 * when only is NULL); coord holds every point's cell. */
op_status op_sss_grid_build(sss_grid *g, const void *p, size_t stride, int n,
                            const unsigned char *only, op_v3 origin, float cell, op_error *err);
void op_sss_grid_free(sss_grid *g);

/* The items [*lo, *hi) of cell c; 0 (and an empty range) when it has none. */
static inline int grid_cell(const sss_grid *g, const int32_t c[3], uint32_t *lo, uint32_t *hi)
{
    uint32_t b = g->occ.size ? cell_slot(&g->occ, c) : 0;
    if (!g->occ.size || g->occ.tab[3 * (size_t)b] == INT32_MIN) {
        *lo = *hi = 0;
        return 0;
    }
    *lo = g->start[b];
    *hi = g->end[b];
    return 1;
}

/* Runs the statements after i for every point i whose cell lies within radius r of p (a
 * superset of the points within r), in a fixed order (by cell, then by index); `continue`
 * skips to the next point. */
#define GRID_FOR_EACH(g, p, r, i, ...)                                                            \
    do {                                                                                           \
        int32_t lo_[3], hi_[3], c_[3];                                                             \
        cell_of(&(g)->cells, v3_sub((p), v3s(r)), lo_);                                            \
        cell_of(&(g)->cells, v3_add((p), v3s(r)), hi_);                                            \
        for (c_[2] = lo_[2]; c_[2] <= hi_[2]; c_[2]++)                                             \
            for (c_[1] = lo_[1]; c_[1] <= hi_[1]; c_[1]++)                                         \
                for (c_[0] = lo_[0]; c_[0] <= hi_[0]; c_[0]++) {                                   \
                    uint32_t k0_, k1_;                                                             \
                    grid_cell((g), c_, &k0_, &k1_);                                                \
                    for (uint32_t k_ = k0_; k_ < k1_; k_++) {                                      \
                        int i = (int)(g)->items[k_];                                               \
                        __VA_ARGS__                                                                \
                    }                                                                              \
                }                                                                                  \
    } while (0)

#endif
