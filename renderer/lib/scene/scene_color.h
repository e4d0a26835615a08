/* scene_color.h - scene colours to linear sRGB (Rec. 709 primaries, D65 white): sRGB decoding,
 * "#rrggbb", sampled spectra and black bodies through the CIE 1931 colour matching functions. */
#ifndef OP_SCENE_COLOR_H
#define OP_SCENE_COLOR_H

#include <stddef.h>

#include "opaline.h"

/* The sRGB transfer function, decoded (encoded value in [0, 1] -> linear), per component;
 * values outside [0, 1] are extended symmetrically (sign kept, curve mirrored). */
double op_srgb_to_linear(double v);

/* "#rrggbb" (case-insensitive hex, sRGB-encoded) to linear RGB. Returns 0 when s is not of
 * that form. */
int op_color_parse_hex(const char *s, double rgb[3]);

/* How a sampled spectrum becomes RGB, as the scene's dialect reads it. */
typedef enum op_spectrum_reading {
    /* XYZ through the CIE functions, normalized by the integral of y: Mitsuba 0.6's RGB build
     * (every spectrum) and Mitsuba 3 (an emitter's); a spectrum flat at 1 is the equal-energy
     * white, (1.205, 0.948, 0.909) in sRGB. Negative components are clipped to 0. */
    OP_SPECTRUM_PLAIN,
    /* white-balanced so that a flat spectrum v gives exactly (v, v, v): the colour of a
     * reflectance under the sRGB white, as Mitsuba 3 reads a non-emitter's spectrum (it weights
     * by D65 to the same end; the two agree on flat spectra and closely on smooth ones) */
    OP_SPECTRUM_REFLECTANCE
} op_spectrum_reading;

/* A spectrum sampled at strictly increasing wavelengths (nm), linear between samples and 0
 * outside them, to linear sRGB read as how says. Fails (OP_ERR_INPUT) on fewer than one sample,
 * wavelengths not increasing or outside (0, 10000), or values not finite. A single sample is a
 * constant (grey). */
op_status op_color_from_samples(const double *lambda_nm, const double *value, int n,
                                op_spectrum_reading how, double rgb[3], op_error *err);

/* Parses a Mitsuba spectrum value: "v" (a constant: grey v), "r, g, b" (Mitsuba 0.6's RGB
 * bins) or "l1:v1, l2:v2, ..." pairs (read as how says). */
op_status op_color_parse_spectrum(const char *text, op_spectrum_reading how, double rgb[3],
                                  op_error *err);

/* Parses a spectrum file: lines "wavelength value", blank lines and '#' comments ignored. */
op_status op_color_read_spectrum_file(const char *path, op_spectrum_reading how, double rgb[3],
                                      op_error *err);

/* The colour of a black body at kelvin (> 0), normalized to luminance Y = 1, with negative
 * (out of gamut) components clipped to 0. */
op_status op_color_blackbody(double kelvin, double rgb[3], op_error *err);

/* CIE XYZ to linear sRGB (D65). */
void op_color_xyz_to_rgb(const double xyz[3], double rgb[3]);

#endif
