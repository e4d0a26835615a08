/* test_image.c - image files: PNG, OpenEXR (half and float) and PFM round trips, exposure and
 * clamping, failed writes that leave nothing, and unreadable files. */
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
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
