/* film.c - films, reconstruction filters, and developing and writing the image (see film.h). */
#include "camera/film.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include "math/vec.h"
#include "scene/scene_color.h"

/* The 1-D profile of a tabulated filter at x (|x| <= radius), unnormalized. */
static double table_profile(const op_filter_table *t, double radius, double x)
{
    if (t->kind == 1) { /* Lanczos: sinc(x) sinc(x / lobes) */
        double a = fabs(x);
        if (a >= radius)
            return 0.0;
        if (a < 1e-6)
            return 1.0;
        double px = M_PI * a, pl = px / t->lobes;
        return sin(px) / px * sin(pl) / pl;
    }
    /* Mitchell-Netravali over radius 2, scaled to the filter's radius */
    double a = fabs(2.0 * x / radius), b = t->b, c = t->c;
    if (a < 1.0)
        return ((12.0 - 9.0 * b - 6.0 * c) * a * a * a + (-18.0 + 12.0 * b + 6.0 * c) * a * a +
                (6.0 - 2.0 * b)) / 6.0;
    if (a < 2.0)
        return ((-b - 6.0 * c) * a * a * a + (6.0 * b + 30.0 * c) * a * a +
                (-12.0 * b - 48.0 * c) * a + (8.0 * b + 24.0 * c)) / 6.0;
    return 0.0;
}

/* Tabulates the profile's magnitude per bin (the mean of 16 points of each) and its integral. */
static void table_build(op_filter_table *t, double radius)
{
    double w = 2.0 * radius / OP_FILTER_BINS, sum = 0.0, abs_sum = 0.0;
    t->cdf[0] = 0.0f;
    double run = 0.0;
    for (int i = 0; i < OP_FILTER_BINS; i++) {
        double bin = 0.0;
        for (int k = 0; k < 16; k++) {
            double f = table_profile(t, radius, -radius + w * (i + (k + 0.5) / 16.0));
            sum += f * w / 16.0;
            bin += fabs(f) / 16.0;
        }
        bin = fmax(bin, 1e-9); /* every bin can be drawn: f is non-zero inside almost all */
        abs_sum += bin * w;
        run += bin;
        t->cdf[i + 1] = (float)run;
    }
    for (int i = 1; i <= OP_FILTER_BINS; i++)
        t->cdf[i] = (float)(t->cdf[i] / run);
    t->cdf[OP_FILTER_BINS] = 1.0f;
    t->integral = sum;
    t->abs_integral = abs_sum;
}

/* Draws x from the table; returns f(x) / (pdf(x) integral of f). */
static float table_sample(const op_film *film, float u, float *x)
{
    const op_filter_table *t = &film->table;
    int lo = 0, hi = OP_FILTER_BINS; /* cdf[lo] <= u < cdf[hi] */
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (t->cdf[mid] <= u)
            lo = mid;
        else
            hi = mid;
    }
    double r = film->filter_radius, w = 2.0 * r / OP_FILTER_BINS;
    double p_bin = (double)t->cdf[lo + 1] - (double)t->cdf[lo];
    double frac = p_bin > 0.0 ? ((double)u - t->cdf[lo]) / p_bin : 0.5;
    frac = fmin(fmax(frac, 0.0), 1.0);
    double xv = -r + w * (lo + frac);
    *x = (float)xv;
    double pdf = p_bin / w;
    return pdf > 0.0 ? (float)(table_profile(t, r, xv) / (pdf * t->integral)) : 0.0f;
}

static op_status build_filter(op_node *f, op_film *out, op_error *err)
{
    out->filter = OP_FILTER_GAUSSIAN;
    out->stddev = 0.5f;
    out->filter_radius = 2.0f;
    if (!f)
        return OP_OK;
    f->used = 1;
    if (strcmp(f->type, "box") == 0) {
        out->filter = OP_FILTER_BOX;
        out->filter_radius = 0.5f;
    } else if (strcmp(f->type, "tent") == 0) {
        double r;
        GET_OR_FAIL(op_node_float(f, "radius", 1.0, &r, err));
        if (!(r > 0.0 && r <= 16.0))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <rfilter type=\"tent\">: radius %g is "
                                "not in (0, 16]", f->file, f->line, r);
        out->filter = OP_FILTER_TENT;
        out->filter_radius = (float)r;
    } else if (strcmp(f->type, "gaussian") == 0) {
        double sd;
        GET_OR_FAIL(op_node_float(f, "stddev", 0.5, &sd, err));
        if (!(sd > 0.0 && sd <= 4.0))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <rfilter type=\"gaussian\">: stddev %g "
                                "is not in (0, 4]", f->file, f->line, sd);
        out->stddev = (float)sd;
        out->filter_radius = 4.0f * (float)sd;
    } else if (strcmp(f->type, "mitchell") == 0 || strcmp(f->type, "catmullrom") == 0) {
        int mitchell = strcmp(f->type, "mitchell") == 0;
        double r, b, c;
        GET_OR_FAIL(op_node_float(f, "radius", 2.0, &r, err));
        GET_OR_FAIL(op_node_float(f, "B", mitchell ? 1.0 / 3.0 : 0.0, &b, err));
        GET_OR_FAIL(op_node_float(f, "C", mitchell ? 1.0 / 3.0 : 0.5, &c, err));
        if (!(r > 0.0 && r <= 16.0))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <rfilter type=\"%s\">: radius %g is "
                                "not in (0, 16]", f->file, f->line, f->type, r);
        if (!(fabs(b) <= 10.0 && fabs(c) <= 10.0))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <rfilter type=\"%s\">: B %g and C %g "
                                "are not both in [-10, 10]", f->file, f->line, f->type, b, c);
        out->filter = OP_FILTER_TABLE;
        out->filter_radius = (float)r;
        out->table.kind = 0;
        out->table.b = b;
        out->table.c = c;
    } else if (strcmp(f->type, "lanczos") == 0) {
        long long lobes;
        GET_OR_FAIL(op_node_int(f, "lobes", 3, &lobes, err));
        if (lobes < 1 || lobes > 16)
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <rfilter type=\"lanczos\">: lobes "
                                "%lld is not in 1 .. 16", f->file, f->line, lobes);
        out->filter = OP_FILTER_TABLE;
        out->filter_radius = (float)lobes;
        out->table.kind = 1;
        out->table.lobes = (int)lobes;
    } else {
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <rfilter type=\"%s\">: unknown filter "
                            "(box, tent, gaussian, mitchell, catmullrom, lanczos)", f->file,
                            f->line, f->type);
    }
    if (out->filter == OP_FILTER_TABLE) {
        table_build(&out->table, out->filter_radius);
        if (!(out->table.integral > 1e-6 * out->table.abs_integral))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <rfilter type=\"%s\">: the filter's "
                                "integral is not positive", f->file, f->line, f->type);
    }
    return OP_OK;
}

op_status op_film_set_crop(op_film *film, long long x, long long y, long long w, long long h,
                           const char *where, op_error *err)
{
    if (x < 0 || y < 0 || w < 1 || h < 1 || x + w > film->full_width ||
        y + h > film->full_height)
        return op_error_set(err, OP_ERR_INPUT, "%s: crop window %lldx%lld at (%lld, %lld) is not "
                            "inside the %dx%d film", where, w, h, x, y, film->full_width,
                            film->full_height);
    film->crop_x = (int)x;
    film->crop_y = (int)y;
    film->width = (int)w;
    film->height = (int)h;
    return OP_OK;
}

/* The view transform film names (viewTransform, viewConfig, viewDisplay, viewLook,
 * viewExposure, viewGamma), checked; none when it names no viewTransform. A config that is not
 * there is replaced by $OCIO's, as a farm's nodes name theirs. */
static op_status build_view(op_node *film, op_film *out, op_error *err)
{
    static const char *const params[] = {"viewConfig", "viewDisplay", "viewLook", "viewExposure",
                                         "viewGamma"};
    out->view_gamma = 1.0;
    if (!op_node_has(film, "viewTransform")) {
        for (size_t i = 0; i < sizeof params / sizeof params[0]; i++)
            if (op_node_has(film, params[i]))
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <film>: %s without viewTransform",
                                    film->file, film->line, params[i]);
        return OP_OK;
    }
    if (out->mfilm)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <film type=\"mfilm\">: a measurement has "
                            "no viewTransform", film->file, film->line);
    static const char *const tonemap[] = {"gamma", "exposure", "tonemapMethod", "key", "burn"};
    for (size_t i = 0; out->ldr && i < sizeof tonemap / sizeof tonemap[0]; i++)
        if (op_node_has(film, tonemap[i]))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <film>: %s and viewTransform both "
                                "develop the PNG: give one", film->file, film->line, tonemap[i]);
    const char *view, *config, *display, *look;
    GET_OR_FAIL(op_node_string(film, "viewTransform", NULL, &view, err));
    GET_OR_FAIL(op_node_string(film, "viewConfig", NULL, &config, err));
    GET_OR_FAIL(op_node_string(film, "viewDisplay", "", &display, err));
    GET_OR_FAIL(op_node_string(film, "viewLook", "", &look, err));
    GET_OR_FAIL(op_node_float(film, "viewExposure", 0.0, &out->view_exposure, err));
    GET_OR_FAIL(op_node_float(film, "viewGamma", 1.0, &out->view_gamma, err));
    const char *env = getenv("OCIO");
    char *path = config ? op_node_resolve(film, config) : NULL;
    if (config && !path)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    if (path && access(path, R_OK) != 0 && env && env[0]) {
        op_log(OP_LOG_WARN, "%s:%d: <film>: viewConfig %s is not there: using $OCIO (%s)",
               film->file, film->line, path, env);
        free(path);
        path = NULL;
    }
    if (!path && !(env && env[0]))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <film>: viewTransform \"%s\" names no "
                            "viewConfig and $OCIO is not set", film->file, film->line, view);
    snprintf(out->view_config, sizeof out->view_config, "%s", path ? path : env);
    free(path);
    snprintf(out->view, sizeof out->view, "%s", view);
    snprintf(out->view_display, sizeof out->view_display, "%s", display);
    snprintf(out->view_look, sizeof out->view_look, "%s", look);
    op_view_transform vt;
    op_film_view_transform(out, &vt);
    op_error why = {0};
    op_status st = op_view_transform_check(&vt, &why);
    if (st)
        return op_error_set(err, st, "%s:%d: <film>: viewTransform: %s", film->file, film->line,
                            why.message);
    return OP_OK;
}

op_status op_film_build(op_node *film, op_film *out, op_error *err)
{
    memset(out, 0, sizeof *out);
    out->full_width = 768;
    out->full_height = 576;
    out->half_float = 1;
    out->gamma = -1.0;
    out->pixel_format = OP_PIXFMT_RGBA;
    out->extension = ".exr";
    out->matrix = OP_MATRIX_MATLAB;
    out->digits = 4;
    snprintf(out->variable, sizeof out->variable, "%s", "data");
    op_node *filter = NULL;
    if (film) {
        film->used = 1;
        if (strcmp(film->type, "hdrfilm") != 0 && strcmp(film->type, "ldrfilm") != 0 &&
            strcmp(film->type, "mfilm") != 0)
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <film type=\"%s\">: unknown film "
                                "(hdrfilm, ldrfilm, mfilm)", film->file, film->line, film->type);
        out->ldr = strcmp(film->type, "ldrfilm") == 0;
        out->mfilm = strcmp(film->type, "mfilm") == 0;
        out->extension = out->ldr ? ".png" : out->mfilm ? ".m" : ".exr";
        long long w, h, cx, cy, cw, ch, side = out->mfilm ? 1 : 0;
        GET_OR_FAIL(op_node_int(film, "width", side ? side : 768, &w, err));
        GET_OR_FAIL(op_node_int(film, "height", side ? side : 576, &h, err));
        if (w < 1 || h < 1 || w > OP_IMAGE_MAX_SIDE || h > OP_IMAGE_MAX_SIDE)
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <film>: size %lldx%lld is not in "
                                "1..%d", film->file, film->line, w, h, OP_IMAGE_MAX_SIDE);
        if ((size_t)(w * h) > OP_IMAGE_MAX_PIXELS)
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <film>: size %lldx%lld = %lld pixels "
                                "is more than the %zu pixels (2^30) an image can hold", film->file,
                                film->line, w, h, w * h, OP_IMAGE_MAX_PIXELS);
        GET_OR_FAIL(op_node_int(film, "cropOffsetX", 0, &cx, err));
        GET_OR_FAIL(op_node_int(film, "cropOffsetY", 0, &cy, err));
        GET_OR_FAIL(op_node_int(film, "cropWidth", w, &cw, err));
        GET_OR_FAIL(op_node_int(film, "cropHeight", h, &ch, err));
        out->full_width = (int)w;
        out->full_height = (int)h;
        char where[300];
        snprintf(where, sizeof where, "%s:%d: <film>", film->file, film->line);
        GET_OR_FAIL(op_film_set_crop(out, cx, cy, cw, ch, where, err));
        const char *fn, *pf, *cf;
        GET_OR_FAIL(op_node_string(film, "filename", NULL, &fn, err));
        if (fn)
            snprintf(out->filename, sizeof out->filename, "%s", fn);
        GET_OR_FAIL(op_node_string(film, "pixelFormat",
                                   out->ldr ? "rgb" : out->mfilm ? "luminance" : "rgba", &pf, err));
        if (strcmp(pf, "rgb") == 0)
            out->pixel_format = OP_PIXFMT_RGB;
        else if (strcmp(pf, "rgba") == 0)
            out->pixel_format = OP_PIXFMT_RGBA;
        else if (strcmp(pf, "luminance") == 0)
            out->pixel_format = OP_PIXFMT_LUMINANCE;
        else
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <film>: pixelFormat \"%s\" is not rgb, "
                                "rgba or luminance", film->file, film->line, pf);
        if (out->mfilm) {
            const char *ff, *var;
            long long digits;
            GET_OR_FAIL(op_node_string(film, "fileFormat", "matlab", &ff, err));
            if (strcasecmp(ff, "mathematica") == 0)
                out->matrix = OP_MATRIX_MATHEMATICA;
            else if (strcasecmp(ff, "numpy") == 0)
                out->extension = ".npy";
            else if (strcasecmp(ff, "matlab") != 0)
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <film type=\"mfilm\">: fileFormat "
                                    "\"%s\" is not matlab, mathematica or numpy", film->file,
                                    film->line, ff);
            GET_OR_FAIL(op_node_int(film, "digits", 4, &digits, err));
            if (digits < 1 || digits > 17)
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <film type=\"mfilm\">: digits %lld "
                                    "is not in 1..17", film->file, film->line, digits);
            out->digits = (int)digits;
            GET_OR_FAIL(op_node_string(film, "variable", "data", &var, err));
            if (!op_matrix_variable_valid(var))
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <film type=\"mfilm\">: variable "
                                    "\"%s\" is not a name of letters, digits and _ after a "
                                    "letter (at most 63)", film->file, film->line, var);
            snprintf(out->variable, sizeof out->variable, "%s", var);
        } else if (!out->ldr) {
            GET_OR_FAIL(op_node_string(film, "componentFormat", "float16", &cf, err));
            if (strcmp(cf, "float16") == 0)
                out->half_float = 1;
            else if (strcmp(cf, "float32") == 0)
                out->half_float = 0;
            else
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <film>: componentFormat \"%s\" is "
                                    "not float16 or float32", film->file, film->line, cf);
            const char *ff;
            GET_OR_FAIL(op_node_string(film, "fileFormat", "openexr", &ff, err));
            if (strcmp(ff, "openexr") == 0)
                out->extension = ".exr";
            else if (strcmp(ff, "pfm") == 0)
                out->extension = ".pfm";
            else if (strcmp(ff, "rgbe") == 0)
                out->extension = ".hdr";
            else
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <film>: fileFormat \"%s\" is not "
                                    "openexr, pfm or rgbe", film->file, film->line, ff);
        } else {
            GET_OR_FAIL(op_node_float(film, "gamma", -1.0, &out->gamma, err));
            GET_OR_FAIL(op_node_float(film, "exposure", 0.0, &out->exposure, err));
            if (!(out->gamma == -1.0 || (out->gamma > 0.0 && out->gamma < 10.0)))
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <film>: gamma %g is neither -1 "
                                    "(sRGB) nor in (0, 10)", film->file, film->line, out->gamma);
            if (!isfinite(out->exposure) || fabs(out->exposure) > 64.0)
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <film>: exposure %g is out of "
                                    "range", film->file, film->line, out->exposure);
            const char *ff, *tm;
            GET_OR_FAIL(op_node_string(film, "fileFormat", "png", &ff, err));
            if (strcmp(ff, "png") != 0)
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <film>: fileFormat \"%s\": only png "
                                    "is supported", film->file, film->line, ff);
            GET_OR_FAIL(op_node_string(film, "tonemapMethod", "gamma", &tm, err));
            if (strcmp(tm, "reinhard") == 0)
                out->reinhard = 1;
            else if (strcmp(tm, "gamma") != 0)
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <film>: tonemapMethod \"%s\" is not "
                                    "gamma or reinhard", film->file, film->line, tm);
            GET_OR_FAIL(op_node_float(film, "key", 0.18, &out->key, err));
            GET_OR_FAIL(op_node_float(film, "burn", 0.0, &out->burn, err));
            if (!(out->key > 0.0 && out->key <= 1e6) || !(out->burn >= 0.0 && out->burn <= 1.0))
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <film>: key %g must be > 0 and burn "
                                    "%g in [0, 1]", film->file, film->line, out->key, out->burn);
            if (!out->reinhard && (op_node_has(film, "key") || op_node_has(film, "burn")))
                op_log(OP_LOG_WARN, "%s:%d: <film>: key and burn apply to tonemapMethod "
                       "\"reinhard\" only", film->file, film->line);
        }
        GET_OR_FAIL(build_view(film, out, err));
        for (int i = 0; i < film->nchildren; i++) {
            op_node *c = film->children[i];
            if (strcmp(c->tag, "rfilter") != 0)
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <%s> is not allowed in <film>",
                                    c->file, c->line, c->tag);
            filter = c;
        }
    } else {
        out->width = out->full_width;
        out->height = out->full_height;
        out->view_gamma = 1.0;
    }
    GET_OR_FAIL(build_filter(filter, out, err));
    if (out->mfilm && !filter) { /* Mitsuba's mfilm: a box filter unless it names one */
        out->filter = OP_FILTER_BOX;
        out->filter_radius = 0.5f;
    }
    return OP_OK;
}

/* Reinhard et al.'s photographic operator as Mitsuba 0.6's ldrfilm applies it: the image's
 * log-average luminance (log(1e-3 + Y) averaged) and maximum Y set the scale key / avg and the
 * white point; each pixel's Y becomes Lp (1 + Lp / (Lwhite^2 b^4)) / (1 + Lp) with Lp = Y scale
 * and b = clamp(1 - burn, 1e-8, 1), chromaticity kept. */
typedef struct reinhard_op {
    float scale, inv_wp2; /* scale 0: a black image, left black */
} reinhard_op;

/* The operator's parameters for the RGBA image pixels[0..n) under film's key and burn. */
static void reinhard_prepare(const op_film *film, const float *rgba, size_t n, reinhard_op *r)
{
    double log_sum = 0.0, max_lum = 0.0;
    for (size_t i = 0; i < n; i++) {
        const float *p = rgba + 4 * i;
        double y = 0.212671 * p[0] + 0.715160 * p[1] + 0.072169 * p[2];
        if (!isfinite(y))
            y = 0.0;
        max_lum = fmax(max_lum, y);
        log_sum += log(1e-3 + fmax(y, 0.0));
    }
    r->scale = 0.0f;
    r->inv_wp2 = 0.0f;
    if (!(max_lum > 0.0) || n == 0)
        return;
    double avg = exp(log_sum / (double)n);
    double burn = fmin(1.0, fmax(1e-8, 1.0 - film->burn));
    double scale = film->key / avg, white = max_lum * scale;
    r->scale = (float)scale;
    r->inv_wp2 = (float)(1.0 / (white * white * pow(burn, 4.0)));
}

/* Tonemaps one linear Rec. 709 RGB value in place (black stays black). */
static void reinhard_apply(const reinhard_op *r, float rgb[3])
{
    float X = rgb[0] * 0.412453f + rgb[1] * 0.357580f + rgb[2] * 0.180423f;
    float Y = rgb[0] * 0.212671f + rgb[1] * 0.715160f + rgb[2] * 0.072169f;
    float Z = rgb[0] * 0.019334f + rgb[1] * 0.119193f + rgb[2] * 0.950227f;
    float sum = X + Y + Z;
    if (!(sum > 0.0f) || !(Y > 0.0f) || r->scale == 0.0f || !isfinite(sum)) {
        rgb[0] = rgb[1] = rgb[2] = 0.0f;
        return;
    }
    float x = X / sum, y = Y / sum, lp = Y * r->scale;
    Y = lp * (1.0f + lp * r->inv_wp2) / (1.0f + lp);
    float ratio = Y / y;
    X = ratio * x;
    Z = ratio * (1.0f - x - y);
    rgb[0] = 3.240479f * X - 1.537150f * Y - 0.498535f * Z;
    rgb[1] = -0.969256f * X + 1.875991f * Y + 0.041556f * Z;
    rgb[2] = 0.055648f * X - 0.204043f * Y + 1.057311f * Z;
}

/* Inverse CDF of the tent 1 - |x| on [-1, 1]. */
static float tent_warp(float u)
{
    return u < 0.5f ? sqrtf(2.0f * u) - 1.0f : 1.0f - sqrtf(2.0f - 2.0f * u);
}

float op_film_sample_offset(const op_film *film, float u1, float u2, float *dx, float *dy)
{
    switch (film->filter) {
    case OP_FILTER_TABLE:
        return table_sample(film, u1, dx) * table_sample(film, u2, dy);
    case OP_FILTER_BOX:
        *dx = u1 - 0.5f;
        *dy = u2 - 0.5f;
        break;
    case OP_FILTER_TENT:
        *dx = tent_warp(u1) * film->filter_radius;
        *dy = tent_warp(u2) * film->filter_radius;
        break;
    case OP_FILTER_GAUSSIAN: {
        /* Box-Muller, truncated at the filter radius by folding the radius into range. */
        float r = film->stddev * sqrtf(-2.0f * logf(fmaxf(1.0f - u1, 1e-12f)));
        if (r > film->filter_radius)
            r = fmodf(r, film->filter_radius);
        float phi = 2.0f * OP_PI * u2;
        *dx = r * cosf(phi);
        *dy = r * sinf(phi);
        break;
    }
    }
    return 1.0f;
}

void op_film_view_transform(const op_film *film, op_view_transform *vt)
{
    vt->config = film->view_config;
    vt->display = film->view_display;
    vt->view = film->view;
    vt->look = film->view_look;
    vt->exposure = film->view_exposure;
    vt->gamma = film->view_gamma;
}

static int has_ext(const char *path, const char *ext)
{
    size_t n = strlen(path), e = strlen(ext);
    return n > e && strcasecmp(path + n - e, ext) == 0;
}

const char *op_film_image_format(const op_film *film, const char *path)
{
    static const char *const formats[] = {".exr", ".png", ".pfm", ".hdr", ".m", ".npy"};
    for (size_t i = 0; i < sizeof formats / sizeof formats[0]; i++)
        if (has_ext(path, formats[i]))
            return formats[i];
    const char *slash = strrchr(path, '/');
    return strchr(slash ? slash + 1 : path, '.') ? NULL : film->extension;
}

op_status op_film_write_image(const op_film *film, const op_image *img, const char *path,
                              op_error *err)
{
    if (!img || img->channels != 4)
        return op_error_set(err, OP_ERR_INPUT, "%s: no RGBA image to write", path);
    const char *ext = op_film_image_format(film, path);
    if (!ext)
        return op_error_set(err, OP_ERR_INPUT, "%s: unknown image format (use .exr, .png, .pfm, "
                            ".hdr, .m or .npy)", path);
    int is_exr = !strcmp(ext, ".exr"), is_png = !strcmp(ext, ".png"), is_pfm = !strcmp(ext, ".pfm");
    int is_hdr = !strcmp(ext, ".hdr"), is_matrix = !strcmp(ext, ".m");
    int is_npy = !strcmp(ext, ".npy");
    int oc = film->pixel_format == OP_PIXFMT_RGBA ? 4 : (film->pixel_format == OP_PIXFMT_RGB ? 3 : 1);
    if ((is_pfm || is_hdr || (is_png && !film->ldr)) && oc == 4)
        oc = 3; /* PFM and RGBE have no alpha; a PNG from an hdrfilm is a preview, opaque */
    op_image out, viewed = {0};
    op_status st;
    if (is_png && film->view[0]) { /* displayed values, stored as the sRGB encoder's inverse */
        op_view_transform vt;
        op_film_view_transform(film, &vt);
        if ((st = op_image_alloc(&viewed, img->width, img->height, 4, err)) != OP_OK)
            return st;
        memcpy(viewed.pixels, img->pixels, (size_t)img->width * img->height * 4 * sizeof(float));
        if ((st = op_view_transform_apply(&vt, &viewed, err)) != OP_OK) {
            op_image_free(&viewed);
            return st;
        }
        for (size_t i = 0; i < (size_t)img->width * img->height; i++)
            for (int c = 0; c < 3; c++)
                viewed.pixels[4 * i + c] = (float)op_srgb_to_linear(viewed.pixels[4 * i + c]);
        img = &viewed;
    }
    st = op_image_alloc(&out, img->width, img->height, oc, err);
    if (st) {
        op_image_free(&viewed);
        return st;
    }
    size_t n = (size_t)img->width * img->height;
    int reinhard = is_png && film->ldr && film->reinhard && !film->view[0];
    reinhard_op rh;
    if (reinhard)
        reinhard_prepare(film, img->pixels, n, &rh);
    /* Reinhard replaces the exposure */
    double exposure = film->ldr && !reinhard && !film->view[0] ? film->exposure : 0.0;
    for (size_t i = 0; i < n; i++) {
        const float *p = img->pixels + 4 * i;
        float *q = out.pixels + (size_t)oc * i;
        float rgb[3] = {p[0], p[1], p[2]};
        if (reinhard)
            reinhard_apply(&rh, rgb);
        if (is_png && film->ldr && film->gamma > 0.0 && !film->view[0]) {
            /* op_image_write_png encodes sRGB; pre-warp so the stored value is x^(1/gamma) */
            float sc = (float)exp2(exposure);
            for (int c = 0; c < 3; c++) {
                float v = fmaxf(rgb[c] * sc, 0.0f);
                rgb[c] = (float)op_srgb_to_linear(pow(fmin(v, 1.0), 1.0 / film->gamma));
            }
        }
        if (oc == 1) {
            q[0] = 0.2126f * rgb[0] + 0.7152f * rgb[1] + 0.0722f * rgb[2];
        } else {
            q[0] = rgb[0];
            q[1] = rgb[1];
            q[2] = rgb[2];
            if (oc == 4)
                q[3] = p[3];
        }
    }
    if (is_exr)
        st = op_image_write_exr(path, &out, film->half_float, err);
    else if (is_pfm)
        st = op_image_write_pfm(path, &out, err);
    else if (is_hdr)
        st = op_image_write_hdr(path, &out, err);
    else if (is_matrix)
        st = op_image_write_matrix(path, &out, film->matrix, film->digits, film->variable, err);
    else if (is_npy)
        st = op_image_write_npy(path, &out, err);
    else
        st = op_image_write_png(path, &out, film->gamma < 0.0 ? (float)exposure : 0.0f, err);
    op_image_free(&out);
    op_image_free(&viewed);
    return st;
}
