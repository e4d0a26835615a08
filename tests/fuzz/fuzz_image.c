/* fuzz_image.c - the image reader on arbitrary bytes: every format it tells by content (PFM
 * here; OpenEXR, PNG, JPEG, TIFF, HDR, BMP, PNM through OpenImageIO) and, the file being named
 * .tga, TGA for the rest, with a limit of 2^22 pixels (a header may declare up to the default
 * 2^27, 1.6 GB of floats: allowed, but not what fuzzing is for). An image it accepts has
 * positive dimensions and 1 to 4 channels, and the header-only reader (op_image_read_size)
 * gives the same size and channels for it. */
#include "fuzz_support.h"

#include "opaline.h"
#include "opaline_image.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = op_fuzz_file(data, size, ".tga");
    int w, h, c;
    op_error err;
    op_status sized = op_image_read_size(path, &w, &h, &c, &err);
    op_image img;
    if (op_image_read_limited(path, 1, (uint64_t)1 << 22, &img, NULL, &err) != OP_OK)
        return 0;
    op_fuzz_require(img.width > 0 && img.height > 0 && img.channels >= 1 && img.channels <= 4 &&
                        img.pixels,
                    "image accepted with bad dimensions");
    op_fuzz_require(sized == OP_OK && w == img.width && h == img.height && c == img.channels,
                    "the header's size is not the image's");
    op_image_free(&img);
    return 0;
}
