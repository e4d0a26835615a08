/* image_seeds.c - image_seeds DIR: writes small images of every format the image reader takes
 * through OpenImageIO into DIR (fuzz_image's seeds, with those run_fuzz.sh renders). */
#include "image_samples.h"

#include <stdio.h>
#include <string.h>

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: image_seeds DIR\n");
        return 2;
    }
    static const struct {
        const char *name, *type;
        int channels;
    } seeds[] = {
        {"rgb.jpg", "uint8", 3},    {"grey.jpg", "uint8", 1},    {"rgb.tga", "uint8", 3},
        {"rgba.tga", "uint8", 4},   {"rgb8.tif", "uint8", 3},    {"rgba16.tif", "uint16", 4},
        {"grey.tif", "float", 1},   {"rgb.hdr", "float", 3},     {"rgb16.png", "uint16", 3},
        {"ga16.png", "uint16", 2},  {"rgba.bmp", "uint8", 4},    {"rgb.ppm", "uint8", 3},
        {"grey.pgm", "uint8", 1}, {"rgbah.exr", "half", 4},
    };
    float px[6 * 4 * 4];
    for (int i = 0; i < 6 * 4 * 4; i++)
        px[i] = (float)((i * 37) % 101) / 100.0f;
    char path[4096];
    int failed = 0;
    for (size_t s = 0; s < sizeof seeds / sizeof seeds[0]; s++) {
        snprintf(path, sizeof path, "%s/%s", argv[1], seeds[s].name);
        failed |= op_test_write_image(path, 6, 4, seeds[s].channels, seeds[s].type, px, NULL);
    }
    static const char *const layers[] = {"R", "G", "B", "diffuse.R", "diffuse.G", "diffuse.B"};
    snprintf(path, sizeof path, "%s/layers.exr", argv[1]);
    failed |= op_test_write_image(path, 6, 4, 6, "half", px, layers);
    return failed ? 1 : 0;
}
