/* fit_table.c - the method table of `opaline-factor factor` (fit_table.h). */
#include "fit_table.h"

#include <stdio.h>
#include <string.h>

static const fit_method *const methods[] = {&op_fit_svd, &op_fit_tucker, &op_fit_kcta,
                                            &op_fit_nmf, &op_fit_raw};
#define NMETHODS (sizeof methods / sizeof methods[0])

const fit_method *op_fit_find(op_method m)
{
    for (size_t i = 0; i < NMETHODS; i++)
        if (methods[i]->method == m)
            return methods[i];
    return NULL;
}

const fit_method *op_fit_method(size_t i)
{
    return i < NMETHODS ? methods[i] : NULL;
}

void op_fit_names(unsigned options, const char *sep, const char *last_sep, char *buf, size_t n)
{
    size_t count = 0, listed = 0, len = 0;
    for (size_t i = 0; i < NMETHODS; i++)
        count += (methods[i]->options & options) == options;
    if (n)
        buf[0] = '\0';
    for (size_t i = 0; i < NMETHODS && len < n; i++) {
        if ((methods[i]->options & options) != options)
            continue;
        const char *before = listed == 0 ? "" : listed + 1 == count ? last_sep : sep;
        int k = snprintf(buf + len, n - len, "%s%s", before, op_method_name(methods[i]->method));
        len += k > 0 ? (size_t)k : 0;
        listed++;
    }
}
