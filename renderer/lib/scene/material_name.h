/* material_name.h - the material names a scene may give besides preset names and paths. */
#ifndef OP_MATERIAL_NAME_H
#define OP_MATERIAL_NAME_H

#include <stddef.h>

#include "opaline_material.h"

/* The long material names of the Blender/Mitsuba plugin (Onel, Kurt, Ozturk), e.g.
 * "SVD S10 Div100 Add1 for Rd Chess4x4 v1(277x277x39x39)": "<METHOD> <params> for Rd <Name> ...",
 * where each param is letters followed by a number. Returns 1 when name has that form, writing
 * the preset name (METHOD, the params other than Div and Add, and Name joined by '_', e.g.
 * "SVD_S10_Chess4x4", "TUCKER_T15_P7_Chess4x4") to out, the method to *method, and Div (A) and
 * Add (B) to *a and *b (0 when absent); returns 0 otherwise (out untouched). */
int op_parse_long_material_name(const char *name, char *out, size_t n, op_method *method, double *a,
                           double *b);

#endif
