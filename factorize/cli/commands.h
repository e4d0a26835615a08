/* commands.h - the subcommands of opaline-factor. Each takes the arguments after its name and
 * returns a process exit code (0 success, 2 bad input, 1 other failure), having reported any
 * error through op_log. */
#ifndef OP_FACTOR_COMMANDS_H
#define OP_FACTOR_COMMANDS_H

int op_cmd_dataset(int argc, char **argv); /* make a synthetic dataset (dataset_cmd.c) */
int op_cmd_import(int argc, char **argv);  /* bring in a NumPy .npy dataset (import_cmd.c) */
int op_cmd_factor(int argc, char **argv);  /* factor a dataset into a material (factor_cmd.c) */
int op_cmd_info(int argc, char **argv);    /* describe a material file (info_cmd.c) */

#endif
