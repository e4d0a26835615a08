/* albedo_png.h - the thumbnail `opaline-factor factor --albedo-png` writes. */
#ifndef OP_FACTOR_ALBEDO_PNG_H
#define OP_FACTOR_ALBEDO_PNG_H

#include "fit.h"
#include "opaline.h"

/* The albedo map (channels x rows of ds) as an sRGB PNG at path, box-filtered down to at most
 * 512 pixels on a side, scaled so that its brightest value is at most 1. */
op_status op_albedo_png_write(const char *path, const dataset *ds, const float *albedo,
                              op_error *err);

#endif
