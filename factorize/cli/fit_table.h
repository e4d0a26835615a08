/* fit_table.h - the factorization methods `opaline-factor factor` runs: one entry (fit.h) per
 * method, in the order messages list them. Adding a method adds its fit_<name>.c here. */
#ifndef OP_FACTOR_FIT_TABLE_H
#define OP_FACTOR_FIT_TABLE_H

#include "fit.h"

#include <stddef.h>

/* The entries, each defined in its fit_<name>.c. */
extern const fit_method op_fit_svd, op_fit_tucker, op_fit_kcta, op_fit_nmf, op_fit_raw;

/* The entry of method m, or NULL when the factor command does not fit it. */
const fit_method *op_fit_find(op_method m);
/* The i-th entry, or NULL when i is past the last. */
const fit_method *op_fit_method(size_t i);
/* The names of the methods taking every option in `options` (all methods for 0), joined by
 * sep with last_sep before the last one ("svd, tucker or raw"), into buf (n bytes). */
void op_fit_names(unsigned options, const char *sep, const char *last_sep, char *buf, size_t n);

#endif
