/* grid.c - uniform grids over space for the subsurface pre-pass (see grid.h). */
#include "sss/grid.h"

int cell_set_add(cell_set *cs, const int32_t c[3])
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

/* An occupied cell as the build sorts them: its coordinates and slot. */
typedef struct cell_rec {
    int32_t x, y, z;
    uint32_t slot;
} cell_rec;

static int cell_order(const void *a, const void *b)
{
    const cell_rec *p = a, *q = b;
    if (p->z != q->z)
        return p->z < q->z ? -1 : 1;
    if (p->y != q->y)
        return p->y < q->y ? -1 : 1;
    return p->x < q->x ? -1 : p->x > q->x;
}

void op_sss_grid_free(sss_grid *g)
{
    free(g->occ.tab);
    free(g->start);
    free(g->end);
    free(g->items);
    free(g->coord);
    memset(g, 0, sizeof *g);
}

op_status op_sss_grid_build(sss_grid *g, const void *p, size_t stride, int n,
                            const unsigned char *only, op_v3 origin, float cell, op_error *err)
{
    memset(g, 0, sizeof *g);
    g->cells = (sss_cells){cell, origin};
    g->occ.cells = g->cells;
    size_t count = 0;
    int ok = (g->coord = malloc(3 * (size_t)(n > 0 ? n : 1) * sizeof *g->coord)) != NULL;
    for (int i = 0; ok && i < n; i++) {
        op_v3 q;
        memcpy(&q, (const char *)p + (size_t)i * stride, sizeof q);
        cell_of(&g->cells, q, g->coord + 3 * (size_t)i);
        if (!only || only[i]) {
            ok = cell_set_add(&g->occ, g->coord + 3 * (size_t)i);
            count++;
        }
    }
    cell_rec *rec = NULL;
    if (ok) {
        size_t slots = g->occ.size ? g->occ.size : 1;
        g->start = calloc(slots, sizeof *g->start);
        g->end = calloc(slots, sizeof *g->end);
        g->items = malloc((count ? count : 1) * sizeof *g->items);
        rec = malloc((g->occ.count ? g->occ.count : 1) * sizeof *rec);
        ok = g->start && g->end && g->items && rec;
    }
    if (!ok) {
        free(rec);
        op_sss_grid_free(g);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for the subsurface grid");
    }
    /* the occupied cells in order, each given its room (end counts its points first) */
    uint32_t cells = 0;
    for (uint32_t b = 0; b < g->occ.size; b++)
        if (g->occ.tab[3 * (size_t)b] != INT32_MIN)
            rec[cells++] = (cell_rec){g->occ.tab[3 * (size_t)b], g->occ.tab[3 * (size_t)b + 1],
                                      g->occ.tab[3 * (size_t)b + 2], b};
    qsort(rec, cells, sizeof *rec, cell_order);
    for (int i = 0; i < n; i++)
        if (!only || only[i])
            g->end[cell_slot(&g->occ, g->coord + 3 * (size_t)i)]++;
    uint32_t at = 0;
    for (uint32_t k = 0; k < cells; k++) {
        uint32_t b = rec[k].slot;
        g->start[b] = at;
        at += g->end[b];
        g->end[b] = g->start[b];
    }
    free(rec);
    for (int i = 0; i < n; i++) /* in ascending index; end counts up to its place */
        if (!only || only[i])
            g->items[g->end[cell_slot(&g->occ, g->coord + 3 * (size_t)i)]++] = (uint32_t)i;
    return OP_OK;
}
