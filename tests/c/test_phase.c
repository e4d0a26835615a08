/* test_phase.c - the phase functions (isotropic, Henyey-Greenstein, Rayleigh) against their
 * definitions:
 * - normalization: op_phase_eval integrates to 1 over the sphere (Simpson's rule in the
 *   deflection cosine, at several azimuths: the value depends on the deflection alone);
 * - sampling: op_phase_sample returns op_phase_eval's value at the direction it draws, and the
 *   directions it draws follow that density (a chi-square test on bins of deflection cosine and
 *   azimuth, the expected counts integrated from op_phase_eval); a negative control checks that
 *   the test tells one phase function's samples from another's density;
 * - Rayleigh's sampling is the exact inverse of its cumulative distribution (c^3 + 3 c + 4) / 8,
 *   and its second moment E[c^2] is 2/5; HG's mean cosine is g. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "math/rng.h"
#include "medium/phase.h"
#include "test_support.h"

#define NZ 32         /* bins in the deflection cosine */
#define NPHI 8        /* bins in the azimuth */
#define NSAMPLES 200000

static const struct {
    const char *name;
    op_phase phase;
} phases[] = {
    {"isotropic", {OP_PHASE_ISOTROPIC, 0.0f}}, {"hg 0.3", {OP_PHASE_HG, 0.3f}},
    {"hg -0.7", {OP_PHASE_HG, -0.7f}},         {"hg 0.9", {OP_PHASE_HG, 0.9f}},
    {"rayleigh", {OP_PHASE_RAYLEIGH, 0.0f}},
};
#define NPHASES ((int)(sizeof phases / sizeof *phases))

/* The incident direction of every test (pointing back along the arriving ray), and a frame of
 * its own around the forward direction -wi: (e1, e2, fwd), built here rather than by the
 * renderer's op_frame_from_normal that the sampler uses. */
typedef struct frame {
    double e1[3], e2[3], fwd[3];
} frame;

static op_v3 incident(void)
{
    return v3_norm(v3(0.3f, -0.5f, 0.8f));
}

static frame frame_of(op_v3 wi)
{
    frame f;
    double n = sqrt((double)v3_dot(wi, wi));
    f.fwd[0] = -wi.x / n, f.fwd[1] = -wi.y / n, f.fwd[2] = -wi.z / n;
    /* e1: the world x axis made perpendicular to fwd; e2 = fwd x e1 */
    double d = f.fwd[0];
    double e[3] = {1.0 - d * f.fwd[0], -d * f.fwd[1], -d * f.fwd[2]};
    double len = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
    for (int k = 0; k < 3; k++)
        f.e1[k] = e[k] / len;
    f.e2[0] = f.fwd[1] * f.e1[2] - f.fwd[2] * f.e1[1];
    f.e2[1] = f.fwd[2] * f.e1[0] - f.fwd[0] * f.e1[2];
    f.e2[2] = f.fwd[0] * f.e1[1] - f.fwd[1] * f.e1[0];
    return f;
}

/* The direction of deflection cosine c and azimuth phi in f. */
static op_v3 direction(const frame *f, double c, double phi)
{
    double s = sqrt(fmax(0.0, 1.0 - c * c)), a = s * cos(phi), b = s * sin(phi);
    double w[3];
    for (int k = 0; k < 3; k++)
        w[k] = a * f->e1[k] + b * f->e2[k] + c * f->fwd[k];
    return v3((float)w[0], (float)w[1], (float)w[2]);
}

/* The deflection cosine and azimuth of w in f. */
static void angles(const frame *f, op_v3 w, double *c, double *phi)
{
    double x = 0.0, y = 0.0, z = 0.0, v[3] = {w.x, w.y, w.z};
    for (int k = 0; k < 3; k++) {
        x += v[k] * f->e1[k];
        y += v[k] * f->e2[k];
        z += v[k] * f->fwd[k];
    }
    *c = z;
    *phi = atan2(y, x);
    if (*phi < 0.0)
        *phi += 2.0 * M_PI;
}

/* Simpson's rule for the integral of p's density over deflection cosines [c0, c1] at azimuth
 * phi, with n (even) intervals. */
static double integrate_cosine(const op_phase *p, const frame *f, op_v3 wi, double c0, double c1,
                               double phi, int n)
{
    double h = (c1 - c0) / n, sum = 0.0;
    for (int i = 0; i <= n; i++) {
        double w = i == 0 || i == n ? 1.0 : (i % 2 ? 4.0 : 2.0);
        sum += w * op_phase_eval(p, wi, direction(f, c0 + h * i, phi));
    }
    return sum * h / 3.0;
}

static void test_normalized(void **state)
{
    (void)state;
    op_v3 wi = incident();
    frame f = frame_of(wi);
    for (int i = 0; i < NPHASES; i++)
        for (int j = 0; j < 5; j++) {
            double phi = 2.0 * M_PI * j / 5.0 + 0.1;
            double total = 2.0 * M_PI * integrate_cosine(&phases[i].phase, &f, wi, -1.0, 1.0, phi,
                                                         40000);
            if (!(fabs(total - 1.0) < 1e-4))
                fail_msg("%s: integral %.6f at azimuth %.2f, not 1", phases[i].name, total, phi);
        }
}

/* A normal deviate for the chi-square statistic x of k degrees of freedom (Wilson and Hilferty
 * 1931: (x / k)^(1/3) is close to normal, mean 1 - 2 / (9 k), variance 2 / (9 k)). */
static double chi2_z(double x, int k)
{
    double v = 2.0 / (9.0 * k);
    return (cbrt(x / k) - (1.0 - v)) / sqrt(v);
}

/* The chi-square test's deviate for NSAMPLES directions drawn by samp against the density of
 * dens; checks on the way that every sample returns eval's value at its direction. */
static double chi2_deviate(const op_phase *samp, const op_phase *dens, const char *what,
                           uint64_t seed)
{
    op_v3 wi = incident();
    frame f = frame_of(wi);
    static double obs[NZ * NPHI], expect[NZ * NPHI];
    for (int bz = 0; bz < NZ; bz++) {
        double c0 = -1.0 + 2.0 * bz / NZ, c1 = -1.0 + 2.0 * (bz + 1) / NZ;
        double mass = integrate_cosine(dens, &f, wi, c0, c1, 0.3, 200) * 2.0 * M_PI / NPHI;
        for (int bp = 0; bp < NPHI; bp++) {
            expect[bz * NPHI + bp] = NSAMPLES * mass;
            obs[bz * NPHI + bp] = 0.0;
        }
    }
    op_rng rng = op_rng_seed(seed, 17, 29);
    for (int i = 0; i < NSAMPLES; i++) {
        float u1 = op_rng_float(&rng), u2 = op_rng_float(&rng);
        op_v3 wo;
        float pdf = op_phase_sample(samp, wi, u1, u2, &wo);
        float ev = op_phase_eval(samp, wi, wo);
        if (!(fabsf(pdf - ev) <= 1e-4f * ev) || !(fabsf(v3_dot(wo, wo) - 1.0f) < 1e-5f))
            fail_msg("%s: sample %d returned density %g, eval %g, |wo|^2 %g", what, i,
                     (double)pdf, (double)ev, (double)v3_dot(wo, wo));
        double c, phi;
        angles(&f, wo, &c, &phi);
        int bz = (int)((c + 1.0) * 0.5 * NZ), bp = (int)(phi / (2.0 * M_PI) * NPHI);
        bz = bz < 0 ? 0 : bz >= NZ ? NZ - 1 : bz;
        bp = bp < 0 ? 0 : bp >= NPHI ? NPHI - 1 : bp;
        obs[bz * NPHI + bp] += 1.0;
    }
    /* bins expecting fewer than 5 pooled into one */
    double chi2 = 0.0, pool_o = 0.0, pool_e = 0.0;
    int bins = 0;
    for (int i = 0; i < NZ * NPHI; i++) {
        if (expect[i] < 5.0) {
            pool_o += obs[i];
            pool_e += expect[i];
            continue;
        }
        double d = obs[i] - expect[i];
        chi2 += d * d / expect[i];
        bins++;
    }
    if (pool_e > 0.0) {
        chi2 += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        bins++;
    }
    assert_true(bins > 20);
    return chi2_z(chi2, bins - 1);
}

static void test_sampling(void **state)
{
    (void)state;
    /* one-sided p of about 2e-4 per test: a correct sampler fails with probability 1e-3 */
    const double limit = 3.5;
    for (int i = 0; i < NPHASES; i++) {
        double z = chi2_deviate(&phases[i].phase, &phases[i].phase, phases[i].name, 100 + i);
        if (!(z < limit))
            fail_msg("%s: chi-square deviate %.2f over %.1f", phases[i].name, z, limit);
    }
    /* the test sees a wrong density: HG 0.3's samples against Rayleigh's, Rayleigh's against
     * the isotropic density */
    double z1 = chi2_deviate(&phases[1].phase, &phases[4].phase, "hg 0.3 as rayleigh", 7);
    double z2 = chi2_deviate(&phases[4].phase, &phases[0].phase, "rayleigh as isotropic", 8);
    if (!(z1 > 10.0 && z2 > 10.0))
        fail_msg("negative controls: deviates %.2f and %.2f, expected far above %.1f", z1, z2,
                 limit);
}

/* Rayleigh: op_phase_sample(u1) has CDF(c) = u1 exactly (up to float rounding); the moments. */
static void test_rayleigh_inversion(void **state)
{
    (void)state;
    const op_phase *ray = &phases[4].phase;
    op_v3 wi = incident();
    frame f = frame_of(wi);
    for (int i = 0; i <= 1000; i++) {
        float u = fminf((float)i / 1000.0f, 0x1.fffffep-1f);
        op_v3 wo;
        op_phase_sample(ray, wi, u, 0.37f, &wo);
        double c, phi;
        angles(&f, wo, &c, &phi);
        double cdf = (c * c * c + 3.0 * c + 4.0) / 8.0;
        if (!(fabs(cdf - u) < 2e-6))
            fail_msg("rayleigh: u %.6f gave cosine %.7f, whose CDF is %.7f", (double)u, c, cdf);
    }
    /* E[c] = 0, E[c^2] = 3/8 Int c^2 (1 + c^2) dc = 2/5; HG's E[c] = g */
    for (int k = 0; k < NPHASES; k++) {
        op_rng rng = op_rng_seed(5, 17, 29);
        double m1 = 0.0, m2 = 0.0;
        enum { N = 400000 };
        for (int i = 0; i < N; i++) {
            float u1 = op_rng_float(&rng), u2 = op_rng_float(&rng);
            op_v3 wo;
            op_phase_sample(&phases[k].phase, wi, u1, u2, &wo);
            double c = -(double)v3_dot(wi, wo);
            m1 += c;
            m2 += c * c;
        }
        m1 /= N;
        m2 /= N;
        const op_phase *p = &phases[k].phase;
        double want1 = p->type == OP_PHASE_HG ? p->g : 0.0;
        /* the standard error of a mean of N cosines is at most 1 / sqrt(N) = 0.0016 */
        if (!(fabs(m1 - want1) < 0.008))
            fail_msg("%s: mean cosine %.5f, expected %.5f", phases[k].name, m1, want1);
        if (p->type == OP_PHASE_RAYLEIGH && !(fabs(m2 - 0.4) < 0.008))
            fail_msg("rayleigh: mean squared cosine %.5f, expected 0.4", m2);
        if (p->type == OP_PHASE_ISOTROPIC && !(fabs(m2 - 1.0 / 3.0) < 0.008))
            fail_msg("isotropic: mean squared cosine %.5f, expected 1/3", m2);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_normalized),
        cmocka_unit_test(test_sampling),
        cmocka_unit_test(test_rayleigh_inversion),
    };
    return op_test_exit_status(cmocka_run_group_tests(tests, NULL, NULL));
}
