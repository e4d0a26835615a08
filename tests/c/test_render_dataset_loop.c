/* test_render_dataset_loop.c - the dataset generator and the volumetric path tracer agree: a
 * chessboard sample simulated by the Monte Carlo generator (factorize/dataset) and the same
 * sample built as a heterogeneous medium and rendered with volpath give the same Rd(x_i, x_o)
 * within their Monte Carlo errors.
 *
 * The sample: a chessboard of Skin1 and Ketchup (2 mm squares, 1 mm pixels, a 4 x 4 pixel tile
 * repeated), one index of refraction for the whole sample, 1 (index-matched: light crosses the
 * surface unrefracted), reduced coefficients with isotropic scattering as the generator uses.
 * Rd(x_i, x_o) is the power leaving through pixel x_o per power entering through pixel x_i
 * under diffuse light (docs/datasets.md).
 *
 * The render (Mitsuba 3 XML): the sample as a box 65 mm wide and 40 mm deep (deep and wide
 * enough to stand for the generator's semi-infinite tiled slab: light reaching its sides or floor
 * is below the noise) whose medium is a grid of one voxel per pixel looked up `nearest`; above
 * pixel x_i, 1 um over the surface, a pixel-sized Lambertian area light of radiance 1 facing
 * down, so that pixel receives irradiance pi, cosine-distributed; above the 5 x 5 pixels around
 * x_i, 2 um over the surface, an irradiancemeter rectangle facing down whose film pixels are the
 * surface pixels under them, each reading the exitance of its pixel: Rd = reading / pi. Both
 * shapes are black. The meter's pixel over x_i itself sees the light's back, so that entry is
 * not compared. Each estimate's standard error: the generator's own, the render's from the
 * spread of RUNS independent renders, so that each entry's z-score follows Student's t with
 * RUNS - 1 = 15 degrees of freedom: mean z^2 15 / 13 = 1.15 (standard deviation about 0.15 over
 * the 144 entries), |z| beyond 5.5 with probability 6e-5 per entry.
 *
 * The loop caught a defect of shadow rays: one crossing an index-matched boundary went on from
 * the origin moved off the surface in its old direction, parallel to the line to the light
 * sample, met the light's surface before its end, and was counted as occluded: light outside the
 * medium reached points inside it by next-event estimation at about half its strength (mean z^2
 * 29 before the fix). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dataset_layout.h"
#include "dataset_montecarlo.h"
#include "opaline_render.h"
#include "test_support.h"

enum {
    TILE = 4,       /* pixels per tile side */
    KERNEL = 5,     /* exit pixels per side around x_i */
    GRID = 65,      /* voxels per side of the rendered sample (odd: pixel 0 in the middle) */
    RUNS = 16,      /* independent renders per incident pixel */
};

/* Writes a .vol grid (Mitsuba's format, float32, 3 channels) of GRID x GRID x 1 voxels whose
 * voxel (i, j) holds f(medium of pixel (i - GRID / 2, j - GRID / 2), channel). */
static const char *write_grid(const char *name, const op_layout *l, int albedo)
{
    const char *path = op_test_tmp_path(name);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    int32_t hdr[5] = {1, GRID, GRID, 1, 3};
    float box[6] = {0, 0, 0, 1, 1, 1};
    assert_int_equal(fwrite("VOL\3", 1, 4, f), 4);
    assert_int_equal(fwrite(hdr, sizeof hdr, 1, f), 1); /* little-endian hosts, as CI's */
    assert_int_equal(fwrite(box, sizeof box, 1, f), 1);
    for (int j = 0; j < GRID; j++)
        for (int i = 0; i < GRID; i++) {
            const op_medium *m = l->media[op_layout_at(l, i - GRID / 2, j - GRID / 2)];
            for (int c = 0; c < 3; c++) {
                double t = m->sigma_s[c] + m->sigma_a[c];
                float v = (float)(albedo ? m->sigma_s[c] / t : t);
                assert_int_equal(fwrite(&v, sizeof v, 1, f), 1);
            }
        }
    assert_int_equal(fclose(f), 0);
    return path;
}

/* The scene with the light over pixel (xi, yi) and the meter over the KERNEL^2 pixels around it. */
static const char *scene(const char *sigma_t, const char *albedo, int xi, int yi, int spp)
{
    static char text[8192];
    const char *grid_fmt =
        "<volume type=\"gridvolume\" name=\"%s\"><string name=\"filename\" value=\"%s\"/>"
        "<string name=\"filter_type\" value=\"nearest\"/><transform name=\"to_world\">"
        "<translate x=\"-0.5\" y=\"-0.5\"/><scale x=\"%d\" y=\"%d\" z=\"40\"/>"
        "<translate z=\"-40\"/></transform></volume>";
    char grids[2][1024];
    snprintf(grids[0], sizeof grids[0], grid_fmt, "sigma_t", sigma_t, GRID, GRID);
    snprintf(grids[1], sizeof grids[1], grid_fmt, "albedo", albedo, GRID, GRID);
    int n = snprintf(
        text, sizeof text,
        "<scene version=\"3.0.0\"><integrator type=\"volpath\"><integer name=\"max_depth\" "
        "value=\"-1\"/></integrator>"
        "<shape type=\"cube\"><transform name=\"to_world\"><scale x=\"%g\" y=\"%g\" z=\"20\"/>"
        "<translate z=\"-20\"/></transform><bsdf type=\"null\"/>"
        "<medium type=\"heterogeneous\" name=\"interior\">%s%s<phase type=\"isotropic\"/>"
        "</medium></shape>"
        "<shape type=\"rectangle\"><boolean name=\"flip_normals\" value=\"true\"/>"
        "<transform name=\"to_world\"><scale value=\"0.5\"/><translate x=\"%d\" y=\"%d\" "
        "z=\"0.001\"/></transform><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0\"/>"
        "</bsdf><emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter></shape>"
        "<shape type=\"rectangle\"><boolean name=\"flip_normals\" value=\"true\"/>"
        "<transform name=\"to_world\"><scale value=\"%g\"/><translate x=\"%d\" y=\"%d\" "
        "z=\"0.002\"/></transform><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0\"/>"
        "</bsdf><sensor type=\"irradiancemeter\"><sampler type=\"independent\"><integer "
        "name=\"sample_count\" value=\"%d\"/></sampler><film type=\"hdrfilm\"><integer "
        "name=\"width\" value=\"%d\"/><integer name=\"height\" value=\"%d\"/><rfilter "
        "type=\"box\"/></film></sensor></shape></scene>",
        GRID / 2.0, GRID / 2.0, grids[0], grids[1], xi, yi, KERNEL / 2.0, xi, yi, spp, KERNEL,
        KERNEL);
    assert_true(n > 0 && n < (int)sizeof text);
    return text;
}

/* Compares the render of incident pixel (xi, yi) (a pixel of the tile) with row yi * TILE + xi
 * of the generator's dataset d; adds each entry's squared z-score to *z2 (and counts them in *n)
 * and returns the largest |z|. */
static double compare_row(const op_layout *l, const op_dataset *d, const char *sigma_t,
                          const char *albedo, int xi, int yi, int spp, double *z2, int *n)
{
    static double sum[3][KERNEL * KERNEL], sq[3][KERNEL * KERNEL];
    memset(sum, 0, sizeof sum);
    memset(sq, 0, sizeof sq);
    const char *path = op_test_write_temp("loop.xml", scene(sigma_t, albedo, xi, yi, spp));
    for (int r = 0; r < RUNS; r++) {
        op_image img = op_test_render_image(path, spp, 2, (uint64_t)r + 1);
        assert_int_equal(img.width, KERNEL);
        assert_int_equal(img.height, KERNEL);
        for (int p = 0; p < KERNEL * KERNEL; p++)
            for (int c = 0; c < 3; c++) {
                double v = img.pixels[(size_t)img.channels * (size_t)p + (size_t)c] / M_PI;
                sum[c][p] += v;
                sq[c][p] += v * v;
            }
        op_image_free(&img);
    }
    size_t row = (size_t)yi * TILE + (size_t)xi;
    double worst = 0;
    for (int c = 0; c < 3; c++)
        for (int p = 0; p < KERNEL * KERNEL; p++) {
            int dx = p % KERNEL - KERNEL / 2, dy = p / KERNEL - KERNEL / 2;
            if (dx == 0 && dy == 0)
                continue;
            double mean = sum[c][p] / RUNS;
            double var = fmax(sq[c][p] / RUNS - mean * mean, 0.0) * RUNS / (RUNS - 1);
            double se_r = sqrt(var / RUNS);
            size_t e = row * KERNEL * KERNEL + (size_t)p; /* the same (dy, dx) layout */
            double g = d->rd[c][e], se_g = d->se[c][e];
            double z = (mean - g) / sqrt(se_r * se_r + se_g * se_g);
            print_message("x_i (%d, %d) %s, exit (%+d, %+d) %s, channel %d: volpath %.5f +- "
                          "%.5f, generator %.5f +- %.5f, z %+.2f\n", xi, yi,
                          l->media[op_layout_at(l, xi, yi)]->name, dx, dy,
                          l->media[op_layout_at(l, xi + dx, yi + dy)]->name, c, mean, se_r, g,
                          se_g, z);
            *z2 += z * z;
            (*n)++;
            worst = fmax(worst, fabs(z));
        }
    return worst;
}

static void test_chessboard_loop(void **state)
{
    (void)state;
    const op_medium *a = op_medium_lookup("skin1"), *b = op_medium_lookup("ketchup");
    op_layout l;
    op_error err = {0};
    OP_ASSERT_OK(op_layout_chessboard(&l, TILE, TILE, 0.1 * TILE, 0.1 * TILE, 2, a, b, &err),
                 err);
    l.eta = 1.0;
    /* the generator: rows 0 .. 2 (pixels (0, 0) in Skin1 and (2, 0) in Ketchup) */
    op_dataset d;
    OP_ASSERT_OK(op_dataset_alloc_block(&d, TILE, TILE, KERNEL, 1, 3, &err), err);
    op_mc_options o = {.photons = 200000, .seed = 11, .threads = 2};
    op_mc_stats stats;
    OP_ASSERT_OK(op_mc_generate(&l, &o, &d, &stats, &err), err);
    const char *sigma_t = write_grid("sigma_t.vol", &l, 0), *albedo = write_grid("albedo.vol", &l, 1);
    double z2 = 0, worst = 0;
    int n = 0;
    worst = fmax(worst, compare_row(&l, &d, sigma_t, albedo, 0, 0, 256, &z2, &n));
    worst = fmax(worst, compare_row(&l, &d, sigma_t, albedo, 2, 0, 256, &z2, &n));
    print_message("%d entries: mean z^2 %.3f, largest |z| %.2f\n", n, z2 / n, worst);
    op_dataset_free(&d);
    op_layout_free(&l);
    if (!(z2 / n < 1.8) || !(worst < 5.5))
        fail_msg("volpath and the generator disagree: mean z^2 %.3f (at most 1.8), largest |z| "
                 "%.2f (at most 5.5)", z2 / n, worst);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_chessboard_loop),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
