/* test_render_mask.c - the mask BSDF (Mitsuba's cut-out opacity): a fully transparent shape
 * leaves the image unchanged and casts no shadow, opacity 0.5 halves both its shadow and its
 * coverage within noise, the result does not depend on the thread count, and an area light
 * wearing a transparent mask is invisible from behind (the add-on's Cycles lights); with
 * visibleToCamera=false it is not seen directly but still lights the scene and shows in mirrors. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "opaline_render.h"
#include "test_support.h"

#define RES 48

/* Renders scene text (written to a temporary file) with spp samples and threads workers;
 * returns the renderer, which owns the image. */
static op_renderer *render_text(const char *text, int spp, int threads)
{
    op_renderer *r = op_test_render(op_test_write_temp("scene.xml", text), spp, threads, 0);
    const op_image *img = op_renderer_image(r);
    assert_non_null(img);
    assert_int_equal(img->width, RES);
    assert_int_equal(img->height, RES);
    return r;
}

/* The camera looks straight down from z = 4 (fov 60, +x to the right of the image) at a plane
 * z = 0 of albedo 0.6; `extra` adds objects. */
static op_renderer *render_plane(const char *integrator, const char *extra, int spp, int threads)
{
    char text[4096];
    int n = snprintf(
        text, sizeof text,
        "<scene version=\"0.6.0\">"
        " <integrator type=\"%s\"/>"
        " <sensor type=\"perspective\"><float name=\"fov\" value=\"60\"/>"
        "  <transform name=\"toWorld\"><lookat origin=\"0,0,4\" target=\"0,0,0\" up=\"0,1,0\"/>"
        "  </transform>"
        "  <film type=\"hdrfilm\"><integer name=\"width\" value=\"%d\"/>"
        "   <integer name=\"height\" value=\"%d\"/><rfilter type=\"box\"/></film></sensor>"
        " <shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"10\"/></transform>"
        "  <bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.6\"/></bsdf></shape>"
        "%s</scene>",
        integrator, RES, RES, extra);
    assert_true(n > 0 && n < (int)sizeof text);
    return render_text(text, spp, threads);
}

/* A point light at (0.6, 0, 2) and, unless opacity is NULL, a black 0.6 x 0.6 square at z = 1
 * centred on (-0.8, 0) wearing a mask of that opacity. The camera sees the square over world
 * x in [-1.47, -0.67] of the plane; the light throws its shadow onto x in [-2.8, -1.6]: the two
 * footprints are disjoint, split at x = -1.535. */
static op_renderer *render_occluder(const char *opacity, int threads)
{
    char extra[1024];
    int n = snprintf(
        extra, sizeof extra,
        " <emitter type=\"point\"><point name=\"position\" x=\"0.6\" y=\"0\" z=\"2\"/>"
        "  <rgb name=\"intensity\" value=\"10\"/></emitter>"
        "%s%s%s",
        opacity ? " <shape type=\"rectangle\"><transform name=\"toWorld\">"
                  "  <scale value=\"0.3\"/><translate x=\"-0.8\" y=\"0\" z=\"1\"/></transform>"
                  "  <bsdf type=\"mask\"><float name=\"opacity\" value=\""
                : "",
        opacity ? opacity : "",
        opacity ? "\"/><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0\"/></bsdf>"
                  "  </bsdf></shape>"
                : "");
    assert_true(n > 0 && n < (int)sizeof extra);
    return render_plane("path", extra, 64, threads);
}

/* World x on the plane z = 0 of pixel column x. */
static double world_x(int x)
{
    return 4.0 * tan(30.0 * M_PI / 180.0) * (2.0 * (x + 0.5) / RES - 1.0);
}

/* Sums channel 0 of a - b over the shadow side (world x < -1.535) and the rest. */
static void effect(const op_image *a, const op_image *b, double *shadow, double *cover)
{
    *shadow = *cover = 0.0;
    for (int y = 0; y < RES; y++)
        for (int x = 0; x < RES; x++) {
            size_t i = 4 * ((size_t)y * RES + (size_t)x);
            double d = (double)a->pixels[i] - (double)b->pixels[i];
            if (world_x(x) < -1.535)
                *shadow += d;
            else
                *cover += d;
        }
}

static void test_transparent_and_half(void **state)
{
    (void)state;
    op_renderer *ref = render_occluder(NULL, 2);
    op_renderer *clear = render_occluder("0", 2);
    op_renderer *opaque = render_occluder("1", 2);
    op_renderer *half = render_occluder("0.5", 2);
    const op_image *ir = op_renderer_image(ref), *ic = op_renderer_image(clear);
    const op_image *io = op_renderer_image(opaque), *ih = op_renderer_image(half);

    /* fully transparent: the same image, pixel by pixel (only the rays' origins move) */
    double worst = 0.0;
    for (size_t i = 0; i < (size_t)RES * RES * 4; i++) {
        double d = fabs((double)ic->pixels[i] - (double)ir->pixels[i]);
        double rel = d / (fabs((double)ir->pixels[i]) + 1e-6);
        if (rel > worst)
            worst = rel;
    }
    if (worst > 1e-3)
        fail_msg("opacity 0: worst relative pixel difference %.3g to no occluder", worst);

    /* opaque: a black square and a shadow, both large */
    double so, co, sh, ch, sc, cc;
    effect(ir, io, &so, &co);
    effect(ir, ih, &sh, &ch);
    effect(ir, ic, &sc, &cc);
    double total = 0.0;
    for (size_t i = 0; i < (size_t)RES * RES; i++)
        total += ir->pixels[4 * i];
    if (!(so > 0.02 * total && co > 0.02 * total))
        fail_msg("opaque occluder: shadow %.4g, coverage %.4g of %.4g: the test scene is wrong",
                 so, co, total);
    /* opacity 0.5: half the shadow (exactly: shadow rays take the transmittance) and half the
     * coverage (camera rays pass with probability 1/2: noise) */
    print_message("opacity 0: worst pixel difference %.3g; opacity 0.5: shadow effect %.4f, "
                  "coverage effect %.4f of the opaque ones\n", worst, sh / so, ch / co);
    if (fabs(sh / so - 0.5) > 0.005)
        fail_msg("opacity 0.5: shadow effect %.4f of the opaque one, expected 0.5", sh / so);
    if (fabs(ch / co - 0.5) > 0.05)
        fail_msg("opacity 0.5: coverage effect %.4f of the opaque one, expected 0.5", ch / co);
    if (fabs(sc) > 1e-4 * so || fabs(cc) > 1e-4 * co)
        fail_msg("opacity 0: effects %.3g, %.3g", sc, cc);

    /* the stochastic pass-through uses the pixels' own streams: threads do not matter */
    op_renderer *half1 = render_occluder("0.5", 1);
    const op_image *ih1 = op_renderer_image(half1);
    assert_memory_equal(ih->pixels, ih1->pixels, (size_t)RES * RES * 4 * sizeof(float));

    op_renderer_free(ref);
    op_renderer_free(clear);
    op_renderer_free(opaque);
    op_renderer_free(half);
    op_renderer_free(half1);
}

/* Radiance of the plane (albedo 0.6) at (px, py, 0) under a downward disk light of radius r,
 * radiance le at height h: rho / pi * E by a midpoint rule over the disk (polar cells). */
static double disk_lit_plane(double px, double py, double r, double h, double le)
{
    const int n = 100;
    double e = 0.0;
    for (int i = 0; i < n; i++) {
        double rr = r * (i + 0.5) / n;
        for (int j = 0; j < n; j++) {
            double ph = 2.0 * M_PI * (j + 0.5) / n;
            double dx = rr * cos(ph) - px, dy = rr * sin(ph) - py, d2 = dx * dx + dy * dy + h * h;
            e += le * h * h / (d2 * d2) * rr * (r / n) * (2.0 * M_PI / n);
        }
    }
    return 0.6 / M_PI * e;
}

static void test_area_light_from_behind(void **state)
{
    (void)state;
    /* A disk light of radius 0.5 and radiance 5 at height 1 facing down, wearing a transparent
     * mask, seen from above (its back): the plane below it shows through, lit by the disk
     * (L = rho Le R^2 / (h^2 + R^2) = 0.6 right under the centre). */
    const char *extra =
        " <shape type=\"disk\"><transform name=\"toWorld\"><scale value=\"0.5\"/>"
        "  <rotate x=\"1\" angle=\"180\"/><translate z=\"1\"/></transform>"
        "  <emitter type=\"area\"><rgb name=\"radiance\" value=\"5\"/></emitter>"
        "  <bsdf type=\"mask\"><float name=\"opacity\" value=\"0\"/></bsdf></shape>";
    op_renderer *r = render_plane("direct", extra, 256, 2);
    const op_image *img = op_renderer_image(r);
    double sum = 0.0, expect = 0.0;
    int n = 0;
    for (int y = RES / 2 - 2; y < RES / 2 + 2; y++)
        for (int x = RES / 2 - 2; x < RES / 2 + 2; x++) {
            sum += img->pixels[4 * (y * RES + x)];
            expect += disk_lit_plane(world_x(x), -world_x(y), 0.5, 1.0, 5.0);
            n++;
        }
    sum /= n;
    expect /= n;
    print_message("area light from behind: centre %.4f, expected %.4f\n", sum, expect);
    op_renderer_free(r);
    /* pixel footprints and the 96-gon make the image ~0.6 % darker than at pixel centres */
    if (fabs(sum / expect - 1.0) > 0.02)
        fail_msg("area light seen from behind: centre %.4f, expected %.4f", sum, expect);
}

/* The mean of channel 0 over the 4 x 4 centre pixels of img. */
static double centre_mean(const op_image *img)
{
    double sum = 0.0;
    for (int y = RES / 2 - 2; y < RES / 2 + 2; y++)
        for (int x = RES / 2 - 2; x < RES / 2 + 2; x++)
            sum += img->pixels[4 * (y * RES + x)];
    return sum / 16.0;
}

/* The camera looks down from z = 4 at a mirror (reflectance 0.5) at z = 0 with a disk light of
 * radius 0.5 and radiance 5 at z = 1 facing up (flip = 0: toward the camera) or down (flip = 1:
 * toward the mirror), visible to the camera or not. */
static op_renderer *render_disk_mirror(int flip, int visible)
{
    char text[4096];
    int n = snprintf(
        text, sizeof text,
        "<scene version=\"0.6.0\">"
        " <integrator type=\"path\"/>"
        " <sensor type=\"perspective\"><float name=\"fov\" value=\"60\"/>"
        "  <transform name=\"toWorld\"><lookat origin=\"0,0,4\" target=\"0,0,0\" up=\"0,1,0\"/>"
        "  </transform>"
        "  <film type=\"hdrfilm\"><integer name=\"width\" value=\"%d\"/>"
        "   <integer name=\"height\" value=\"%d\"/><rfilter type=\"box\"/></film></sensor>"
        " <shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"10\"/></transform>"
        "  <bsdf type=\"conductor\"><string name=\"material\" value=\"none\"/>"
        "   <rgb name=\"specularReflectance\" value=\"0.5\"/></bsdf></shape>"
        " <shape type=\"disk\"><transform name=\"toWorld\"><scale value=\"0.5\"/>"
        "  <rotate x=\"1\" angle=\"%d\"/><translate z=\"1\"/></transform>"
        "  <emitter type=\"area\"><rgb name=\"radiance\" value=\"5\"/>"
        "   <boolean name=\"visibleToCamera\" value=\"%s\"/></emitter>"
        "  <bsdf type=\"mask\"><float name=\"opacity\" value=\"0\"/></bsdf></shape>"
        "</scene>",
        RES, RES, flip ? 180 : 0, visible ? "true" : "false");
    assert_true(n > 0 && n < (int)sizeof text);
    return render_text(text, 4, 2);
}

static void test_area_light_hidden_from_camera(void **state)
{
    (void)state;
    /* facing the camera: seen directly (5) unless hidden (then the black sky in the mirror) */
    op_renderer *up_vis = render_disk_mirror(0, 1), *up_hid = render_disk_mirror(0, 0);
    /* facing the mirror: seen only in it (0.5 * 5), hidden or not */
    op_renderer *dn_vis = render_disk_mirror(1, 1), *dn_hid = render_disk_mirror(1, 0);
    double uv = centre_mean(op_renderer_image(up_vis)), uh = centre_mean(op_renderer_image(up_hid));
    double dv = centre_mean(op_renderer_image(dn_vis)), dh = centre_mean(op_renderer_image(dn_hid));
    print_message("disk light centre: facing camera %.4f (hidden %.4f), facing mirror %.4f "
                  "(hidden %.4f)\n", uv, uh, dv, dh);
    if (fabs(uv - 5.0) > 1e-3 || uh != 0.0)
        fail_msg("disk facing the camera: %.4f visible, %.4f hidden; expected 5 and 0", uv, uh);
    if (fabs(dv - 2.5) > 1e-3 || fabs(dh - 2.5) > 1e-3)
        fail_msg("disk seen in the mirror: %.4f visible, %.4f hidden; expected 2.5", dv, dh);
    op_renderer_free(up_vis);
    op_renderer_free(up_hid);
    op_renderer_free(dn_vis);
    op_renderer_free(dn_hid);

    /* it still lights the scene: the disk from test_area_light_from_behind, hidden */
    const char *extra =
        " <shape type=\"disk\"><transform name=\"toWorld\"><scale value=\"0.5\"/>"
        "  <rotate x=\"1\" angle=\"180\"/><translate z=\"1\"/></transform>"
        "  <emitter type=\"area\"><rgb name=\"radiance\" value=\"5\"/>"
        "   <boolean name=\"visibleToCamera\" value=\"false\"/></emitter>"
        "  <bsdf type=\"mask\"><float name=\"opacity\" value=\"0\"/></bsdf></shape>";
    op_renderer *r = render_plane("direct", extra, 64, 2);
    double got = centre_mean(op_renderer_image(r)), expect = 0.0;
    for (int y = RES / 2 - 2; y < RES / 2 + 2; y++)
        for (int x = RES / 2 - 2; x < RES / 2 + 2; x++)
            expect += disk_lit_plane(world_x(x), -world_x(y), 0.5, 1.0, 5.0) / 16.0;
    op_renderer_free(r);
    if (fabs(got / expect - 1.0) > 0.03)
        fail_msg("hidden area light: plane centre %.4f, expected %.4f", got, expect);
}

static void test_mask_parse(void **state)
{
    (void)state;
    /* an rgb opacity and a mask without a nested bsdf are valid; a twosided mask too */
    op_renderer *r = render_plane(
        "direct",
        " <emitter type=\"point\"><point name=\"position\" x=\"0\" y=\"0\" z=\"2\"/>"
        "  <rgb name=\"intensity\" value=\"1\"/></emitter>"
        " <shape type=\"sphere\"><float name=\"radius\" value=\"0.2\"/>"
        "  <bsdf type=\"twosided\"><bsdf type=\"mask\"><rgb name=\"opacity\" value=\"0 0 0\"/>"
        "  </bsdf></bsdf></shape>",
        4, 2);
    const op_image *img = op_renderer_image(r);
    /* the transparent sphere under the light neither shows nor shadows the centre */
    const float *c = img->pixels + 4 * ((RES / 2) * RES + RES / 2);
    double expect = 0.6 / M_PI * 1.0 / 4.0;
    if (fabs(c[0] / expect - 1.0) > 0.02)
        fail_msg("transparent sphere: centre %.5f, expected %.5f", c[0], expect);
    op_renderer_free(r);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_transparent_and_half),
        cmocka_unit_test(test_area_light_from_behind),
        cmocka_unit_test(test_area_light_hidden_from_camera),
        cmocka_unit_test(test_mask_parse),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
