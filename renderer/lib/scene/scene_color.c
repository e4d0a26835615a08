/* scene_color.c - see scene_color.h. The CIE 1931 2-degree colour matching functions are the
 * multi-lobe Gaussian fit of Wyman, Sloan and Shirley (JCGT 2013), accurate to about 1 % of
 * the tabulated functions, which is far below what a scene's colours need. */
#include "scene/scene_color.h"
#include "scene/scene_desc.h" /* op_scan_double */

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define LAMBDA_MIN 360.0
#define LAMBDA_MAX 830.0
#define MAX_SAMPLES 4096

double op_srgb_to_linear(double v)
{
    double a = fabs(v);
    double r = a <= 0.04045 ? a / 12.92 : pow((a + 0.055) / 1.055, 2.4);
    return v < 0 ? -r : r;
}

static int hex_digit(int c)
{
    if (c >= '0' && c <= '9')
        return c - '0';
    c = tolower(c);
    if (c >= 'a' && c <= 'f')
        return c - 'a' + 10;
    return -1;
}

int op_color_parse_hex(const char *s, double rgb[3])
{
    if (!s || s[0] != '#' || strlen(s) != 7)
        return 0;
    for (int i = 0; i < 3; i++) {
        int hi = hex_digit((unsigned char)s[1 + 2 * i]), lo = hex_digit((unsigned char)s[2 + 2 * i]);
        if (hi < 0 || lo < 0)
            return 0;
        rgb[i] = op_srgb_to_linear((hi * 16 + lo) / 255.0);
    }
    return 1;
}

void op_color_xyz_to_rgb(const double xyz[3], double rgb[3])
{
    static const double m[3][3] = {{3.2404542, -1.5371385, -0.4985314},
                                   {-0.9692660, 1.8760108, 0.0415560},
                                   {0.0556434, -0.2040259, 1.0572252}};
    double r[3];
    for (int i = 0; i < 3; i++)
        r[i] = m[i][0] * xyz[0] + m[i][1] * xyz[1] + m[i][2] * xyz[2];
    memcpy(rgb, r, sizeof r);
}

/* A two-sided Gaussian lobe. */
static double lobe(double x, double mu, double s1, double s2)
{
    double t = (x - mu) / (x < mu ? s1 : s2);
    return exp(-0.5 * t * t);
}

static void cmf(double l, double out[3])
{
    out[0] = 1.056 * lobe(l, 599.8, 37.9, 31.0) + 0.362 * lobe(l, 442.0, 16.0, 26.7) -
             0.065 * lobe(l, 501.1, 20.4, 26.2);
    out[1] = 0.821 * lobe(l, 568.8, 46.9, 40.5) + 0.286 * lobe(l, 530.9, 16.3, 31.1);
    out[2] = 1.217 * lobe(l, 437.0, 11.8, 36.0) + 0.681 * lobe(l, 459.0, 26.0, 13.8);
}

/* XYZ of a spectrum given as a function, integrated at 1 nm over [360, 830]. */
typedef double (*spectrum_fn)(const void *user, double lambda);

static void integrate(spectrum_fn f, const void *user, double xyz[3])
{
    xyz[0] = xyz[1] = xyz[2] = 0.0;
    for (double l = LAMBDA_MIN; l <= LAMBDA_MAX; l += 1.0) {
        double c[3], s = f(user, l);
        cmf(l, c);
        for (int k = 0; k < 3; k++)
            xyz[k] += s * c[k];
    }
}

static double flat_one(const void *user, double lambda)
{
    return 1.0;
}

typedef struct samples {
    const double *l, *v;
    int n;
} samples;

static double sampled(const void *user, double lambda)
{
    const samples *s = user;
    if (lambda < s->l[0] || lambda > s->l[s->n - 1])
        return 0.0;
    int lo = 0, hi = s->n - 1;
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (s->l[mid] <= lambda)
            lo = mid;
        else
            hi = mid;
    }
    double t = (lambda - s->l[lo]) / (s->l[hi] - s->l[lo]);
    return s->v[lo] + t * (s->v[hi] - s->v[lo]);
}

op_status op_color_from_samples(const double *lambda_nm, const double *value, int n,
                                op_spectrum_reading how, double rgb[3], op_error *err)
{
    if (n < 1)
        return op_error_set(err, OP_ERR_INPUT, "a spectrum needs at least one sample");
    for (int i = 0; i < n; i++) {
        if (!isfinite(value[i]) || !(lambda_nm[i] > 0.0 && lambda_nm[i] < 10000.0))
            return op_error_set(err, OP_ERR_INPUT, "spectrum sample %d (%g nm: %g) is not valid",
                                i + 1, lambda_nm[i], value[i]);
        if (i > 0 && !(lambda_nm[i] > lambda_nm[i - 1]))
            return op_error_set(err, OP_ERR_INPUT,
                                "spectrum wavelengths must increase (%g nm follows %g nm)",
                                lambda_nm[i], lambda_nm[i - 1]);
    }
    if (n == 1) {
        rgb[0] = rgb[1] = rgb[2] = value[0];
        return OP_OK;
    }
    samples s = {lambda_nm, value, n};
    double xyz[3], white_xyz[3], white[3];
    integrate(sampled, &s, xyz);
    integrate(flat_one, NULL, white_xyz);
    op_color_xyz_to_rgb(xyz, rgb);
    if (how == OP_SPECTRUM_PLAIN) {
        for (int k = 0; k < 3; k++)
            rgb[k] = fmax(rgb[k] / white_xyz[1], 0.0);
        return OP_OK;
    }
    op_color_xyz_to_rgb(white_xyz, white);
    for (int k = 0; k < 3; k++)
        rgb[k] /= white[k];
    return OP_OK;
}

op_status op_color_parse_spectrum(const char *text, op_spectrum_reading how, double rgb[3],
                                  op_error *err)
{
    if (!strchr(text, ':')) {
        /* one value: a grey; a plain list is one value per spectral bin, which Mitsuba 0.6's
         * (default) RGB build has three of: linear RGB */
        double v[4];
        int n = 0;
        const char *p = text;
        for (;;) {
            while (isspace((unsigned char)*p) || (n > 0 && *p == ','))
                p++;
            if (!*p)
                break;
            char *end;
            if (n == 4 || !op_scan_double(p, &end, &v[n]))
                break;
            n++;
            p = end;
        }
        if (*p || (n != 1 && n != 3))
            return op_error_set(err, OP_ERR_INPUT, "bad spectrum value '%s': expected one value, "
                                "three (linear RGB, as Mitsuba 0.6's RGB build reads a plain list) "
                                "or 'wavelength:value' pairs", text);
        for (int c = 0; c < 3; c++)
            rgb[c] = v[n == 1 ? 0 : c];
        return OP_OK;
    }
    double *l = malloc(MAX_SAMPLES * sizeof(double)), *v = malloc(MAX_SAMPLES * sizeof(double));
    if (!l || !v) {
        free(l);
        free(v);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    }
    int n = 0;
    const char *p = text;
    op_status st = OP_OK;
    for (;;) {
        while (isspace((unsigned char)*p) || *p == ',')
            p++;
        if (!*p)
            break;
        char *end;
        if (n == MAX_SAMPLES) {
            st = op_error_set(err, OP_ERR_INPUT, "spectrum has more than %d samples", MAX_SAMPLES);
            break;
        }
        if (!op_scan_double(p, &end, &l[n]) || *end != ':' || !op_scan_double(end + 1, &end, &v[n]) ||
            !(*end == '\0' || *end == ',' || isspace((unsigned char)*end))) {
            st = op_error_set(err, OP_ERR_INPUT,
                              "bad spectrum '%s': expected 'wavelength:value' pairs", text);
            break;
        }
        n++;
        p = end;
    }
    if (st == OP_OK)
        st = op_color_from_samples(l, v, n, how, rgb, err);
    free(l);
    free(v);
    return st;
}

op_status op_color_read_spectrum_file(const char *path, op_spectrum_reading how, double rgb[3],
                                      op_error *err)
{
    FILE *f;
    op_status opened = op_file_open_stream(path, &f, NULL, err);
    if (opened != OP_OK)
        return opened;
    double *l = malloc(MAX_SAMPLES * sizeof(double)), *v = malloc(MAX_SAMPLES * sizeof(double));
    if (!l || !v) {
        free(l);
        free(v);
        fclose(f);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    }
    char line[512];
    int n = 0, lineno = 0;
    op_status st = OP_OK;
    while (st == OP_OK && fgets(line, sizeof line, f)) {
        lineno++;
        char *p = line, *end;
        while (isspace((unsigned char)*p))
            p++;
        if (!*p || *p == '#')
            continue;
        if (n == MAX_SAMPLES) {
            st = op_error_set(err, OP_ERR_INPUT, "%s: more than %d samples", path, MAX_SAMPLES);
            break;
        }
        if (!op_scan_double(p, &end, &l[n]) || !op_scan_double(end, &end, &v[n])) {
            st = op_error_set(err, OP_ERR_INPUT, "%s:%d: expected 'wavelength value'", path, lineno);
            break;
        }
        while (isspace((unsigned char)*end))
            end++;
        if (*end && *end != '#') {
            st = op_error_set(err, OP_ERR_INPUT, "%s:%d: expected 'wavelength value'", path, lineno);
            break;
        }
        n++;
    }
    if (st == OP_OK && ferror(f))
        st = op_error_set(err, OP_ERR_INPUT, "%s: read error", path);
    fclose(f);
    if (st == OP_OK) {
        st = op_color_from_samples(l, v, n, how, rgb, err);
        if (st != OP_OK)
            op_error_prefix(err, "%s: ", path);
    }
    free(l);
    free(v);
    return st;
}

static double planck(const void *user, double lambda_nm)
{
    const double h = 6.62607015e-34, c = 2.99792458e8, k = 1.380649e-23;
    double T = *(const double *)user, l = lambda_nm * 1e-9;
    return 2.0 * h * c * c / (pow(l, 5) * expm1(h * c / (l * k * T)));
}

op_status op_color_blackbody(double kelvin, double rgb[3], op_error *err)
{
    if (!(kelvin > 0.0) || !isfinite(kelvin))
        return op_error_set(err, OP_ERR_INPUT, "black body temperature %g K is not positive", kelvin);
    double xyz[3];
    integrate(planck, &kelvin, xyz);
    if (!(xyz[1] > 0.0) || !isfinite(xyz[1]))
        return op_error_set(err, OP_ERR_INPUT, "black body at %g K emits no visible light", kelvin);
    double y = xyz[1];
    for (int k = 0; k < 3; k++)
        xyz[k] /= y;
    op_color_xyz_to_rgb(xyz, rgb);
    for (int k = 0; k < 3; k++)
        rgb[k] = fmax(rgb[k], 0.0);
    return OP_OK;
}
