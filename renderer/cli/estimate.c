/* estimate.c - the memory estimate of a render (see estimate.h). */
#include "estimate.h"

#include <sys/resource.h>

/* Bytes per irradiance point of the pre-pass: the point (positions, normals, tangents,
 * irradiance, exitance), its two hashed grids, the receiver maps and the scatter pass's
 * accumulators, rounded up. */
enum { SSS_BYTES_PER_POINT = 256, IMAGE_BYTES_PER_PIXEL = 2 * 4 * sizeof(float) };

void op_estimate_render(const op_scene_info *info, const op_scene_limits *lim, op_estimate *e)
{
    struct rusage ru;
    e->loaded_bytes = getrusage(RUSAGE_SELF, &ru) == 0 ? (long long)ru.ru_maxrss * 1024 : 0;
    e->image_bytes = (long long)info->width * info->height * IMAGE_BYTES_PER_PIXEL;
    long long points = (long long)info->subsurface_shapes * lim->sss_max_points;
    if (points > lim->sss_points)
        points = lim->sss_points;
    e->sss_bytes = points * SSS_BYTES_PER_POINT;
    e->total_bytes = e->loaded_bytes + e->image_bytes + e->sss_bytes;
}
