/* test_dataset_montecarlo.c - generator 1 (Monte Carlo transport) at small sizes: against the
 * analytic dipole where diffusion holds and the closed-form total diffuse reflectance, energy,
 * visible heterogeneity, and bit-identical results whatever the thread count (reciprocity:
 * test_dataset_reciprocity.c). */
#include "test_support.h"

#include "dataset_generate.h"
#include "dataset_diffusion.h"
#include "dataset_montecarlo.h"
#include "opaline.h"
#include "opaline_material.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static void run_mc_inc(const op_layout *l, int k, uint64_t photons, uint64_t seed, int threads,
                       op_mc_incidence inc, op_dataset *d, op_mc_stats *s)
{
    op_error err = {0};
    op_status st = op_dataset_alloc(d, l->width, l->height, k, 1, &err);
    OP_ASSERT_OK(st, err);
    op_mc_options o = {.photons = photons, .seed = seed, .threads = threads, .incidence = inc};
    st = op_mc_generate(l, &o, d, s, &err);
    OP_ASSERT_OK(st, err);
    st = op_dataset_check(d, &err);
    OP_ASSERT_OK(st, err);
}

static void run_mc(const op_layout *l, int k, uint64_t photons, uint64_t seed, int threads,
                   op_dataset *d, op_mc_stats *s)
{
    run_mc_inc(l, k, photons, seed, threads, OP_MC_DIFFUSE, d, s);
}

/* One 0.5 mm incident pixel of marble, tiled: an infinite homogeneous half-space. Beyond three
 * transport mean free paths (1.5 mm; 1/sigma_t' <= 0.46 mm) the rings of the kernel agree with
 * the pixel-integrated dipole within 8 % (measured: within 4 %); the total diffuse reflectance
 * agrees with the closed form within 3 % (measured: 1.2 %). Normal incidence, the dipole's own
 * setting. The rings are checked at eta 1.3 (the layout's one eta), where these bounds were
 * measured: the dipole's near-field error grows with eta (at Marble's own 1.5, ring 3 is 15 %
 * off); the total at Marble's own 1.5 is checked too (the generator reads the medium's eta). */
static void homogeneous_matches_dipole(void **state)
{
    const op_medium *m = op_medium_lookup("marble");
    const double pix = 0.5;
    const int K = 17, h = K / 2;
    op_layout l;
    op_error err = {0};
    op_status st = op_layout_homogeneous(&l, 1, 1, pix / 10, pix / 10, m, &err);
    OP_ASSERT_OK(st, err);
    op_dataset d;
    op_mc_stats s;
    assert_true(m->eta == 1.5);
    run_mc_inc(&l, K, 20000, 12, 2, OP_MC_NORMAL, &d, &s);
    for (int c = 0; c < 3; c++) {
        double closed = op_dipole_total(m->sigma_s[c], m->sigma_a[c], m->eta);
        if (fabs(s.total_reflectance[c] - closed) > 0.03 * closed)
            fail_msg("channel %d at eta 1.5: total reflectance %.4f, closed form %.4f", c,
                     s.total_reflectance[c], closed);
    }
    op_dataset_free(&d);
    const double eta = l.eta = 1.3;
    run_mc_inc(&l, K, 60000, 11, 2, OP_MC_NORMAL, &d, &s);
    for (int c = 0; c < 3; c++) {
        double closed = op_dipole_total(m->sigma_s[c], m->sigma_a[c], eta);
        if (fabs(s.total_reflectance[c] - closed) > 0.03 * closed)
            fail_msg("channel %d: total reflectance %.4f, closed form %.4f", c,
                     s.total_reflectance[c], closed);
        op_dipole dp;
        op_dipole_init(&dp, m->sigma_s[c], m->sigma_a[c], eta);
        for (int r = 3; r <= h; r++) {
            double mc = 0, se2 = 0, dip = 0;
            for (int dy = -h; dy <= h; dy++)
                for (int dx = -h; dx <= h; dx++) {
                    if ((int)lround(hypot(dx, dy)) != r)
                        continue;
                    int col = (dy + h) * K + dx + h;
                    mc += d.rd[c][col];
                    se2 += (double)d.se[c][col] * d.se[c][col];
                    dip += op_dipole_pixel(&dp, abs(dx) * pix, abs(dy) * pix, pix, pix, 8);
                }
            double tol = 0.08 * dip + 3 * sqrt(se2);
            if (fabs(mc - dip) > tol)
                fail_msg("channel %d ring %d: MC %.5g +- %.2g, dipole %.5g", c, r, mc, sqrt(se2),
                         dip);
        }
    }
    op_dataset_free(&d);
    op_layout_free(&l);
}

/* Bit-identical for 1 and 3 threads; a different seed gives different noise. */
static void reproducible_whatever_the_threads(void **state)
{
    op_layout l;
    op_error err = {0};
    op_status st = op_layout_veins(&l, 5, 4, 0.5, 0.4, 2, 0.5, 9, op_medium_lookup("marble"),
                                   op_medium_lookup("vein"), &err);
    OP_ASSERT_OK(st, err);
    op_dataset a, b, c;
    op_mc_stats sa, sb, sc;
    run_mc(&l, 5, 300, 42, 1, &a, &sa);
    run_mc(&l, 5, 300, 42, 3, &b, &sb);
    run_mc(&l, 5, 300, 43, 2, &c, &sc);
    size_t n = (size_t)5 * 4 * 25 * sizeof(float);
    for (int k = 0; k < 3; k++) {
        assert_memory_equal(a.rd[k], b.rd[k], n);
        assert_memory_equal(a.se[k], b.se[k], n);
    }
    assert_int_equal(sa.steps, sb.steps);
    assert_memory_not_equal(a.rd[0], c.rd[0], n);
    op_dataset_free(&a);
    op_dataset_free(&b);
    op_dataset_free(&c);
    op_layout_free(&l);
}

/* Light that crosses a square boundary (marble -> skin1) differs from light that stays in
 * either medium, by far more than the standard errors. 1 mm pixels, squares of 2 x 2. */
static void heterogeneity_shows(void **state)
{
    const op_medium *a = op_medium_lookup("marble"), *b = op_medium_lookup("skin1");
    op_layout chess, ha, hb;
    op_error err = {0};
    op_status st = op_layout_chessboard(&chess, 8, 8, 0.8, 0.8, 4, a, b, &err);
    OP_ASSERT_OK(st, err);
    st = op_layout_homogeneous(&ha, 1, 1, 0.1, 0.1, a, &err);
    OP_ASSERT_OK(st, err);
    st = op_layout_homogeneous(&hb, 1, 1, 0.1, 0.1, b, &err);
    OP_ASSERT_OK(st, err);
    op_dataset dc, da, db;
    op_mc_stats s;
    const int K = 7;
    run_mc(&chess, K, 12000, 5, 2, &dc, &s);
    run_mc(&ha, K, 60000, 5, 2, &da, &s);
    run_mc(&hb, K, 60000, 5, 2, &db, &s);
    /* Incident pixel (1, 0) lies in square (0, 0), medium 0; the exit pixels (2..3, 0..1) are
     * square (1, 0), medium 1. Summed over those four, in some channel the chessboard differs
     * from each homogeneous medium by more than 5 standard errors. */
    int row = 1;
    double zmax_a = 0, zmax_b = 0;
    for (int c = 0; c < 3; c++) {
        double v = 0, va = 0, vb = 0, sv = 0, sa = 0, sb = 0;
        for (int dy = 0; dy <= 1; dy++)
            for (int dx = 1; dx <= 2; dx++) {
                int col = (dy + 3) * K + 3 + dx;
                v += dc.rd[c][row * K * K + col];
                sv += (double)dc.se[c][row * K * K + col] * dc.se[c][row * K * K + col];
                va += da.rd[c][col];
                sa += (double)da.se[c][col] * da.se[c][col];
                vb += db.rd[c][col];
                sb += (double)db.se[c][col] * db.se[c][col];
            }
        print_message("channel %d: chess %.4g +- %.2g, %s %.4g +- %.2g, %s %.4g +- %.2g\n", c, v,
                      sqrt(sv), a->name, va, sqrt(sa), b->name, vb, sqrt(sb));
        zmax_a = fmax(zmax_a, fabs(v - va) / sqrt(sv + sa));
        zmax_b = fmax(zmax_b, fabs(v - vb) / sqrt(sv + sb));
    }
    assert_true(zmax_a > 5);
    assert_true(zmax_b > 5);
    op_dataset_free(&dc);
    op_dataset_free(&da);
    op_dataset_free(&db);
    op_layout_free(&chess);
    op_layout_free(&ha);
    op_layout_free(&hb);
}

/* The same material through both generators, with the Monte Carlo file written and read back:
 * prints how far diffusion is from Monte Carlo (albedo and entries), and checks the SE
 * sections and the crc. */
static void compare_with_diffusion_and_write(void **state)
{
    op_dataset_spec spec;
    op_error err = {0};
    op_status st = op_dataset_spec_defaults("chess4x4", &spec, &err);
    OP_ASSERT_OK(st, err);
    spec.width = spec.height = 8;
    spec.kernel = 7;
    spec.size_x_cm = spec.size_y_cm = 0.8;
    spec.threads = 2;
    spec.photons = 1000;
    op_dataset mc, df;
    op_mc_stats s;
    spec.generator = OP_GEN_MONTECARLO;
    st = op_dataset_generate(&spec, &mc, &s, &err);
    OP_ASSERT_OK(st, err);
    spec.generator = OP_GEN_DIFFUSION;
    st = op_dataset_generate(&spec, &df, NULL, &err);
    OP_ASSERT_OK(st, err);
    int cols = 49;
    for (int c = 0; c < 3; c++) {
        double am = 0, ad = 0, num = 0, den = 0;
        for (int r = 0; r < 64; r++)
            for (int j = 0; j < cols; j++) {
                double a = mc.rd[c][r * cols + j], b = df.rd[c][r * cols + j];
                am += a;
                ad += b;
                if (j != 24) { /* off the incident pixel, where diffusion is meant to hold */
                    num += (a - b) * (a - b);
                    den += a * a;
                }
            }
        print_message("chess 8x8 px, 1 mm, K 7, channel %d: mean albedo MC %.4f diffusion %.4f; "
                      "relative RMS difference off-centre %.3f\n", c, am / 64, ad / 64,
                      sqrt(num / den));
        /* Measured (marble/skin1, 1000 photons; Monte Carlo refracting between the squares,
         * diffusion at the board's one index 1.5): albedo within 2 to 7 %, 31 to 40 % RMS over
         * the off-centre entries (1 mm pixels: the first ring is only 2 mean free paths out). */
        assert_true(fabs(am - ad) < 0.2 * am);
        assert_true(sqrt(num / den) < 0.6);
    }
    const char *path = op_test_tmp_path("mc.opm");
    st = op_dataset_write(&mc, path, &err);
    OP_ASSERT_OK(st, err);
    op_material *m;
    st = op_material_open(path, &m, &err);
    OP_ASSERT_OK(st, err);
    uint64_t bytes = 0;
    const float *se = op_material_section(m, "SE.G", &bytes);
    assert_non_null(se);
    assert_int_equal(bytes, 64 * 49 * 4);
    assert_memory_equal(se, mc.se[1], bytes);
    assert_int_equal(op_material_get_info(m)->dataset_crc, op_dataset_crc(&mc));
    assert_true(strstr(op_material_get_info(m)->generator, "montecarlo") != NULL);
    op_material_close(m);
    op_dataset_free(&mc);
    op_dataset_free(&df);
}

int main(void)
{
    op_log_set_level(OP_LOG_WARN);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(homogeneous_matches_dipole),
        cmocka_unit_test(reproducible_whatever_the_threads),
        cmocka_unit_test(heterogeneity_shows),
        cmocka_unit_test(compare_with_diffusion_and_write),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
