/* test_robust_inputs.c - the input-file module (op_file) and the escaping of text from files
 * (op_text_escape): what tests/e2e/test_robust_inputs.sh checks through the programs, here at
 * the edges the programs cannot reach (limits, the full fault table, truncated escapes). */
#include "test_support.h"

#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static void escape_keeps_text_and_escapes_controls(void **state)
{
    (void)state;
    char out[128];
    /* Printable ASCII and valid UTF-8 (é, €, an emoji) pass unchanged. */
    const char *plain = "Marble \xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80 back\\slash";
    assert_int_equal(op_text_escape(out, sizeof out, plain), strlen(plain));
    assert_string_equal(out, plain);
    /* C0 controls, DEL, the C1 control U+009B (CSI), a lone 0x9b, overlong and truncated
     * sequences and a UTF-16 surrogate are escaped byte by byte. */
    op_text_escape(out, sizeof out, "a\x1b[31m\t\n\r\x7f\xc2\x9b\x9b\xc0\xaf\xe2\x82\xed\xa0\x80z");
    assert_string_equal(out, "a\\x1b[31m\\t\\n\\r\\x7f\\xc2\\x9b\\x9b\\xc0\\xaf\\xe2\\x82\\xed\\xa0"
                             "\\x80z");
    /* A short buffer: always terminated, never a cut escape or character. */
    assert_int_equal(op_text_escape(out, 6, "ab\x1b"), 2);
    assert_string_equal(out, "ab");
    assert_int_equal(op_text_escape(out, 4, "a\xc3\xa9\xc3\xa9"), 3);
    assert_string_equal(out, "a\xc3\xa9");
    assert_int_equal(op_text_escape(out, 1, "abc"), 0);
    assert_string_equal(out, "");
}

static void read_limits_and_types(void **state)
{
    (void)state;
    op_error err = {0};
    char *data = NULL;
    size_t n = 0;
    const char *path = op_test_write_temp("ten.txt", "0123456789");
    OP_ASSERT_OK(op_file_read(path, 10, &data, &n, &err), err);
    assert_int_equal(n, 10);
    assert_int_equal(data[10], '\0');
    free(data);
    assert_int_equal(op_file_read(path, 9, &data, &n, &err), OP_ERR_INPUT);
    assert_non_null(strstr(err.message, "limit of 9 bytes"));
    assert_null(data);
    /* Empty files read and map as nothing. */
    const char *empty = op_test_write_temp("empty.txt", "");
    OP_ASSERT_OK(op_file_read(empty, 10, &data, &n, &err), err);
    assert_int_equal(n, 0);
    free(data);
    op_file_view v;
    OP_ASSERT_OK(op_file_map(empty, &v, &err), err);
    assert_null(v.data);
    assert_int_equal(v.size, 0);
    op_file_unmap(&v);
    /* A folder and a missing file: bad input, named. */
    const char *dir = op_test_tmp_path("folder");
    assert_int_equal(mkdir(dir, 0700), 0);
    int fd;
    assert_int_equal(op_file_open(dir, &fd, NULL, &err), OP_ERR_INPUT);
    assert_non_null(strstr(err.message, ": is a directory, not a file"));
    assert_int_equal(fd, -1);
    assert_int_equal(op_file_map(op_test_tmp_path("absent"), &v, &err), OP_ERR_INPUT);
    assert_non_null(strstr(err.message, "absent: no such file"));
    rmdir(dir);
}

/* More files mapped at once than the fault table holds: the rest are read into memory, and
 * every view holds its file's bytes. */
static void more_maps_than_the_table(void **state)
{
    (void)state;
    enum { N = 300 };
    static op_file_view v[N];
    op_error err = {0};
    char text[32];
    int read_in = 0;
    for (int i = 0; i < N; i++) {
        snprintf(text, sizeof text, "file %d", i);
        OP_ASSERT_OK(op_file_map(op_test_write_temp("map.txt", text), &v[i], &err), err);
        read_in += v[i].slot < 0;
    }
    assert_true(read_in >= N - 256);
    for (int i = 0; i < N; i++) {
        snprintf(text, sizeof text, "file %d", i);
        assert_int_equal(v[i].size, strlen(text));
        assert_memory_equal(v[i].data, text, v[i].size);
    }
    for (int i = 0; i < N; i++)
        op_file_unmap(&v[i]);
    /* The slots are free again. */
    OP_ASSERT_OK(op_file_map(op_test_write_temp("again.txt", "again"), &v[0], &err), err);
    assert_true(v[0].slot >= 0);
    op_file_unmap(&v[0]);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(escape_keeps_text_and_escapes_controls),
        cmocka_unit_test(read_limits_and_types),
        cmocka_unit_test(more_maps_than_the_table),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
