/* rgbe.h - Radiance RGBE (.hdr) images, as Mitsuba's hdrfilm writes with fileFormat="rgbe":
 * Greg Ward's shared-exponent format, 4 bytes a pixel, written uncompressed (flat scanlines,
 * which every RGBE reader accepts), rows from the top. */
#ifndef OP_RGBE_H
#define OP_RGBE_H

#include "opaline.h"
#include "opaline_image.h"

/* Encodes one linear RGB value (negative and non-finite channels count as 0). */
void op_rgbe_encode(const float rgb[3], unsigned char out[4]);
/* Decodes what op_rgbe_encode wrote. */
void op_rgbe_decode(const unsigned char in[4], float rgb[3]);
/* Writes the first three channels of img (a grey image repeats its one channel) to path
 * through op_output. */
op_status op_rgbe_write(const char *path, const op_image *img, op_error *err);

#endif
