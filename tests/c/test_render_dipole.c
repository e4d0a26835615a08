/* test_render_dipole.c - <subsurface type="dipole">: the profile Rd(r) against an independent
 * evaluation of Jensen et al.'s formula, the closed-form total against numerical integration,
 * and a flat slab under uniform irradiance whose exitance is the total diffuse reflectance, in
 * metre and millimetre scenes; the named media, the explicit coefficients and the errors. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sss/dipole_profile.h"
#include "dipole_reference.h"
#include "opaline_render.h"
#include "scene/render_scene.h"
#include "integrator/integrator.h"
#include "test_support.h"

/* Skin1 from Jensen et al. 2001 (1/mm), eta 1.3, written out here independently of
 * sss/dipole_profile.c. */
static const double skin_sp[3] = {0.74, 0.88, 1.01}, skin_a[3] = {0.032, 0.17, 0.48};

static void test_profile(void **state)
{
    (void)state;
    op_sss_dipole d;
    double eta = 0.0;
    assert_true(op_sss_dipole_lookup("sKiN1", d.sigma_sp, d.sigma_a, &eta));
    d.eta = eta;
    assert_true(fabs(eta - 1.3) < 1e-12);
    assert_false(op_sss_dipole_lookup("Skin3", d.sigma_sp, d.sigma_a, &eta));
    static const double radii[] = {0.0, 0.1, 0.5, 1.0, 2.5, 7.0};
    for (int c = 0; c < 3; c++) {
        for (size_t k = 0; k < sizeof radii / sizeof radii[0]; k++) {
            double want = ref_dipole_rd(skin_sp[c], skin_a[c], 1.3, radii[k]);
            double got = op_sss_dipole_rd(&d, c, radii[k]);
            if (fabs(got - want) > 1e-9 * want)
                fail_msg("channel %d, r = %g mm: Rd %.9g, expected %.9g", c, radii[k], got, want);
        }
        /* the closed-form total is the integral of the profile (trapezoid on a fine log grid) */
        double sum = 0.0, prev_r = 0.0, prev_f = 0.0;
        for (int i = 0; i <= 200000; i++) {
            double r = 1e-5 * pow(1e7, i / 200000.0);
            double f = 2.0 * M_PI * r * ref_dipole_rd(skin_sp[c], skin_a[c], 1.3, r);
            sum += 0.5 * (f + prev_f) * (r - prev_r);
            prev_r = r;
            prev_f = f;
        }
        double total = op_sss_dipole_total(&d, c), closed = ref_dipole_total(skin_sp[c], skin_a[c], 1.3);
        if (fabs(total - closed) > 1e-9 || fabs(sum - closed) > 1e-4 * closed)
            fail_msg("channel %d: Rd_total %.6f, closed form %.6f, integral %.6f", c, total, closed,
                     sum);
    }
    /* the derivatives against central differences of the independent profile */
    for (int c = 0; c < 3; c++)
        for (size_t k = 1; k < sizeof radii / sizeof radii[0]; k++) {
            double r = radii[k], h = 1e-4 * r, f[3];
            op_sss_dipole_rd_derivs(&d, c, r, f);
            double fm = ref_dipole_rd(skin_sp[c], skin_a[c], 1.3, r - h);
            double f0 = ref_dipole_rd(skin_sp[c], skin_a[c], 1.3, r);
            double fp = ref_dipole_rd(skin_sp[c], skin_a[c], 1.3, r + h);
            double d1 = (fp - fm) / (2 * h), d2 = (fp - 2 * f0 + fm) / (h * h);
            if (fabs(f[0] - f0) > 1e-9 * f0 || fabs(f[1] - d1) > 1e-5 * fabs(d1) ||
                fabs(f[2] - d2) > 1e-3 * fabs(d2))
                fail_msg("channel %d, r = %g: Rd, Rd', Rd'' %.9g %.9g %.9g, expected %.9g %.9g %.9g",
                         c, r, f[0], f[1], f[2], f0, d1, d2);
        }
    /* the radius holds all but the asked fraction */
    double R = op_sss_dipole_radius(&d, 1e-3);
    assert_true(R > 5.0 && R < 100.0);
}

/* A flat square of half-side `half` scene units facing +z under irradiance 1 along -z, with the
 * dipole element body given, seen from above by a 4 x 4 camera over its centre (a square of
 * half-side half / 8), so that the pre-pass computes what the centre needs. */
static const char *slab_scene(const char *name, double half, const char *body)
{
    static char path[1024];
    char text[4096];
    snprintf(path, sizeof path, "%s", op_test_tmp_path(name));
    snprintf(text, sizeof text,
             "<scene version=\"0.6.0\"><integrator type=\"path\"/>"
             " <sensor type=\"perspective\"><float name=\"fov\" value=\"28.0725\"/>"
             "  <transform name=\"toWorld\"><lookat origin=\"0,0,%g\" target=\"0,0,0\" "
             "   up=\"0,1,0\"/></transform>"
             "  <film type=\"hdrfilm\"><integer name=\"width\" value=\"4\"/>"
             "   <integer name=\"height\" value=\"4\"/><rfilter type=\"box\"/></film></sensor>"
             " <emitter type=\"directional\"><vector name=\"direction\" x=\"0\" y=\"0\" z=\"-1\"/>"
             "  <rgb name=\"irradiance\" value=\"1\"/></emitter>"
             " <shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"%g\"/>"
             "  </transform><subsurface type=\"dipole\">%s%s"
             "  <integer name=\"irrSamples\" value=\"1\"/></subsurface></shape>"
             "</scene>",
             half / 2.0, half,
             strstr(body, "name=\"scale\"") || strstr(body, "sceneUnitsPerMetre")
                 ? "" : "<float name=\"sceneUnitsPerMetre\" value=\"1\"/>",
             body);
    op_test_write_text(path, text);
    return path;
}

/* Mean exitance over the centre (9 x 9 positions over a square of half-side `inner`, within
 * the camera's view) of the slab scene at path, the pre-pass marking receivers by the camera. */
static void slab_exitance(const char *path, double inner, double out[3])
{
    op_error err = {0};
    op_scene *scene = NULL;
    op_status st = op_scene_load(path, NULL, 0, &scene, &err);
    OP_ASSERT_OK(st, err);
    op_sss_prepass_options o = {2, 0, NULL, NULL, NULL, 0, NULL, &op_path_transport};
    op_sss_prepass *pre = NULL;
    st = op_sss_prepass_run(scene, &o, &pre, &err);
    OP_ASSERT_OK(st, err);
    out[0] = out[1] = out[2] = 0.0;
    int n = 0;
    for (int j = 0; j < 9; j++)
        for (int i = 0; i < 9; i++) {
            op_v3 p = v3((float)(inner * (i / 4.0 - 1.0)), (float)(inner * (j / 4.0 - 1.0)), 0.0f);
            op_v3 m;
            if (!op_sss_lookup(pre, 0, p, v3(0.0f, 0.0f, 1.0f), &m))
                fail_msg("%s: no exitance at (%g, %g)", path, p.x, p.y);
            out[0] += m.x;
            out[1] += m.y;
            out[2] += m.z;
            n++;
        }
    for (int c = 0; c < 3; c++)
        out[c] /= n;
    op_sss_prepass_free(pre);
    op_scene_free(scene);
}

static void test_slab_total_reflectance(void **state)
{
    (void)state;
    /* metres: a 5 cm square, Skin1 by default; the 0.1 % radius (2.1 cm) around the central
     * 8 mm the test reads stays inside */
    double m[3], mm[3];
    slab_exitance(slab_scene("m.xml", 0.025, ""), 0.004, m);
    /* the same in a millimetre scene: sceneUnitsPerMetre 1000 */
    slab_exitance(slab_scene("mm.xml", 25.0, "<string name=\"material\" value=\"skin1\"/>"
                                             "<float name=\"sceneUnitsPerMetre\" value=\"1000\"/>"),
                  4.0, mm);
    for (int c = 0; c < 3; c++) {
        double want = ref_dipole_total(skin_sp[c], skin_a[c], 1.3);
        if (fabs(m[c] - want) > 0.01 * want || fabs(mm[c] - want) > 0.01 * want)
            fail_msg("channel %d: exitance %.4f (m), %.4f (mm); Rd_total %.4f", c, m[c], mm[c],
                     want);
    }
    /* explicit coefficients: sigmaT/albedo and sigmaA/sigmaS with g describe the same medium */
    char body[1024];
    snprintf(body, sizeof body,
             "<rgb name=\"sigmaT\" value=\"%g, %g, %g\"/><rgb name=\"albedo\" value=\"%g, %g, %g\"/>"
             "<float name=\"intIOR\" value=\"1.3\"/>",
             skin_sp[0] + skin_a[0], skin_sp[1] + skin_a[1], skin_sp[2] + skin_a[2],
             skin_sp[0] / (skin_sp[0] + skin_a[0]), skin_sp[1] / (skin_sp[1] + skin_a[1]),
             skin_sp[2] / (skin_sp[2] + skin_a[2]));
    double e[3];
    slab_exitance(slab_scene("ta.xml", 0.025, body), 0.004, e);
    snprintf(body, sizeof body,
             "<rgb name=\"sigmaA\" value=\"%g, %g, %g\"/><rgb name=\"sigmaS\" value=\"%g, %g, %g\"/>"
             "<float name=\"g\" value=\"0.5\"/><float name=\"intIOR\" value=\"1.3\"/>",
             skin_a[0], skin_a[1], skin_a[2], 2 * skin_sp[0], 2 * skin_sp[1], 2 * skin_sp[2]);
    double f[3];
    slab_exitance(slab_scene("as.xml", 0.025, body), 0.004, f);
    for (int c = 0; c < 3; c++) {
        assert_true(fabs(e[c] - m[c]) < 1e-3 * m[c]);
        assert_true(fabs(f[c] - m[c]) < 1e-3 * m[c]);
    }
    /* Mitsuba's meaning of scale: explicit coefficients are per scene unit, times scale (here
     * 1/mm x 1000 in a metre scene); the named table's entries are x 100, times scale (here
     * x 100 x 0.01 = 1/mm in a millimetre scene) */
    double ms[3], mt[3];
    snprintf(body, sizeof body,
             "<rgb name=\"sigmaA\" value=\"%g, %g, %g\"/><rgb name=\"sigmaS\" value=\"%g, %g, %g\"/>"
             "<float name=\"intIOR\" value=\"1.3\"/><float name=\"scale\" value=\"1000\"/>",
             skin_a[0], skin_a[1], skin_a[2], skin_sp[0], skin_sp[1], skin_sp[2]);
    slab_exitance(slab_scene("mts_explicit.xml", 0.025, body), 0.004, ms);
    slab_exitance(slab_scene("mts_table.xml", 25.0, "<string name=\"material\" value=\"skin1\"/>"
                                                    "<float name=\"scale\" value=\"0.01\"/>"),
                  4.0, mt);
    for (int c = 0; c < 3; c++) {
        if (fabs(ms[c] - m[c]) > 1e-3 * m[c] || fabs(mt[c] - mm[c]) > 1e-3 * mm[c])
            fail_msg("channel %d: Mitsuba scale: %.5f vs %.5f (explicit), %.5f vs %.5f (table)",
                     c, ms[c], m[c], mt[c], mm[c]);
    }
    /* marble: a far longer footprint */
    double mb[3];
    slab_exitance(slab_scene("marble.xml", 0.06, "<string name=\"material\" value=\"Marble\"/>"),
                  0.006, mb);
    static const double msp[3] = {2.19, 2.62, 3.00}, ma[3] = {0.0021, 0.0041, 0.0071};
    for (int c = 0; c < 3; c++) {
        double want = ref_dipole_total(msp[c], ma[c], 1.5);
        if (fabs(mb[c] - want) > 0.01 * want)
            fail_msg("marble channel %d: exitance %.4f, Rd_total %.4f", c, mb[c], want);
    }
}

static void expect_error(const char *body, const char *needle)
{
    op_error err = {0};
    op_scene *scene = NULL;
    op_status st = op_scene_load(slab_scene("bad.xml", 0.05, body), NULL, 0, &scene, &err);
    assert_int_equal(st, OP_ERR_INPUT);
    if (!strstr(err.message, needle))
        fail_msg("message \"%s\" lacks \"%s\"", err.message, needle);
}

static void test_errors(void **state)
{
    (void)state;
    expect_error("<string name=\"material\" value=\"Skin9\"/>", "Skin9");
    expect_error("<string name=\"material\" value=\"Skin1\"/><rgb name=\"sigmaA\" value=\"1\"/>",
                 "either");
    expect_error("<rgb name=\"sigmaA\" value=\"0\"/><rgb name=\"sigmaS\" value=\"0\"/>",
                 "not both 0");
    expect_error("<float name=\"intIOR\" value=\"0.5\"/>", "[1, 3]");
    expect_error("<float name=\"scale\" value=\"2\"/><float name=\"sceneUnitsPerMetre\" "
                 "value=\"2\"/>", "not both");
}

int main(void)
{
    op_log_set_level(OP_LOG_WARN);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_profile),
        cmocka_unit_test(test_slab_total_reflectance),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
