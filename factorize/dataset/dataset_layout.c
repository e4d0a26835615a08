/* dataset_layout.c - chessboards, veins, inclusions, strata, skin and homogeneous samples as
 * pixel maps. Every random choice comes from a splitmix64 hash of the seed, so a layout is a
 * pure function of its arguments. */
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
    l->eta = 0;
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

/* Uniform in [0, 1) from (seed, i). */
static double hash01(uint64_t seed, uint64_t i)
{
    return (double)(op_hash64(seed ^ op_hash64(i)) >> 11) * (1.0 / 9007199254740992.0);
}

/* Value noise in [-1, 1] with lattice periods pu, pv; u, v in lattice units. */
static double periodic_noise2(double u, double v, int pu, int pv, uint64_t seed)
{
    double fu = floor(u), fv = floor(v);
    double tu = u - fu, tv = v - fv;
    tu = tu * tu * (3 - 2 * tu);
    tv = tv * tv * (3 - 2 * tv);
    int iu = (int)fu, iv = (int)fv;
    double c[4];
    for (int k = 0; k < 4; k++) {
        int a = ((iu + (k & 1)) % pu + pu) % pu, b = ((iv + (k >> 1)) % pv + pv) % pv;
        uint64_t hsh =
            op_hash64(seed ^ op_hash64((uint64_t)a * 73856093u + (uint64_t)b * 19349663u));
        c[k] = (double)(hsh >> 11) * (2.0 / 9007199254740992.0) - 1.0;
    }
    double top = c[0] + (c[1] - c[0]) * tu, bot = c[2] + (c[3] - c[2]) * tu;
    return top + (bot - top) * tv;
}

/* Value noise in [-1, 1] with lattice period p in both axes. */
static double periodic_noise(double u, double v, int p, uint64_t seed)
{
    return periodic_noise2(u, v, p, p, seed);
}

/* Two-octave periodic noise over the unit tile (u, v in [0, 1)), base lattice pu x pv. */
static double tile_fbm(double u, double v, int pu, int pv, uint64_t seed)
{
    return periodic_noise2(u * pu, v * pv, pu, pv, seed) +
           0.5 * periodic_noise2(u * 2 * pu, v * 2 * pv, 2 * pu, 2 * pv, seed + 1);
}

/* Lattice cells per tile side for features about feature_mm across on a side of side_mm
 * (at least 2: a lattice of period 1 is constant). */
static int lattice_cells(double side_mm, double feature_mm)
{
    double n = side_mm / feature_mm;
    return n < 2 ? 2 : n > 4096 ? 4096 : (int)lround(n);
}

/* d wrapped into [-period/2, period/2). */
static double wrap_delta(double d, double period)
{
    return d - period * floor(d / period + 0.5);
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

typedef struct ranked {
    double value;
    size_t index;
} ranked;

/* Descending by value, then ascending by index: a total order, so the ranking is unique. */
static int ranked_cmp(const void *pa, const void *pb)
{
    const ranked *a = pa, *b = pb;
    if (a->value != b->value)
        return a->value < b->value ? 1 : -1;
    return a->index < b->index ? -1 : a->index > b->index;
}

op_status op_layout_inclusions(op_layout *l, int w, int h, double sx, double sy,
                               double fraction, double radius_mm, uint64_t seed,
                               const op_medium *a, const op_medium *b, op_error *err)
{
    if (!(fraction >= 0 && fraction <= 1) || !(radius_mm > 0) || !isfinite(radius_mm))
        return op_error_set(err, OP_ERR_INPUT, "inclusions: fraction %g must be in [0, 1] and "
                            "radius %g mm positive", fraction, radius_mm);
    op_status st = layout_init(l, w, h, sx, sy, a, b, err);
    if (st != OP_OK)
        return st;
    size_t n = (size_t)w * (size_t)h, want = (size_t)llround(fraction * (double)n);
    double wmm = 10 * sx, hmm = 10 * sy;
    /* Enough blobs that their discs alone would cover about the fraction; the threshold then
     * makes the coverage exact, growing or shrinking every blob alike. */
    double blobs_d = ceil(1.3 * fraction * wmm * hmm / (M_PI * radius_mm * radius_mm));
    int blobs = blobs_d < 1 ? 1 : blobs_d > 4096 ? 4096 : (int)blobs_d;
    double(*blob)[5] = malloc((size_t)blobs * sizeof *blob); /* cx, cy, r, cos, sin */
    ranked *rank = malloc(n * sizeof *rank);
    if (!blob || !rank) {
        free(blob), free(rank), op_layout_free(l);
        return op_error_set(err, OP_ERR_NOMEM, "inclusions: out of memory");
    }
    for (int i = 0; i < blobs; i++) {
        uint64_t k = (uint64_t)i * 8;
        double angle = M_PI * hash01(seed, k + 3);
        blob[i][0] = wmm * hash01(seed, k);
        blob[i][1] = hmm * hash01(seed, k + 1);
        blob[i][2] = radius_mm * (0.5 + hash01(seed, k + 2));
        blob[i][3] = cos(angle);
        blob[i][4] = sin(angle);
    }
    int pu = lattice_cells(wmm, 2 * radius_mm), pv = lattice_cells(hmm, 2 * radius_mm);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double px = (x + 0.5) * l->pixel_x, py = (y + 0.5) * l->pixel_y, best = -1e300;
            for (int i = 0; i < blobs; i++) {
                /* An ellipse 1.6 : 1 along the blob's angle, same area as the disc. */
                double dx = wrap_delta(px - blob[i][0], wmm), dy = wrap_delta(py - blob[i][1], hmm);
                double along = (dx * blob[i][3] + dy * blob[i][4]) / 1.265;
                double across = (-dx * blob[i][4] + dy * blob[i][3]) * 1.265;
                double v = 1 - hypot(along, across) / blob[i][2];
                if (v > best)
                    best = v;
            }
            size_t idx = (size_t)y * w + x;
            double edge = tile_fbm((x + 0.5) / w, (y + 0.5) / h, pu, pv, seed ^ 0x5a5aULL);
            rank[idx].value = best + 0.2 * edge;
            rank[idx].index = idx;
        }
    qsort(rank, n, sizeof *rank, ranked_cmp);
    for (size_t i = 0; i < want; i++)
        l->map[rank[i].index] = 1;
    free(blob), free(rank);
    return OP_OK;
}

op_status op_layout_layers(op_layout *l, int w, int h, double sx, double sy, int count,
                           double layer_mm, double wave_mm, uint64_t seed, const op_medium *a,
                           const op_medium *b, op_error *err)
{
    double hmm = 10 * sy, period = count >= 1 ? hmm / count : 0, pixel_y = h > 0 ? hmm / h : 0;
    if (count < 1 || count > 4096 || !(layer_mm > 0) || !(layer_mm <= period / 2) ||
        !(0.75 * layer_mm >= pixel_y) || !(wave_mm >= 0) || !isfinite(wave_mm))
        return op_error_set(err, OP_ERR_INPUT,
                            "layers: %d bands of %g mm (waving %g mm) on %g mm: needs 1 to 4096 "
                            "bands, at most half the band period (%g mm) and at least 4/3 of a "
                            "pixel (%g mm) thick", count, layer_mm, wave_mm, hmm, period / 2,
                            4 * pixel_y / 3);
    op_status st = layout_init(l, w, h, sx, sy, a, b, err);
    if (st != OP_OK)
        return st;
    /* Band i: centre (i + 0.5 + jitter) * period + wave(u), jitter within +-0.15 period, full
     * thickness layer_mm * base_i * (1 + 0.08 swell_i(u)), base_i in [0.85, 1.15]: adjacent
     * bands stay at least 0.7 - 0.62 periods apart, so none touch. */
    int pu = lattice_cells(10 * sx, 10 * sx / 3);
    for (int x = 0; x < w; x++) {
        double u = (x + 0.5) / w;
        double wave = wave_mm * tile_fbm(u, 0.5, pu, 1, seed) / 1.5;
        for (int i = 0; i < count; i++) {
            uint64_t k = (uint64_t)i * 4;
            double centre = (i + 0.5 + 0.3 * (hash01(seed, k) - 0.5)) * period + wave;
            double swell = periodic_noise2(u * 2 * pu, i + 0.5, 2 * pu, count, seed + 7);
            double half = 0.5 * layer_mm * (0.85 + 0.3 * hash01(seed, k + 1)) * (1 + 0.08 * swell);
            for (int y = 0; y < h; y++)
                if (fabs(wrap_delta((y + 0.5) * l->pixel_y - centre, hmm)) < half)
                    l->map[(size_t)y * w + x] = 1;
        }
    }
    return OP_OK;
}

/* Pores per tile side: one per pitch, at least one. */
static int pore_cells(double side_mm, double pitch_mm)
{
    double n = side_mm / pitch_mm;
    return n < 1 ? 1 : n > 4096 ? 4096 : (int)lround(n);
}

int op_layout_skin_pores(int w, int h, double sx, double sy, double pore_pitch_mm)
{
    (void)w, (void)h;
    return pore_cells(10 * sx, pore_pitch_mm) * pore_cells(10 * sy, pore_pitch_mm);
}

op_status op_layout_skin(op_layout *l, int w, int h, double sx, double sy, double pitch_mm,
                         double pore_mm, double vein_mm, uint64_t seed, const op_medium *a,
                         const op_medium *b, op_error *err)
{
    if (!(pitch_mm > 0) || !(pore_mm > 0) || !(pore_mm < 0.2 * pitch_mm) || !(vein_mm >= 0) ||
        !isfinite(pitch_mm) || !isfinite(vein_mm))
        return op_error_set(err, OP_ERR_INPUT, "skin: pores %g mm every %g mm, veins %g mm: "
                            "pores must be positive and under a fifth of their pitch, veins "
                            ">= 0 (0: none)", pore_mm, pitch_mm, vein_mm);
    op_status st = layout_init(l, w, h, sx, sy, a, b, err);
    if (st != OP_OK)
        return st;
    double wmm = 10 * sx, hmm = 10 * sy;
    int nx = pore_cells(wmm, pitch_mm), ny = pore_cells(hmm, pitch_mm);
    double cw = wmm / nx, ch = hmm / ny;
    /* Veins: where the noise is within vein_mm / 2 of its zero set (first-order distance
     * |n| / |grad n|), features about 4 pore pitches across. */
    int pu = lattice_cells(wmm, 4 * pitch_mm), pv = lattice_cells(hmm, 4 * pitch_mm);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double px = (x + 0.5) * l->pixel_x, py = (y + 0.5) * l->pixel_y;
            int cx = (int)floor(px / cw), cy = (int)floor(py / ch), in = 0;
            /* A pore lies within 0.2 .. 0.8 of its cell with radius under 0.2 cells: only
             * the cell itself can reach the pixel, but the neighbours cost little. */
            for (int j = -1; j <= 1 && !in; j++)
                for (int i = -1; i <= 1 && !in; i++) {
                    int ci = ((cx + i) % nx + nx) % nx, cj = ((cy + j) % ny + ny) % ny;
                    uint64_t k = ((uint64_t)cj * (uint64_t)nx + (uint64_t)ci) * 4;
                    double ox = (ci + 0.2 + 0.6 * hash01(seed, k)) * cw;
                    double oy = (cj + 0.2 + 0.6 * hash01(seed, k + 1)) * ch;
                    double r = pore_mm * (0.6 + 0.4 * hash01(seed, k + 2));
                    in = hypot(wrap_delta(px - ox, wmm), wrap_delta(py - oy, hmm)) < r;
                }
            if (!in && vein_mm > 0) {
                double u = (x + 0.5) / w, v = (y + 0.5) / h, du = 0.5 / w, dv = 0.5 / h;
                uint64_t vs = seed ^ 0xa5a5ULL;
                double n0 = tile_fbm(u, v, pu, pv, vs);
                double gx = (tile_fbm(u + du, v, pu, pv, vs) - tile_fbm(u - du, v, pu, pv, vs)) /
                            (2 * du * wmm);
                double gy = (tile_fbm(u, v + dv, pu, pv, vs) - tile_fbm(u, v - dv, pu, pv, vs)) /
                            (2 * dv * hmm);
                double g = hypot(gx, gy);
                in = g > 0 && fabs(n0) / g < vein_mm / 2;
            }
            l->map[(size_t)y * w + x] = (uint8_t)in;
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
