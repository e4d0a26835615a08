/* test_npy.c - the .npy headers opaline writes (op_npy_write_header) are NumPy's format 1.0 as
 * its specification lays them out (magic, version, little-endian length, a dict padded with
 * spaces and a newline so that the data start at a multiple of 64 bytes) and read back through
 * op_npy_parse_header with their shape; op_image_write_npy writes the header and the pixels,
 * rows from the top, channels interleaved. */
#include "test_support.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void header_round_trip(void **state)
{
    (void)state;
    const long long extents[8] = {3, 0, 1, 65535, 1LL << 40, 9223372036854775807LL, 7, 2};
    for (int ndim = 1; ndim <= 8; ndim++) {
        unsigned char buf[OP_NPY_HEADER_SIZE];
        memset(buf, 0xAA, sizeof buf);
        size_t n = op_npy_write_header(buf, ndim, extents);
        assert_true(n >= 64 && n <= OP_NPY_HEADER_SIZE && n % 64 == 0);
        assert_memory_equal(buf, "\x93NUMPY\x01\x00", 8);
        assert_int_equal(buf[8] | buf[9] << 8, n - 10);
        assert_int_equal(buf[n - 1], '\n');
        /* the dict, then only spaces up to the newline */
        const char *dict = (const char *)buf + 10, *close = memchr(dict, '}', n - 10);
        assert_non_null(close);
        for (const char *p = close + 1; p < (const char *)buf + n - 1; p++)
            assert_int_equal(*p, ' ');
        assert_true(!strncmp(dict, "{'descr': '<f4', 'fortran_order': False, 'shape': (", 51));
        /* a 1-tuple is spelled (n,) as in Python */
        if (ndim == 1)
            assert_true(!strncmp(dict + 51, "3,)", 3));
        op_npy_header h;
        op_error err = {0};
        OP_ASSERT_OK(op_npy_parse_header(buf, n, "w.npy", &h, &err), err);
        assert_int_equal(h.itemsize, 4);
        assert_int_equal(h.big_endian, 0);
        assert_int_equal(h.ndim, ndim);
        for (int i = 0; i < ndim; i++)
            assert_true(h.shape[i] == extents[i]);
        assert_true(h.data_offset == n);
    }
}

/* Reads the whole file at path (at most cap bytes) into buf; returns its size. */
static size_t slurp(const char *path, unsigned char *buf, size_t cap)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    size_t n = fread(buf, 1, cap, f);
    fclose(f);
    return n;
}

static void image_arrays(void **state)
{
    (void)state;
    for (int channels = 1; channels <= 4; channels += 1 + (channels == 1)) {
        op_image img;
        op_error err = {0};
        OP_ASSERT_OK(op_image_alloc(&img, 3, 2, channels, &err), err);
        for (int i = 0; i < 3 * 2 * channels; i++)
            img.pixels[i] = 0.25f * (float)i - 1.0f;
        const char *path = op_test_tmp_path("image.npy");
        OP_ASSERT_OK(op_image_write_npy(path, &img, &err), err);
        unsigned char buf[1024];
        size_t size = slurp(path, buf, sizeof buf);
        op_npy_header h;
        OP_ASSERT_OK(op_npy_parse_header(buf, size, path, &h, &err), err);
        assert_int_equal(h.ndim, channels == 1 ? 2 : 3);
        assert_true(h.shape[0] == 2 && h.shape[1] == 3);
        if (channels > 1)
            assert_true(h.shape[2] == channels);
        assert_true(size == h.data_offset + 4u * 3u * 2u * (unsigned)channels);
        for (int i = 0; i < 3 * 2 * channels; i++) {
            unsigned char *p = buf + h.data_offset + 4 * (size_t)i;
            uint32_t bits = op_get_le32(p);
            float v;
            memcpy(&v, &bits, sizeof v);
            if (v != img.pixels[i])
                fail_msg("%d channels: value %d is %g, written %g", channels, i, (double)v,
                         (double)img.pixels[i]);
        }
        op_image_free(&img);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(header_round_trip),
        cmocka_unit_test(image_arrays),
    };
    return op_test_exit_status(cmocka_run_group_tests(tests, NULL, NULL));
}
