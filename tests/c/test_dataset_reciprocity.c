/* test_dataset_reciprocity.c - both dataset generators on samples whose two media differ in index
 * of refraction (Marble 1.5, Skin1 1.3; Marble 1.5, Ketchup 1.3) obey reciprocity.
 *
 * The relation. Rd(x_i, x_o) is the power leaving through x_o per power *entering* through x_i
 * under diffuse light from air (docs/datasets.md). Transport from air back into air is
 * reciprocal: the power that diffuse light falling on pixel x_i sends out through x_o equals that
 * of the reverse. The power entering is the power falling times the hemispherical transmittance
 * T(n) = integral over mu of 2 mu (1 - F(mu; 1 -> n)), n the index where the light enters, so
 *     T(n_i) Rd(x_i, x_o) = T(n_o) Rd(x_o, x_i).
 * The eta^2 of the radiance invariant (L / n^2 is conserved through a refracting interface) does
 * not multiply Rd itself: it is inside T, since T(n) = n^2 T_int(n), T_int the transmittance of
 * the same surface from inside. For 1.5 and 1.3, T(1.3) / T(1.5) = 1.034. A sample that lets
 * light pass unrefracted between media of different index breaks the invariant and obeys
 * T_int(n_i) Rd(x_i, x_o) = T_int(n_o) Rd(x_o, x_i) instead: Rd from marble to skin 1.376 times
 * Rd back. With one index for the whole sample both relations are plain symmetry. */
#include "test_support.h"

#include "dataset_diffusion.h"
#include "dataset_generate.h"
#include "dataset_montecarlo.h"
#include "opaline.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Unpolarized Fresnel reflectance from index n1 into n2 at incidence cosine c (1 beyond the
 * critical angle). */
static double fresnel(double c, double n1, double n2)
{
    double r = n1 / n2, s2 = r * r * (1 - c * c);
    if (s2 >= 1)
        return 1;
    double ct = sqrt(1 - s2);
    double rs = (n1 * c - n2 * ct) / (n1 * c + n2 * ct), rp = (n1 * ct - n2 * c) / (n1 * ct + n2 * c);
    return 0.5 * (rs * rs + rp * rp);
}

/* T(n): the fraction of diffuse light from air that enters index n (midpoint rule, error far
 * below 1e-6). */
static double transmittance(double n)
{
    const int steps = 100000;
    double sum = 0;
    for (int i = 0; i < steps; i++) {
        double mu = (i + 0.5) / steps;
        sum += 2 * mu * (1 - fresnel(mu, 1, n));
    }
    return sum / steps;
}

static void run_mc(const op_layout *l, int k, uint64_t photons, uint64_t seed, op_dataset *d)
{
    op_error err = {0};
    op_mc_stats s;
    op_status st = op_dataset_alloc(d, l->width, l->height, k, 1, &err);
    OP_ASSERT_OK(st, err);
    op_mc_options o = {.photons = photons, .seed = seed, .threads = 2};
    st = op_mc_generate(l, &o, d, &s, &err);
    OP_ASSERT_OK(st, err);
    st = op_dataset_check(d, &err);
    OP_ASSERT_OK(st, err);
}

/* The cross-square transport of channel c: *ab sums Rd over the pairs whose incident pixel holds
 * medium 0 and exit pixel medium 1 (within the kernel, exits wrapped periodically), *ba the
 * reverse; se_* their standard errors from the entries' (summed in quadrature: one photon leaves
 * through one pixel only, so entries of a row are anticorrelated and this overestimates). */
static void cross_transport(const op_layout *l, const op_dataset *d, int c, double *ab,
                            double *se_ab, double *ba, double *se_ba)
{
    int K = d->kernel, h = K / 2;
    double v[2] = {0, 0}, v2[2] = {0, 0};
    for (int y = 0; y < l->height; y++)
        for (int x = 0; x < l->width; x++)
            for (int dy = -h; dy <= h; dy++)
                for (int dx = -h; dx <= h; dx++) {
                    int mi = op_layout_at(l, x, y), mo = op_layout_at(l, x + dx, y + dy);
                    if (mi == mo)
                        continue;
                    size_t e = ((size_t)y * l->width + x) * K * K + (size_t)(dy + h) * K + dx + h;
                    v[mi] += d->rd[c][e];
                    v2[mi] += (double)d->se[c][e] * d->se[c][e];
                }
    *ab = v[0];
    *se_ab = sqrt(v2[0]);
    *ba = v[1];
    *se_ba = sqrt(v2[1]);
}

/* z-score of T(n_0) S_01 - T(n_1) S_10 for channel c of a Monte Carlo dataset of l. */
static double cross_z(const op_layout *l, const op_dataset *d, int c, const char *what)
{
    double ab, sab, ba, sba;
    cross_transport(l, d, c, &ab, &sab, &ba, &sba);
    double t0 = transmittance(op_layout_eta(l, 0)), t1 = transmittance(op_layout_eta(l, 1));
    double z = (t0 * ab - t1 * ba) / sqrt(t0 * t0 * sab * sab + t1 * t1 * sba * sba);
    print_message("%s, channel %d: %s -> %s %.5g +- %.2g, back %.5g +- %.2g (ratio %.4f, "
                  "reciprocity wants %.4f), z = %.1f\n", what, c, l->media[0]->name,
                  l->media[1]->name, ab, sab, ba, sba, ab / ba, t1 / t0, z);
    return z;
}

/* A Marble / Skin1 chessboard of 2 x 2 mm squares (1 mm pixels, a 4 x 4 tile), Monte Carlo with
 * diffuse incidence: in every channel the cross-square transport obeys the relation above within
 * 4 standard errors. With each medium's own index (1.5, 1.3) the light refracts and reflects at
 * the squares' sides; with one index (1.3) the same board is plainly symmetric. */
static void montecarlo_mixed_index_board(void **state)
{
    (void)state;
    const op_medium *a = op_medium_lookup("marble"), *b = op_medium_lookup("skin1");
    assert_true(a->eta == 1.5 && b->eta == 1.3);
    op_layout l;
    op_error err = {0};
    op_status st = op_layout_chessboard(&l, 4, 4, 0.4, 0.4, 2, a, b, &err);
    OP_ASSERT_OK(st, err);
    op_dataset d;
    double z[2][3];
    for (int k = 0; k < 2; k++) {
        l.eta = k ? 1.3 : 0;
        run_mc(&l, 5, 6000, 7, &d);
        for (int c = 0; c < 3; c++)
            z[k][c] = cross_z(&l, &d, c, k ? "eta 1.3" : "eta 1.5, 1.3");
        op_dataset_free(&d);
    }
    op_layout_free(&l);
    for (int k = 0; k < 2; k++)
        for (int c = 0; c < 3; c++)
            if (!(fabs(z[k][c]) < 4))
                fail_msg("channel %d: the %s board is not reciprocal, z = %.1f", c,
                         k ? "one-index" : "mixed-index", z[k][c]);
}

/* Pair by pair on a Marble / Ketchup chessboard (1.5, 1.3; Ketchup's green and blue are nearly
 * pure absorbers): T(n_i) Rd(x_i, x_o) and T(n_o) Rd(x_o, x_i) agree within their standard errors:
 * over all pairs the mean squared z-score is near 1 and no pair is a wild outlier. (With normal
 * incidence they do not: the mean z^2 grows with the photon count, 5.6 at 20000 photons on
 * marble/skin1.) */
static void montecarlo_pairs_within_error(void **state)
{
    (void)state;
    op_layout l;
    op_error err = {0};
    op_status st = op_layout_chessboard(&l, 8, 8, 0.8, 0.8, 4, op_medium_lookup("marble"),
                                        op_medium_lookup("ketchup"), &err);
    OP_ASSERT_OK(st, err);
    op_dataset d;
    const int K = 5, h = K / 2, W = 8, H = 8;
    const double t[2] = {transmittance(op_layout_eta(&l, 0)), transmittance(op_layout_eta(&l, 1))};
    run_mc(&l, K, 3000, 3, &d);
    double z2 = 0, zmax = 0;
    int pairs = 0;
    for (int c = 0; c < 3; c++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++)
                for (int dy = -h; dy <= h; dy++)
                    for (int dx = -h; dx <= h; dx++) {
                        if (dy < 0 || (dy == 0 && dx <= 0))
                            continue; /* each unordered pair once */
                        int xo = ((x + dx) % W + W) % W, yo = ((y + dy) % H + H) % H;
                        double ti = t[op_layout_at(&l, x, y)], to = t[op_layout_at(&l, xo, yo)];
                        size_t i = ((size_t)y * W + x) * K * K + (dy + h) * K + dx + h;
                        size_t o = ((size_t)yo * W + xo) * K * K + (h - dy) * K + h - dx;
                        double var = ti * ti * d.se[c][i] * d.se[c][i] +
                                     to * to * d.se[c][o] * d.se[c][o];
                        if (var <= 0)
                            continue;
                        double z = (ti * d.rd[c][i] - to * d.rd[c][o]) / sqrt(var);
                        z2 += z * z;
                        zmax = fmax(zmax, fabs(z));
                        pairs++;
                    }
    assert_true(pairs > 1000);
    print_message("marble/ketchup pairs: mean z^2 %.3f over %d pairs, max |z| %.2f\n", z2 / pairs,
                  pairs, zmax);
    if (z2 / pairs > 1.4 || zmax > 6)
        fail_msg("reciprocity: mean z^2 %.3f over %d pairs, max |z| %.2f", z2 / pairs, pairs, zmax);
    op_dataset_free(&d);
    op_layout_free(&l);
}

/* The diffusion generator gives a sample of two indices one: its base medium's (the first), or
 * the spec's eta. A dipole per pair of points has no interface to refract at, and a per-point
 * index would have to enter the table as T(n_i) / T(n_o), which no dipole supplies. So the mixed
 * board is exactly the board generated with eta 1.5 given, and exactly symmetric (T is the same
 * everywhere); its generator text says the one index. */
static void diffusion_mixed_index_board(void **state)
{
    (void)state;
    op_dataset_spec s;
    op_error err = {0};
    op_status st = op_dataset_spec_defaults("chess4x4", &s, &err);
    OP_ASSERT_OK(st, err);
    s.width = s.height = 16;
    s.kernel = 9;
    s.size_x_cm = s.size_y_cm = 0.8;
    s.threads = 2;
    assert_true(s.media[0]->eta == 1.5 && s.media[1]->eta == 1.3);
    op_dataset mixed, one;
    st = op_dataset_generate(&s, &mixed, NULL, &err);
    OP_ASSERT_OK(st, err);
    s.eta = 1.5;
    st = op_dataset_generate(&s, &one, NULL, &err);
    OP_ASSERT_OK(st, err);
    size_t n = (size_t)16 * 16 * 81;
    for (int c = 0; c < 3; c++) {
        double diff = 0;
        for (size_t i = 0; i < n; i++)
            diff = fmax(diff, fabs(mixed.rd[c][i] - one.rd[c][i]) / fmax(one.rd[c][i], 1e-30));
        if (diff > 0)
            fail_msg("channel %d: the mixed board differs from the board at eta 1.5 by up to "
                     "%.3g (relative)", c, diff);
    }
    if (!strstr(mixed.generator, "eta=1.5") || strstr(mixed.generator, "1.5,"))
        fail_msg("generator text '%s' does not give the one index 1.5", mixed.generator);
    int K = 9, h = K / 2;
    for (int c = 0; c < 3; c++)
        for (int y = 0; y < 16; y++)
            for (int x = 0; x < 16; x++)
                for (int dy = -h; dy <= h; dy++)
                    for (int dx = -h; dx <= h; dx++) {
                        int xo = ((x + dx) % 16 + 16) % 16, yo = ((y + dy) % 16 + 16) % 16;
                        float a = mixed.rd[c][(y * 16 + x) * K * K + (dy + h) * K + dx + h];
                        float b = mixed.rd[c][(yo * 16 + xo) * K * K + (h - dy) * K + h - dx];
                        if (a != b)
                            fail_msg("channel %d: Rd((%d,%d) -> %+d,%+d) = %g, back %g", c, x, y,
                                     dx, dy, (double)a, (double)b);
                    }
    op_dataset_free(&mixed);
    op_dataset_free(&one);
}

int main(void)
{
    op_log_set_level(OP_LOG_ERROR);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(montecarlo_mixed_index_board),
        cmocka_unit_test(montecarlo_pairs_within_error),
        cmocka_unit_test(diffusion_mixed_index_board),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
