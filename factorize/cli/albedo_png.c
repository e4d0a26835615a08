/* albedo_png.c - the albedo map's thumbnail (albedo_png.h). */
#include "albedo_png.h"
#include "opaline.h"
#include "opaline_image.h"

#include <math.h>

op_status op_albedo_png_write(const char *path, const dataset *ds, const float *albedo,
                              op_error *err)
{
    int w = ds->info.width, h = ds->info.height, ch = ds->info.channels;
    int f = 1;
    while ((w + f - 1) / f > 512 || (h + f - 1) / f > 512)
        f++;
    op_image img;
    op_status st = op_image_alloc(&img, (w + f - 1) / f, (h + f - 1) / f, ch, err);
    if (st != OP_OK)
        return st;
    float peak = 0;
    for (int y = 0; y < img.height; y++)
        for (int x = 0; x < img.width; x++)
            for (int c = 0; c < ch; c++) {
                double sum = 0;
                int n = 0;
                for (int yy = y * f; yy < h && yy < (y + 1) * f; yy++)
                    for (int xx = x * f; xx < w && xx < (x + 1) * f; xx++, n++)
                        sum += albedo[(int64_t)c * ds->rows + (int64_t)yy * w + xx];
                float v = (float)(sum / n);
                img.pixels[((size_t)y * img.width + x) * ch + c] = v;
                peak = v > peak ? v : peak;
            }
    float stops = peak > 1.0f ? -log2f(peak) : 0.0f;
    st = op_image_write_png(path, &img, stops, err);
    op_image_free(&img);
    return st;
}
