/* dialect.h - the two grammars of Mitsuba scene files and how one tree serves both.
 *
 * A file's <scene version="..."> names its dialect: 0.x and 1.x are Mitsuba 0.4-0.6 (and
 * opaline's own files), whose parameter names are camelCase (toWorld, intIOR); 2.x and 3.x are
 * Mitsuba 2/3, whose names are snake_case (to_world, int_ior). The reader records every
 * parameter under its Mitsuba 0.6 name, so the builders read one set of names; the name as
 * written is kept for messages, and the node remembers its file's dialect for the few defaults
 * and meanings that differ (docs/scene-format.md lists them). A file is read in its own dialect
 * only: a name spelled in the other one is an error that says so, never an unused parameter. */
#ifndef OP_SCENE_DIALECT_H
#define OP_SCENE_DIALECT_H

#include <stddef.h>

typedef enum op_dialect {
    OP_DIALECT_MITSUBA_0 = 0, /* Mitsuba 0.4-0.6, opaline's own files */
    OP_DIALECT_MITSUBA_3      /* Mitsuba 2.x and 3.x */
} op_dialect;

/* What a version string declares: 0 and *d on success (*unusual set when the version is a
 * Mitsuba 0.x/1.x one other than 0.5 and 0.6, read as 0.6 with a warning); -1 when it is not
 * major.minor[.patch] or names a Mitsuba release that does not exist (4 and later). */
int op_dialect_from_version(const char *version, op_dialect *d, int *unusual);

/* "Mitsuba 0.6" or "Mitsuba 3", for messages. */
const char *op_dialect_label(op_dialect d);

/* The Mitsuba 0.6 name of the parameter spelled as written in dialect d, into out (cap
 * bytes). Returns 0 on success; -1 when the spelling belongs to the other dialect (a Mitsuba 3
 * file's camelCase name, a 0.x file's snake_case one), with *hint the name as the file's own
 * dialect spells it, in hint (hcap bytes); -2 when it does not fit. A name that is not letters,
 * digits and underscores (an exporter's label such as "mat-Material") is no parameter of either
 * dialect and is kept as written. */
int op_dialect_param_name(op_dialect d, const char *spelled, char *out, size_t cap, char *hint,
                          size_t hcap);

#endif
