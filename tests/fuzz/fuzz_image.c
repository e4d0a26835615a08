/* fuzz_image.c - the image reader (OpenEXR, PNG or PFM, chosen by content) on arbitrary bytes;
 * an image it accepts has positive dimensions and 1 to 4 channels. */
#include "fuzz_support.h"

#include "opaline.h"
#include "opaline_image.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    op_image img;
    op_error err;
    if (op_image_read(op_fuzz_file(data, size, ".img"), &img, &err) != OP_OK)
        return 0;
    op_fuzz_require(img.width > 0 && img.height > 0 && img.channels >= 1 && img.channels <= 4 &&
                        img.pixels,
                    "image accepted with bad dimensions");
    op_image_free(&img);
    return 0;
}
