/* test_render_texture.c - bitmap and checkerboard textures as a BSDF's reflectance: texel
 * lookups (bilinear, nearest, the wrap modes, uscale/uoffset, Mitsuba's v from the image's top
 * row), PNG sRGB decoding and the gamma override, a plane seen through the albedo view and lit
 * by a light showing the texels where they belong, one read per file, nothing read for bsdfs no
 * shape uses, and clear errors for bad files and parameters. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "scene/render_scene.h"
#include "scene/scene_color.h"
#include "test_support.h"
#include "bsdf/texture.h"

#define RES 32

/* The bytes of a 2 x 2 RGB image, rows from the top: red, green / blue, grey 128. */
static const unsigned char quad[12] = {255, 0, 0, 0, 255, 0, 0, 0, 255, 128, 128, 128};

/* Writes an 8-bit PNG holding exactly bytes (w x h, RGB, rows from the top). */
static void write_png_bytes(const char *path, int w, int h, const unsigned char *bytes)
{
    op_error err = {0};
    op_image img;
    OP_ASSERT_OK(op_image_alloc(&img, w, h, 3, &err), err);
    for (int i = 0; i < 3 * w * h; i++)
        img.pixels[i] = (float)op_srgb_to_linear(bytes[i] / 255.0);
    OP_ASSERT_OK(op_image_write_png(path, &img, 0.0f, &err), err);
    op_image_free(&img);
}

/* A fresh folder with a space in its name, holding "tex dir/a b.png" (the quad). */
static const char *scene_dir(void)
{
    static char dir[1024];
    snprintf(dir, sizeof dir, "%s", op_test_tmp_path("scene dir"));
    assert_int_equal(mkdir(dir, 0755), 0);
    char sub[1100], png[1200];
    snprintf(sub, sizeof sub, "%s/tex dir", dir);
    assert_int_equal(mkdir(sub, 0755), 0);
    snprintf(png, sizeof png, "%s/a b.png", sub);
    write_png_bytes(png, 2, 2, quad);
    return dir;
}

/* Writes dir/scene.xml: the camera at z = 4 looks down at the rectangle [-1, 1]^2 (which
 * exactly fills the square image: +x to the right, +y up), wearing `bsdf`, with `extra`
 * objects. Returns the path. */
static const char *write_scene(const char *dir, const char *integrator, const char *bsdf,
                               const char *extra)
{
    static char path[1200];
    char text[8192];
    int n = snprintf(
        text, sizeof text,
        "<scene version=\"0.5.0\">\n"
        " <integrator type=\"%s\"/>\n"
        " <sensor type=\"perspective\"><float name=\"fov\" value=\"28.072486935852954\"/>\n"
        "  <transform name=\"toWorld\"><lookat origin=\"0,0,4\" target=\"0,0,0\" up=\"0,1,0\"/>\n"
        "  </transform>\n"
        "  <sampler type=\"independent\"><integer name=\"sampleCount\" value=\"4\"/></sampler>\n"
        "  <film type=\"hdrfilm\"><integer name=\"width\" value=\"%d\"/>\n"
        "   <integer name=\"height\" value=\"%d\"/><rfilter type=\"box\"/></film></sensor>\n"
        " <shape type=\"rectangle\">\n%s\n </shape>\n"
        "%s</scene>\n",
        integrator, RES, RES, bsdf, extra);
    assert_true(n > 0 && n < (int)sizeof text);
    snprintf(path, sizeof path, "%s/scene.xml", dir);
    op_test_write_text(path, text);
    return path;
}

static op_v3 pixel(const op_image *img, int x, int y)
{
    const float *p = img->pixels + (size_t)img->channels * ((size_t)y * (size_t)img->width + x);
    return v3(p[0], p[1], p[2]);
}

static void assert_v3_near(op_v3 a, op_v3 b, double tol)
{
    if (fabs(a.x - b.x) > tol || fabs(a.y - b.y) > tol || fabs(a.z - b.z) > tol)
        fail_msg("(%g, %g, %g) is not (%g, %g, %g) within %g", a.x, a.y, a.z, b.x, b.y, b.z, tol);
}

/* The linear value of the quad's texel (column i, row j from the top). */
static op_v3 quad_texel(int i, int j)
{
    const unsigned char *b = quad + 3 * (2 * j + i);
    return v3((float)op_srgb_to_linear(b[0] / 255.0), (float)op_srgb_to_linear(b[1] / 255.0),
              (float)op_srgb_to_linear(b[2] / 255.0));
}

/* Mitsuba's convention: v = 0 is the image's top row. On the rectangle, uv = ((x + 1) / 2,
 * (y + 1) / 2), so the image's top row lies along y = -1: the bottom of the picture. The
 * albedo view of each quadrant (away from the seams) is its texel exactly, for nearest and,
 * with clamp, for bilinear lookups alike; with repeat, bilinear lookups blend across the seams
 * (the image's edge pixels mix opposite texels). */
static void test_orientation_albedo(void **state)
{
    (void)state;
    const char *filters[] = {"nearest", "bilinear"};
    for (int f = 0; f < 2; f++) {
        const char *dir = scene_dir();
        char bsdf[1024];
        snprintf(bsdf, sizeof bsdf,
                 "<bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">"
                 "<string name=\"filename\" value=\"tex dir/a b.png\"/>"
                 "<string name=\"filterType\" value=\"%s\"/>"
                 "<string name=\"wrapMode\" value=\"clamp\"/></texture></bsdf>",
                 filters[f]);
        op_image img = op_test_render_image(write_scene(dir, "albedo", bsdf, ""), 4, 1, 0);
        /* render quadrant (top/bottom, left/right) -> texel (column, row from the top), seen
         * at pixels whose uv stay within a quarter of the edges: between the edge and the
         * texel centres, where clamped bilinear lookups see one texel only */
        int q = RES / 8;
        assert_v3_near(pixel(&img, q, RES - 1 - q), quad_texel(0, 0), 1e-5);     /* bottom-left */
        assert_v3_near(pixel(&img, RES - 1 - q, RES - 1 - q), quad_texel(1, 0), 1e-5);
        assert_v3_near(pixel(&img, q, q), quad_texel(0, 1), 1e-5);               /* top-left */
        assert_v3_near(pixel(&img, RES - 1 - q, q), quad_texel(1, 1), 1e-5);
        /* the corners too: clamped, not wrapped */
        assert_v3_near(pixel(&img, 0, 0), quad_texel(0, 1), 1e-5);
        assert_v3_near(pixel(&img, RES - 1, RES - 1), quad_texel(1, 0), 1e-5);
        op_image_free(&img);
    }
}

/* The same plane under a far point light straight above: the lit image is the texture times
 * the same shading everywhere in the middle, so each quadrant's colour ratio follows its
 * texel (catches a lookup that only the albedo view gets right). Twosided wraps it too. */
static void test_lit_plane(void **state)
{
    (void)state;
    const char *dir = scene_dir();
    const char *bsdf =
        "<bsdf type=\"twosided\"><bsdf type=\"diffuse\">"
        "<texture type=\"bitmap\" name=\"reflectance\">"
        "<string name=\"filename\" value=\"tex dir/a b.png\"/>"
        "<string name=\"filterType\" value=\"nearest\"/></texture></bsdf></bsdf>";
    const char *light = " <emitter type=\"directional\"><vector name=\"direction\" x=\"0\" "
                        "y=\"0\" z=\"-1\"/><rgb name=\"irradiance\" value=\"3.14159265\"/>"
                        "</emitter>\n";
    op_image img = op_test_render_image(write_scene(dir, "direct", bsdf, light), 4, 1, 0);
    /* irradiance pi straight down on a Lambertian plane: radiance = reflectance */
    int q = RES / 4;
    assert_v3_near(pixel(&img, q, RES - 1 - q), quad_texel(0, 0), 1e-3);
    assert_v3_near(pixel(&img, RES - 1 - q, RES - 1 - q), quad_texel(1, 0), 1e-3);
    assert_v3_near(pixel(&img, q, q), quad_texel(0, 1), 1e-3);
    assert_v3_near(pixel(&img, RES - 1 - q, q), quad_texel(1, 1), 1e-3);
    op_image_free(&img);
}

/* sRGB decoding of 8-bit PNGs: byte 128 is 0.2158 linear; gamma 1 keeps 128 / 255, gamma 2.2
 * gives (128 / 255)^2.2, gamma -1 is sRGB again. op_image_read_stored returns the bytes. */
static void test_gamma(void **state)
{
    (void)state;
    const char *dir = scene_dir();
    char png[1200];
    snprintf(png, sizeof png, "%s/tex dir/a b.png", dir);
    op_error err = {0};
    op_image raw;
    int encoded = 0;
    OP_ASSERT_OK(op_image_read_stored(png, &raw, &encoded, &err), err);
    assert_int_equal(encoded, 1);
    for (int i = 0; i < 12; i++)
        assert_true(fabs(raw.pixels[i] - quad[i] / 255.0) < 1e-6);
    op_image_free(&raw);
    struct {
        const char *gamma;
        double want;
    } cases[] = {{NULL, 0.2158605}, {"1", 128.0 / 255.0}, {"2.2", 0.2195}, {"-1", 0.2158605}};
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        char bsdf[1024], g[128] = "";
        if (cases[k].gamma)
            snprintf(g, sizeof g, "<float name=\"gamma\" value=\"%s\"/>", cases[k].gamma);
        snprintf(bsdf, sizeof bsdf,
                 "<bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">"
                 "<string name=\"filename\" value=\"tex dir/a b.png\"/>%s"
                 "<string name=\"filterType\" value=\"nearest\"/></texture></bsdf>", g);
        op_image img = op_test_render_image(write_scene(dir, "albedo", bsdf, ""), 1, 1, 0);
        op_v3 p = pixel(&img, RES - 2, 1); /* texel (1, 1): grey 128 */
        if (fabs(p.x - cases[k].want) > 2e-4 || fabs(p.z - cases[k].want) > 2e-4)
            fail_msg("gamma %s: %g, want %g", cases[k].gamma ? cases[k].gamma : "(auto)", p.x,
                     cases[k].want);
        op_image_free(&img);
    }
    /* float files are linear by default: a PFM texel of 0.25 stays 0.25 */
    char pfm[1200];
    snprintf(pfm, sizeof pfm, "%s/lin.pfm", dir);
    op_image lin;
    OP_ASSERT_OK(op_image_alloc(&lin, 1, 1, 3, &err), err);
    lin.pixels[0] = lin.pixels[1] = lin.pixels[2] = 0.25f;
    OP_ASSERT_OK(op_image_write_pfm(pfm, &lin, &err), err);
    op_image_free(&lin);
    OP_ASSERT_OK(op_image_read_stored(pfm, &lin, &encoded, &err), err);
    assert_int_equal(encoded, 0);
    op_image_free(&lin);
    op_image img = op_test_render_image(
        write_scene(dir, "albedo",
                    "<bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">"
                    "<string name=\"filename\" value=\"lin.pfm\"/></texture></bsdf>", ""),
        1, 1, 0);
    assert_v3_near(pixel(&img, 5, 7), v3s(0.25f), 1e-6);
    op_image_free(&img);
}

/* A texture over a hand-made 4 x 1 image of values 0, 0.25, 0.5, 0.75 (one row, linear). */
static op_texture ramp_texture(op_image *img, op_tex_wrap wrap, int nearest)
{
    op_error err = {0};
    OP_ASSERT_OK(op_image_alloc(img, 4, 1, 3, &err), err);
    for (int i = 0; i < 4; i++)
        for (int c = 0; c < 3; c++)
            img->pixels[3 * i + c] = 0.25f * (float)i;
    op_texture t;
    memset(&t, 0, sizeof t);
    t.type = OP_TEX_BITMAP;
    t.img = img;
    t.nearest = nearest;
    t.wrap_u = t.wrap_v = wrap;
    t.uscale = t.vscale = 1.0f;
    return t;
}

/* Texel centres are at (i + 0.5) / 4; bilinear lookups interpolate between them, and the wrap
 * mode decides what lies beyond the edges. */
static void test_lookup_and_wrap(void **state)
{
    (void)state;
    op_image img;
    op_texture t = ramp_texture(&img, OP_WRAP_REPEAT, 0);
    assert_true(fabs(op_texture_eval(&t, 0.5f, 0.5f).x - 0.375f) < 1e-6); /* centres 1 and 2 */
    assert_true(fabs(op_texture_eval(&t, 0.625f, 0.5f).x - 0.5f) < 1e-6);
    /* repeat: u = 0 lies between the last texel (0.75) and the first (0) */
    assert_true(fabs(op_texture_eval(&t, 0.0f, 0.5f).x - 0.375f) < 1e-6);
    assert_true(fabs(op_texture_eval(&t, 3.0f, 0.5f).x - 0.375f) < 1e-6);
    assert_true(fabs(op_texture_eval(&t, -0.375f, 0.5f).x - 0.5f) < 1e-5); /* = 0.625 */
    /* uscale 2, uoffset 0.25: u = 0.1875 -> 0.625 */
    t.uscale = 2.0f;
    t.uoffset = 0.25f;
    assert_true(fabs(op_texture_eval(&t, 0.1875f, 0.5f).x - 0.5f) < 1e-6);
    t.uscale = 1.0f;
    t.uoffset = 0.0f;
    /* clamp: beyond the edges the edge texels */
    t.wrap_u = OP_WRAP_CLAMP;
    assert_true(fabs(op_texture_eval(&t, 0.0f, 0.5f).x - 0.0f) < 1e-6);
    assert_true(fabs(op_texture_eval(&t, 7.0f, 0.5f).x - 0.75f) < 1e-6);
    assert_true(fabs(op_texture_eval(&t, -5.0f, 0.5f).x - 0.0f) < 1e-6);
    /* mirror: u in (1, 2) reads the image backwards, u = 1 is the last texel */
    t.wrap_u = OP_WRAP_MIRROR;
    assert_true(fabs(op_texture_eval(&t, 1.0f, 0.5f).x - 0.75f) < 1e-6);
    assert_true(fabs(op_texture_eval(&t, 1.875f, 0.5f).x - 0.0f) < 1e-6);
    assert_true(fabs(op_texture_eval(&t, 1.375f, 0.5f).x - 0.5f) < 1e-6);
    assert_true(fabs(op_texture_eval(&t, -0.125f, 0.5f).x - 0.0f) < 1e-6);
    /* zero / one outside */
    t.wrap_u = OP_WRAP_ZERO;
    assert_true(fabs(op_texture_eval(&t, 1.5f, 0.5f).x) < 1e-6);
    assert_true(fabs(op_texture_eval(&t, 0.875f, 0.5f).x - 0.75f) < 1e-6);
    t.wrap_u = OP_WRAP_ONE;
    assert_true(fabs(op_texture_eval(&t, -0.5f, 0.5f).x - 1.0f) < 1e-6);
    /* nearest: the texel the point falls in */
    t.wrap_u = OP_WRAP_REPEAT;
    t.nearest = 1;
    assert_true(fabs(op_texture_eval(&t, 0.49f, 0.5f).x - 0.25f) < 1e-6);
    assert_true(fabs(op_texture_eval(&t, 0.51f, 0.5f).x - 0.5f) < 1e-6);
    assert_true(fabs(op_texture_eval(&t, 1.01f, 0.5f).x - 0.0f) < 1e-6);
    assert_true(fabs(op_texture_eval(&t, NAN, 0.5f).x) < 1e-6); /* no crash, black */
    op_image_free(&img);
}

/* Mitsuba's checkerboard: cells of 1/2 in (scaled) uv, color0 where both cell indices have the
 * same parity; defaults 0.4 and 0.2. Rendered: uscale 2 gives four columns. */
static void test_checkerboard(void **state)
{
    (void)state;
    const char *dir = scene_dir();
    op_image img = op_test_render_image(
        write_scene(dir, "albedo",
                    "<bsdf type=\"diffuse\"><texture type=\"checkerboard\" name=\"reflectance\">"
                    "<float name=\"uscale\" value=\"2\"/>"
                    "<rgb name=\"color0\" value=\"0.9, 0.1, 0.1\"/></texture></bsdf>", ""),
        1, 1, 0);
    /* u = (x + 0.5) / RES * 2, v = 1 - (y + 0.5) / RES: bottom rows have v < 0.5 (cell 0) */
    for (int cx = 0; cx < 4; cx++) {
        int x = cx * RES / 4 + RES / 8;
        op_v3 bottom = pixel(&img, x, RES - 2), top = pixel(&img, x, 1);
        op_v3 c0 = v3(0.9f, 0.1f, 0.1f), c1 = v3s(0.2f);
        assert_v3_near(bottom, cx % 2 == 0 ? c0 : c1, 1e-6);
        assert_v3_near(top, cx % 2 == 0 ? c1 : c0, 1e-6);
    }
    op_image_free(&img);
}

static op_scene *load_ok(const char *path)
{
    op_error err = {0};
    op_scene *s = NULL;
    OP_ASSERT_OK(op_scene_load(path, NULL, 0, &s, &err), err);
    return s;
}

/* One file read once for every texture that names it (nested or referenced, in diffuse and
 * roughplastic); a texture whose bsdf no shape uses is never read, even when its file is
 * missing (it is reported as unused, like any unused object). */
static void test_shared_and_unused(void **state)
{
    (void)state;
    const char *dir = scene_dir();
    const char *extra =
        " <texture type=\"bitmap\" id=\"t\"><string name=\"filename\" value=\"tex dir/a b.png\"/>"
        " </texture>\n"
        " <bsdf type=\"roughplastic\" id=\"p\"><ref name=\"diffuseReflectance\" id=\"t\"/></bsdf>\n"
        " <shape type=\"sphere\"><ref id=\"p\"/></shape>\n"
        " <shape type=\"cube\"><bsdf type=\"plastic\"><texture type=\"bitmap\" "
        "name=\"diffuseReflectance\"><string name=\"filename\" value=\"tex dir/a b.png\"/>"
        "</texture></bsdf></shape>\n";
    const char *unused =
        " <bsdf type=\"diffuse\" id=\"unused\"><texture type=\"bitmap\" name=\"reflectance\">"
        "<string name=\"filename\" value=\"missing.png\"/></texture></bsdf>\n";
    char both[4096];
    snprintf(both, sizeof both, "%s%s", extra, unused);
    op_scene *s = load_ok(write_scene(dir, "albedo", "<ref id=\"p\"/>", both));
    assert_int_equal(op_tex_cache_count(s->textures), 1);
    assert_int_equal(s->bsdfs[0].refl_tex.type, OP_TEX_BITMAP);
    assert_ptr_equal(s->bsdfs[0].refl_tex.img, s->bsdfs[1].refl_tex.img);
    op_scene_free(s);
    /* no shape with a texture: nothing read */
    s = load_ok(write_scene(dir, "albedo", "", unused));
    assert_int_equal(op_tex_cache_count(s->textures), 0);
    op_scene_free(s);
}

/* Loads path expecting failure; the message must contain every string in want. */
static void expect_error(const char *path, const char *const *want, int nwant)
{
    op_error err = {0};
    op_scene *s = NULL;
    op_status st = op_scene_load(path, NULL, 0, &s, &err);
    assert_int_equal(op_exit_code(st), 2); /* bad input, not an internal failure */
    assert_null(s);
    for (int i = 0; i < nwant; i++)
        if (!strstr(err.message, want[i]))
            fail_msg("message \"%s\" lacks \"%s\"", err.message, want[i]);
}

/* A missing file, a file that is no image, a bad wrap mode or filter, both a colour and a
 * texture: errors naming the scene file and line (and the image file). */
static void test_errors(void **state)
{
    (void)state;
    const char *dir = scene_dir();
    char bad[1200];
    snprintf(bad, sizeof bad, "%s/bad.png", dir);
    op_test_write_text(bad, "not a png\n");
    struct {
        const char *bsdf;
        const char *want[3];
    } cases[] = {
        {"<bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">"
         "<string name=\"filename\" value=\"nope.png\"/></texture></bsdf>",
         {"scene.xml:10", "nope.png", "no such file"}},
        {"<bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">"
         "<string name=\"filename\" value=\"bad.png\"/></texture></bsdf>",
         {"scene.xml:10", "bad.png", "not an OpenEXR, PNG or PFM"}},
        {"<bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">"
         "<string name=\"filename\" value=\"tex dir/a b.png\"/>"
         "<string name=\"wrapModeV\" value=\"wobble\"/></texture></bsdf>",
         {"scene.xml:10", "wrapModeV", "wobble"}},
        {"<bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">"
         "<string name=\"filename\" value=\"tex dir/a b.png\"/>"
         "<string name=\"filterType\" value=\"cubic\"/></texture></bsdf>",
         {"scene.xml:10", "filterType", "cubic"}},
        {"<bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\"/></bsdf>",
         {"scene.xml:10", "filename", "bitmap"}},
        {"<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.5\"/>"
         "<texture type=\"checkerboard\" name=\"reflectance\"/></bsdf>",
         {"scene.xml:10", "both", "reflectance"}},
        {"<bsdf type=\"diffuse\"><texture type=\"wood\" name=\"reflectance\"/></bsdf>",
         {"scene.xml:10", "wood", "unknown texture type"}},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++)
        expect_error(write_scene(dir, "albedo", cases[k].bsdf, ""), cases[k].want, 3);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_orientation_albedo), cmocka_unit_test(test_lit_plane),
        cmocka_unit_test(test_gamma),              cmocka_unit_test(test_lookup_and_wrap),
        cmocka_unit_test(test_checkerboard),       cmocka_unit_test(test_shared_and_unused),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
