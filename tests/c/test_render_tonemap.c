/* test_render_tonemap.c - ldrfilm's tonemapMethod="reinhard" (Mitsuba 0.6): the PNG written
 * holds Reinhard's operator applied to the rendered image (checked against an independent
 * double-precision implementation of Mitsuba's formula, within 8-bit rounding), the brightest
 * pixel maps to luminance 1 when burn = 0, burn = 1 burns every lit pixel out to white, and
 * bad key / burn / tonemapMethod values are rejected. And hdrfilm's fileFormat="rgbe": a .hdr
 * file (Radiance header, flat RGBE scanlines from the top) holding the image within RGBE's
 * precision, named by the film's default extension. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "opaline_render.h"
#include "test_support.h"

#define RES 24

/* A plane lit by a point light close to it: luminance falls off strongly across the image. */
static const char *scene_text(const char *film_extra)
{
    static char text[2048];
    int n = snprintf(
        text, sizeof text,
        "<scene version=\"0.6.0\"><integrator type=\"direct\"/>"
        " <sensor type=\"perspective\"><float name=\"fov\" value=\"60\"/>"
        "  <transform name=\"toWorld\"><lookat origin=\"0,0,4\" target=\"0,0,0\" up=\"0,1,0\"/>"
        "  </transform><film type=\"ldrfilm\"><integer name=\"width\" value=\"%d\"/>"
        "   <integer name=\"height\" value=\"%d\"/><rfilter type=\"box\"/>%s</film></sensor>"
        " <shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"10\"/></transform>"
        "  <bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.7, 0.5, "
        "0.3\"/></bsdf></shape>"
        " <emitter type=\"point\"><point name=\"position\" x=\"1\" y=\"0.5\" z=\"0.5\"/>"
        "  <rgb name=\"intensity\" value=\"20\"/></emitter>"
        "</scene>",
        RES, RES, film_extra);
    assert_true(n > 0 && n < (int)sizeof text);
    return text;
}

static double srgb_encode(double v)
{
    v = v < 0.0 ? 0.0 : (v > 1.0 ? 1.0 : v);
    return v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1.0 / 2.4) - 0.055;
}

/* Mitsuba's tonemapReinhard over the RGBA image, in doubles, into out (RGB). */
static void reference_reinhard(const op_image *img, double key, double burn, double *out)
{
    size_t n = (size_t)img->width * img->height;
    double lsum = 0.0, lmax = 0.0;
    for (size_t i = 0; i < n; i++) {
        const float *p = img->pixels + 4 * i;
        double y = p[0] * 0.212671 + p[1] * 0.715160 + p[2] * 0.072169;
        lmax = fmax(lmax, y);
        lsum += log(1e-3 + y);
    }
    double avg = exp(lsum / n);
    burn = fmin(1.0, fmax(1e-8, 1.0 - burn));
    double scale = key / avg, lw = lmax * scale, inv = 1.0 / (lw * lw * pow(burn, 4.0));
    for (size_t i = 0; i < n; i++) {
        const float *p = img->pixels + 4 * i;
        double X = p[0] * 0.412453 + p[1] * 0.357580 + p[2] * 0.180423;
        double Y = p[0] * 0.212671 + p[1] * 0.715160 + p[2] * 0.072169;
        double Z = p[0] * 0.019334 + p[1] * 0.119193 + p[2] * 0.950227;
        double *o = out + 3 * i;
        if (X + Y + Z <= 0.0) {
            o[0] = o[1] = o[2] = 0.0;
            continue;
        }
        double x = X / (X + Y + Z), y = Y / (X + Y + Z), lp = Y * scale;
        Y = lp * (1.0 + lp * inv) / (1.0 + lp);
        X = Y / y * x;
        Z = Y / y * (1.0 - x - y);
        o[0] = 3.240479 * X - 1.537150 * Y - 0.498535 * Z;
        o[1] = -0.969256 * X + 1.875991 * Y + 0.041556 * Z;
        o[2] = 0.055648 * X - 0.204043 * Y + 1.057311 * Z;
    }
}

/* Renders the scene with film_extra, writes it as PNG, reads the PNG back (linear) into *png
 * and the HDR render into *hdr. */
static void render_png(const char *film_extra, op_image *hdr, op_image *png)
{
    const char *xml = op_test_write_temp("tm.xml", scene_text(film_extra));
    *hdr = op_test_render_image(xml, 4, 2, 1);
    op_scene *sc = NULL;
    op_error err;
    OP_ASSERT_OK(op_scene_load(xml, NULL, 0, &sc, &err), err);
    const char *path = op_test_tmp_path("tm.png");
    OP_ASSERT_OK(op_scene_write_image(sc, hdr, path, &err), err);
    OP_ASSERT_OK(op_image_read(path, png, &err), err);
    op_scene_free(sc);
}

/* The largest difference, in 8-bit sRGB steps, between png and the reference. */
static double max_step_error(const op_image *png, const double *ref)
{
    double worst = 0.0;
    for (int i = 0; i < png->width * png->height; i++)
        for (int c = 0; c < 3; c++) {
            double got = srgb_encode(png->pixels[png->channels * i + c]);
            double want = srgb_encode(ref[3 * i + c]);
            worst = fmax(worst, fabs(got - want) * 255.0);
        }
    return worst;
}

static void test_reinhard_matches_mitsuba(void **state)
{
    (void)state;
    const double keys[2] = {0.18, 0.5}, burns[2] = {0.0, 0.3};
    for (int k = 0; k < 2; k++) {
        char extra[256];
        snprintf(extra, sizeof extra,
                 "<string name=\"tonemapMethod\" value=\"reinhard\"/>"
                 "<float name=\"key\" value=\"%g\"/><float name=\"burn\" value=\"%g\"/>"
                 "<float name=\"exposure\" value=\"5\"/>", /* ignored by reinhard */
                 keys[k], burns[k]);
        op_image hdr, png;
        render_png(extra, &hdr, &png);
        double *ref = malloc(sizeof(double) * 3 * RES * RES);
        assert_non_null(ref);
        reference_reinhard(&hdr, keys[k], burns[k], ref);
        double worst = max_step_error(&png, ref);
        print_message("reinhard key %g burn %g: worst error %.2f 8-bit steps\n", keys[k], burns[k],
                      worst);
        if (worst > 1.01)
            fail_msg("reinhard key %g burn %g: PNG differs from Mitsuba's operator by %.2f steps",
                     keys[k], burns[k], worst);
        if (k == 0) {
            /* burn 0: the brightest pixel's luminance maps to exactly 1 */
            int best = 0;
            double bl = -1.0;
            for (int i = 0; i < RES * RES; i++) {
                const float *p = hdr.pixels + 4 * i;
                double y = p[0] * 0.212671 + p[1] * 0.715160 + p[2] * 0.072169;
                if (y > bl) {
                    bl = y;
                    best = i;
                }
            }
            const double *o = ref + 3 * best;
            double y = o[0] * 0.212671 + o[1] * 0.715160 + o[2] * 0.072169;
            assert_true(fabs(y - 1.0) < 1e-3);
            /* and the tonemapped image is not the plain clamp of the gamma method */
            op_image hdr2, png2;
            render_png("", &hdr2, &png2);
            double diff = 0.0;
            for (int i = 0; i < RES * RES * png.channels; i++)
                diff = fmax(diff, fabs(png.pixels[i] - png2.pixels[i]));
            assert_true(diff > 0.05);
            op_image_free(&hdr2);
            op_image_free(&png2);
        }
        free(ref);
        op_image_free(&hdr);
        op_image_free(&png);
    }
    /* burn 1: every lit pixel is white */
    op_image hdr, png;
    render_png("<string name=\"tonemapMethod\" value=\"reinhard\"/>"
               "<float name=\"burn\" value=\"1\"/>",
               &hdr, &png);
    for (int i = 0; i < RES * RES; i++)
        if (hdr.pixels[4 * i] > 1e-4f)
            assert_true(png.pixels[png.channels * i + 1] > 0.99f);
    op_image_free(&hdr);
    op_image_free(&png);
}

static void test_reinhard_bad_values(void **state)
{
    (void)state;
    const char *bad[3] = {"<string name=\"tonemapMethod\" value=\"filmic\"/>",
                          "<string name=\"tonemapMethod\" value=\"reinhard\"/>"
                          "<float name=\"key\" value=\"0\"/>",
                          "<string name=\"tonemapMethod\" value=\"reinhard\"/>"
                          "<float name=\"burn\" value=\"1.5\"/>"};
    for (int i = 0; i < 3; i++) {
        op_scene *sc = NULL;
        op_error err;
        op_status st =
            op_scene_load(op_test_write_temp("bad.xml", scene_text(bad[i])), NULL, 0, &sc, &err);
        assert_int_equal(st, OP_ERR_INPUT);
        assert_null(sc);
        assert_non_null(strstr(err.message, "<film>"));
    }
}

/* Reads a flat RGBE file as written by the renderer into rgb (w * h * 3 floats, malloc'ed). */
static float *read_rgbe(const char *path, int *w, int *h)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    char line[256];
    assert_non_null(fgets(line, sizeof line, f));
    assert_string_equal(line, "#?RADIANCE\n");
    int format = 0;
    while (fgets(line, sizeof line, f) && line[0] != '\n')
        format |= strcmp(line, "FORMAT=32-bit_rle_rgbe\n") == 0;
    assert_true(format);
    assert_int_equal(fscanf(f, "-Y %d +X %d\n", h, w), 2);
    float *rgb = malloc(sizeof(float) * 3 * (size_t)*w * *h);
    assert_non_null(rgb);
    for (int i = 0; i < *w * *h; i++) {
        unsigned char b[4];
        assert_int_equal(fread(b, 1, 4, f), 4);
        if (b[3] == 0) {
            rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = 0.0f;
            continue;
        }
        for (int c = 0; c < 3; c++)
            rgb[3 * i + c] = (float)ldexp(b[c] + 0.5, b[3] - 136);
    }
    assert_int_equal(fgetc(f), EOF);
    fclose(f);
    return rgb;
}

static void test_hdrfilm_rgbe(void **state)
{
    (void)state;
    char text[2048];
    snprintf(text, sizeof text, "%s", scene_text(""));
    /* the same scene on an hdrfilm writing RGBE */
    char *film = strstr(text, "<film type=\"ldrfilm\">");
    assert_non_null(film);
    memcpy(film, "<film type=\"hdrfilm\">", strlen("<film type=\"hdrfilm\">"));
    char *end = strstr(text, "</film>");
    const char *ff = "<string name=\"fileFormat\" value=\"rgbe\"/>";
    memmove(end + strlen(ff), end, strlen(end) + 1);
    memcpy(end, ff, strlen(ff));
    op_scene *sc = NULL;
    op_error err;
    const char *xml = op_test_write_temp("rgbe.xml", text);
    OP_ASSERT_OK(op_scene_load(xml, NULL, 0, &sc, &err), err);
    op_scene_info info;
    op_scene_get_info(sc, &info);
    assert_string_equal(info.film_extension, ".hdr");
    op_renderer *r = op_test_render(xml, 4, 2, 1);
    const op_image *img = op_renderer_image(r);
    const char *path = op_test_tmp_path("out.hdr");
    OP_ASSERT_OK(op_scene_write_image(sc, img, path, &err), err);
    int w, h;
    float *rgb = read_rgbe(path, &w, &h);
    assert_int_equal(w, RES);
    assert_int_equal(h, RES);
    double lit = 0.0;
    for (int i = 0; i < w * h; i++) {
        const float *p = img->pixels + 4 * i;
        float mx = fmaxf(p[0], fmaxf(p[1], p[2]));
        lit = fmax(lit, mx);
        for (int c = 0; c < 3; c++)
            /* 8 mantissa bits shared by the pixel's channels */
            if (fabsf(rgb[3 * i + c] - p[c]) > mx / 128.0f + 1e-30f)
                fail_msg("pixel %d channel %d: RGBE %g, image %g", i, c, rgb[3 * i + c], p[c]);
    }
    assert_true(lit > 0.1);
    free(rgb);
    op_renderer_free(r);
    op_scene_free(sc);
}

int main(void)
{
    op_log_set_level(OP_LOG_WARN);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_reinhard_matches_mitsuba),
        cmocka_unit_test(test_reinhard_bad_values),
        cmocka_unit_test(test_hdrfilm_rgbe),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
