/* fuzz_tile_list.c - the tile list of `opaline-render --merge-tiles` (op_tiles_merge) on
 * arbitrary bytes, in a folder holding the two tiles of a 4 x 2 film (a.exr at 0,0 and b.exr
 * at 2,0, each 2 x 2, tagged as --raw-exr tags them). A list it accepts gives the whole film,
 * every pixel the value its tile holds there; a list it refuses leaves no image. */
#include "fuzz_support.h"

#include "opaline.h"
#include "opaline_image.h"
#include "tile_merge.h"

#include <stdlib.h>
#include <string.h>

enum { W = 4, H = 2, T = 2 };
#define SCENE_TAG "key=00000000000000aa film=4x2"

/* The film's value at pixel x, y, channel c: tells every pixel and channel apart. */
static float expected(int x, int y, int c)
{
    return (float)(x + 10 * y + 100 * c);
}

static void write_tile(const char *name, int x0)
{
    op_image img;
    op_error err;
    op_fuzz_require(op_image_alloc(&img, T, H, 4, &err) == OP_OK, "out of memory");
    for (int y = 0; y < H; y++)
        for (int x = 0; x < T; x++)
            for (int c = 0; c < 4; c++)
                img.pixels[(y * T + x) * 4 + c] = expected(x0 + x, y, c);
    char tag[128];
    snprintf(tag, sizeof tag, "%s crop=%d,0,%d,%d", SCENE_TAG, x0, T, H);
    const char *path = op_fuzz_folder_file(name, (const uint8_t *)"", 0);
    op_fuzz_require(op_image_write_exr_attr(path, &img, 0, OP_TILE_ATTR, tag, &err) == OP_OK,
                    "cannot write a tile");
    op_image_free(&img);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static int ready;
    if (!ready++) {
        write_tile("a.exr", 0);
        write_tile("b.exr", T);
    }
    char list[4500];
    snprintf(list, sizeof list, "%s", op_fuzz_folder_file("list.txt", data, size));
    op_image img;
    op_error err;
    if (op_tiles_merge(list, W, H, SCENE_TAG, &img, &err) != OP_OK) {
        op_fuzz_require(img.pixels == NULL, "a refused list left an image");
        return 0;
    }
    op_fuzz_require(img.width == W && img.height == H && img.channels == 4, "wrong size");
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            for (int c = 0; c < 4; c++)
                op_fuzz_require(img.pixels[(y * W + x) * 4 + c] == expected(x, y, c),
                                "a pixel is not its tile's");
    op_image_free(&img);
    return 0;
}
