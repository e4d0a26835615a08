/* test_support.h - what the cmocka tests share: cmocka itself, temporary paths, and the
 * location of ../shared (tests that need it skip with a message when it is absent). */
#ifndef OP_TEST_SUPPORT_H
#define OP_TEST_SUPPORT_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "opaline.h"

/* A fresh path under the test build's tmp folder: "<tmp>/<test name>-<counter>-<suffix>". */
const char *op_test_tmp_path(const char *suffix);
/* The shared folder's path + rel, or NULL (after printing why) when it is absent. */
const char *op_test_shared_path(const char *rel);
/* How many entries of folder dir have names starting with prefix. */
int op_test_count_prefix(const char *dir, const char *prefix);
/* Fails the test with the error's message unless st is OP_OK. */
#define OP_ASSERT_OK(st, err)                                                                      \
    do {                                                                                           \
        if ((st) != OP_OK)                                                                         \
            fail_msg("%s: %s", op_status_name(st), (err).message);                                 \
    } while (0)

#endif
