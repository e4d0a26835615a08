/* dataset_layout.h - where each medium is on a synthetic sample: a map of W x H pixels, each
 * holding medium 0 or medium 1 (the material is a function of position through the pixel that
 * contains it). The sample tiles the plane periodically: position (x, y) in mm, anywhere, lies
 * in pixel (floor(x / pixel_x) mod W, floor(y / pixel_y) mod H). The medium is the same at every
 * depth (columns through a semi-infinite slab). */
#ifndef OP_FACTOR_DATASET_LAYOUT_H
#define OP_FACTOR_DATASET_LAYOUT_H

#include "media.h"
#include "opaline.h"

#include <stdint.h>

typedef struct op_layout {
    int width, height;          /* pixels */
    double pixel_x, pixel_y;    /* pixel size, mm */
    const op_medium *media[2];  /* media[1] == media[0] for a homogeneous sample */
    uint8_t *map;               /* width * height entries, 0 or 1, row y * width + x */
} op_layout;

/* Every pixel medium a. */
op_status op_layout_homogeneous(op_layout *l, int w, int h, double size_x_cm, double size_y_cm,
                                const op_medium *a, op_error *err);
/* An n x n chessboard of a and b over the sample, a in the top-left square; n even keeps the
 * pattern seamless under periodic tiling. Square (i, j) holds the pixels whose centres it holds. */
op_status op_layout_chessboard(op_layout *l, int w, int h, double size_x_cm, double size_y_cm,
                               int n, const op_medium *a, const op_medium *b, op_error *err);
/* Marble `a` crossed by thin veins of `b`: turbulent sine stripes (Perlin's marble) built from
 * periodic value noise, so the pattern is seamless under tiling. `stripes` sets how many veins
 * cross the sample, vein_mm their width; `seed` picks the noise. */
op_status op_layout_veins(op_layout *l, int w, int h, double size_x_cm, double size_y_cm,
                          int stripes, double vein_mm, uint64_t seed, const op_medium *a,
                          const op_medium *b, op_error *err);
void op_layout_free(op_layout *l);

/* Medium index (0 or 1) of pixel (x, y), any integers (wrapped periodically). */
static inline int op_layout_at(const op_layout *l, int64_t x, int64_t y)
{
    int64_t xm = x % l->width, ym = y % l->height;
    if (xm < 0)
        xm += l->width;
    if (ym < 0)
        ym += l->height;
    return l->map[ym * l->width + xm];
}

/* Fraction of pixels holding medium 1. */
double op_layout_fraction(const op_layout *l);

#endif
