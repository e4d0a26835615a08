/* fuzz_sidecar.c - the JSON sidecar reader of `opaline-factor import` (op_sidecar_parse) on
 * arbitrary bytes, given exactly as op_file_read would (a NUL byte after the data, in a buffer
 * of that size, so that ASan sees any read past it); a sidecar it accepts has a finite,
 * positive size and terminated strings. */
#include "fuzz_support.h"

#include "opaline.h"
#include "sidecar.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static int quiet;
    if (!quiet++)
        op_log_set_level(OP_LOG_ERROR); /* unknown keys are warnings */
    char *text = malloc(size + 1);
    op_fuzz_require(text != NULL, "out of memory");
    memcpy(text, data, size);
    text[size] = '\0';
    op_sidecar sc;
    op_error err;
    if (op_sidecar_parse(text, size, "fuzz.json", &sc, &err) == OP_OK) {
        op_fuzz_require(isfinite(sc.size_x_cm) && sc.size_x_cm > 0 && isfinite(sc.size_y_cm) &&
                            sc.size_y_cm > 0, "size_cm is not finite and positive");
        op_fuzz_require(memchr(sc.name, 0, sizeof sc.name) && memchr(sc.source, 0, sizeof sc.source),
                        "unterminated string");
    }
    free(text);
    return 0;
}
