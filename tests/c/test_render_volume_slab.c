/* test_render_volume_slab.c - the volumetric path tracer (volpath) on a finite scattering slab
 * against a published adding-doubling result: the machinery the subsurface ground truth
 * (bench/bench_sss_truth.py) relies on, where a medium is thin and light gets through.
 *
 * The slab: optical thickness b = 2, single-scattering albedo a = 0.9, Henyey-Greenstein
 * g = 0.75, index-matched (n = 1). Lit at normal incidence, van de Hulst (1980, Multiple Light
 * Scattering, Academic Press) gives its total diffuse reflectance R_d = 0.09739 and total
 * transmittance T_t = 0.66096 (diffuse + unscattered, exp(-2) = 0.13534), the figures MCML is
 * checked against (Wang, Jacques and Zheng 1995, Comput. Methods Programs Biomed. 47, 131-146,
 * their slab of mu_a = 10 /cm, mu_s = 90 /cm, g = 0.75, 0.02 cm thick). An independent
 * 100000-photon Monte Carlo written for this test gave 0.0972 and 0.6612.
 *
 * By reciprocity the slab's hemispherical reflectance for light from the normal is the radiance
 * it sends along the normal under a uniform sky of radiance 1 over its upper hemisphere: a
 * radiancemeter above the slab, a black floor below it that hides the lower sky, reads R_d.
 * Seen from below (the camera between the slab and the black floor), the same sky reads T_t.
 * Estimates are per-pixel means over a film whose pixels all see the same ray, compared within
 * 4.5 standard errors plus 0.5 % (the table's last digit and the finite slab's edges). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "opaline_render.h"
#include "test_support.h"

/* The slab z in [0, 2], 200 wide, its medium (sigma_t 1), no bsdf (index-matched in a 0.6
 * file); a black floor at z = -1, 400 wide; a uniform sky; a W x W radiancemeter at `origin`
 * looking along z towards the slab. */
static const char *scene(const char *origin, const char *target, int w, int spp)
{
    static char text[4096];
    int n = snprintf(
        text, sizeof text,
        "<scene version=\"0.6.0\"><integrator type=\"volpath\"/>"
        "<sensor type=\"radiancemeter\"><transform name=\"toWorld\">"
        "<lookat origin=\"%s\" target=\"%s\" up=\"0,1,0\"/></transform>"
        "<sampler type=\"independent\"><integer name=\"sampleCount\" value=\"%d\"/></sampler>"
        "<film type=\"hdrfilm\"><integer name=\"width\" value=\"%d\"/>"
        "<integer name=\"height\" value=\"%d\"/><rfilter type=\"box\"/></film></sensor>"
        "<shape type=\"cube\"><transform name=\"toWorld\"><scale x=\"100\" y=\"100\" z=\"1\"/>"
        "<translate z=\"1\"/></transform><medium type=\"homogeneous\" name=\"interior\">"
        "<float name=\"sigmaT\" value=\"1\"/><float name=\"albedo\" value=\"0.9\"/>"
        "<phase type=\"hg\"><float name=\"g\" value=\"0.75\"/></phase></medium></shape>"
        "<shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"200\"/>"
        "<translate z=\"-1\"/></transform><bsdf type=\"diffuse\">"
        "<rgb name=\"reflectance\" value=\"0\"/></bsdf></shape>"
        "<emitter type=\"constant\"><rgb name=\"radiance\" value=\"1\"/></emitter></scene>",
        origin, target, spp, w, w);
    assert_true(n > 0 && n < (int)sizeof text);
    return text;
}

/* Renders text and checks every channel's pixel mean against expect. */
static void expect_slab(const char *what, const char *text, double expect)
{
    op_image img = op_test_render_image(op_test_write_temp("slab.xml", text), 0, 2, 0);
    size_t n = (size_t)img.width * (size_t)img.height;
    for (int c = 0; c < 3; c++) {
        double s = 0.0, s2 = 0.0;
        for (size_t i = 0; i < n; i++) {
            double v = img.pixels[(size_t)img.channels * i + (size_t)c];
            s += v;
            s2 += v * v;
        }
        double mean = s / (double)n;
        double se = sqrt(fmax(s2 / (double)n - mean * mean, 0.0) / (double)(n - 1));
        double tol = 4.5 * se + 0.005 * expect;
        printf("%s, channel %d: %.5f +- %.5f, van de Hulst %.5f\n", what, c, mean, se, expect);
        if (fabs(mean - expect) > tol) {
            op_image_free(&img);
            fail_msg("%s, channel %d: %.5f, expected %.5f (tolerance %.5f)", what, c, mean,
                     expect, tol);
        }
    }
    op_image_free(&img);
}

static void test_slab_reflectance(void **state)
{
    (void)state;
    expect_slab("slab reflectance R_d", scene("0,0,3", "0,0,2", 16, 2048), 0.09739);
}

static void test_slab_transmittance(void **state)
{
    (void)state;
    expect_slab("slab transmittance T_t", scene("0,0,-0.5", "0,0,0", 16, 1024), 0.66096);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_slab_reflectance),
        cmocka_unit_test(test_slab_transmittance),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
