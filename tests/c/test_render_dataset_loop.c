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

/* Unpolarized Fresnel reflectance from index 1 into n at incidence cosine c. */
static double fresnel(double c, double n)
{
    double s2 = (1 - c * c) / (n * n), ct = sqrt(1 - s2);
    double rs = (c - n * ct) / (c + n * ct), rp = (ct - n * c) / (ct + n * c);
    return 0.5 * (rs * rs + rp * rp);
}

/* T(n): the fraction of diffuse light from air that enters index n (midpoint rule). */
static double transmittance(double n)
{
    const int steps = 100000;
    double sum = 0;
    for (int i = 0; i < steps; i++) {
        double mu = (i + 0.5) / steps;
        sum += 2 * mu * (1 - fresnel(mu, n));
    }
    return sum / steps;
}

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
static const char *scene(const char *sigma_t, const char *albedo, double eta, int xi, int yi,
                         int spp)
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
    char boundary[256] = "<bsdf type=\"null\"/>";
    if (eta != 1.0)
        snprintf(boundary, sizeof boundary, "<bsdf type=\"dielectric\"><float name=\"int_ior\" "
                 "value=\"%g\"/><float name=\"ext_ior\" value=\"1\"/></bsdf>", eta);
    int n = snprintf(
        text, sizeof text,
        "<scene version=\"3.0.0\"><integrator type=\"volpath\"><integer name=\"max_depth\" "
        "value=\"-1\"/></integrator>"
        "<shape type=\"cube\"><transform name=\"to_world\"><scale x=\"%g\" y=\"%g\" z=\"20\"/>"
        "<translate z=\"-20\"/></transform>%s"
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
        GRID / 2.0, GRID / 2.0, boundary, grids[0], grids[1], xi, yi, KERNEL / 2.0, xi, yi, spp, KERNEL,
        KERNEL);
    assert_true(n > 0 && n < (int)sizeof text);
    return text;
}

/* The group of exit offset (dx, dy) from incident pixel (xi, yi): each entry its own
 * (per_entry), else the ring (|d| 1 or 2 in the max norm) and whether the exit pixel's medium is
 * the incident one's; -1 for x_i itself. */
static int group_of(const op_layout *l, int per_entry, int xi, int yi, int dx, int dy)
{
    if (dx == 0 && dy == 0)
        return -1;
    if (per_entry)
        return (dy + KERNEL / 2) * KERNEL + dx + KERNEL / 2;
    int ring = abs(dx) > abs(dy) ? abs(dx) : abs(dy);
    return 2 * (ring - 1) + (op_layout_at(l, xi, yi) != op_layout_at(l, xi + dx, yi + dy));
}

enum { GROUPS = KERNEL * KERNEL };

/* Compares the render of incident pixel (xi, yi) (a pixel of the tile) under a boundary of index
 * eta with row yi * TILE + xi of the generator's dataset d, summed over groups (group_of); adds
 * each group's squared z-score to *z2 (and counts them in *n) and returns the largest |z|. The
 * reading of a meter pixel is pi T(eta) Rd: the light's irradiance is pi, of which T(eta)
 * enters. */
static double compare_row(const op_layout *l, const op_dataset *d, const char *sigma_t,
                          const char *albedo, double eta, int per_entry, int xi, int yi, int spp,
                          double *z2, int *n)
{
    double sum[3][GROUPS] = {{0}}, sq[3][GROUPS] = {{0}}, gen[3][GROUPS] = {{0}},
           gen_var[3][GROUPS] = {{0}};
    int used[GROUPS] = {0};
    const char *path = op_test_write_temp("loop.xml", scene(sigma_t, albedo, eta, xi, yi, spp));
    double norm = M_PI * transmittance(eta);
    for (int r = 0; r < RUNS; r++) {
        op_image img = op_test_render_image(path, spp, 2, (uint64_t)r + 1);
        assert_int_equal(img.width, KERNEL);
        assert_int_equal(img.height, KERNEL);
        for (int c = 0; c < 3; c++) {
            double run[GROUPS] = {0};
            for (int p = 0; p < KERNEL * KERNEL; p++) {
                int g = group_of(l, per_entry, xi, yi, p % KERNEL - KERNEL / 2,
                                 p / KERNEL - KERNEL / 2);
                if (g >= 0)
                    run[g] += img.pixels[(size_t)img.channels * (size_t)p + (size_t)c] / norm;
            }
            for (int g = 0; g < GROUPS; g++) {
                sum[c][g] += run[g];
                sq[c][g] += run[g] * run[g];
            }
        }
        op_image_free(&img);
    }
    size_t row = (size_t)yi * TILE + (size_t)xi;
    for (int c = 0; c < 3; c++)
        for (int p = 0; p < KERNEL * KERNEL; p++) {
            int g = group_of(l, per_entry, xi, yi, p % KERNEL - KERNEL / 2,
                             p / KERNEL - KERNEL / 2);
            if (g < 0)
                continue;
            size_t e = row * KERNEL * KERNEL + (size_t)p; /* the same (dy, dx) layout */
            gen[c][g] += d->rd[c][e];
            /* (entries of a row are anticorrelated: summing variances overestimates) */
            gen_var[c][g] += (double)d->se[c][e] * d->se[c][e];
            used[g] = 1;
        }
    double worst = 0;
    for (int c = 0; c < 3; c++)
        for (int g = 0; g < GROUPS; g++) {
            if (!used[g])
                continue;
            double mean = sum[c][g] / RUNS;
            double var = fmax(sq[c][g] / RUNS - mean * mean, 0.0) * RUNS / (RUNS - 1);
            double se_r = sqrt(var / RUNS), se_g = sqrt(gen_var[c][g]);
            double z = (mean - gen[c][g]) / sqrt(se_r * se_r + se_g * se_g);
            print_message("eta %g, x_i (%d, %d) %s, group %2d, channel %d: volpath %.5f +- %.5f, "
                          "generator %.5f +- %.5f, z %+.2f\n", eta, xi, yi,
                          l->media[op_layout_at(l, xi, yi)]->name, g, c, mean, se_r, gen[c][g],
                          se_g, z);
            *z2 += z * z;
            (*n)++;
            worst = fmax(worst, fabs(z));
        }
    return worst;
}

/* The chessboard at one index eta, both ways, from a Skin1 pixel and a Ketchup pixel. */
static void loop_at(double eta, int per_entry, uint64_t photons, int spp)
{
    const op_medium *a = op_medium_lookup("skin1"), *b = op_medium_lookup("ketchup");
    op_layout l;
    op_error err = {0};
    OP_ASSERT_OK(op_layout_chessboard(&l, TILE, TILE, 0.1 * TILE, 0.1 * TILE, 2, a, b, &err),
                 err);
    l.eta = eta;
    /* the generator: rows 0 .. 2 (pixels (0, 0) in Skin1 and (2, 0) in Ketchup) */
    op_dataset d;
    OP_ASSERT_OK(op_dataset_alloc_block(&d, TILE, TILE, KERNEL, 1, 3, &err), err);
    op_mc_options o = {.photons = photons, .seed = 11, .threads = 2};
    op_mc_stats stats;
    OP_ASSERT_OK(op_mc_generate(&l, &o, &d, &stats, &err), err);
    const char *sigma_t = write_grid("sigma_t.vol", &l, 0), *albedo = write_grid("albedo.vol", &l, 1);
    double z2 = 0, worst = 0;
    int n = 0;
    worst = fmax(worst, compare_row(&l, &d, sigma_t, albedo, eta, per_entry, 0, 0, spp, &z2, &n));
    worst = fmax(worst, compare_row(&l, &d, sigma_t, albedo, eta, per_entry, 2, 0, spp, &z2, &n));
    print_message("eta %g: %d comparisons, mean z^2 %.3f, largest |z| %.2f\n", eta, n, z2 / n,
                  worst);
    op_dataset_free(&d);
    op_layout_free(&l);
    if (!(z2 / n < 1.8) || !(worst < 5.5))
        fail_msg("eta %g: volpath and the generator disagree: mean z^2 %.3f (at most 1.8), "
                 "largest |z| %.2f (at most 5.5)", eta, z2 / n, worst);
}

/* Index-matched: every entry of the two rows but x_i's own. */
static void test_chessboard_index_matched(void **state)
{
    (void)state;
    loop_at(1.0, 1, 200000, 256);
}

/* Behind a smooth dielectric of index 1.3 (the light reaches the meter's paths only by leaving
 * the sample towards it: noisier), summed per ring and medium. */
static void test_chessboard_dielectric(void **state)
{
    (void)state;
    loop_at(1.3, 0, 200000, 1024);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_chessboard_index_matched),
        cmocka_unit_test(test_chessboard_dielectric),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
