/* dataset_layout.h - where each medium is on a synthetic sample: a map of W x H pixels, each
 * holding medium 0 or medium 1 (the material is a function of position through the pixel that
 * contains it). The sample tiles the plane periodically: position (x, y) in mm, anywhere, lies
 * in pixel (floor(x / pixel_x) mod W, floor(y / pixel_y) mod H). The medium is the same at every
 * depth (columns through a semi-infinite slab). */
#ifndef OP_FACTOR_DATASET_LAYOUT_H
#define OP_FACTOR_DATASET_LAYOUT_H

#include "opaline.h"

#include <stdint.h>

typedef struct op_layout {
    int width, height;          /* pixels */
    double pixel_x, pixel_y;    /* pixel size, mm */
    const op_medium *media[2];  /* media[1] == media[0] for a homogeneous sample */
    uint8_t *map;               /* width * height entries, 0 or 1, row y * width + x */
    double eta;                 /* > 0: one index of refraction for the whole sample; 0 (as the
                                   constructors leave it): each medium's own op_medium.eta */
} op_layout;

/* The relative index of refraction of medium m (0 or 1) of l. */
static inline double op_layout_eta(const op_layout *l, int m)
{
    return l->eta > 0 ? l->eta : l->media[m]->eta;
}

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
/* Inclusions: irregular blobs of `b` in `a` (each blob a jittered disc with noisy edges,
 * radius about radius_mm), covering exactly round(fraction * W * H) pixels: the blob field is
 * thresholded at the rank that gives that count. Seamless under tiling; `seed` fixes it.
 * 0 <= fraction <= 1. */
op_status op_layout_inclusions(op_layout *l, int w, int h, double size_x_cm, double size_y_cm,
                               double fraction, double radius_mm, uint64_t seed,
                               const op_medium *a, const op_medium *b, op_error *err);
/* Strata: `count` bands of `b` in `a`, stacked along y, each about layer_mm thick (per band
 * 0.75 to 1.25 times that, swelling along x), their mid-lines waving along x by up to wave_mm.
 * Every column crosses exactly `count` bands of b; the mean band thickness is layer_mm to
 * within the band jitter. Needs count >= 1 and layer_mm at most half the band period
 * (H * pixel_y / count), wave_mm >= 0. */
op_status op_layout_layers(op_layout *l, int w, int h, double size_x_cm, double size_y_cm,
                           int count, double layer_mm, double wave_mm, uint64_t seed,
                           const op_medium *a, const op_medium *b, op_error *err);
/* Skin-like: a dermis `a` with pores and fine capillary veins of `b`. One pore per cell of a
 * grid of pitch about pore_pitch_mm (jittered centre, radius 0.6 to 1.0 times pore_mm); veins
 * are the zero set of a periodic noise, vein_mm wide. Seamless; `seed` fixes it. */
op_status op_layout_skin(op_layout *l, int w, int h, double size_x_cm, double size_y_cm,
                         double pore_pitch_mm, double pore_mm, double vein_mm, uint64_t seed,
                         const op_medium *a, const op_medium *b, op_error *err);
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
/* Number of pores op_layout_skin makes on a sample of w x h pixels of the given size. */
int op_layout_skin_pores(int w, int h, double size_x_cm, double size_y_cm, double pore_pitch_mm);

#endif
