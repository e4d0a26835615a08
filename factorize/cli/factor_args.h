/* factor_args.h - the command line of `opaline-factor factor`: its usage text, and its parsing
 * into factor_args (fit.h) with the method's defaults applied (its entry's defaults()). */
#ifndef OP_FACTOR_ARGS_H
#define OP_FACTOR_ARGS_H

#include "fit.h"
#include "opaline.h"

#include <stdio.h>

/* Prints the usage text, the methods and their default -T from the method table. */
void op_factor_usage(FILE *f);
/* Parses the arguments after "factor" (argv[0] is "factor"): OP_ERR_INPUT naming the option at
 * fault, an option the chosen method does not take included. */
op_status op_factor_parse_args(int argc, char **argv, factor_args *a, op_error *err);

#endif
