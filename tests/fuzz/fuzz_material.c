/* fuzz_material.c - the material reader (op_material_open) on arbitrary bytes; a file it
 * accepts must evaluate to finite, non-negative Rd everywhere it is asked. */
#include "fuzz_support.h"

#include "opaline.h"
#include "opaline_material.h"

#include <math.h>
#include <stdlib.h>

static void require_rd(float v)
{
    op_fuzz_require(isfinite(v) && v >= 0.0f, "Rd is negative, NaN or infinite");
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    op_material *m;
    op_error err;
    if (op_material_open(op_fuzz_file(data, size, ".opm"), &m, &err) != OP_OK)
        return 0;
    const op_material_info *in = op_material_get_info(m);
    int w = in->width, h = in->height, k = in->kernel, r = k / 2;
    float *row = malloc((size_t)k * (size_t)k * sizeof *row);
    float *albedo = malloc((size_t)w * (size_t)h * (size_t)in->channels * sizeof *albedo);
    op_fuzz_require(row && albedo, "out of memory for a material that opened");
    for (int c = 0; c < in->channels; c++) {
        const int xs[2] = {0, w - 1}, ys[2] = {0, h - 1};
        for (int i = 0; i < 2; i++) {
            op_material_eval_row(m, c, xs[i], ys[i], row);
            for (int j = 0; j < k * k; j++)
                require_rd(row[j]);
            for (int d = -r; d <= r; d++)
                require_rd(op_material_eval(m, c, xs[i], ys[i], d, -d));
        }
    }
    if (op_material_albedo_map(m, albedo, &err) == OP_OK)
        for (size_t i = 0; i < (size_t)w * (size_t)h * (size_t)in->channels; i++)
            op_fuzz_require(isfinite(albedo[i]), "albedo is NaN or infinite");
    free(row);
    free(albedo);
    op_material_close(m);
    return 0;
}
