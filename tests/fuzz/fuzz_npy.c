/* fuzz_npy.c - the .npy header parser of `opaline-factor import` (op_npy_parse_header) on
 * arbitrary bytes; a header it accepts has a float item size, at most 8 non-negative
 * dimensions and data that starts inside what was read or right after it. */
#include "fuzz_support.h"

#include "opaline.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    op_npy_header h;
    op_error err;
    if (op_npy_parse_header(data, size, "fuzz.npy", &h, &err) != OP_OK)
        return 0;
    op_fuzz_require(h.itemsize == 4 || h.itemsize == 8, "item size is not 4 or 8");
    op_fuzz_require(h.ndim >= 0 && h.ndim <= 8, "more than 8 dimensions");
    for (int i = 0; i < h.ndim; i++)
        op_fuzz_require(h.shape[i] >= 0, "negative dimension");
    op_fuzz_require(h.data_offset <= size && h.data_offset <= OP_NPY_MAX_HEADER,
                    "data offset beyond the header read");
    return 0;
}
