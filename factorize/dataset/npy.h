/* npy.h - the header of a NumPy .npy file (format versions 1 to 3), parsed from bytes. */
#ifndef OP_NPY_H
#define OP_NPY_H

#include <stddef.h>
#include <stdint.h>

#include "opaline.h"

/* The most leading bytes of a file that op_npy_parse_header reads: the preamble and the
 * largest header it accepts (64 KiB). */
#define OP_NPY_MAX_HEADER (12 + 65536)

typedef struct op_npy_header {
    int itemsize;        /* 4 or 8 (float32 or float64) */
    int big_endian;
    int ndim;            /* <= 8 */
    long long shape[8];  /* each >= 0 */
    uint64_t data_offset; /* where the array's bytes start */
} op_npy_header;

/* Parses the header at the start of buf, which holds the file's first n bytes (all of them, or
 * at least OP_NPY_MAX_HEADER): magic, version, and the dict's descr (float32 or float64, any
 * byte order), fortran_order (must be False) and shape. OP_ERR_FORMAT for a file that is no
 * .npy or a malformed header, OP_ERR_INPUT for a valid header opaline does not take; messages
 * start with path. */
op_status op_npy_parse_header(const unsigned char *buf, size_t n, const char *path,
                              op_npy_header *h, op_error *err);

#endif
