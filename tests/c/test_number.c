/* test_number.c - op_parse_numbers, the one reader of command-line numbers: the whole text,
 * finite, in range, whole when asked; a refusal names the option and the text, and leaves the
 * output alone. */
#include "test_support.h"

#include <math.h>
#include <string.h>

/* op_parse_number(text) with the flags and range, expected to succeed with value want. */
static void accepts(const char *text, double lo, double hi, int flags, double want)
{
    op_error err = {0};
    double v = -12345;
    OP_ASSERT_OK(op_parse_number("-x", text, lo, hi, flags, &v, &err), err);
    assert_true(v == want);
}

/* The same, expected to fail with a message holding "-x TEXT:" and needle. */
static void refuses(const char *text, double lo, double hi, int flags, const char *needle)
{
    op_error err = {0};
    double v = -12345;
    assert_int_equal(op_parse_number("-x", text, lo, hi, flags, &v, &err), OP_ERR_INPUT);
    char head[256];
    snprintf(head, sizeof head, "-x %s: ", text);
    if (strncmp(err.message, head, strlen(head)) || !strstr(err.message, needle))
        fail_msg("'%s': message '%s' lacks '%s' or '%s'", text, err.message, head, needle);
    assert_true(v == -12345);
}

static void whole_numbers(void **state)
{
    (void)state;
    accepts("7", 1, 1024, OP_NUMBER_WHOLE, 7);
    accepts("+1024", 1, 1024, OP_NUMBER_WHOLE, 1024);
    accepts("-3", -5, 5, OP_NUMBER_WHOLE, -3);
    accepts("1099511627776", 1, 0x1p40, OP_NUMBER_WHOLE, 0x1p40);
    refuses("0", 1, 1024, OP_NUMBER_WHOLE, "need a whole number in [1, 1024]");
    refuses("1025", 1, 1024, OP_NUMBER_WHOLE, "[1, 1024]");
    refuses("1099511627777", 1, 0x1p40, OP_NUMBER_WHOLE, "[1, 1099511627776]");
    refuses("2.5", 1, 1024, OP_NUMBER_WHOLE, "whole number");
    refuses("1e2", 1, 1024, OP_NUMBER_WHOLE, "whole number");
    refuses("0x10", 1, 1024, OP_NUMBER_WHOLE, "whole number");
    refuses("99999999999999999999999", 1, 1024, OP_NUMBER_WHOLE, "whole number");
}

static void real_numbers(void **state)
{
    (void)state;
    accepts("0.25", 0, 1, 0, 0.25);
    accepts("1e-3", 0, 1, 0, 1e-3);
    accepts("0", 0, 1, 0, 0);
    accepts("1", 0, 1, 0, 1);
    refuses("0", 0, 1, OP_NUMBER_ABOVE_LO | OP_NUMBER_BELOW_HI, "need a number in (0, 1)");
    refuses("1", 0, 1, OP_NUMBER_ABOVE_LO | OP_NUMBER_BELOW_HI, "(0, 1)");
    refuses("1", 0, 1, OP_NUMBER_BELOW_HI, "[0, 1)");
    refuses("-0.5", 0, 1, 0, "[0, 1]");
    refuses("nan", 0, 1, 0, "number");
    refuses("inf", 0, INFINITY, 0, "number");
    refuses("1e999", 0, INFINITY, 0, "number");
}

static void whole_text_only(void **state)
{
    (void)state;
    refuses("", 0, 10, 0, "number");
    refuses(" 3", 0, 10, OP_NUMBER_WHOLE, "whole number");
    refuses("3 ", 0, 10, OP_NUMBER_WHOLE, "whole number");
    refuses("3x", 0, 10, 0, "number");
    refuses("3,4", 0, 10, 0, "number");
    op_error err = {0};
    double v;
    assert_int_equal(op_parse_number("--spp", NULL, 1, 2, 0, &v, &err), OP_ERR_INPUT);
    assert_string_equal(err.message, "--spp needs a value");
    /* a NULL error is accepted, as everywhere */
    assert_int_equal(op_parse_number("--spp", "x", 1, 2, 0, &v, NULL), OP_ERR_INPUT);
}

static void lists(void **state)
{
    (void)state;
    op_error err = {0};
    double v[4] = {-1, -1, -1, -1};
    OP_ASSERT_OK(op_parse_numbers("--crop", "0,8,16,65536", 4, 0, 65536, OP_NUMBER_WHOLE, v,
                                  &err),
                 err);
    assert_true(v[0] == 0 && v[1] == 8 && v[2] == 16 && v[3] == 65536);
    const char *bad[] = {"1,2,3", "1,2,3,4,5", "1,2,,4", "1,2,3,", ",1,2,3", "1,2,3,x",
                         "1,-2,3,4", "1, 2,3,4"};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        double w[4] = {-1, -1, -1, -1};
        assert_int_equal(op_parse_numbers("--crop", bad[i], 4, 0, 65536, OP_NUMBER_WHOLE, w, &err),
                         OP_ERR_INPUT);
        char want[128];
        snprintf(want, sizeof want, "--crop %s: need 4 comma-separated whole numbers in [0, 65536]",
                 bad[i]);
        assert_string_equal(err.message, want);
        assert_true(w[0] == -1 && w[1] == -1 && w[2] == -1 && w[3] == -1);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(whole_numbers),
        cmocka_unit_test(real_numbers),
        cmocka_unit_test(whole_text_only),
        cmocka_unit_test(lists),
    };
    return op_test_exit_status(cmocka_run_group_tests(tests, NULL, NULL));
}
