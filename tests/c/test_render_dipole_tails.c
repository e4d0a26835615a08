/* test_render_dipole_tails.c - the dipole's tail outside a lit spot through a whole camera
 * render (issue 29, "Dipole tails, blue"), for Skimmilk and Skin1 (Jensen et al. 2001's
 * coefficients, written here), every channel: a slab in a millimetre scene lit by a hard-edged
 * spot (a disk of radius a), seen from above by a camera whose pixels are a thirtieth of the
 * shortest diffusion length L_min (a few per irradiance point spacing, so that a pixel shows the
 * exitance where it is rather than averaged over the points around it). Every pixel whose
 * centre lies within L/4 of 1, 2 and 4 diffusion lengths L = 1/sigma_tr of a channel beyond
 * the disk's edge must be within 3 % of the exact convolution of Jensen et al.'s profile with
 * the disk, integrated over the pixel, plus 3 standard deviations of the pixel's own sampling
 * noise (the reference's variation over the pixel over the samples per pixel): the issue asks
 * 5 %; a lookup that takes the weighted mean of the points around it instead of their linear
 * fit is off by up to 5.5 % here (blue), and 3 % fails it. The reference is
 * dipole_reference.h's closed form, integrated here independently of renderer/lib/sss/. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dipole_reference.h"
#include "opaline_render.h"
#include "test_support.h"

typedef struct medium {
    const char *name;
    double sp[3], sa[3], eta; /* per mm */
} medium;

static const medium media[] = {
    {"Skimmilk", {0.70, 1.22, 1.90}, {0.0014, 0.0025, 0.0142}, 1.3},
    {"Skin1", {0.74, 0.88, 1.01}, {0.032, 0.17, 0.48}, 1.3},
};

enum { SPP = 16, ROWS = 16, TABLE = 41 };

static double diffusion_length(const medium *m, int c)
{
    return 1.0 / sqrt(3.0 * m->sa[c] * (m->sa[c] + m->sp[c]));
}

/* The exitance at distance x (mm) from the centre of a disk of radius a lit by a point light of
 * intensity D^2 at height D (irradiance D^3 / (D^2 + rho^2)^1.5): the profile integrated in
 * polar coordinates about the point of exit, M(x) = int Rd(s) s (int over the arc of E) ds, the
 * arc the part of the circle of radius s about x inside the disk, so that the steep part of Rd
 * near x is resolved however short the diffusion length. s = s0 + (s1 - s0) (1 - cos u) / 2
 * takes out the square-root ends of the arc's angle. (Within 2e-6 of 4000 x 24 nodes.) */
static double spot_exitance(const medium *m, int c, double a, double D, double x)
{
    enum { NU = 1500, NPHI = 12 };
    double s0 = x > a ? x - a : 0.0, s1 = x + a, sum = 0.0;
    for (int i = 0; i < NU; i++) {
        double u = M_PI * (i + 0.5) / NU, s = s0 + 0.5 * (s1 - s0) * (1.0 - cos(u));
        double ds = 0.5 * (s1 - s0) * sin(u) * M_PI / NU, th = M_PI;
        if (x > 0.0 && s > 0.0) {
            double cs = (x * x + s * s - a * a) / (2.0 * x * s);
            th = cs >= 1.0 ? 0.0 : cs <= -1.0 ? M_PI : acos(cs);
        }
        double arc = 0.0;
        for (int j = 0; j < NPHI; j++) {
            double phi = th * (j + 0.5) / NPHI, rho2 = x * x + s * s - 2.0 * x * s * cos(phi);
            arc += D * D * D / pow(D * D + rho2, 1.5);
        }
        sum += ref_dipole_rd(m->sp[c], m->sa[c], m->eta, s) * s * arc * 2.0 * th / NPHI * ds;
    }
    return sum;
}

/* M(r) tabulated on [r0, r1] (TABLE entries), read back log-linearly. */
typedef struct table {
    double r0, r1, logm[TABLE];
} table;

static void table_make(table *t, const medium *m, int c, double a, double D, double r0, double r1)
{
    t->r0 = r0;
    t->r1 = r1;
    for (int i = 0; i < TABLE; i++)
        t->logm[i] = log(spot_exitance(m, c, a, D, r0 + (r1 - r0) * i / (TABLE - 1)));
}

static double table_at(const table *t, double r)
{
    double x = (r - t->r0) / (t->r1 - t->r0) * (TABLE - 1);
    assert_true(x >= 0.0 && x <= TABLE - 1);
    int i = x >= TABLE - 1 ? TABLE - 2 : (int)x;
    return exp(t->logm[i] + (x - i) * (t->logm[i + 1] - t->logm[i]));
}

/* The reference's mean over the pixel [x0, x0 + w] x [y0, y0 + w] and the standard deviation
 * of a mean of SPP uniform samples in it (3 x 3 Gauss-Legendre). */
static void pixel_reference(const table *t, double x0, double y0, double w, double *mean,
                            double *sd)
{
    static const double gx[3] = {-0.7745966692414834, 0.0, 0.7745966692414834};
    static const double gw[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
    double s1 = 0.0, s2 = 0.0;
    for (int u = 0; u < 3; u++)
        for (int v = 0; v < 3; v++) {
            double x = x0 + 0.5 * w * (1.0 + gx[u]), y = y0 + 0.5 * w * (1.0 + gx[v]);
            double f = table_at(t, hypot(x, y));
            s1 += 0.25 * gw[u] * gw[v] * f;
            s2 += 0.25 * gw[u] * gw[v] * f * f;
        }
    *mean = s1;
    *sd = sqrt(fmax(s2 - s1 * s1, 0.0) / SPP);
}

/* Renders m's slab and checks its bands; returns how many pixels are off. */
static int check_medium(const medium *m)
{
    double L[3], lmax = 0.0, lmin = INFINITY;
    for (int c = 0; c < 3; c++) {
        L[c] = diffusion_length(m, c);
        lmax = fmax(lmax, L[c]);
        lmin = fmin(lmin, L[c]);
    }
    /* the spot of test_render_dipole_accuracy: radius max(1.5 L_max, 8 L_min), lit from 10 a
     * above; the slab covers it and reaches 5 L_max beyond its edge along +x, where the camera
     * looks at the strip from 0.7 L_min to 4.3 L_max beyond the edge, ROWS pixels high */
    double a = fmax(1.5 * lmax, 8.0 * lmin), D = 10.0 * a, cut = atan(a / D) * 180.0 / M_PI;
    double w = lmin / 30.0, x0 = a + 0.7 * lmin;
    int nx = (int)ceil((a + 4.3 * lmax - x0) / w);
    double cx = x0 + 0.5 * nx * w, H = nx * w; /* a fov of 2 atan(1/2) sees nx w from H */
    char text[8192];
    snprintf(text, sizeof text,
             "<scene version=\"0.6.0\"><integrator type=\"path\"/>"
             " <sensor type=\"perspective\"><float name=\"fov\" value=\"%.9g\"/>"
             "  <transform name=\"toWorld\"><lookat origin=\"%.9g,0,%.9g\" target=\"%.9g,0,0\" "
             "   up=\"0,1,0\"/></transform>"
             "  <sampler type=\"independent\"><integer name=\"sampleCount\" value=\"%d\"/></sampler>"
             "  <film type=\"hdrfilm\"><integer name=\"width\" value=\"%d\"/>"
             "   <integer name=\"height\" value=\"%d\"/><rfilter type=\"box\"/></film></sensor>"
             " <emitter type=\"spot\"><transform name=\"toWorld\"><lookat origin=\"0,0,%.9g\" "
             "  target=\"0,0,0\"/></transform><spectrum name=\"intensity\" value=\"%.9g\"/>"
             "  <float name=\"cutoffAngle\" value=\"%.9g\"/><float name=\"beamWidth\" value=\"%.9g\"/>"
             " </emitter>"
             " <shape type=\"rectangle\"><transform name=\"toWorld\">"
             "  <scale x=\"%.9g\" y=\"%.9g\" z=\"1\"/><translate x=\"%.9g\" y=\"0\" z=\"0\"/>"
             "  </transform><subsurface type=\"dipole\">"
             "  <string name=\"material\" value=\"%s\"/><float name=\"sceneUnitsPerMetre\" value=\"1000\"/>"
             "  <integer name=\"irrSamples\" value=\"1\"/></subsurface></shape>"
             "</scene>",
             2.0 * atan(0.5) * 180.0 / M_PI, cx, H, cx, SPP, nx, ROWS, D, D * D, cut, cut,
             0.5 * (2.1 * a + 5.0 * lmax), 1.1 * a, 0.5 * (5.0 * lmax - 0.1 * a), m->name);
    op_image img = op_test_render_image(op_test_write_temp("tails.xml", text), 0, 2, 0);
    assert_int_equal(img.width, nx);
    int off = 0;
    printf("%s: spot radius %.2f mm, pixels %.4f mm (%d x %d), %d samples each\n", m->name, a, w,
           nx, ROWS, SPP);
    printf("  ch  L (mm)   at 1, 2, 4 L: mean and worst of image / reference (in standard "
           "deviations of the pixel noise)\n");
    for (int c = 0; c < 3; c++) {
        printf("  %d  %7.3f ", c, L[c]);
        for (int q = 1; q <= 4; q *= 2) {
            double lo = a + (q - 0.25) * L[c], hi = a + (q + 0.25) * L[c];
            table t;
            table_make(&t, m, c, a, D, lo - w, hi + 2.0 * w + (ROWS * w) * (ROWS * w) / lo);
            double sum = 0.0, worst = 0.0, worst_z = 0.0;
            int n = 0;
            for (int i = 0; i < nx; i++) {
                double px = x0 + i * w;
                if (px + 0.5 * w < lo || px + 0.5 * w > hi)
                    continue;
                for (int j = 0; j < ROWS; j++) {
                    /* rows are symmetric about y = 0, so either orientation of the film */
                    double py = (j - 0.5 * ROWS) * w, want, sd;
                    pixel_reference(&t, px, py, w, &want, &sd);
                    double got = M_PI * img.pixels[4 * ((size_t)j * nx + i) + c];
                    double rel = got / want - 1.0;
                    sum += rel;
                    n++;
                    if (fabs(rel) > fabs(worst)) {
                        worst = rel;
                        worst_z = (got - want) / sd;
                    }
                    off += !(fabs(got - want) <= 0.03 * want + 3.0 * sd);
                }
            }
            assert_true(n >= ROWS);
            printf("  %+6.2f %% %+6.2f %% (%+5.1f)", 100.0 * sum / n, 100.0 * worst, worst_z);
        }
        printf("\n");
    }
    op_image_free(&img);
    return off;
}

static void test_tails(void **state)
{
    (void)state;
    int off = 0;
    for (size_t k = 0; k < sizeof media / sizeof media[0]; k++)
        off += check_medium(&media[k]);
    if (off)
        fail_msg("%d pixels off by more than 3 %% and 3 standard deviations of their noise", off);
}

int main(void)
{
    op_log_set_level(OP_LOG_WARN);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tails),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
