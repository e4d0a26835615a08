/* test_render_sss_furnace.c - a measured material conserves energy on objects of any size
 * (docs/subsurface-rendering.md, *Measured materials on large objects*): a white measured
 * material (every row of the raw Gaussian material sums to 1) on a sphere in a uniform
 * environment of radiance 1 reflects all the light it receives, E = pi everywhere on a convex
 * shape, so every pixel wholly on the sphere shows radiance 1. The spheres go from 1 mm (32
 * material pixels of 0.625 mm) to 30 m (3e10 pixels, more than a layout can index), seen
 * whole from 4 radii away, with a maxPoints that the smallest fit in (every point laid) and the
 * others do not (coarser points over the whole shape), one radius both ways, and a 10 m sphere
 * seen close up (coarser points near the view only). The pixel mean must lie within 3 % of 1
 * and of the 1 mm sphere's (the irradiance of a convex shape in a constant sky has no
 * variance; what is left is the lookup between points and the sphere's facets) and no pixel
 * may exceed 1.15. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "opaline_render.h"
#include "test_support.h"

enum { SIZE = 16 };
#define FOV 40.0

/* The mean and the largest radiance over the pixels wholly on a sphere of radius r carrying the
 * material `mat` at maxPoints max_points, seen from `dist` radii from its centre in a constant
 * sky of radiance 1. */
static void sphere(const char *mat, double r, int max_points, double dist, double *mean,
                   double *most)
{
    char text[4096];
    snprintf(text, sizeof text,
             "<scene version=\"0.6.0\"><integrator type=\"path\"/>"
             " <sensor type=\"perspective\"><float name=\"fov\" value=\"%g\"/>"
             "  <float name=\"nearClip\" value=\"%.9g\"/><float name=\"farClip\" value=\"%.9g\"/>"
             "  <transform name=\"toWorld\"><lookat origin=\"0,0,%.9g\" target=\"0,0,0\" "
             "   up=\"0,1,0\"/></transform>"
             "  <sampler type=\"independent\"><integer name=\"sampleCount\" value=\"2\"/>"
             "  </sampler><film type=\"hdrfilm\"><integer name=\"width\" value=\"%d\"/>"
             "   <integer name=\"height\" value=\"%d\"/><rfilter type=\"box\"/></film></sensor>"
             " <emitter type=\"constant\"><rgb name=\"radiance\" value=\"1\"/></emitter>"
             " <shape type=\"sphere\"><float name=\"radius\" value=\"%.9g\"/>"
             "  <subsurface type=\"raw\"><string name=\"material\" value=\"%s\"/>"
             "   <float name=\"sceneUnitsPerMetre\" value=\"1\"/>"
             "   <integer name=\"irrSamples\" value=\"2\"/>"
             "   <integer name=\"maxPoints\" value=\"%d\"/></subsurface></shape>"
             "</scene>",
             FOV, 0.25 * (dist - 1.0) * r, 100.0 * r, dist * r, SIZE, SIZE, r, mat, max_points);
    const char *path = op_test_write_temp("furnace.xml", text);
    op_image img = op_test_render_image(path, 0, 2, 0);
    /* the pixels whose corners all lie within the sphere's disk */
    double t = tan(FOV * M_PI / 360.0), lim = asin(1.0 / dist), sum = 0.0;
    int n = 0;
    *most = 0.0;
    for (int y = 0; y < SIZE; y++)
        for (int x = 0; x < SIZE; x++) {
            int inside = 1;
            for (int k = 0; k < 4; k++) {
                double u = (2.0 * (x + (k & 1)) / SIZE - 1.0) * t,
                       v = (2.0 * (y + (k >> 1)) / SIZE - 1.0) * t;
                inside &= atan(hypot(u, v)) < lim;
            }
            if (!inside)
                continue;
            for (int c = 0; c < 3; c++) {
                double L = img.pixels[(size_t)img.channels * (y * SIZE + x) + c];
                sum += L;
                *most = fmax(*most, L);
            }
            n += 3;
        }
    op_image_free(&img);
    assert_true(n > 0);
    *mean = sum / n;
}

static void test_white_spheres(void **state)
{
    (void)state;
    char white[1024];
    snprintf(white, sizeof white, "%s", op_test_tmp_path("WhiteFurnace.opm"));
    const double albedo[3] = {1.0, 1.0, 1.0};
    op_test_write_gaussian_raw(white, albedo, 0);
    static const struct {
        double r;
        int max_points;
        double dist;
    } cases[] = {
        {0.001, 3000, 4.0},  /* 32 points: every one laid */
        {0.01, 10000, 4.0},  /* 3220 points: every one laid */
        {0.01, 1000, 4.0},   /* the same sphere coarsened to 1000 */
        {0.1, 3000, 4.0},    /* 3.2e5 */
        {1.0, 3000, 4.0},    /* 3.2e7 */
        {30.0, 3000, 4.0},   /* 2.9e10: more than a layout can index */
        {10.0, 3000, 1.05},  /* 3.2e9, seen close up: coarser points near the view only */
    };
    int bad = 0;
    double first = 0.0;
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        double mean, most;
        sphere(white, cases[i].r, cases[i].max_points, cases[i].dist, &mean, &most);
        printf("radius %g m seen from %g radii, maxPoints %d: mean radiance %.4f, largest "
               "%.4f\n", cases[i].r, cases[i].dist, cases[i].max_points, mean, most);
        if (i == 0)
            first = mean;
        if (!(fabs(mean - 1.0) <= 0.03) || !(most <= 1.15)) {
            printf("  FAILED: a white material in a sky of radiance 1 must show 1\n");
            bad++;
        }
        if (!(fabs(mean - first) <= 0.03)) {
            printf("  FAILED: %.4f differs from the 1 mm sphere's %.4f\n", mean, first);
            bad++;
        }
    }
    assert_int_equal(bad, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_white_spheres),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
