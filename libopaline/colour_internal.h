/* colour_internal.h - what libopaline's view transforms (colour.c) share with their
 * OpenColorIO module (colour_ocio.cpp); private to this folder. */
#ifndef OPALINE_COLOUR_INTERNAL_H
#define OPALINE_COLOUR_INTERNAL_H

#include <stddef.h>

#include "image_internal.h" /* opaline.h and opaline_image.h, for C and C++ */

#ifdef __cplusplus
extern "C" {
#endif

/* What colour.c lends the OpenColorIO module (which links no part of libopaline). */
typedef struct op_colour_host {
    op_status (*error_set)(op_error *err, op_status status, const char *fmt, ...);
} op_colour_host;

/* The OpenColorIO module: opaline-ocio.so (colour_ocio.cpp), loaded by colour.c when a view
 * transform is first checked or applied; its one entry point is OP_COLOUR_OCIO_ENTRY. */
#define OP_COLOUR_OCIO_MODULE "opaline-ocio.so"
#define OP_COLOUR_OCIO_ENTRY "op_colour_ocio_apply"
/* Builds vt's processor (OP_ERR_INPUT naming a config, display, view or look that OpenColorIO
 * does not know) and applies it to the n RGBA pixels of rgba (premultiplied, as
 * op_view_transform_apply says); rgba NULL: builds it only. */
typedef op_status (*op_colour_ocio_apply_fn)(const op_colour_host *host,
                                             const op_view_transform *vt, float *rgba, size_t n,
                                             op_error *err);

#ifdef __cplusplus
}
#endif
#endif
