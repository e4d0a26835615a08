/* image_internal.h - what libopaline's image reader (image.c) shares with its OpenImageIO
 * module (image_oiio.cpp); private to this folder. */
#ifndef OPALINE_IMAGE_INTERNAL_H
#define OPALINE_IMAGE_INTERNAL_H

#include <stdint.h>

#ifdef __cplusplus
/* opaline.h's one C11 atomic type, which C++ before C++23 spells std::atomic_int; the C
 * header <stdatomic.h> that opaline.h includes is kept out (clang's defines C macros that
 * break libstdc++), by the include guards of clang's, GCC's and libstdc++'s. */
#include <atomic>
using std::atomic_int;
#define __CLANG_STDATOMIC_H
#define _STDATOMIC_H
#define _GLIBCXX_STDATOMIC_H
#endif
#include "opaline.h"
#include "opaline_image.h"

#ifdef __cplusplus
extern "C" {
#endif

/* What image.c lends the OpenImageIO module (which links no part of libopaline). */
typedef struct op_image_host {
    op_status (*error_set)(op_error *err, op_status status, const char *fmt, ...);
    op_status (*alloc)(op_image *img, int width, int height, int channels, op_error *err);
    void (*free)(op_image *img);
    float (*srgb_decode)(float v);
    float (*srgb_encode)(float v);
    op_status (*check_pixels)(const char *path, const char *kind, uint64_t w, uint64_t h,
                              uint64_t max_pixels, op_error *err);
} op_image_host;

/* The OpenImageIO module: opaline-oiio.so (image_oiio.cpp), loaded by image.c when it first
 * reads a format other than PNG, OpenEXR and PFM (or an OpenEXR compression image.c's
 * OpenEXR library cannot decode), since OpenImageIO and the libraries it loads take Debian's
 * programs 0.7 s and 130 MB to start; its one entry point is OP_IMAGE_OIIO_ENTRY. */
#define OP_IMAGE_OIIO_MODULE "opaline-oiio.so"
#define OP_IMAGE_OIIO_ENTRY "op_image_oiio_read"
/* Reads path through OpenImageIO's reader of format ("jpeg", "tiff", "hdr", "bmp", "pnm",
 * "targa", and "openexr" for the compressions OpenEXR's C library cannot decode; kind names it
 * in messages): the RGB(A) or grey(+alpha) channels of the first
 * subimage (TIFF page). Integer pixels (8, 16 or 32 bits) are sRGB-encoded unless the file
 * declares another transfer curve: decoded to linear light when decode is set, else returned
 * as sRGB-encoded values in [0, 1] with *encoded = 1. Float pixels are linear, returned as
 * stored, *encoded = 0. The size is checked against the sides' limits and max_pixels from the
 * header, before anything is decoded; with header_only, only the size and channels are set
 * (pixels NULL). */
typedef op_status (*op_image_oiio_read_fn)(const op_image_host *host, const char *path,
                                           const char *format, const char *kind, int decode,
                                           uint64_t max_pixels, int header_only, op_image *img,
                                           int *encoded, op_error *err);

#ifdef __cplusplus
}
#endif
#endif
