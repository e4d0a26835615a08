/* test_render_mc_reference.c - the renderer against the Monte Carlo generator's own volumetric
 * transport. For a medium of the table and one colour channel c, a "grey" medium (channel c's
 * coefficients in all three channels, so the three channels of one dataset are three independent
 * Monte Carlo estimates) is traced by op_mc_generate (normal incidence, the dipole's setting) into
 * a 1 x 1 pixel raw material of kernel K: one Rd row per channel, the same row at every position.
 * On a homogeneous slab (millimetre scene) lit by a hard-edged spot (a disk of radius a = 2 L,
 * L the channel's diffusion length) or by uniform light:
 *  (a) the exact answer the rows give: the exitance M(x) = integral over the disk of E(y)
 *      Rd~((x - y) / pixel) / pixel^2, Rd~ the row interpolated bilinearly between its offsets
 *      (zero beyond the kernel), the disk integrated in polar coordinates; its standard error from
 *      the rows' own (sum of (dM/dRd_k)^2 se_k^2); under uniform light the row sum;
 *  (b) the renderer's exitance with that dataset as a `raw` material (op_sss_prepass_run as a
 *      render runs it, camera-marked, then op_sss_lookup);
 *  (c) the renderer's dipole for the same grey medium, and (d) the dipole's closed form
 *      (dipole_reference.h) integrated over the disk, which tells the renderer's error from the
 *      model's (bench mode).
 * Exitance is averaged over rings of 32 directions at 1, 2 and 4 L outside the disk's edge; the
 * total is the ring integral out to the kernel's reach against P_in x row sum.
 * The test (seconds): Skin1 red, small kernel, 100000 photons per row: (b) within 3 standard
 * errors of (a) plus the interpolation bias h^2 / (12 L^2) of the renderer's lookup radius
 * h = 2 pixels (docs/subsurface-rendering.md, "Estimator, bias and parameters"), and the uniform
 * slab within 1 % of the row sum (the goal for a uniform slab).
 * `test_render_mc_reference --table [PHOTONS [MEDIUM]]` (bench/bench_sss_reference.sh) prints
 * the full table for several media and channels, with the dipole. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "dataset.h"
#include "dipole_reference.h"
#include "dataset_montecarlo.h"
#include "integrator/integrator.h"
#include "opaline_render.h"
#include "scene/render_scene.h"
#include "test_support.h"

#define NANG 32 /* directions per ring: a multiple of 4, symmetric under the slab's flips */

typedef struct mcref_case {
    const char *medium;
    int channel;        /* the medium's channel made grey */
    uint64_t photons;   /* per channel of the grey dataset */
    double pix_per_L;   /* material pixels per diffusion length */
    int full;           /* 1: kernel reaching 2a + 4.5 L, total and dipole; 0: the fast test */
} mcref_case;

typedef struct mcref_result {
    double L, pix, a, D, p_in, eta, sp, sa;
    int K, points;
    double mc_total[3], rowsum[3], rowse[3], mc_seconds, raw_seconds;
    double ref[3][4], se[3][4], got[3][4]; /* per replica: 1, 2, 4 L, total */
    double uni_got[3];
    double dip[4], dip_uni, dip_seconds;   /* full only: (c), channel 0 of grey */
    double cf[4], cf_uni;                  /* full only: (d) */
} mcref_result;

static double distance_of(const mcref_result *r, int q)
{
    return r->a + (double)(1 << q) * r->L;
}

/* The irradiance of the spot at distance rho from the disk's centre (1 there, 0 outside). */
static double spot_e(const mcref_result *r, double rho)
{
    return rho < r->a ? r->D * r->D * r->D / pow(r->D * r->D + rho * rho, 1.5) : 0.0;
}

/* The mean over the positions (px, py) of (a)'s exitance for row rd (K x K), and in grad (K x K,
 * zeroed by the caller) the derivative of that mean with respect to every kernel value. */
static double ref_exitance(const mcref_result *r, const float *rd, const double *px,
                           const double *py, int npos, double *grad)
{
    const int nr = 48, nphi = 192, K = r->K, half = K / 2;
    double sum = 0.0, inv = 1.0 / (r->pix * r->pix * npos);
    for (int i = 0; i < nr; i++) {
        double rho = r->a * (i + 0.5) / nr, w0 = spot_e(r, rho) * rho * (r->a / nr) *
                                                 (2.0 * M_PI / nphi) * inv;
        for (int j = 0; j < nphi; j++) {
            double phi = 2.0 * M_PI * (j + 0.5) / nphi, yx = rho * cos(phi), yy = rho * sin(phi);
            for (int p = 0; p < npos; p++) {
                double dx = (px[p] - yx) / r->pix, dy = (py[p] - yy) / r->pix;
                double fx = floor(dx), fy = floor(dy), tx = dx - fx, ty = dy - fy;
                int ox = (int)fx, oy = (int)fy;
                for (int b = 0; b < 2; b++) {
                    int oyb = oy + b;
                    if (oyb < -half || oyb > half)
                        continue;
                    for (int c = 0; c < 2; c++) {
                        int oxa = ox + c;
                        if (oxa < -half || oxa > half)
                            continue;
                        int col = (oyb + half) * K + oxa + half;
                        double w = w0 * (c ? tx : 1.0 - tx) * (b ? ty : 1.0 - ty);
                        sum += w * rd[col];
                        grad[col] += w;
                    }
                }
            }
        }
    }
    return sum;
}

/* A slab [-S, S]^2 in z = 0 carrying sss_xml, the emitter given, seen from above by a 32 x 32
 * camera over [-V, V]^2. */
static const char *slab_scene(const char *name, const char *sss_xml, const char *emitter,
                              double S, double V)
{
    static char text[8192];
    double fov = 2.0 * atan(0.25) * 180.0 / M_PI;
    snprintf(text, sizeof text,
             "<scene version=\"0.6.0\"><integrator type=\"path\"/>"
             " <sensor type=\"perspective\"><float name=\"fov\" value=\"%.9g\"/>"
             "  <transform name=\"toWorld\"><lookat origin=\"0,0,%.9g\" target=\"0,0,0\" "
             "   up=\"0,1,0\"/></transform>"
             "  <sampler type=\"independent\"><integer name=\"sampleCount\" value=\"1\"/></sampler>"
             "  <film type=\"hdrfilm\"><integer name=\"width\" value=\"32\"/>"
             "   <integer name=\"height\" value=\"32\"/><rfilter type=\"box\"/></film></sensor>"
             " %s"
             " <shape type=\"rectangle\"><transform name=\"toWorld\">"
             "  <scale x=\"%.9g\" y=\"%.9g\" z=\"1\"/></transform>%s</shape>"
             "</scene>",
             fov, 4.0 * V, emitter, S, S, sss_xml);
    return op_test_write_temp(name, text);
}

static op_v3 lookup(const op_sss_prepass *cache, double x, double y)
{
    op_v3 m;
    if (!op_sss_lookup(cache, 0, v3((float)x, (float)y, 0.0f), v3(0.0f, 0.0f, 1.0f), &m))
        fail_msg("no exitance at (%g, %g) mm: not a receiver", x, y);
    return m;
}

/* The ring positions at radius rho. */
static void ring(double rho, double *px, double *py)
{
    for (int j = 0; j < NANG; j++) {
        double t = 2.0 * M_PI * (j + 0.5) / NANG;
        px[j] = rho * cos(t);
        py[j] = rho * sin(t);
    }
}

/* Mean exitance per channel on the ring at rho. */
static op_v3 ring_exitance(const op_sss_prepass *cache, double rho)
{
    double px[NANG], py[NANG];
    ring(rho, px, py);
    op_v3 s = v3s(0.0f);
    for (int j = 0; j < NANG; j++)
        s = v3_add(s, v3_scale(lookup(cache, px[j], py[j]), 1.0f / NANG));
    return s;
}

static double chan(op_v3 v, int c)
{
    return c == 0 ? v.x : c == 1 ? v.y : v.z;
}

/* The spot's and the uniform light's emitters. */
static void emitters(const mcref_result *r, char *spot, char *uni, size_t cap)
{
    double cut = atan(r->a / r->D) * 180.0 / M_PI;
    snprintf(spot, cap,
             "<emitter type=\"spot\"><transform name=\"toWorld\"><lookat origin=\"0,0,%.9g\" "
             "target=\"0,0,0\"/></transform><spectrum name=\"intensity\" value=\"%.9g\"/>"
             "<float name=\"cutoffAngle\" value=\"%.9g\"/>"
             "<float name=\"beamWidth\" value=\"%.9g\"/></emitter>",
             r->D, r->D * r->D, cut, cut);
    snprintf(uni, cap, "<emitter type=\"directional\"><vector name=\"direction\" x=\"0\" y=\"0\" "
                       "z=\"-1\"/><rgb name=\"irradiance\" value=\"1\"/></emitter>");
}

/* Measures (b) (and (c) when full) in the scenes carrying sss_xml; fills got[3][4] and uni[3]. */
static void measure(const mcref_result *r, const mcref_case *k, const char *sss_xml,
                    double got[3][4], double uni[3], double *seconds, int *points)
{
    char spot[1024], unil[1024];
    emitters(r, spot, unil, sizeof spot);
    int half = r->K / 2;
    double reach = r->a + (half + 1) * r->pix; /* the exitance's support */
    double V = k->full ? reach + 2.0 * r->pix : r->a + 4.5 * r->L;
    double S = fmax(V, r->a + (half + 1.5) * r->pix) + r->pix;
    op_scene *scene = NULL;
    double secs = 0.0;
    const char *path = slab_scene("spot.xml", sss_xml, spot, S, V);
    op_sss_prepass *cache = op_test_sss_prepass(path, &scene, &secs);
    *seconds = secs;
    *points = op_sss_prepass_points(cache, 0);
    for (int q = 0; q < 3; q++) {
        op_v3 m = ring_exitance(cache, distance_of(r, q));
        for (int c = 0; c < 3; c++)
            got[c][q] = chan(m, c);
    }
    for (int c = 0; c < 3; c++)
        got[c][3] = NAN;
    if (k->full) { /* the ring integral of the exitance out to its support */
        double dr = 0.5 * r->pix, tot[3] = {0, 0, 0};
        for (double rho = 0.5 * dr; rho < reach + dr; rho += dr) {
            op_v3 m = ring_exitance(cache, rho);
            for (int c = 0; c < 3; c++)
                tot[c] += 2.0 * M_PI * rho * dr * chan(m, c);
        }
        for (int c = 0; c < 3; c++)
            got[c][3] = tot[c];
    }
    op_sss_prepass_free(cache);
    op_scene_free(scene);
    /* uniform light: the mean over 5 x 5 positions at the centre */
    path = slab_scene("uniform.xml", sss_xml, unil, S, V);
    cache = op_test_sss_prepass(path, &scene, &secs);
    *seconds += secs;
    op_v3 s = v3s(0.0f);
    for (int j = 0; j < 5; j++)
        for (int i = 0; i < 5; i++)
            s = v3_add(s, v3_scale(lookup(cache, r->pix * (i - 2), r->pix * (j - 2)), 1.0f / 25));
    for (int c = 0; c < 3; c++)
        uni[c] = chan(s, c);
    op_sss_prepass_free(cache);
    op_scene_free(scene);
}

static void mcref_run(const mcref_case *k, mcref_result *r)
{
    memset(r, 0, sizeof *r);
    const op_medium *m = op_medium_lookup(k->medium);
    assert_non_null(m);
    op_medium grey = *m;
    for (int c = 0; c < 3; c++) {
        grey.sigma_s[c] = m->sigma_s[k->channel];
        grey.sigma_a[c] = m->sigma_a[k->channel];
    }
    r->sp = grey.sigma_s[0];
    r->sa = grey.sigma_a[0];
    r->eta = grey.eta;
    r->L = 1.0 / sqrt(3.0 * r->sa * (r->sa + r->sp));
    r->pix = r->L / k->pix_per_L;
    r->a = 2.0 * r->L;
    r->D = 10.0 * r->a;
    r->p_in = 2.0 * M_PI * r->D * r->D * (1.0 - r->D / sqrt(r->D * r->D + r->a * r->a));
    /* the kernel reaches from the disk's far edge to 4.5 L beyond its near edge (full), or 4.5 L
     * beyond the edge from the centre (fast: (a) and (b) truncate alike) */
    int half = (int)ceil(((k->full ? 2.0 : 1.0) * r->a + 4.5 * r->L) / r->pix);
    r->K = 2 * half + 1;

    /* the Monte Carlo dataset: one pixel, K x K, written as a raw material */
    op_error err = {0};
    op_layout l;
    op_status st = op_layout_homogeneous(&l, 1, 1, r->pix / 10.0, r->pix / 10.0, &grey, &err);
    OP_ASSERT_OK(st, err);
    op_dataset d;
    st = op_dataset_alloc(&d, 1, 1, r->K, 1, &err);
    OP_ASSERT_OK(st, err);
    d.size_x_cm = d.size_y_cm = r->pix / 10.0;
    snprintf(d.name, sizeof d.name, "MCRef%s%d", m->name, k->channel);
    snprintf(d.generator, sizeof d.generator, "montecarlo normal %llu photons",
             (unsigned long long)k->photons);
    op_mc_options o = {.photons = k->photons, .seed = 7, .threads = 2,
                       .incidence = OP_MC_NORMAL, .progress = NULL};
    op_mc_stats ms;
    op_log_level lv = op_log_get_level();
    op_log_set_level(OP_LOG_ERROR); /* no progress lines */
    st = op_mc_generate(&l, &o, &d, &ms, &err);
    op_log_set_level(lv);
    OP_ASSERT_OK(st, err);
    r->mc_seconds = ms.seconds;
    char mat[1024];
    snprintf(mat, sizeof mat, "%s", op_test_tmp_path("mc.opm"));
    st = op_dataset_write(&d, mat, &err);
    OP_ASSERT_OK(st, err);

    /* (a) */
    int cols = r->K * r->K;
    double *grad = malloc((size_t)cols * sizeof(double));
    assert_non_null(grad);
    for (int c = 0; c < 3; c++) {
        r->mc_total[c] = ms.total_reflectance[c];
        double s = 0.0, s2 = 0.0;
        for (int i = 0; i < cols; i++) {
            s += d.rd[c][i];
            s2 += (double)d.se[c][i] * d.se[c][i];
        }
        r->rowsum[c] = s;
        r->rowse[c] = sqrt(s2);
        for (int q = 0; q < 3; q++) {
            double px[NANG], py[NANG], v2 = 0.0;
            ring(distance_of(r, q), px, py);
            memset(grad, 0, (size_t)cols * sizeof(double));
            r->ref[c][q] = ref_exitance(r, d.rd[c], px, py, NANG, grad);
            for (int i = 0; i < cols; i++)
                v2 += grad[i] * grad[i] * (double)d.se[c][i] * d.se[c][i];
            r->se[c][q] = sqrt(v2);
        }
        r->ref[c][3] = r->p_in * s; /* the integral of Rd~ is the row sum */
        r->se[c][3] = r->p_in * r->rowse[c];
    }
    free(grad);

    /* (b) */
    char xml[2048];
    snprintf(xml, sizeof xml,
             "<subsurface type=\"raw\"><string name=\"material\" value=\"%s\"/>"
             "<float name=\"scale\" value=\"1000\"/><integer name=\"irrSamples\" value=\"1\"/>"
             "</subsurface>",
             mat);
    measure(r, k, xml, r->got, r->uni_got, &r->raw_seconds, &r->points);
    if (k->full) { /* (c) */
        snprintf(xml, sizeof xml,
                 "<subsurface type=\"dipole\"><rgb name=\"sigmaA\" value=\"%.9g\"/>"
                 "<rgb name=\"sigmaS\" value=\"%.9g\"/><float name=\"intIOR\" value=\"%.9g\"/>"
                 "<float name=\"scale\" value=\"1000\"/><integer name=\"irrSamples\" value=\"1\"/>"
                 "</subsurface>",
                 r->sa, r->sp, r->eta);
        double got[3][4], uni[3];
        int pts;
        measure(r, k, xml, got, uni, &r->dip_seconds, &pts);
        for (int q = 0; q < 4; q++)
            r->dip[q] = got[0][q];
        r->dip_uni = uni[0];
        for (int q = 0; q < 3; q++)
            r->cf[q] = ref_dipole_spot(r->sp, r->sa, r->eta, r->a, r->D, distance_of(r, q));
        r->cf_uni = ref_dipole_total(r->sp, r->sa, r->eta);
        r->cf[3] = r->p_in * r->cf_uni;
    }
    op_dataset_free(&d);
    op_layout_free(&l);
}

/* The renderer's interpolation bias at distance scale L: h^2 / (12 L^2), h = 2 pixels. */
static double interp_bias(const mcref_result *r)
{
    double h = 2.0 * r->pix;
    return h * h / (12.0 * r->L * r->L);
}

static void test_raw_matches_montecarlo(void **state)
{
    (void)state;
    mcref_case k = {"Skin1", 0, 100000, 4.0, 0};
    mcref_result r;
    mcref_run(&k, &r);
    int failures = 0;
    printf("Skin1 red (grey), L %.3f mm, pixel %.3f mm, K %d, %llu photons, %d points\n", r.L,
           r.pix, r.K, (unsigned long long)k.photons, r.points);
    printf("row  (b)/(a) - 1 [standard errors of (a)] (tolerance) at 1, 2, 4 L; "
           "uniform (b)/(row sum) - 1\n");
    for (int c = 0; c < 3; c++) {
        printf("  %d    ", c);
        for (int q = 0; q < 3; q++) {
            double rel = r.got[c][q] / r.ref[c][q] - 1.0, z = rel * r.ref[c][q] / r.se[c][q];
            double tol = 3.0 * r.se[c][q] / r.ref[c][q] + interp_bias(&r);
            printf("  %+6.2f %% [%+5.1f] (<= %.1f %%)", 100.0 * rel, z, 100.0 * tol);
            if (!(fabs(rel) <= tol)) {
                failures++;
                printf(" <-");
            }
        }
        double ru = r.uni_got[c] / r.rowsum[c] - 1.0;
        printf("   uniform %+6.3f %%\n", 100.0 * ru);
        if (!(fabs(ru) <= 0.01)) {
            failures++;
            printf("   <- uniform off by more than 1 %%\n");
        }
    }
    if (failures)
        fail_msg("%d values beyond the Monte Carlo reference's noise", failures);
}

/* The bench's table (bench/bench_sss_reference.sh). */
static uint64_t table_photons = 200000;
static const char *table_only; /* NULL, or the one medium to run */

static void table(void **state)
{
    (void)state;
    static const struct {
        const char *medium;
        int channel;
    } cases[] = {{"Skin1", 0}, {"Skin1", 1}, {"Skin1", 2}, {"Ketchup", 0}, {"Ketchup", 1},
                 {"Skin2", 2}, {"Potato", 2}, {"Chicken1", 1}, {"Skimmilk", 2}, {"Marble", 2}};
    printf("(a) the MC rows' exact answer, mean of 3 independent rows (+- its standard error); "
           "(b) raw render of those rows, (b)/(a) - 1 averaged over the rows [mean z-score]; "
           "(c) the renderer's dipole / (a) - 1; (d) the dipole's closed form / (a) - 1; "
           "(c)/(d) - 1: the renderer's own dipole error\n");
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        if (table_only && strcasecmp(table_only, cases[i].medium))
            continue;
        mcref_case k = {cases[i].medium, cases[i].channel, table_photons, 6.0, 1};
        mcref_result r;
        mcref_run(&k, &r);
        /* (a) pooled over the three replicas; (b) against each replica, shown as the mean */
        double a[4], se[4], b[4], z[4];
        for (int q = 0; q < 4; q++) {
            a[q] = se[q] = b[q] = z[q] = 0.0;
            for (int c = 0; c < 3; c++) {
                a[q] += r.ref[c][q] / 3.0;
                se[q] += r.se[c][q] * r.se[c][q] / 9.0;
                b[q] += (r.got[c][q] / r.ref[c][q] - 1.0) / 3.0;
                z[q] += (r.got[c][q] - r.ref[c][q]) / r.se[c][q] / 3.0;
            }
            se[q] = sqrt(se[q]);
        }
        double rows = (r.rowsum[0] + r.rowsum[1] + r.rowsum[2]) / 3.0;
        double all = (r.mc_total[0] + r.mc_total[1] + r.mc_total[2]) / 3.0;
        double ub = (r.uni_got[0] / r.rowsum[0] + r.uni_got[1] / r.rowsum[1] +
                     r.uni_got[2] / r.rowsum[2]) / 3.0 - 1.0;
        printf("\n%s channel %d (grey): L %.3f mm, pixel %.3f mm, K %d, spot radius 2 L, "
               "%d points, %llu photons per row; MC %.1f s, raw %.1f s, dipole %.1f s "
               "(pre-passes)\n",
               k.medium, k.channel, r.L, r.pix, r.K, r.points,
               (unsigned long long)table_photons, r.mc_seconds, r.raw_seconds, r.dip_seconds);
        printf("  where          (a) MC rows            (b)-(a)          (c)-(a)   (d)-(a)"
               "   (c)-(d)\n");
        static const char *where[4] = {"1 L outside", "2 L outside", "4 L outside", "total"};
        for (int q = 0; q < 4; q++)
            printf("  %-11s  %.4e +- %4.1f %%  %+6.2f %% [%+4.1f]  %+7.2f %% %+7.2f %% %+7.2f %%\n",
                   where[q], a[q], 100.0 * se[q] / a[q], 100.0 * b[q], z[q],
                   100.0 * (r.dip[q] / a[q] - 1.0), 100.0 * (r.cf[q] / a[q] - 1.0),
                   100.0 * (r.dip[q] / r.cf[q] - 1.0));
        printf("  uniform      %.4f (row sum; all escaping %.4f)  %+6.3f %%  %+7.2f %% %+7.2f %% "
               "%+7.2f %%\n",
               rows, all, 100.0 * ub, 100.0 * (r.dip_uni / rows - 1.0),
               100.0 * (r.cf_uni / rows - 1.0), 100.0 * (r.dip_uni / r.cf_uni - 1.0));
        fflush(stdout);
    }
}

int main(int argc, char **argv)
{
    op_log_set_level(OP_LOG_WARN);
    if (argc > 1 && !strcmp(argv[1], "--table")) {
        if (argc > 2)
            table_photons = strtoull(argv[2], NULL, 10);
        if (argc > 3)
            table_only = argv[3];
        const struct CMUnitTest t[] = {cmocka_unit_test(table)};
        return cmocka_run_group_tests(t, NULL, NULL);
    }
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_raw_matches_montecarlo),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
