/* fuzz_volume.c - the .vol grid reader (medium/volume_grid.h) on arbitrary bytes: a grid it
 * accepts has 1 or 3 channels, finite minima no larger than its maxima, and finite lookups
 * within them anywhere, in both layouts, bounded or not. */
#include "fuzz_support.h"

#include "medium/volume_grid.h"

#include <float.h>
#include <math.h>

static void require_within(const op_volume *v, op_v3 x)
{
    op_v3 lo = op_volume_min(v), hi = op_volume_max(v);
    for (int c = 0; c < 3; c++) {
        float a = v3_get(lo, c), b = v3_get(hi, c), y = v3_get(x, c);
        op_fuzz_require(isfinite(y), "a lookup is not finite");
        /* interpolation rounds: a relative margin, and an absolute one for subnormal values */
        float tol = 1e-3f * fmaxf(fabsf(a), fabsf(b)) + FLT_MIN;
        op_fuzz_require(y == 0.0f || (y >= a - tol && y <= b + tol),
                        "a lookup lies outside the grid's range");
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    op_volume *v;
    op_error err;
    if (op_volume_read(op_fuzz_file(data, size, ".vol"), &v, &err) != OP_OK)
        return 0;
    int ch = op_volume_channels(v);
    op_fuzz_require(ch == 1 || ch == 3, "a channel count other than 1 or 3");
    op_v3 lo = op_volume_min(v), hi = op_volume_max(v);
    for (int c = 0; c < 3; c++)
        op_fuzz_require(isfinite(v3_get(lo, c)) && v3_get(lo, c) <= v3_get(hi, c),
                        "bad minimum or maximum");
    op_matrix4 id = op_matrix4_identity();
    static const float pts[][3] = {{0.5f, 0.5f, 0.5f}, {0, 0, 0},         {1, 1, 1},
                                   {-3, 0.2f, 7},      {0.99f, 0.01f, 1}, {NAN, 0.5f, 0.5f}};
    for (int layout = 0; layout < 2; layout++)
        for (int bounded = 0; bounded < 2; bounded++) {
            op_volume_place(v, &id, layout ? OP_VOLUME_VERTICES : OP_VOLUME_CELLS, bounded);
            for (size_t i = 0; i < sizeof pts / sizeof pts[0]; i++)
                require_within(v, op_volume_eval(v, v3(pts[i][0], pts[i][1], pts[i][2])));
        }
    op_volume_free(v);
    return 0;
}
