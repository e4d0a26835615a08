/* estimate.c - the memory estimate of a render (see estimate.h). */
#include "estimate.h"

/* Bytes per irradiance point of the pre-pass at its peak, rounded up: the point (positions,
 * normals, tangents, irradiance, exitance: 92), the dipole's tree (nodes, order, positions,
 * normals, weights, aggregates: about 160) and the weights handed to it (36), three hashed
 * grids (interpolation, the normalization's ball, the thinned receivers: 32 each), the
 * receiver and source maps (11) and the pre-pass cache's copy (25): about 420 (measured: 352
 * for a Marble square of 754579 points). A measured material's scatter accumulators take at
 * most 16 x 12 bytes per point and SSS_SCATTER_BYTES (sss/scatter.c's MAX_ACC_BYTES) more. */
enum { SSS_BYTES_PER_POINT = 448, IMAGE_BYTES_PER_PIXEL = 2 * 4 * sizeof(float) };
#define SSS_SCATTER_BYTES (256LL * 1024 * 1024)

void op_estimate_render(const op_scene_info *info, const op_scene_limits *lim, op_estimate *e)
{
    e->loaded_bytes = info->load_bytes;
    e->image_bytes = (long long)info->width * info->height * IMAGE_BYTES_PER_PIXEL;
    long long points = (long long)info->subsurface_shapes * lim->sss_max_points;
    if (points > lim->sss_points)
        points = lim->sss_points;
    long long scatter = points * 16 * 12;
    e->sss_bytes = points * SSS_BYTES_PER_POINT +
                   (scatter < SSS_SCATTER_BYTES ? scatter : SSS_SCATTER_BYTES);
    e->total_bytes = e->loaded_bytes + e->image_bytes + e->sss_bytes;
}
