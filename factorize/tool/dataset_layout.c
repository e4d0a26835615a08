/* dataset_layout.c - chessboards, veined marble and homogeneous samples as pixel maps. */
#include "dataset_layout.h"

#include <math.h>
#include <stdlib.h>

static op_status layout_init(op_layout *l, int w, int h, double sx, double sy,
                             const op_medium *a, const op_medium *b, op_error *err)
{
    l->map = NULL;
    if (w <= 0 || h <= 0 || !(sx > 0) || !(sy > 0) || !isfinite(sx) || !isfinite(sy))
        return op_error_set(err, OP_ERR_INPUT, "sample of %d x %d pixels, %g x %g cm: sizes must "
                                               "be positive", w, h, sx, sy);
    if (!a || !b)
        return op_error_set(err, OP_ERR_INTERNAL, "layout without media");
    l->width = w;
    l->height = h;
    l->pixel_x = 10.0 * sx / w;
    l->pixel_y = 10.0 * sy / h;
    l->media[0] = a;
    l->media[1] = b;
    l->map = calloc((size_t)w * (size_t)h, 1);
    if (!l->map)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for a %d x %d medium map", w, h);
    return OP_OK;
}

op_status op_layout_homogeneous(op_layout *l, int w, int h, double sx, double sy,
                                const op_medium *a, op_error *err)
{
    return layout_init(l, w, h, sx, sy, a, a, err);
}

op_status op_layout_chessboard(op_layout *l, int w, int h, double sx, double sy, int n,
                               const op_medium *a, const op_medium *b, op_error *err)
{
    if (n < 1)
        return op_error_set(err, OP_ERR_INPUT, "chessboard of %d squares per side", n);
    op_status st = layout_init(l, w, h, sx, sy, a, b, err);
    if (st != OP_OK)
        return st;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            int i = (int)floor((x + 0.5) * n / w), j = (int)floor((y + 0.5) * n / h);
            l->map[(size_t)y * w + x] = (uint8_t)((i + j) & 1);
        }
    return OP_OK;
}

/* splitmix64: the hash behind the noise lattice. */
static uint64_t mix64(uint64_t z)
{
    z += 0x9e3779b97f4a7c15ULL;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

/* Value noise in [-1, 1] with lattice period p in both axes; u, v in lattice units. */
static double periodic_noise(double u, double v, int p, uint64_t seed)
{
    double fu = floor(u), fv = floor(v);
    double tu = u - fu, tv = v - fv;
    tu = tu * tu * (3 - 2 * tu);
    tv = tv * tv * (3 - 2 * tv);
    int iu = (int)fu, iv = (int)fv;
    double c[4];
    for (int k = 0; k < 4; k++) {
        int a = ((iu + (k & 1)) % p + p) % p, b = ((iv + (k >> 1)) % p + p) % p;
        uint64_t hsh = mix64(seed ^ mix64((uint64_t)a * 73856093u + (uint64_t)b * 19349663u));
        c[k] = (double)(hsh >> 11) * (2.0 / 9007199254740992.0) - 1.0;
    }
    double top = c[0] + (c[1] - c[0]) * tu, bot = c[2] + (c[3] - c[2]) * tu;
    return top + (bot - top) * tv;
}

op_status op_layout_veins(op_layout *l, int w, int h, double sx, double sy, int stripes,
                          double vein_mm, uint64_t seed, const op_medium *a, const op_medium *b,
                          op_error *err)
{
    if (stripes < 1 || !(vein_mm > 0))
        return op_error_set(err, OP_ERR_INPUT, "veins: %d stripes of %g mm", stripes, vein_mm);
    op_status st = layout_init(l, w, h, sx, sy, a, b, err);
    if (st != OP_OK)
        return st;
    /* Stripes run diagonally: phase 2 pi (fx u + fy v) with integer frequencies keeps the
     * pattern periodic over the unit tile (u, v in [0, 1)); the turbulence is periodic too. */
    int fx = stripes, fy = (stripes + 1) / 2;
    double freq_per_mm = sqrt((fx / (10 * sx)) * (fx / (10 * sx)) + (fy / (10 * sy)) * (fy / (10 * sy)));
    /* |sin| < t holds over a band asin(t) / (pi f) wide around each zero, two zeros a period. */
    double half = fmin(0.45 * M_PI, M_PI * freq_per_mm * vein_mm);
    double t = sin(half);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double u = (x + 0.5) / w, v = (y + 0.5) / h, turb = 0, amp = 1;
            for (int o = 0, p = 4; o < 3; o++, p *= 2, amp *= 0.5)
                turb += amp * periodic_noise(u * p, v * p, p, seed + (uint64_t)o);
            double phase = 2 * M_PI * (fx * u + fy * v) + 2.5 * turb;
            l->map[(size_t)y * w + x] = (uint8_t)(fabs(sin(phase)) < t);
        }
    return OP_OK;
}

void op_layout_free(op_layout *l)
{
    if (l) {
        free(l->map);
        l->map = NULL;
    }
}

double op_layout_fraction(const op_layout *l)
{
    size_t n = (size_t)l->width * (size_t)l->height, ones = 0;
    for (size_t i = 0; i < n; i++)
        ones += l->map[i];
    return (double)ones / (double)n;
}
