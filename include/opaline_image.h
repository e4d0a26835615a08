/*
 * opaline_image.h - image files: linear-light float images, written as PNG, OpenEXR, PFM,
 * Radiance HDR, a text matrix (MATLAB, Mathematica) or a NumPy array, and read from those and
 * JPEG, TIFF, BMP, PNM and TGA; view transforms (OpenColorIO's) for display-referred output.
 * Errors and conventions: opaline.h.
 */
#ifndef OPALINE_IMAGE_H
#define OPALINE_IMAGE_H

#include <stddef.h>
#include <stdint.h>

#include "opaline.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Pixels are linear-light floats, row-major from the top row, `channels` interleaved per pixel
 * (1 = grey, 3 = RGB, 4 = RGBA). */
typedef struct op_image {
    int width, height, channels;
    float *pixels;
} op_image;

/* The largest image opaline holds: each side at most OP_IMAGE_MAX_SIDE, width x height at most
 * OP_IMAGE_MAX_PIXELS (far above any render, far below overflow). A scene's film is refused
 * beyond them when it loads. */
#define OP_IMAGE_MAX_SIDE 65536
#define OP_IMAGE_MAX_PIXELS ((size_t)1 << 30)

/* A zeroed image; a size beyond the limits above or a channel count not 1, 3 or 4 is
 * OP_ERR_INPUT. */
op_status op_image_alloc(op_image *img, int width, int height, int channels, op_error *err);
void op_image_free(op_image *img);
/* 8-bit sRGB PNG after multiplying by 2^exposure_stops; values are clamped to [0, 1]. */
op_status op_image_write_png(const char *path, const op_image *img, float exposure_stops,
                             op_error *err);
/* OpenEXR (via its C API), half floats when half_float != 0, else 32-bit floats. */
op_status op_image_write_exr(const char *path, const op_image *img, int half_float, op_error *err);
/* op_image_write_exr with one more header attribute, the string attr_name = attr_value. */
op_status op_image_write_exr_attr(const char *path, const op_image *img, int half_float,
                                  const char *attr_name, const char *attr_value, op_error *err);
/* The string attribute name of an OpenEXR file's first part into out (n bytes, truncated),
 * "" when it has none; OP_ERR_FORMAT when path is not a readable OpenEXR file. */
op_status op_image_exr_attr(const char *path, const char *name, char *out, size_t n,
                            op_error *err);
/* Portable float map, little-endian. */
op_status op_image_write_pfm(const char *path, const op_image *img, op_error *err);
/* Radiance RGBE (.hdr): shared-exponent RGB, 4 bytes a pixel (a grey image repeats its
 * channel, alpha is dropped). */
op_status op_image_write_hdr(const char *path, const op_image *img, op_error *err);
/* The text formats of op_image_write_matrix. */
typedef enum op_matrix_format { OP_MATRIX_MATLAB, OP_MATRIX_MATHEMATICA } op_matrix_format;
/* The image as a text matrix of height rows by width columns per channel, each value with
 * `digits` (1..17) significant digits, assigned to `variable` (letters, digits and _ after a
 * letter): MATLAB's "variable = [a, b;\n\tc, d];" (a channel k > 1 as "variable(:, :, k) =
 * [...];", Inf and NaN as MATLAB spells them) or Mathematica's "variable = {{a, b},\n\t{c, d}};"
 * (several channels as Transpose[{channel, ...}, {3,1,2}], exponents as *^, Infinity and
 * Indeterminate), the layouts of Mitsuba 0.6's mfilm. A bad digits or variable is
 * OP_ERR_INPUT. */
op_status op_image_write_matrix(const char *path, const op_image *img, op_matrix_format format,
                                int digits, const char *variable, op_error *err);
/* Whether name is a variable name op_image_write_matrix accepts. */
int op_matrix_variable_valid(const char *name);
/* The image as a NumPy .npy array (format 1.0, little-endian float32, C order) of shape
 * (height, width) for one channel, (height, width, channels) for more, rows from the top: the
 * layout of Mitsuba 0.6's mfilm with fileFormat numpy. */
op_status op_image_write_npy(const char *path, const op_image *img, op_error *err);
/* Reads an image file into linear floats: OpenEXR, PNG (8 or 16 bits), JPEG, TIFF, Radiance
 * HDR, BMP, PNM or PFM, chosen by content, or TGA (which has no signature) by the name's
 * extension .tga. PNG (libpng), OpenEXR (its C API) and PFM are read here, the others through
 * OpenImageIO, loaded on first use. Integer pixels are sRGB-encoded unless the file declares another curve (a PNG's
 * gAMA) and are decoded to linear light; alpha and float pixels are returned as stored. Of OpenEXR files, the channels R, G, B
 * (and A), or Y (else R) alone, of the first part that has them; other layers are skipped.
 * A file with several images (TIFF pages) gives its first. Grey with alpha becomes RGBA. */
op_status op_image_read(const char *path, op_image *img, op_error *err);
/* The same, but integer files keep their sRGB-encoded values (code / largest code; a file with
 * another declared curve is re-encoded as sRGB) instead of being decoded, so that a caller can
 * apply another transfer curve; *encoded is set to 1 for those and to 0 for float files
 * (OpenEXR, HDR, PFM, float TIFF), whose values both functions return as stored. */
op_status op_image_read_stored(const char *path, op_image *img, int *encoded, op_error *err);
/* The most pixels (width x height) the two readers above accept: 2^27 (16384 x 8192). */
#define OP_IMAGE_DEFAULT_MAX_PIXELS ((uint64_t)1 << 27)
/* op_image_read (decode != 0) or op_image_read_stored (decode == 0; encoded may be NULL) with
 * another pixel limit: an image whose header says it has more than max_pixels pixels is refused
 * (OP_ERR_INPUT naming the limit "image-pixels") before anything is decoded or allocated. */
op_status op_image_read_limited(const char *path, int decode, uint64_t max_pixels, op_image *img,
                                int *encoded, op_error *err);
/* op_image_read_limited of the OpenEXR layer named: the channels layer.R, layer.G, layer.B
 * (and layer.A, or layer.Y alone) of the first part that has them, or R, G, B ... of the part
 * named layer; NULL or "" is the default layer. A file without that layer, or a layer named
 * for another format, is OP_ERR_INPUT naming it. */
op_status op_image_read_layer(const char *path, const char *layer, int decode,
                              uint64_t max_pixels, op_image *img, int *encoded, op_error *err);
/* The width, height and channels (as op_image_read would give them) of any file it reads,
 * from its header: no pixel is decoded and no pixel limit applies. The readers'
 * errors for a file they refuse before decoding; 0, 0, 0 then. */
op_status op_image_read_size(const char *path, int *width, int *height, int *channels,
                             op_error *err);

/* A view transform of an OpenColorIO configuration, as Blender applies its scene's colour
 * management (view settings, display device) to a render it saves display-referred: 2^exposure
 * in the scene-linear role, then the look (NULL, "" or "None": none), then the display's view,
 * then the power 1 / gamma. */
typedef struct op_view_transform {
    const char *config;         /* the config.ocio file */
    const char *display;        /* NULL or "": the config's default display */
    const char *view;
    const char *look;
    double exposure;            /* stops */
    double gamma;               /* > 0; 1: none */
} op_view_transform;
/* Whether OpenColorIO reads vt's config and knows its display, view and look: OP_ERR_INPUT
 * naming what it lacks (the names it has), or when OpenColorIO's module (opaline-ocio.so) is
 * missing. */
op_status op_view_transform_check(const op_view_transform *vt, op_error *err);
/* Applies vt to the scene-linear RGB of img (3 or 4 channels) in place, leaving display-encoded
 * values; RGBA pixels are premultiplied: their colour is divided by alpha (when it is in (0, 1))
 * before and multiplied after, as Blender does. */
op_status op_view_transform_apply(const op_view_transform *vt, op_image *img, op_error *err);

#ifdef __cplusplus
}
#endif
#endif
