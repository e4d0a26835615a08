/* test_core.c - errors, crash-safe output and progress reporting. */
#include "test_support.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static void error_set_and_prefix(void **state)
{
    op_error err = {0};
    assert_int_equal(op_error_set(&err, OP_ERR_INPUT, "bad value %d", 7), OP_ERR_INPUT);
    assert_string_equal(err.message, "bad value 7");
    assert_int_equal(op_error_prefix(&err, "scene.xml:%d: ", 12), OP_ERR_INPUT);
    assert_string_equal(err.message, "scene.xml:12: bad value 7");
    /* A NULL error is accepted everywhere. */
    assert_int_equal(op_error_set(NULL, OP_ERR_IO, "x"), OP_ERR_IO);
}

static void error_prefix_truncates_safely(void **state)
{
    op_error err = {0};
    char longtext[3000];
    memset(longtext, 'a', sizeof longtext - 1);
    longtext[sizeof longtext - 1] = '\0';
    op_error_set(&err, OP_ERR_FORMAT, "%s", longtext);
    op_error_prefix(&err, "%s", longtext);
    assert_int_equal(strlen(err.message), sizeof err.message - 1);
}

static void exit_codes(void **state)
{
    assert_int_equal(op_exit_code(OP_OK), 0);
    assert_int_equal(op_exit_code(OP_ERR_INPUT), 2);
    assert_int_equal(op_exit_code(OP_ERR_FORMAT), 2);
    assert_int_equal(op_exit_code(OP_ERR_IO), 1);
    assert_int_equal(op_exit_code(OP_ERR_CANCELLED), 130);
}

static void output_commit_replaces_atomically(void **state)
{
    const char *path = op_test_tmp_path("out.txt");
    FILE *f = fopen(path, "w");
    fputs("old", f);
    fclose(f);

    op_error err = {0};
    op_output *o;
    OP_ASSERT_OK(op_output_open(path, &o, &err), err);
    op_output_write(o, "new contents", 12);
    /* Until commit, the old file is intact. */
    f = fopen(path, "r");
    char buf[32] = {0};
    assert_int_equal(fread(buf, 1, sizeof buf, f), 3);
    fclose(f);
    assert_string_equal(buf, "old");
    OP_ASSERT_OK(op_output_commit(o, &err), err);

    f = fopen(path, "r");
    memset(buf, 0, sizeof buf);
    assert_int_equal(fread(buf, 1, sizeof buf, f), 12);
    fclose(f);
    assert_string_equal(buf, "new contents");
}

static void output_abort_leaves_nothing(void **state)
{
    const char *path = op_test_tmp_path("aborted.bin");
    op_error err = {0};
    op_output *o;
    OP_ASSERT_OK(op_output_open(path, &o, &err), err);
    op_output_write(o, "partial", 7);
    op_output_abort(o);
    struct stat st;
    assert_int_not_equal(stat(path, &st), 0);

    char dir[1024];
    snprintf(dir, sizeof dir, "%s", path);
    char *slash = strrchr(dir, '/');
    *slash = '\0';
    assert_int_equal(op_test_count_prefix(dir, slash + 1), 0);
}

static void output_into_missing_folder_fails_cleanly(void **state)
{
    op_error err = {0};
    op_output *o = (op_output *)0x1;
    assert_int_equal(op_output_open("/nonexistent-folder/x.bin", &o, &err), OP_ERR_IO);
    assert_null(o);
    assert_non_null(strstr(err.message, "/nonexistent-folder/x.bin"));
}

typedef struct progress_seen {
    int calls;
    double last_fraction;
} progress_seen;

static void record_progress(void *user, const char *label, double fraction, double eta)
{
    progress_seen *s = user;
    assert_string_equal(label, "work");
    assert_true(fraction >= s->last_fraction);
    s->last_fraction = fraction;
    s->calls++;
}

static void progress_callback_reaches_one(void **state)
{
    progress_seen seen = {0, 0.0};
    op_progress *p = op_progress_begin("work", 10, record_progress, &seen);
    assert_non_null(p);
    for (int i = 0; i < 10; i++)
        op_progress_advance(p, 1);
    op_progress_end(p);
    assert_true(seen.calls >= 1);
    assert_float_equal(seen.last_fraction, 1.0, 1e-12);
    /* NULL is accepted. */
    op_progress_advance(NULL, 1);
    op_progress_end(NULL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(error_set_and_prefix),
        cmocka_unit_test(error_prefix_truncates_safely),
        cmocka_unit_test(exit_codes),
        cmocka_unit_test(output_commit_replaces_atomically),
        cmocka_unit_test(output_abort_leaves_nothing),
        cmocka_unit_test(output_into_missing_folder_fails_cleanly),
        cmocka_unit_test(progress_callback_reaches_one),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
