/* test_image.c - image files: PNG, OpenEXR (half and float) and PFM round trips, exposure and
 * clamping, failed writes that leave nothing, unreadable files; the formats read through
 * OpenImageIO (JPEG, TGA, TIFF, HDR, BMP, PNM, 16-bit PNG, OpenEXR layers) against the values
 * written, their limits and their errors. */
#include "image_samples.h"
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* A test pattern with values spanning [0, 1.5) and some structure per channel. */
static void fill_pattern(op_image *img)
{
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++)
            for (int c = 0; c < img->channels; c++)
                img->pixels[((size_t)y * img->width + x) * img->channels + c] =
                    (float)((x * 7 + y * 13 + c * 31) % 97) / 64.0f;
}

static double srgb(double v)
{
    if (v <= 0)
        return 0;
    if (v >= 1)
        return 1;
    return v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1 / 2.4) - 0.055;
}

static void write_bytes(const char *path, const void *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, n, f), n);
    fclose(f);
}

static size_t read_bytes(const char *path, unsigned char **data)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    *data = malloc((size_t)n);
    assert_int_equal(fread(*data, 1, (size_t)n, f), (size_t)n);
    fclose(f);
    return (size_t)n;
}

static void png_round_trip_channels(int channels)
{
    op_error err = {0};
    op_image img, back;
    OP_ASSERT_OK(op_image_alloc(&img, 23, 17, channels, &err), err);
    fill_pattern(&img);
    const char *path = op_test_tmp_path("rt.png");
    OP_ASSERT_OK(op_image_write_png(path, &img, 0.0f, &err), err);
    OP_ASSERT_OK(op_image_read(path, &back, &err), err);
    assert_int_equal(back.width, 23);
    assert_int_equal(back.height, 17);
    assert_int_equal(back.channels, channels);
    for (size_t i = 0; i < (size_t)23 * 17 * channels; i++) {
        double v = img.pixels[i], r = back.pixels[i];
        if (channels == 4 && i % 4 == 3) /* alpha is stored linearly, clamped */
            assert_true(fabs(fmin(v, 1.0) - r) <= 0.5 / 255 + 1e-6);
        else /* colour: equal after 8-bit sRGB quantization */
            assert_true(fabs(srgb(v) - srgb(r)) <= 0.5 / 255 + 1e-5);
    }
    op_image_free(&img);
    op_image_free(&back);
    unlink(path);
}

static void png_round_trip(void **state)
{
    png_round_trip_channels(1);
    png_round_trip_channels(3);
    png_round_trip_channels(4);
}

static void png_exposure_and_clamp(void **state)
{
    op_error err = {0};
    op_image img, back;
    OP_ASSERT_OK(op_image_alloc(&img, 3, 1, 3, &err), err);
    float vals[9] = {0.25f, 0.25f, 0.25f, 4.0f, 100.0f, -1.0f, NAN, 0.0f, 0.125f};
    memcpy(img.pixels, vals, sizeof vals);
    const char *path = op_test_tmp_path("exp.png");
    OP_ASSERT_OK(op_image_write_png(path, &img, 1.0f, &err), err); /* one stop: x2 */
    OP_ASSERT_OK(op_image_read(path, &back, &err), err);
    assert_true(fabs(srgb(back.pixels[0]) - srgb(0.5)) <= 0.5 / 255 + 1e-5);
    assert_float_equal(back.pixels[3], 1.0, 1e-6); /* clamped */
    assert_float_equal(back.pixels[4], 1.0, 1e-6);
    assert_float_equal(back.pixels[5], 0.0, 1e-6); /* negative -> 0 */
    assert_float_equal(back.pixels[6], 0.0, 1e-6); /* NaN -> 0 */
    assert_true(fabs(srgb(back.pixels[8]) - srgb(0.25)) <= 0.5 / 255 + 1e-5);
    op_image_free(&back);
    /* Minus two stops: 0.25 -> 0.0625. */
    OP_ASSERT_OK(op_image_write_png(path, &img, -2.0f, &err), err);
    OP_ASSERT_OK(op_image_read(path, &back, &err), err);
    assert_true(fabs(srgb(back.pixels[0]) - srgb(0.0625)) <= 0.5 / 255 + 1e-5);
    op_image_free(&back);
    op_image_free(&img);
    unlink(path);
}

static void exr_round_trip_one(int channels, int half)
{
    op_error err = {0};
    op_image img, back;
    /* 37 rows: not a multiple of the 16-line ZIP chunk. */
    OP_ASSERT_OK(op_image_alloc(&img, 29, 37, channels, &err), err);
    fill_pattern(&img);
    img.pixels[0] = 1234.5f;
    img.pixels[1 % channels] = channels > 1 ? 1e-3f : img.pixels[0];
    const char *path = op_test_tmp_path(half ? "h.exr" : "f.exr");
    OP_ASSERT_OK(op_image_write_exr(path, &img, half, &err), err);
    OP_ASSERT_OK(op_image_read(path, &back, &err), err);
    assert_int_equal(back.width, 29);
    assert_int_equal(back.height, 37);
    assert_int_equal(back.channels, channels);
    for (size_t i = 0; i < (size_t)29 * 37 * channels; i++) {
        if (half) {
            if (!(fabs(img.pixels[i] - back.pixels[i]) <= 1e-3 * fabs(img.pixels[i]) + 1e-7))
                fail_msg("channels %d pixel value %zu: wrote %g read %g", channels, i,
                         img.pixels[i], back.pixels[i]);
        }
        else
            assert_true(img.pixels[i] == back.pixels[i]);
    }
    op_image_free(&img);
    op_image_free(&back);
    unlink(path);
}

static void exr_round_trip(void **state)
{
    for (int half = 0; half <= 1; half++) {
        exr_round_trip_one(1, half);
        exr_round_trip_one(3, half);
        exr_round_trip_one(4, half);
    }
}

static void exr_half_is_smaller(void **state)
{
    op_error err = {0};
    op_image img;
    OP_ASSERT_OK(op_image_alloc(&img, 64, 64, 3, &err), err);
    for (size_t i = 0; i < (size_t)64 * 64 * 3; i++) /* incompressible-ish noise */
        img.pixels[i] = (float)((i * 2654435761u) % 100003) / 100003.0f;
    const char *ph = op_test_tmp_path("s.exr"), *pf = op_test_tmp_path("s.exr");
    OP_ASSERT_OK(op_image_write_exr(ph, &img, 1, &err), err);
    OP_ASSERT_OK(op_image_write_exr(pf, &img, 0, &err), err);
    struct stat sh, sf;
    assert_int_equal(stat(ph, &sh), 0);
    assert_int_equal(stat(pf, &sf), 0);
    assert_true(sh.st_size < sf.st_size);
    op_image_free(&img);
    unlink(ph);
    unlink(pf);
}

static void pfm_round_trip(void **state)
{
    op_error err = {0};
    for (int channels = 1; channels <= 4; channels += (channels == 1 ? 2 : 1)) {
        op_image img, back;
        OP_ASSERT_OK(op_image_alloc(&img, 5, 4, channels, &err), err);
        fill_pattern(&img);
        const char *path = op_test_tmp_path("rt.pfm");
        OP_ASSERT_OK(op_image_write_pfm(path, &img, &err), err);
        /* The header and bottom-to-top order. */
        unsigned char *bytes;
        size_t n = read_bytes(path, &bytes);
        int oc = channels == 1 ? 1 : 3;
        const char *head = channels == 1 ? "Pf\n5 4\n-1.0\n" : "PF\n5 4\n-1.0\n";
        assert_memory_equal(bytes, head, strlen(head));
        assert_int_equal(n, strlen(head) + (size_t)5 * 4 * oc * 4);
        float first;
        memcpy(&first, bytes + strlen(head), 4); /* bottom-left pixel, little-endian host */
        assert_true(first == img.pixels[(size_t)3 * 5 * channels]);
        free(bytes);
        OP_ASSERT_OK(op_image_read(path, &back, &err), err);
        assert_int_equal(back.channels, oc); /* PFM has no alpha */
        for (int p = 0; p < 20; p++)
            for (int k = 0; k < oc; k++)
                assert_true(back.pixels[p * oc + k] == img.pixels[p * channels + k]);
        op_image_free(&img);
        op_image_free(&back);
        unlink(path);
    }
}

static void bad_path_leaves_nothing(void **state)
{
    op_error err = {0};
    op_image img;
    OP_ASSERT_OK(op_image_alloc(&img, 8, 8, 3, &err), err);
    fill_pattern(&img);
    /* A folder that does not exist. */
    const char *missing = op_test_tmp_path("nodir/out.png");
    assert_int_equal(op_image_write_png(missing, &img, 0, &err), OP_ERR_IO);
    assert_non_null(strstr(err.message, "nodir"));
    assert_int_equal(op_image_write_exr(missing, &img, 1, &err), OP_ERR_IO);
    assert_int_equal(op_image_write_pfm(missing, &img, &err), OP_ERR_IO);

    /* The destination is a folder: the rename fails late and the temporary must vanish. */
    char dir[1024], parent[1024];
    snprintf(dir, sizeof dir, "%s", op_test_tmp_path("isdir"));
    assert_int_equal(mkdir(dir, 0755), 0);
    snprintf(parent, sizeof parent, "%s", dir);
    char *slash = strrchr(parent, '/');
    assert_non_null(slash);
    *slash = '\0';
    const char *base = slash + 1;
    char prefix[1100];
    snprintf(prefix, sizeof prefix, "%s.tmp", base);
    assert_int_equal(op_image_write_png(dir, &img, 0, &err), OP_ERR_IO);
    assert_int_equal(op_test_count_prefix(parent, prefix), 0);
    assert_int_equal(op_image_write_exr(dir, &img, 0, &err), OP_ERR_IO);
    assert_int_equal(op_test_count_prefix(parent, prefix), 0);
    assert_int_equal(op_image_write_pfm(dir, &img, &err), OP_ERR_IO);
    assert_int_equal(op_test_count_prefix(parent, prefix), 0);
    rmdir(dir);
    op_image_free(&img);
}

static void unreadable_files(void **state)
{
    op_error err = {0};
    op_image img;
    /* Missing file: bad input, named as such. */
    assert_int_equal(op_image_read(op_test_tmp_path("absent.exr"), &img, &err), OP_ERR_INPUT);
    assert_non_null(strstr(err.message, "absent.exr: no such file"));
    assert_null(img.pixels);

    /* Plain text, an empty file. */
    const char *txt = op_test_tmp_path("text.png");
    write_bytes(txt, "hello, not an image\n", 20);
    assert_int_equal(op_image_read(txt, &img, &err), OP_ERR_FORMAT);
    assert_non_null(strstr(err.message, txt));
    write_bytes(txt, "", 0);
    assert_int_equal(op_image_read(txt, &img, &err), OP_ERR_FORMAT);
    unlink(txt);

    /* Truncated PNG, EXR and PFM files of a real image. */
    op_image src;
    OP_ASSERT_OK(op_image_alloc(&src, 40, 40, 3, &err), err);
    fill_pattern(&src);
    const char *png = op_test_tmp_path("t.png"), *exr = op_test_tmp_path("t.exr"),
               *pfm = op_test_tmp_path("t.pfm"), *cut = op_test_tmp_path("cut");
    OP_ASSERT_OK(op_image_write_png(png, &src, 0, &err), err);
    OP_ASSERT_OK(op_image_write_exr(exr, &src, 1, &err), err);
    OP_ASSERT_OK(op_image_write_pfm(pfm, &src, &err), err);
    const char *files[3] = {png, exr, pfm};
    for (int f = 0; f < 3; f++) {
        unsigned char *bytes;
        size_t n = read_bytes(files[f], &bytes);
        size_t cuts[4] = {4, 12, n / 2, n - 16};
        for (int k = 0; k < 4; k++) {
            write_bytes(cut, bytes, cuts[k]);
            op_status st = op_image_read(cut, &img, &err);
            if (st != OP_ERR_FORMAT)
                fail_msg("file %d cut at %zu of %zu: %s (%s)", f, cuts[k], n, op_status_name(st),
                         err.message);
            assert_null(img.pixels);
        }
        /* Corrupted bytes in the middle are detected or decoded, never a crash. */
        memcpy(bytes + n / 2, "\xff\xff\xff\xff\xff\xff\xff\xff", 8);
        write_bytes(cut, bytes, n);
        if (op_image_read(cut, &img, &err) == OP_OK)
            op_image_free(&img);
        free(bytes);
        unlink(files[f]);
    }
    unlink(cut);
    op_image_free(&src);
}

static double srgb_to_linear(double v)
{
    return v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4);
}

/* A smooth pattern of values in [0, 1] (alpha in [0.25, 1]) for the formats below: smooth, so
 * that JPEG keeps it within a few codes. */
static void fill_unit(float *p, int w, int h, int c)
{
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int k = 0; k < c; k++)
                p[((size_t)y * w + x) * c + k] =
                    (c == 4 && k == 3) || (c == 2 && k == 1)
                        ? 0.25f + 0.75f * (float)(x + y) / (float)(w + h - 2)
                        : (float)(x * (k + 1) + 2 * y) / (float)((w - 1) * (k + 1) + 2 * (h - 1));
}

/* An 8-bit binary PNM (P6 for 3 channels, P5 for 1) of src's values in [0, 1], by hand. */
static void write_pnm8(const char *path, int w, int h, int channels, const float *src)
{
    unsigned char buf[64 + 13 * 7 * 3];
    int n = snprintf((char *)buf, 64, "P%d\n%d %d\n255\n", channels == 3 ? 6 : 5, w, h);
    assert_true(n > 0 && w * h * channels <= 13 * 7 * 3);
    for (int i = 0; i < w * h * channels; i++)
        buf[n + i] = (unsigned char)lrintf(src[i] * 255.0f);
    write_bytes(path, buf, (size_t)(n + w * h * channels));
}

typedef struct {
    const char *name, *type;
    int channels, out_channels; /* as written; as op_image gives them */
    int encoded;
    double tol; /* of stored values, against those written (0: exact, or one integer code) */
} format_case;

/* Each format written by OpenImageIO and read back: size, channels, stored values (integer
 * formats: the codes / largest code; float ones: the values), decoding (sRGB for integer
 * colour, none for alpha and floats) and the header-only size. */
static void formats_read_back(void **state)
{
    static const format_case cases[] = {
        {"rgb.jpg", "uint8", 3, 3, 1, 0.08},    {"grey.jpg", "uint8", 1, 1, 1, 0.08},
        {"rgb.tga", "uint8", 3, 3, 1, 0},       {"rgba.tga", "uint8", 4, 4, 1, 0},
        {"rgb8.tif", "uint8", 3, 3, 1, 0},      {"rgba16.tif", "uint16", 4, 4, 1, 0},
        {"ga16.tif", "uint16", 2, 4, 1, 0},     {"rgbf.tif", "float", 3, 3, 0, 0},
        {"grey16.png", "uint16", 1, 1, 1, 0},   {"rgba16.png", "uint16", 4, 4, 1, 0},
        {"ga8.png", "uint8", 2, 4, 1, 0},       {"rgb.bmp", "uint8", 3, 3, 1, 0},
        {"rgb.ppm", "uint8", 3, 3, 1, 0},       {"grey.pgm", "uint8", 1, 1, 1, 0},
        {"rgb.hdr", "float", 3, 3, 0, 0.008},   {"rgbh.exr", "half", 3, 3, 0, 1e-3},
    };
    const int w = 13, h = 7;
    for (size_t f = 0; f < sizeof cases / sizeof cases[0]; f++) {
        const format_case *fc = &cases[f];
        float src[13 * 7 * 4];
        fill_unit(src, w, h, fc->channels);
        const char *path = op_test_tmp_path(fc->name);
        const char *ext = strrchr(fc->name, '.');
        if (strcmp(ext, ".ppm") == 0 || strcmp(ext, ".pgm") == 0)
            write_pnm8(path, w, h, fc->channels, src); /* OpenImageIO 2.5 writes these wrong */
        else
            assert_int_equal(op_test_write_image(path, w, h, fc->channels, fc->type, src, NULL), 0);
        op_error err = {0};
        op_image dec, raw;
        int encoded = -1, sw, sh, sc;
        OP_ASSERT_OK(op_image_read(path, &dec, &err), err);
        OP_ASSERT_OK(op_image_read_stored(path, &raw, &encoded, &err), err);
        OP_ASSERT_OK(op_image_read_size(path, &sw, &sh, &sc, &err), err);
        if (dec.width != w || dec.height != h || dec.channels != fc->out_channels ||
            encoded != fc->encoded || sw != w || sh != h || sc != fc->out_channels)
            fail_msg("%s: %dx%dx%d encoded %d, size %dx%dx%d", fc->name, dec.width, dec.height,
                     dec.channels, encoded, sw, sh, sc);
        double largest = strcmp(fc->type, "uint8") == 0 ? 255 : 65535;
        int oc = fc->out_channels;
        for (int i = 0; i < w * h; i++)
            for (int k = 0; k < oc; k++) {
                /* grey + alpha comes back as RGBA with the grey repeated */
                int sk = fc->channels == 2 ? (k == 3 ? 1 : 0) : k;
                double v = src[i * fc->channels + sk];
                double want = fc->encoded ? round(v * largest) / largest : v;
                double got = raw.pixels[i * oc + k], lin = dec.pixels[i * oc + k];
                int alpha = oc == 4 && k == 3;
                /* integer codes: within one (OpenImageIO rounds halves its own way) */
                double tol = fc->tol > 0 ? fc->tol * fmax(1, v) : fc->encoded ? 1 / largest : 0;
                if (!(fabs(got - want) <= tol + 1e-6))
                    fail_msg("%s pixel %d channel %d: wrote %g, stored %g", fc->name, i, k, v, got);
                double want_lin = fc->encoded && !alpha ? srgb_to_linear(got) : got;
                if (!(fabs(lin - want_lin) <= 1e-5))
                    fail_msg("%s pixel %d channel %d: decoded %g, want %g", fc->name, i, k, lin,
                             want_lin);
            }
        op_image_free(&dec);
        op_image_free(&raw);
        unlink(path);
    }
}

/* 16-bit PNGs (and PNMs) keep their precision: 256 consecutive codes stay 256 values,
 * code / 65535. */
static void png16_precision(void **state)
{
    float src[256];
    for (int i = 0; i < 256; i++)
        src[i] = (float)((30000 + i) / 65535.0);
    const char *path = op_test_tmp_path("ramp16.png");
    assert_int_equal(op_test_write_image(path, 256, 1, 1, "uint16", src, NULL), 0);
    op_error err = {0};
    op_image raw;
    int encoded;
    OP_ASSERT_OK(op_image_read_stored(path, &raw, &encoded, &err), err);
    assert_int_equal(encoded, 1);
    for (int i = 0; i < 256; i++) {
        assert_float_equal(raw.pixels[i], (30000 + i) / 65535.0, 1e-7);
        if (i > 0)
            assert_true(raw.pixels[i] > raw.pixels[i - 1]);
    }
    op_image_free(&raw);
    unlink(path);
    /* A 16-bit PGM (big-endian codes), written here: 0, 1, 30000, 65535 of 65535. */
    const unsigned char pgm[] = "P5\n4 1\n65535\n\x00\x00\x00\x01\x75\x30\xff\xff";
    path = op_test_tmp_path("ramp16.pgm");
    write_bytes(path, pgm, sizeof pgm - 1);
    OP_ASSERT_OK(op_image_read_stored(path, &raw, &encoded, &err), err);
    assert_int_equal(raw.channels, 1);
    static const double codes[4] = {0, 1, 30000, 65535};
    for (int i = 0; i < 4; i++)
        assert_float_equal(raw.pixels[i], codes[i] / 65535, 1.5 / 65535); /* OIIO 2.4 may round */
    op_image_free(&raw);
    unlink(path);
}

/* An OpenEXR file with a default layer and the layers diffuse and specular: the default RGB,
 * a layer by name (op_image_read_layer), and a layer that is not there. */
static void exr_layers(void **state)
{
    static const char *const names[] = {"R",          "G",          "B",         "diffuse.R",
                                        "diffuse.G",  "diffuse.B",  "diffuse.A", "specular.Y"};
    const int w = 5, h = 3, c = 8;
    float src[5 * 3 * 8];
    for (int i = 0; i < w * h; i++)
        for (int k = 0; k < c; k++)
            src[i * c + k] = (float)(k * 100 + i) + 0.5f;
    const char *path = op_test_tmp_path("layers.exr");
    assert_int_equal(op_test_write_image(path, w, h, c, "float", src, names), 0);
    op_error err = {0};
    op_image img;
    int encoded;
    OP_ASSERT_OK(op_image_read(path, &img, &err), err);
    assert_int_equal(img.channels, 3);
    for (int i = 0; i < w * h; i++)
        for (int k = 0; k < 3; k++)
            assert_true(img.pixels[i * 3 + k] == src[i * c + k]);
    op_image_free(&img);
    OP_ASSERT_OK(op_image_read_layer(path, "diffuse", 1, OP_IMAGE_DEFAULT_MAX_PIXELS, &img,
                                     &encoded, &err), err);
    assert_int_equal(img.channels, 4);
    assert_int_equal(encoded, 0);
    for (int i = 0; i < w * h; i++)
        for (int k = 0; k < 4; k++)
            assert_true(img.pixels[i * 4 + k] == src[i * c + 3 + k]);
    op_image_free(&img);
    OP_ASSERT_OK(op_image_read_layer(path, "specular", 1, OP_IMAGE_DEFAULT_MAX_PIXELS, &img,
                                     NULL, &err), err);
    assert_int_equal(img.channels, 1);
    for (int i = 0; i < w * h; i++)
        assert_true(img.pixels[i] == src[i * c + 7]);
    op_image_free(&img);
    assert_int_equal(op_image_read_layer(path, "albedo", 1, OP_IMAGE_DEFAULT_MAX_PIXELS, &img,
                                         NULL, &err), OP_ERR_INPUT);
    assert_non_null(strstr(err.message, path));
    assert_non_null(strstr(err.message, "\"albedo\""));
    assert_null(img.pixels);
    unlink(path);
}

/* Alpha is read as stored (never premultiplied into the colour). */
static void alpha_unassociated(void **state)
{
    static const char *files[] = {"a.png", "a.tga", "a.tif"};
    float px[4] = {0.8f, 0.4f, 0.2f, 0.5f};
    for (int f = 0; f < 3; f++) {
        const char *path = op_test_tmp_path(files[f]);
        assert_int_equal(op_test_write_image(path, 1, 1, 4, "uint8", px, NULL), 0);
        op_error err = {0};
        op_image raw;
        int encoded;
        OP_ASSERT_OK(op_image_read_stored(path, &raw, &encoded, &err), err);
        for (int k = 0; k < 4; k++)
            if (fabs(raw.pixels[k] - round(px[k] * 255) / 255) > 1e-6)
                fail_msg("%s channel %d: %g", files[f], k, raw.pixels[k]);
        op_image_free(&raw);
        unlink(path);
    }
}

/* Cut short: a JPEG is refused (not grey-filled) with a message naming the file; the other
 * formats are refused or read, never a crash. */
static void truncated_new_formats(void **state)
{
    static const char *files[] = {"cut.jpg", "cut.tga", "cut.tif", "cut.bmp", "cut.hdr",
                                  "cut16.png", "cut.ppm"};
    float src[64 * 48 * 3];
    fill_unit(src, 64, 48, 3);
    for (int f = 0; f < 7; f++) {
        const char *path = op_test_tmp_path(files[f]);
        assert_int_equal(op_test_write_image(path, 64, 48, 3, f == 5 ? "uint16" : "uint8", src,
                                             NULL), 0);
        unsigned char *bytes;
        size_t n = read_bytes(path, &bytes);
        size_t cuts[3] = {n / 2, n - 16, 24};
        for (int k = 0; k < 3; k++) {
            write_bytes(path, bytes, cuts[k]);
            op_error err = {0};
            op_image img;
            op_status st = op_image_read(path, &img, &err);
            if (f == 0 || k == 2) {
                if (st != OP_ERR_FORMAT || !strstr(err.message, path))
                    fail_msg("%s cut at %zu of %zu: %s (%s)", files[f], cuts[k], n,
                             op_status_name(st), err.message);
                assert_null(img.pixels);
            } else if (st == OP_OK) {
                op_image_free(&img);
            }
        }
        free(bytes);
        unlink(path);
    }
}

/* Tiny files whose headers declare a huge image: refused before anything is allocated or
 * decoded, naming the file: by image-pixels (OP_ERR_INPUT), their size still reported by
 * op_image_read_size; or, where the library itself finds the header implausible for the bytes
 * that follow (OpenImageIO 2.5.19's TGA reader, Debian sid's), as a bad file (OP_ERR_FORMAT). */
static void huge_headers_refused_before_decoding(void **state)
{
    unsigned char tga[18] = {0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0x60, 0xea, 0x60, 0xea, 24, 0x20};
    unsigned char bmp[54] = {'B', 'M', 54, 0, 0, 0, 0, 0, 0, 0, 54, 0, 0, 0, 40, 0, 0, 0,
                             0x60, 0xea, 0, 0, 0x60, 0xea, 0, 0, 1, 0, 24, 0};
    const char *hdr = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 60000 +X 60000\n";
    struct {
        const char *name;
        const void *data;
        size_t n;
    } files[] = {{"huge.tga", tga, sizeof tga}, {"huge.bmp", bmp, sizeof bmp},
                 {"huge.hdr", hdr, strlen(hdr)}};
    for (int f = 0; f < 3; f++) {
        const char *path = op_test_tmp_path(files[f].name);
        write_bytes(path, files[f].data, files[f].n);
        op_error err = {0};
        op_image img;
        op_status st = op_image_read(path, &img, &err);
        int by_limit = st == OP_ERR_INPUT && strstr(err.message, "image-pixels");
        if (!(by_limit || st == OP_ERR_FORMAT) || !strstr(err.message, path))
            fail_msg("%s: %s (%s)", files[f].name, op_status_name(st), err.message);
        assert_null(img.pixels);
        if (by_limit) {
            int w, h, c;
            OP_ASSERT_OK(op_image_read_size(path, &w, &h, &c, &err), err);
            assert_int_equal(w, 60000);
            assert_int_equal(h, 60000);
        }
        unlink(path);
    }
}

/* Files that are no image, under image names: OP_ERR_FORMAT naming the file. */
static void not_images(void **state)
{
    static const char *names[] = {"text.jpg", "text.tga", "text.hdr", "text.tif", "text.exr"};
    static const char *texts[] = {"hello, not an image\n", "hello, not an image\n",
                                  "#?RADIANCE\nno header end", "II*\0garbage", "\x76\x2f\x31\x01"};
    static const size_t lens[] = {20, 20, 25, 11, 4};
    for (int f = 0; f < 5; f++) {
        const char *path = op_test_tmp_path(names[f]);
        write_bytes(path, texts[f], lens[f]);
        op_error err = {0};
        op_image img;
        op_status st = op_image_read(path, &img, &err);
        if (st != OP_ERR_FORMAT || !strstr(err.message, path))
            fail_msg("%s: %s (%s)", names[f], op_status_name(st), err.message);
        assert_null(img.pixels);
        unlink(path);
    }
}

static void alloc_rejects_bad_sizes(void **state)
{
    op_error err = {0};
    op_image img;
    assert_int_equal(op_image_alloc(&img, 0, 4, 3, &err), OP_ERR_INPUT);
    assert_int_equal(op_image_alloc(&img, 4, 4, 2, &err), OP_ERR_INPUT);
    assert_int_equal(op_image_alloc(&img, 1 << 20, 1 << 20, 3, &err), OP_ERR_INPUT);
    assert_null(img.pixels);
    op_image_free(&img);
    op_image_free(NULL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(png_round_trip),
        cmocka_unit_test(png_exposure_and_clamp),
        cmocka_unit_test(exr_round_trip),
        cmocka_unit_test(exr_half_is_smaller),
        cmocka_unit_test(pfm_round_trip),
        cmocka_unit_test(bad_path_leaves_nothing),
        cmocka_unit_test(unreadable_files),
        cmocka_unit_test(alloc_rejects_bad_sizes),
        cmocka_unit_test(formats_read_back),
        cmocka_unit_test(png16_precision),
        cmocka_unit_test(exr_layers),
        cmocka_unit_test(alpha_unassociated),
        cmocka_unit_test(truncated_new_formats),
        cmocka_unit_test(huge_headers_refused_before_decoding),
        cmocka_unit_test(not_images),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
