/* rgbe.c - Radiance RGBE images (see rgbe.h). */
#include "light/rgbe.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

void op_rgbe_encode(const float rgb[3], unsigned char out[4])
{
    float c[3];
    for (int k = 0; k < 3; k++)
        c[k] = isfinite(rgb[k]) && rgb[k] > 0.0f ? rgb[k] : 0.0f;
    float v = fmaxf(c[0], fmaxf(c[1], c[2]));
    if (v < 1e-32f) {
        out[0] = out[1] = out[2] = out[3] = 0;
        return;
    }
    int e;
    float m = frexpf(v, &e); /* v = m 2^e, m in [0.5, 1) */
    if (e > 127) {           /* beyond the format's range: the largest value it holds */
        out[0] = out[1] = out[2] = 255;
        out[3] = 255;
        return;
    }
    float scale = m * 256.0f / v;
    for (int k = 0; k < 3; k++) {
        float b = c[k] * scale;
        out[k] = (unsigned char)(b >= 255.0f ? 255 : (int)b);
    }
    out[3] = (unsigned char)(e + 128);
}

void op_rgbe_decode(const unsigned char in[4], float rgb[3])
{
    if (in[3] == 0) {
        rgb[0] = rgb[1] = rgb[2] = 0.0f;
        return;
    }
    float f = ldexpf(1.0f, (int)in[3] - (128 + 8));
    for (int k = 0; k < 3; k++)
        rgb[k] = ((float)in[k] + 0.5f) * f;
}

op_status op_rgbe_write(const char *path, const op_image *img, op_error *err)
{
    if (!img || img->width < 1 || img->height < 1 || img->channels < 1)
        return op_error_set(err, OP_ERR_INPUT, "%s: no image to write", path);
    op_output *out;
    op_status st = op_output_open(path, &out, err);
    if (st)
        return st;
    char header[128];
    int hn = snprintf(header, sizeof header, "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n",
                      img->height, img->width);
    op_output_write(out, header, (size_t)hn);
    unsigned char *row = malloc((size_t)img->width * 4);
    if (!row) {
        op_output_abort(out);
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    }
    int ch = img->channels;
    for (int y = 0; y < img->height; y++) {
        for (int x = 0; x < img->width; x++) {
            const float *p = img->pixels + ((size_t)y * img->width + x) * (size_t)ch;
            float rgb[3] = {p[0], ch >= 3 ? p[1] : p[0], ch >= 3 ? p[2] : p[0]};
            op_rgbe_encode(rgb, row + 4 * (size_t)x);
        }
        op_output_write(out, row, (size_t)img->width * 4);
    }
    free(row);
    return op_output_commit(out, err);
}
