/* fuzz_support.h - what the fuzz targets share. Each target defines LLVMFuzzerTestOneInput;
 * linked with libFuzzer it is fuzzed, linked with fuzz_replay.c it replays saved inputs. */
#ifndef OP_FUZZ_SUPPORT_H
#define OP_FUZZ_SUPPORT_H

#include <stddef.h>
#include <stdint.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* The readers under test take paths: writes data to this process's scratch file, whose name
 * ends in suffix, and returns its path (valid until the next call). Aborts if it cannot. */
const char *op_fuzz_file(const uint8_t *data, size_t size, const char *suffix);

/* Writes data to the file name (a plain name) in this process's scratch folder, made on first
 * use and removed with its files at exit, and returns its path (valid until the next call):
 * for inputs made of several files that name each other. Aborts if it cannot. */
const char *op_fuzz_folder_file(const char *name, const uint8_t *data, size_t size);

/* Aborts (a crash the fuzzer reports) with msg when cond is false: for contracts that a
 * successful read promises, such as finite, non-negative Rd values. */
void op_fuzz_require(int cond, const char *msg);

#endif
