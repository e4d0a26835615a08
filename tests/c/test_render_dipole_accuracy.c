/* test_render_dipole_accuracy.c - the dipole's exitance at every distance, for every named
 * medium of the renderer's table (taken from op_sss_dipole_names(), so a medium added to the
 * table is tested too), against Jensen et al.'s closed form written out in dipole_reference.h,
 * independently of renderer/lib/sss/dipole_profile.c:
 *  - a slab in a millimetre scene lit by a hard-edged spot (a disk of radius a): the exitance
 *    interpolated at 1, 2 and 4 diffusion lengths 1/sigma_tr outside the disk's edge, in every
 *    channel, within 5 % of the profile integrated over the lit disk (media with no absorption
 *    have no diffusion length and skip this part);
 *  - a slab under uniform light: the exitance at its centre within 1 % of Rd_total.
 * The pre-pass runs as in a render: receivers are marked by the camera (which looks at the
 * strip or the centre the test reads), sources are the points the receivers' sums need. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sss/dipole_profile.h"
#include "dipole_reference.h"
#include "integrator/integrator.h"
#include "opaline_render.h"
#include "scene/render_scene.h"
#include "test_support.h"

typedef struct medium {
    char name[32];
    double sp[3], sa[3], eta; /* per mm */
} medium;

/* The media of the renderer's table, by name. */
static int media_list(medium *out, int cap)
{
    char names[1024];
    snprintf(names, sizeof names, "%s", op_sss_dipole_names());
    int n = 0;
    for (char *save = NULL, *t = strtok_r(names, ", ", &save); t && n < cap;
         t = strtok_r(NULL, ", ", &save)) {
        medium *m = &out[n];
        snprintf(m->name, sizeof m->name, "%s", t);
        assert_true(op_sss_dipole_lookup(t, m->sp, m->sa, &m->eta));
        n++;
    }
    assert_true(n >= 12);
    return n;
}

static double diffusion_length(const medium *m, int c)
{
    return 1.0 / sqrt(3.0 * m->sa[c] * (m->sa[c] + m->sp[c]));
}

/* Renders nothing: loads the scene text, runs the pre-pass as a render would (camera-marked
 * receivers, 2 threads) and returns the scene and the pre-pass's result. */
static op_sss_prepass *prepass(const char *name, const char *text, op_scene **scene,
                               double *seconds)
{
    return op_test_sss_prepass(op_test_write_temp(name, text), scene, seconds);
}

/* The scene: a rectangle [x0, x1] x [y0, y1] in z = 0 of the medium (millimetres, scale 1000),
 * the emitter given, a camera 2 w above (cx, 0) looking down over a width w, film nx x ny. */
static void scene_text(char *text, size_t cap, const medium *m, double x0, double x1, double y0,
                       double y1, const char *emitter, double cx, double w, int nx, int ny)
{
    double fov = 2.0 * atan(0.25) * 180.0 / M_PI;
    snprintf(text, cap,
             "<scene version=\"0.6.0\"><integrator type=\"path\"/>"
             " <sensor type=\"perspective\"><float name=\"fov\" value=\"%.9g\"/>"
             "  <transform name=\"toWorld\"><lookat origin=\"%.9g,0,%.9g\" target=\"%.9g,0,0\" "
             "   up=\"0,1,0\"/></transform>"
             "  <sampler type=\"independent\"><integer name=\"sampleCount\" value=\"1\"/></sampler>"
             "  <film type=\"hdrfilm\"><integer name=\"width\" value=\"%d\"/>"
             "   <integer name=\"height\" value=\"%d\"/><rfilter type=\"box\"/></film></sensor>"
             " %s"
             " <shape type=\"rectangle\"><transform name=\"toWorld\">"
             "  <scale x=\"%.9g\" y=\"%.9g\" z=\"1\"/><translate x=\"%.9g\" y=\"%.9g\" z=\"0\"/>"
             "  </transform><subsurface type=\"dipole\">"
             "  <string name=\"material\" value=\"%s\"/><float name=\"sceneUnitsPerMetre\" value=\"1000\"/>"
             "  <integer name=\"irrSamples\" value=\"1\"/></subsurface></shape>"
             "</scene>",
             fov, cx, 2.0 * w, cx, nx, ny, emitter, 0.5 * (x1 - x0), 0.5 * (y1 - y0),
             0.5 * (x0 + x1), 0.5 * (y0 + y1), m->name);
}

static void test_spot_every_distance(void **state)
{
    (void)state;
    medium media[64];
    int n = media_list(media, 64), failures = 0;
    printf("medium      ch  L(mm)   exitance / closed form at 1, 2, 4 L outside the spot's edge\n");
    for (int k = 0; k < n; k++) {
        const medium *m = &media[k];
        double lmax = 0.0, lmin = INFINITY;
        for (int c = 0; c < 3; c++) {
            lmax = fmax(lmax, diffusion_length(m, c));
            lmin = fmin(lmin, diffusion_length(m, c));
        }
        if (!isfinite(lmax)) {
            printf("%-10s  (no absorption: no diffusion length)\n", m->name);
            continue;
        }
        /* a disk of radius 1.5 L_max (at least 8 L_min, some 50 point spacings) lit from 10 a
         * above; the slab covers it and the strip out
         * to 4.5 L_max beyond its edge, where the camera looks */
        double a = fmax(1.5 * lmax, 8.0 * lmin), D = 10.0 * a, cut = atan(a / D) * 180.0 / M_PI;
        double x0 = -1.1 * a, x1 = a + 5.0 * lmax, y = 1.1 * a;
        double s0 = a - 0.2 * lmin, s1 = a + 4.5 * lmax, w = s1 - s0;
        char em[512], text[8192];
        snprintf(em, sizeof em,
                 "<emitter type=\"spot\"><transform name=\"toWorld\"><lookat origin=\"0,0,%.9g\" "
                 "target=\"0,0,0\"/></transform><spectrum name=\"intensity\" value=\"%.9g\"/>"
                 "<float name=\"cutoffAngle\" value=\"%.9g\"/>"
                 "<float name=\"beamWidth\" value=\"%.9g\"/></emitter>",
                 D, D * D, cut, cut);
        scene_text(text, sizeof text, m, x0, x1, -y, y, em, 0.5 * (s0 + s1), w, 64, 2);
        op_scene *scene = NULL;
        double secs = 0.0;
        op_sss_prepass *pre = prepass("spot.xml", text, &scene, &secs);
        for (int c = 0; c < 3; c++) {
            double L = diffusion_length(m, c);
            printf("%-10s  %d  %6.3f ", m->name, c, L);
            for (int q = 0; q < 3; q++) {
                double x = a + (double)(1 << q) * L;
                double want = ref_dipole_spot(m->sp[c], m->sa[c], m->eta, a, D, x);
                op_v3 got;
                if (!op_sss_lookup(pre, 0, v3((float)x, 0.0f, 0.0f), v3(0.0f, 0.0f, 1.0f), &got))
                    fail_msg("%s: no exitance at x = %g mm (not a receiver)", m->name, x);
                double g = c == 0 ? got.x : c == 1 ? got.y : got.z, rel = g / want - 1.0;
                printf("  %+7.2f %%", 100.0 * rel);
                if (!(fabs(rel) <= 0.05)) {
                    failures++;
                    printf(" <-");
                }
            }
            printf(c == 2 ? "   (%d points, %.2f s)\n" : "\n", op_sss_prepass_points(pre, 0),
                   secs);
        }
        op_sss_prepass_free(pre);
        op_scene_free(scene);
    }
    if (failures)
        fail_msg("%d exitance values off by more than 5 %%", failures);
}

static void test_uniform_every_medium(void **state)
{
    (void)state;
    medium media[64];
    int n = media_list(media, 64), failures = 0;
    printf("medium      mean exitance / Rd_total over 5 x 5 points at the centre of a slab under uniform light\n");
    for (int k = 0; k < n; k++) {
        const medium *m = &media[k];
        /* the slab reaches 1.1 x the 0.1 % radius beyond the centre the camera sees */
        op_sss_dipole d;
        for (int c = 0; c < 3; c++) {
            d.sigma_sp[c] = m->sp[c];
            d.sigma_a[c] = m->sa[c];
        }
        d.eta = m->eta;
        double R = 1.1 * op_sss_dipole_radius(&d, 1e-3), w = 0.05 * R;
        char text[8192];
        scene_text(text, sizeof text, m, -R, R, -R, R,
                   "<emitter type=\"directional\"><vector name=\"direction\" x=\"0\" y=\"0\" "
                   "z=\"-1\"/><rgb name=\"irradiance\" value=\"1\"/></emitter>",
                   0.0, w, 4, 4);
        op_scene *scene = NULL;
        double secs = 0.0;
        op_sss_prepass *pre = prepass("uniform.xml", text, &scene, &secs);
        op_v3 got = v3s(0.0f);
        for (int j = 0; j < 5; j++)
            for (int i = 0; i < 5; i++) {
                op_v3 p = v3((float)(w * (i - 2) / 5.0), (float)(w * (j - 2) / 5.0), 0.0f), e;
                if (!op_sss_lookup(pre, 0, p, v3(0.0f, 0.0f, 1.0f), &e))
                    fail_msg("%s: no exitance at (%g, %g)", m->name, p.x, p.y);
                got = v3_add(got, v3_scale(e, 1.0f / 25.0f));
            }
        printf("%-10s", m->name);
        for (int c = 0; c < 3; c++) {
            double want = ref_dipole_total(m->sp[c], m->sa[c], m->eta);
            double g = c == 0 ? got.x : c == 1 ? got.y : got.z, rel = g / want - 1.0;
            printf("  %+6.2f %%", 100.0 * rel);
            if (!(fabs(rel) <= 0.01)) {
                failures++;
                printf(" <-");
            }
        }
        printf("   (%d points, %.2f s)\n", op_sss_prepass_points(pre, 0), secs);
        op_sss_prepass_free(pre);
        op_scene_free(scene);
    }
    if (failures)
        fail_msg("%d exitance values off by more than 1 %%", failures);
}

int main(void)
{
    op_log_set_level(OP_LOG_WARN);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_uniform_every_medium),
        cmocka_unit_test(test_spot_every_distance),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
