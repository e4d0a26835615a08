/* number.c - the one reader of the numbers given to command-line options (opaline.h). */
#include "opaline.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Reads one number from s (the text up to the next ',' or the end) into *v and the place after
 * it into *end; 0 when it is none or breaks the flags' rules. */
static int read_one(const char *s, double lo, double hi, int flags, double *v, const char **end)
{
    char *e;
    /* strtod and strtoll skip leading blanks: the text is read whole, blanks refused */
    if (!*s || strchr(" \t\n\v\f\r", *s))
        return 0;
    errno = 0;
    if (flags & OP_NUMBER_WHOLE)
        *v = (double)strtoll(s, &e, 10);
    else
        *v = strtod(s, &e);
    *end = e;
    if (errno || e == s || !isfinite(*v))
        return 0;
    int above = flags & OP_NUMBER_ABOVE_LO ? *v > lo : *v >= lo;
    int below = flags & OP_NUMBER_BELOW_HI ? *v < hi : *v <= hi;
    return above && below;
}

op_status op_parse_numbers(const char *opt, const char *text, int n, double lo, double hi,
                           int flags, double *out, op_error *err)
{
    if (!text)
        return op_error_set(err, OP_ERR_INPUT, "%s needs a value", opt);
    double v[16];
    int ok = n >= 1 && n <= (int)(sizeof v / sizeof *v);
    const char *s = text;
    for (int i = 0; ok && i < n; i++) {
        const char *end = s;
        ok = read_one(s, lo, hi, flags, &v[i], &end) && *end == (i + 1 < n ? ',' : '\0');
        s = end + 1;
    }
    if (ok) {
        memcpy(out, v, (size_t)n * sizeof *out);
        return OP_OK;
    }
    const char *kind = flags & OP_NUMBER_WHOLE ? "whole number" : "number";
    char count[64];
    if (n == 1)
        snprintf(count, sizeof count, "a %s", kind);
    else
        snprintf(count, sizeof count, "%d comma-separated %ss", n, kind);
    int digits = flags & OP_NUMBER_WHOLE ? 17 : 6;
    return op_error_set(err, OP_ERR_INPUT, "%s %s: need %s in %c%.*g, %.*g%c", opt, text, count,
                        flags & OP_NUMBER_ABOVE_LO ? '(' : '[', digits, lo, digits, hi,
                        flags & OP_NUMBER_BELOW_HI ? ')' : ']');
}

op_status op_parse_number(const char *opt, const char *text, double lo, double hi, int flags,
                          double *out, op_error *err)
{
    return op_parse_numbers(opt, text, 1, lo, hi, flags, out, err);
}
