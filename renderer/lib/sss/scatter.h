/* scatter.h - a measured material's exitance: the irradiance of every source point handed
 * on to the receivers in its kernel's footprint, pair by pair (the exact O(N K^2) sum; the
 * dipole's hierarchical sum is sss/tree.c). docs/subsurface-rendering.md gives the pair values,
 * the normalization and the order of the sums. */
#ifndef OP_SSS_SCATTER_H
#define OP_SSS_SCATTER_H

#include <stdatomic.h>

#include "sss/shape_points.h"

/* The gather grid's cells are half the gather radius r across. The receivers of a source s are
 * the points of the cells of side r (aligned with the grid's) that overlap the box of
 * half-extents E around s (centred: per world axis the smaller of r and the extent of the box of
 * half + 1 kernel pixels along s's tangents plus r along its normal; else r) that lie in the
 * kernel's window. op_sss_gather_cells lists the grid cells of those side-r cells that may meet
 * the window (a cell whose extent along s's tangents misses [-(half + 1), half + 1] pixels has
 * no receiver), at most OP_SSS_GATHER_CELLS, in the order the scatter visits them. */
enum { OP_SSS_GATHER_CELLS = 512 }; /* 8 per axis: E <= r spans 3 side-r cells (4 with rounding) */
int op_sss_gather_cells(const sss_shape *ss, const sss_point *s,
                        int32_t cells[OP_SSS_GATHER_CELLS][3]);

/* Builds ss->gset, the points as the scatter reads them, once ss->gather and ss->rmap are set. */
op_status op_sss_gather_build(sss_shape *ss, op_error *err);
void op_sss_gather_free(sss_shape *ss);

/* Sets the exitance m of every computed receiver of the measured shape ss (ss->gset built, the
 * sources' irradiance known) on `threads` threads, advancing prog by one per point. The result
 * does not depend on the thread count, nor on which other points are receivers or sources. On
 * OP_ERR_CANCELLED (cancel set) or an error the receivers' m is incomplete. */
op_status op_sss_scatter(sss_shape *ss, int threads, atomic_int *cancel, op_progress *prog,
                         op_error *err);

#endif
