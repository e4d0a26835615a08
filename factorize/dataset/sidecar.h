/* sidecar.h - the JSON sidecar of an imported dataset: {"size_cm": [X, Y], "name": "...",
 * "source": "..."}, parsed from bytes by a small strict JSON reader. */
#ifndef OP_SIDECAR_H
#define OP_SIDECAR_H

#include <stddef.h>

#include "opaline.h"

/* The largest sidecar accepted. */
#define OP_SIDECAR_MAX_BYTES 65536

typedef struct op_sidecar {
    double size_x_cm, size_y_cm; /* finite and > 0 after a successful parse */
    char name[128], source[96];  /* "" when absent; truncated; non-ASCII \u escapes become '?' */
} op_sidecar;

/* Parses text, n bytes followed by a NUL byte (as op_file_read returns them): one JSON object
 * with a required "size_cm" and optional "name" and "source"; other keys are skipped with a
 * warning. OP_ERR_INPUT naming path and the byte at fault for anything else. */
op_status op_sidecar_parse(const char *text, size_t n, const char *path, op_sidecar *sc,
                           op_error *err);

#endif
