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

/* A spectrum sampled at strictly increasing wavelengths (nm), linear between samples and 0
 * outside them, to linear sRGB. The result is white-balanced so that a spectrum flat over
 * the visible range (360-830 nm) with value v gives exactly (v, v, v): it is the colour of a
 * reflectance under the sRGB white. Fails (OP_ERR_INPUT) on fewer than one sample, wavelengths
 * not increasing or outside (0, 10000), or values not finite. A single sample is a constant. */
op_status op_color_from_samples(const double *lambda_nm, const double *value, int n, double rgb[3],
                                op_error *err);

/* Parses a Mitsuba spectrum value: "v" (a constant: grey v) or "l1:v1, l2:v2, ..." pairs. */
op_status op_color_parse_spectrum(const char *text, double rgb[3], op_error *err);

/* Parses a spectrum file: lines "wavelength value", blank lines and '#' comments ignored. */
op_status op_color_read_spectrum_file(const char *path, double rgb[3], op_error *err);

/* The colour of a black body at kelvin (> 0), normalized to luminance Y = 1, with negative
 * (out of gamut) components clipped to 0. */
op_status op_color_blackbody(double kelvin, double rgb[3], op_error *err);

/* CIE XYZ to linear sRGB (D65). */
void op_color_xyz_to_rgb(const double xyz[3], double rgb[3]);

#endif
