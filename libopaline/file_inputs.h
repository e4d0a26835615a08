/* file_inputs.h - the inputs of this run, as op_file_open opened them (private to libopaline:
 * output.c asks it so that no output replaces an input; op_file_protect_inputs, in opaline.h,
 * starts the record). */
#ifndef OP_FILE_INPUTS_H
#define OP_FILE_INPUTS_H

#include <stddef.h>
#include <sys/types.h>

/* 1 with the input's path (as first opened, truncated to n bytes) in path when the file dev:ino
 * was opened as an input since op_file_protect_inputs; else 0. Thread-safe. */
int op_file_input_path(dev_t dev, ino_t ino, char *path, size_t n);

#endif
