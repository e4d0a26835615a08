/* test_render_volume.c - the volumetric path tracer (volpath) against exact results:
 * - Beer-Lambert: a slab of pure absorber, index-matched, seen against a uniform sky (from
 *   outside, and from a sensor inside its medium), and a diffuse floor under it lit by a
 *   directional light (the shadow ray's transmittance); the same through a heterogeneous slab
 *   whose extinction rises linearly with depth;
 * - furnace: a sphere of non-absorbing chromatic, anisotropic medium under a uniform sky is
 *   invisible, behind an index-matched and behind a dielectric boundary;
 * - a half-space of isotropic scattering medium (index 1) against Chandrasekhar's H-function,
 *   under a uniform sky and under a directional light at normal incidence;
 * - the path integrator ignores media (Mitsuba's path), and incomplete media are refused.
 * Estimates are per-pixel means over a film whose pixels all see the same ray (radiancemeter),
 * compared within 4.5 standard errors (plus 0.3 % for the geometry's float offsets). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "opaline_render.h"
#include "test_support.h"

/* A radiancemeter at `origin` looking at `target` with a W x W film, spp samples per pixel,
 * integrator `integrator`, then `body`. */
static char *scene_text(const char *integrator, const char *origin, const char *target, int w,
                        int spp, const char *body)
{
    static char text[8192];
    int n = snprintf(text, sizeof text,
                     "<scene version=\"0.6.0\"><integrator type=\"%s\"/>"
                     "<sensor type=\"radiancemeter\"><transform name=\"toWorld\">"
                     "<lookat origin=\"%s\" target=\"%s\" up=\"0,1,0\"/></transform>"
                     "<sampler type=\"independent\"><integer name=\"sampleCount\" value=\"%d\"/>"
                     "</sampler><film type=\"hdrfilm\"><integer name=\"width\" value=\"%d\"/>"
                     "<integer name=\"height\" value=\"%d\"/><rfilter type=\"box\"/></film>"
                     "</sensor>%s</scene>",
                     integrator, origin, target, spp, w, w, body);
    assert_true(n > 0 && n < (int)sizeof text);
    return text;
}

/* Mean and standard error of channel c over the image's pixels. */
static void pixel_stats(const op_image *img, int c, double *mean, double *se)
{
    size_t n = (size_t)img->width * (size_t)img->height;
    double s = 0.0, s2 = 0.0;
    for (size_t i = 0; i < n; i++) {
        double v = img->pixels[(size_t)img->channels * i + (size_t)c];
        s += v;
        s2 += v * v;
    }
    *mean = s / (double)n;
    double var = s2 / (double)n - *mean * *mean;
    *se = sqrt(fmax(var, 0.0) / (double)(n - 1));
}

/* Renders text and checks each channel's pixel mean against expect[c]. */
static void expect_render(const char *what, const char *text, const double expect[3])
{
    op_image img = op_test_render_image(op_test_write_temp("scene.xml", text), 0, 2, 0);
    for (int c = 0; c < 3; c++) {
        double mean, se;
        pixel_stats(&img, c, &mean, &se);
        double tol = 4.5 * se + 0.003 * expect[c] + 1e-6;
        printf("%s, channel %d: %.5f +- %.5f, expected %.5f\n", what, c, mean, se, expect[c]);
        if (fabs(mean - expect[c]) > tol) {
            op_image_free(&img);
            fail_msg("%s, channel %d: %.5f, expected %.5f (tolerance %.5f)", what, c, mean,
                     expect[c], tol);
        }
    }
    op_image_free(&img);
}

/* A box [-L, L]^2 x [z0, z1] of medium `medium` (its inner XML) with boundary `boundary`. */
static void box(char *out, size_t cap, double L, double z0, double z1, const char *medium,
                const char *boundary)
{
    int n = snprintf(out, cap,
                     "<shape type=\"cube\"><transform name=\"toWorld\">"
                     "<scale x=\"%g\" y=\"%g\" z=\"%g\"/><translate z=\"%g\"/></transform>"
                     "%s<medium type=\"homogeneous\" name=\"interior\">%s</medium></shape>",
                     L, L, 0.5 * (z1 - z0), 0.5 * (z1 + z0), boundary, medium);
    assert_true(n > 0 && n < (int)cap);
}

static const char *sky = "<emitter type=\"constant\"><rgb name=\"radiance\" value=\"1\"/></emitter>";

static void test_beer_lambert(void **state)
{
    (void)state;
    const double sa[3] = {0.5, 1.0, 2.0}, d = 1.2;
    char slab[1024], body[4096];
    box(slab, sizeof slab, 50.0, 0.0, d,
        "<rgb name=\"sigmaA\" value=\"0.5, 1, 2\"/><rgb name=\"sigmaS\" value=\"0\"/>", "");
    /* looking up through the slab at the sky */
    snprintf(body, sizeof body, "%s%s", slab, sky);
    double e[3];
    for (int c = 0; c < 3; c++)
        e[c] = exp(-sa[c] * d);
    expect_render("sky through the slab", scene_text("volpath", "0,0,-1", "0,0,1", 16, 1024, body),
                  e);
    /* a floor of albedo 0.5 under the slab, lit straight down (irradiance 3): the camera above
     * sees rho E / pi through the slab twice (the shadow ray's transmittance once) */
    snprintf(body, sizeof body,
             "%s<shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"100\"/>"
             "<translate z=\"-0.5\"/></transform><bsdf type=\"diffuse\">"
             "<rgb name=\"reflectance\" value=\"0.5\"/></bsdf></shape>"
             "<emitter type=\"directional\"><vector name=\"direction\" value=\"0,0,-1\"/>"
             "<rgb name=\"irradiance\" value=\"3\"/></emitter>",
             slab);
    for (int c = 0; c < 3; c++)
        e[c] = 0.5 * 3.0 / M_PI * exp(-2.0 * sa[c] * d);
    expect_render("floor under the slab", scene_text("volpath", "0,0,3", "0,0,0", 16, 1024, body),
                  e);
}

/* A slab z in [0, d] (|x|, |y| < 50) of heterogeneous pure absorber, index-matched, whose
 * extinction rises linearly with z from a to a + b per channel (a Mitsuba 0.6 gridvolume):
 * the sky through it and a floor lit through it show exp(-d (a + b / 2)) (ratio tracking on
 * the shadow ray, delta tracking on the camera's). */
static void test_heterogeneous_beer_lambert(void **state)
{
    (void)state;
    const double a[3] = {0.2, 0.5, 1.0}, b[3] = {1.0, 0.2, 0.6}, d = 1.2;
    unsigned char vol[48 + 2 * 2 * 5 * 3 * 4];
    int32_t hdr[5] = {1, 2, 2, 5, 3};
    float bbox[6] = {-50, -50, 0, 50, 50, (float)d}, *v = (float *)(void *)(vol + 48);
    memcpy(vol, "VOL\3", 4);
    memcpy(vol + 4, hdr, sizeof hdr);
    memcpy(vol + 24, bbox, sizeof bbox);
    for (int i = 0; i < 20; i++)
        for (int c = 0; c < 3; c++)
            v[3 * i + c] = (float)(a[c] + b[c] * (i / 4) / 4.0);
    const char *path = op_test_tmp_path("ramp.vol");
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(vol, 1, sizeof vol, f), sizeof vol);
    fclose(f);
    char slab[2048], body[4096];
    snprintf(slab, sizeof slab,
             "<shape type=\"cube\"><transform name=\"toWorld\"><scale x=\"50\" y=\"50\" "
             "z=\"%g\"/><translate z=\"%g\"/></transform><medium type=\"heterogeneous\" "
             "name=\"interior\"><volume name=\"density\" type=\"gridvolume\"><string "
             "name=\"filename\" value=\"%s\"/></volume><volume name=\"albedo\" "
             "type=\"constvolume\"><rgb name=\"value\" value=\"0\"/></volume></medium></shape>",
             0.5 * d, 0.5 * d, path);
    double e[3];
    snprintf(body, sizeof body, "%s%s", slab, sky);
    for (int c = 0; c < 3; c++)
        e[c] = exp(-d * (a[c] + 0.5 * b[c]));
    expect_render("sky through the heterogeneous slab",
                  scene_text("volpath", "0,0,-1", "0,0,1", 16, 1024, body), e);
    snprintf(body, sizeof body,
             "%s<shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"100\"/>"
             "<translate z=\"-0.5\"/></transform><bsdf type=\"diffuse\">"
             "<rgb name=\"reflectance\" value=\"0.5\"/></bsdf></shape>"
             "<emitter type=\"directional\"><vector name=\"direction\" value=\"0,0,-1\"/>"
             "<rgb name=\"irradiance\" value=\"3\"/></emitter>",
             slab);
    for (int c = 0; c < 3; c++)
        e[c] = 0.5 * 3.0 / M_PI * exp(-2.0 * d * (a[c] + 0.5 * b[c]));
    expect_render("floor under the heterogeneous slab",
                  scene_text("volpath", "0,0,3", "0,0,0", 16, 1024, body), e);
}

static void test_camera_inside(void **state)
{
    (void)state;
    /* the sensor sits in the slab's medium (referenced by both) at depth 0.5 of 1.2, looking
     * up at the sky: exp(-sigma_a 0.7) */
    const char *text =
        "<scene version=\"0.6.0\"><integrator type=\"volpath\"/>"
        "<medium type=\"homogeneous\" id=\"ink\"><rgb name=\"sigmaA\" value=\"0.5, 1, 2\"/>"
        "<rgb name=\"sigmaS\" value=\"0\"/></medium>"
        "<sensor type=\"radiancemeter\"><transform name=\"toWorld\">"
        "<lookat origin=\"0,0,0.5\" target=\"0,0,1\" up=\"0,1,0\"/></transform>"
        "<ref id=\"ink\" name=\"medium\"/>"
        "<sampler type=\"independent\"><integer name=\"sampleCount\" value=\"256\"/>"
        "</sampler><film type=\"hdrfilm\"><integer name=\"width\" value=\"16\"/>"
        "<integer name=\"height\" value=\"16\"/><rfilter type=\"box\"/></film></sensor>"
        "<shape type=\"cube\"><transform name=\"toWorld\"><scale x=\"50\" y=\"50\" "
        "z=\"0.6\"/><translate z=\"0.6\"/></transform><ref id=\"ink\" name=\"interior\"/>"
        "</shape><emitter type=\"constant\"><rgb name=\"radiance\" value=\"1\"/></emitter>"
        "</scene>";
    const double e[3] = {exp(-0.5 * 0.7), exp(-1.0 * 0.7), exp(-2.0 * 0.7)};
    expect_render("camera inside the slab", text, e);
}

static void test_furnace(void **state)
{
    (void)state;
    const char *medium = "<rgb name=\"sigmaT\" value=\"1, 3, 8\"/><rgb name=\"albedo\" "
                         "value=\"1\"/><phase type=\"hg\"><float name=\"g\" value=\"0.6\"/>"
                         "</phase>";
    const char *boundaries[] = {"", "<bsdf type=\"null\"/>",
                                "<bsdf type=\"dielectric\"><float name=\"intIOR\" "
                                "value=\"1.5\"/></bsdf>"};
    const char *names[] = {"furnace, no bsdf", "furnace, null bsdf", "furnace, dielectric"};
    for (int k = 0; k < 3; k++) {
        char body[4096];
        snprintf(body, sizeof body,
                 "<shape type=\"sphere\"><float name=\"radius\" value=\"1\"/>%s"
                 "<medium type=\"homogeneous\" name=\"interior\">%s</medium></shape>%s",
                 boundaries[k], medium, sky);
        const double one[3] = {1.0, 1.0, 1.0};
        /* off-centre, so rays cross the sphere at a slant */
        expect_render(names[k], scene_text("volpath", "0.4,0.3,3", "0.4,0.3,0", 16, 256, body),
                      one);
    }
}

/* Chandrasekhar's H-function for isotropic scattering of single-scattering albedo w at mu = 1,
 * solved by iterating its integral equation in the form
 *   1 / H(mu) = sqrt(1 - w) + (w / 2) int_0^1 mu' H(mu') / (mu + mu') dmu'
 * (Chandrasekhar 1960, Radiative Transfer, eq. V.(11) with the characteristic function w / 2)
 * on a midpoint grid. Checks its zeroth moment int_0^1 H = (2 / w) (1 - sqrt(1 - w)). */
static double chandrasekhar_h1(double w)
{
    enum { N = 800 };
    static double mu[N + 1], h[N + 1];
    for (int i = 0; i < N; i++)
        mu[i] = (i + 0.5) / N;
    mu[N] = 1.0;
    for (int i = 0; i <= N; i++)
        h[i] = 1.0;
    for (int it = 0; it < 2000; it++) {
        double change = 0.0;
        for (int i = 0; i <= N; i++) {
            double integral = 0.0;
            for (int j = 0; j < N; j++)
                integral += mu[j] * h[j] / (mu[i] + mu[j]);
            double hn = 1.0 / (sqrt(1.0 - w) + 0.5 * w * integral / N);
            change = fmax(change, fabs(hn - h[i]));
            h[i] = hn;
        }
        if (change < 1e-12)
            break;
    }
    double h0 = 0.0;
    for (int j = 0; j < N; j++)
        h0 += h[j] / N;
    double want = 2.0 / w * (1.0 - sqrt(1.0 - w));
    if (fabs(h0 - want) > 1e-4 * want)
        fail_msg("H-function for w = %g: zeroth moment %.6f, expected %.6f", w, h0, want);
    return h[N];
}

/* A half-space z < 0 (a box 2000 wide, 60 deep: light that reaches its other faces is
 * negligible) of isotropic medium of albedo w and extinction 1, index-matched. */
static void half_space(char *out, size_t cap, double w)
{
    char medium[256];
    snprintf(medium, sizeof medium, "<float name=\"sigmaT\" value=\"1\"/>"
                                    "<float name=\"albedo\" value=\"%.17g\"/>", w);
    box(out, cap, 1000.0, -60.0, 0.0, medium, "");
}

static void test_half_space_sky(void **state)
{
    (void)state;
    /* Under a uniform sky of radiance 1 the radiance leaving towards mu is, by reciprocity,
     * the plane albedo for incidence mu: A(mu) = 1 - sqrt(1 - w) H(mu) (Chandrasekhar 1960,
     * the plane albedo of a semi-infinite atmosphere scattering isotropically; it follows from
     * the reflection function below and the integral equation of H). Here mu = 1. */
    const double ws[2] = {0.9, 0.99};
    for (int k = 0; k < 2; k++) {
        char hs[1024], body[2048], what[64];
        half_space(hs, sizeof hs, ws[k]);
        snprintf(body, sizeof body, "%s%s", hs, sky);
        double a = 1.0 - sqrt(1.0 - ws[k]) * chandrasekhar_h1(ws[k]);
        const double e[3] = {a, a, a};
        snprintf(what, sizeof what, "half-space albedo %g under the sky", ws[k]);
        expect_render(what, scene_text("volpath", "0,0,1", "0,0,0", 16, 512, body), e);
    }
}

static void test_half_space_directional(void **state)
{
    (void)state;
    /* Lit at normal incidence with irradiance E (pi F in Chandrasekhar's notation), the
     * radiance reflected towards mu is (w F / 4) mu0 / (mu + mu0) H(mu) H(mu0) (Chandrasekhar
     * 1960, the diffuse reflection of a semi-infinite isotropic atmosphere); at mu = mu0 = 1:
     * w E H(1)^2 / (8 pi). Every scattering event's light comes by next-event estimation. */
    const double w = 0.9, E = 2.0;
    char hs[1024], body[2048];
    half_space(hs, sizeof hs, w);
    snprintf(body, sizeof body,
             "%s<emitter type=\"directional\"><vector name=\"direction\" value=\"0,0,-1\"/>"
             "<rgb name=\"irradiance\" value=\"%g\"/></emitter>", hs, E);
    double h = chandrasekhar_h1(w), l = w * E * h * h / (8.0 * M_PI);
    const double e[3] = {l, l, l};
    expect_render("half-space under a directional light",
                  scene_text("volpath", "0,0,1", "0,0,0", 16, 256, body), e);
}

static void test_path_ignores_media_and_refusals(void **state)
{
    (void)state;
    /* path: the absorbing slab is not there (Mitsuba's path ignores media) */
    char slab[1024], body[2048];
    box(slab, sizeof slab, 50.0, 0.0, 1.0, "<rgb name=\"sigmaA\" value=\"2\"/>", "");
    snprintf(body, sizeof body, "%s%s", slab, sky);
    const double one[3] = {1.0, 1.0, 1.0};
    expect_render("path through a medium", scene_text("path", "0,0,-1", "0,0,1", 4, 4, body), one);
    /* a heterogeneous medium without its density volume is refused, naming its line */
    snprintf(body, sizeof body,
             "<shape type=\"sphere\"><medium type=\"heterogeneous\" name=\"interior\"/></shape>");
    op_scene *s = NULL;
    op_error err;
    op_status st = op_scene_load(op_test_write_temp("bad.xml",
                                                    scene_text("volpath", "0,0,3", "0,0,0", 1, 1,
                                                               body)),
                                 NULL, 0, &s, &err);
    assert_int_equal(st, OP_ERR_INPUT);
    printf("refused: %s\n", err.message);
    assert_non_null(strstr(err.message, ".xml:1: <medium type=\"heterogeneous\" "
                                         "name=\"interior\">: no density volume"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_beer_lambert),
        cmocka_unit_test(test_heterogeneous_beer_lambert),
        cmocka_unit_test(test_camera_inside),
        cmocka_unit_test(test_furnace),
        cmocka_unit_test(test_half_space_sky),
        cmocka_unit_test(test_half_space_directional),
        cmocka_unit_test(test_path_ignores_media_and_refusals),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
