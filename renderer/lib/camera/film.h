/* film.h - the film (hdrfilm / ldrfilm / mfilm: size, crop window, output settings), its
 * reconstruction filter, and developing its image into an image file (tone mapping, pixel
 * format, the file format by name). The filter is applied by filter importance sampling:
 * each sample's position within its pixel is drawn from the filter's own distribution (for
 * filters with negative lobes, from a table of its magnitude) and a pixel is the mean of its
 * samples' weighted values, so pixels never share samples and tiles are independent. */
#ifndef OP_FILM_H
#define OP_FILM_H

#include "opaline_image.h"
#include "scene/scene_desc.h"

typedef enum op_filter_type {
    OP_FILTER_BOX,
    OP_FILTER_TENT,
    OP_FILTER_GAUSSIAN,
    OP_FILTER_TABLE /* mitchell, catmullrom, lanczos: sampled from filter_table */
} op_filter_type;

/* A separable filter's 1-D profile f on [-radius, radius], tabulated in OP_FILTER_BINS equal
 * bins: cdf of |f| (bin averages), and f's integral. */
enum { OP_FILTER_BINS = 512 };
typedef struct op_filter_table {
    float cdf[OP_FILTER_BINS + 1];
    double integral;              /* of f (not |f|), > 0 */
    double abs_integral;          /* of |f| over the bins' averages */
    int kind;                     /* 0 Mitchell-Netravali (b, c), 1 Lanczos (lobes) */
    double b, c;                  /* Mitchell-Netravali's B and C */
    int lobes;                    /* Lanczos */
} op_filter_table;
typedef enum op_pixel_format { OP_PIXFMT_RGB, OP_PIXFMT_RGBA, OP_PIXFMT_LUMINANCE } op_pixel_format;

typedef struct op_film {
    int ldr;                    /* ldrfilm */
    int full_width, full_height;
    int crop_x, crop_y, width, height;
    char filename[1024];        /* empty when the film names none */
    op_pixel_format pixel_format;
    int half_float;             /* hdrfilm componentFormat float16 (the default) */
    const char *extension;      /* the fileFormat's: ".exr" (openexr), ".pfm", ".hdr" (rgbe),
                                   ".png" (ldrfilm) */
    double gamma;               /* ldrfilm: -1 = sRGB */
    double exposure;            /* ldrfilm: stops (tonemapMethod gamma) */
    int reinhard;               /* ldrfilm: tonemapMethod reinhard */
    double key, burn;           /* ldrfilm: Reinhard's key (0.18) and burn (0) */
    int mfilm;                  /* mfilm: a measurement written as a text matrix (".m") or a
                                   NumPy array (".npy", fileFormat numpy) */
    op_matrix_format matrix;    /* a ".m" output's format: mfilm's fileFormat (else MATLAB) */
    int digits;                 /* a ".m" output's significant digits (mfilm's digits, 4) */
    char variable[64];          /* a ".m" output's variable (mfilm's variable, "data") */
    op_filter_type filter;
    float filter_radius;        /* box 0.5, tent 1 (or radius), gaussian 4 * stddev,
                                   mitchell/catmullrom 2 (or radius), lanczos lobes */
    float stddev;
    op_filter_table table;      /* OP_FILTER_TABLE's */
    /* opaline's view transform (viewTransform ...): a PNG developed through an OpenColorIO
     * config's display and view, as Blender saves a render; view[0] == '\0': none */
    char view_config[4096], view_display[256], view[256], view_look[256];
    double view_exposure, view_gamma;
} op_film;

/* Reads a <film> (NULL: hdrfilm 768 x 576 with a gaussian filter; an mfilm is 1 x 1 with a box
 * filter and luminance pixels unless it says otherwise). A view transform it names is checked
 * (its config, display, view and look known to OpenColorIO). */
op_status op_film_build(op_node *film, op_film *out, op_error *err);
/* Sets the crop window (Mitsuba's cropOffsetX/Y, cropWidth/Height: the pixels rendered, a
 * rectangle of the full_width x full_height film, top-left origin). A window not inside the
 * film is OP_ERR_INPUT, the message starting with `where`. */
op_status op_film_set_crop(op_film *film, long long x, long long y, long long w, long long h,
                           const char *where, op_error *err);
/* The offset of a sample from its pixel's centre, in pixels, drawn from the filter; returns the
 * weight of the sample's value (1 for box, tent and gaussian; for a filter with negative lobes
 * f(dx) f(dy) / (pdf * integral of f squared), whose mean over samples is 1). */
float op_film_sample_offset(const op_film *film, float u1, float u2, float *dx, float *dy);

/* The film's view transform (pointing into film); view "" when it names none. */
void op_film_view_transform(const op_film *film, op_view_transform *vt);
/* The image format of an output path (".exr", ".png", ".pfm", ".hdr", ".m" a text matrix or
 * ".npy" a NumPy array):
 * by its extension, else the film's when the file name has no dot; NULL for an unknown
 * extension. */
const char *op_film_image_format(const op_film *film, const char *path);
/* Develops the RGBA image under the film's settings and writes it to path in its format
 * (op_film_image_format): hdrfilm's pixelFormat and componentFormat; ldrfilm's tonemapMethod
 * (gamma with exposure, or reinhard), gamma and pixelFormat; a PNG through the film's view
 * transform when it names one (the float formats stay scene-linear). PFM, RGBE and an
 * hdrfilm's PNG (a preview, opaque) drop alpha. */
op_status op_film_write_image(const op_film *film, const op_image *img, const char *path,
                              op_error *err);

#endif
