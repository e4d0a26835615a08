/* opaline-image-compare: judges a render of N samples per pixel against a reference image and
 * the per-pixel variance of one sample, with a z-test on block means (docs/testing.md,
 * "Judging a render against a reference"). Exit 0: the render matches; 1: it does not;
 * 2: bad input (arguments, unreadable or mismatched images). */
#include "opaline.h"
#include "opaline_image.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void usage(FILE *f)
{
    fprintf(f,
        "usage: opaline-image-compare --spp N [options] RENDER REFERENCE VARIANCE\n"
        "Judges RENDER, an image of N samples per pixel, against REFERENCE (the image's\n"
        "expectation, up to its own small noise) and VARIANCE, the variance of a single\n"
        "sample at each pixel (Mitsuba's *_ref_rgb_var.exr). Images are OpenEXR or PFM\n"
        "(8-bit files are refused: clamped and quantized, they measure nothing).\n"
        "\n"
        "The test: the pixels are grouped into BxB blocks; for each block and colour channel\n"
        "  z = (mean of RENDER - mean of REFERENCE) / sqrt(sum of VARIANCE / (n^2 N))\n"
        "over the block's n pixels, a two-sided p-value from the normal distribution, and\n"
        "the render fails when any p-value is below the Sidak level 1 - (1 - ALPHA)^(1/m)\n"
        "of the m block-channel tests: a correct render fails with probability ALPHA.\n"
        "  - block means, not pixels: a mean of n N samples is close to normal even at a\n"
        "    few samples per pixel, where a pixel's heavy-tailed mean is not, and a few\n"
        "    hot pixels do not decide the test alone;\n"
        "  - sum of VARIANCE / (n^2 N) bounds the block mean's variance from above for\n"
        "    independent samples under any pixel filter (a filter that shares samples\n"
        "    between pixels only lowers it), so the test errs towards passing, never\n"
        "    towards a false failure;\n"
        "  - Sidak, not Bonferroni: exact for independent blocks, and by Sidak's\n"
        "    inequality still at most ALPHA for the correlated channels of one block;\n"
        "  - the reference's noise adds VARIANCE / M with --ref-spp M (omitted: none;\n"
        "    Mitsuba's references have thousands of samples per pixel, less than 1 %% of\n"
        "    the variance of a render of up to 32 samples per pixel when M >= 3200).\n"
        "\n"
        "options:\n"
        "  --spp N         samples per pixel of RENDER (required)\n"
        "  --block B       side of the blocks in pixels (default 8; 1 tests pixels, as\n"
        "                  Mitsuba's own render tests do); edge blocks may be smaller\n"
        "  --alpha A       family-wise significance level (default 0.01, Mitsuba's)\n"
        "  --crop X,Y      RENDER is the window at column X, row Y (top-left origin) of\n"
        "                  REFERENCE, as opaline-render --crop X,Y,W,H writes it\n"
        "  --ref-spp M     samples per pixel of REFERENCE, to count its noise\n"
        "  --space S       xyz (default): VARIANCE holds each of X, Y, Z's variance\n"
        "                  written through the XYZ-to-sRGB matrix, as Mitsuba's moment\n"
        "                  integrator does, so the test runs on X, Y, Z (all three\n"
        "                  images converted with the sRGB-to-XYZ matrix, as Mitsuba's\n"
        "                  test does); rgb: VARIANCE holds each stored channel's\n"
        "                  variance, and the test runs on the stored channels\n"
        "  --var-floor V   lower bound of a pixel's single-sample variance (default 1e-4,\n"
        "                  Mitsuba's): a noiseless reference pixel (black background, a\n"
        "                  light seen directly) allows a difference of sqrt(V / N)\n"
        "Alpha is ignored: RGBA compares as RGB; a grey image compares only with grey.\n"
        "Prints one 'name: value' line per figure (blocks, alpha, the per-test level and\n"
        "its |z| limit, max |z| and where, min p and its Sidak-adjusted family-wise\n"
        "p-value, failing tests and blocks, mean relative error, relative bias, the\n"
        "block bias this test resolves, the worst blocks) and 'result: pass' or\n"
        "'result: fail'. Exit 0 pass, 1 fail, 2 bad input.\n");
}

typedef struct options {
    long spp, ref_spp, block;
    int crop_x, crop_y, cropped;
    double alpha, var_floor;
    int xyz;
    const char *render, *reference, *variance;
} options;

/* Reads option a's value v (n comma-separated numbers, op_parse_numbers) into out; 0 when it is
 * not such a value (said). */
static int take_numbers(const char *a, const char *v, int n, double lo, double hi, int flags,
                        double *out)
{
    op_error err = {0};
    if (op_parse_numbers(a, v, n, lo, hi, flags, out, &err) == OP_OK)
        return 1;
    op_log(OP_LOG_ERROR, "%s", err.message);
    return 0;
}

/* 1 when a is an option that takes a value (all of them but --help). */
static int takes_value(const char *a)
{
    static const char *const names[] = {"--spp",   "--ref-spp",   "--block", "--alpha",
                                        "--space", "--var-floor", "--crop"};
    for (size_t i = 0; i < sizeof names / sizeof *names; i++)
        if (!strcmp(a, names[i]))
            return 1;
    return 0;
}

/* Fills o from the command line; 0 after printing why when it is not a valid one, -1 after
 * printing the usage for --help. */
static int parse_options(int argc, char **argv, options *o)
{
    *o = (options){.block = 8, .alpha = 0.01, .var_floor = 1e-4, .xyz = 1};
    const char *files[3];
    int nfiles = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            usage(stdout);
            return -1;
        }
        if (a[0] == '-' && a[1] && !takes_value(a)) {
            op_log(OP_LOG_ERROR, "unknown option %s (--help lists them)", a);
            return 0;
        }
        if (a[0] == '-' && a[1] && !v) {
            op_log(OP_LOG_ERROR, "%s needs a value", a);
            return 0;
        }
        double x[2];
        if (!strcmp(a, "--spp")) {
            if (!take_numbers(a, v, 1, 1, 0x1p40, OP_NUMBER_WHOLE, x))
                return 0;
            o->spp = (long)x[0];
        } else if (!strcmp(a, "--ref-spp")) {
            if (!take_numbers(a, v, 1, 1, 0x1p40, OP_NUMBER_WHOLE, x))
                return 0;
            o->ref_spp = (long)x[0];
        } else if (!strcmp(a, "--block")) {
            if (!take_numbers(a, v, 1, 1, 4096, OP_NUMBER_WHOLE, x))
                return 0;
            o->block = (long)x[0];
        } else if (!strcmp(a, "--alpha")) {
            if (!take_numbers(a, v, 1, 0, 1, OP_NUMBER_ABOVE_LO | OP_NUMBER_BELOW_HI, &o->alpha))
                return 0;
        } else if (!strcmp(a, "--var-floor")) {
            if (!take_numbers(a, v, 1, 0, 1e300, 0, &o->var_floor))
                return 0;
        } else if (!strcmp(a, "--space")) {
            if (strcmp(v, "xyz") && strcmp(v, "rgb")) {
                op_log(OP_LOG_ERROR, "--space %s: need xyz or rgb", v);
                return 0;
            }
            o->xyz = !strcmp(v, "xyz");
        } else if (!strcmp(a, "--crop")) {
            if (!take_numbers(a, v, 2, 0, OP_IMAGE_MAX_SIDE, OP_NUMBER_WHOLE, x))
                return 0;
            o->crop_x = (int)x[0];
            o->crop_y = (int)x[1];
            o->cropped = 1;
        } else {
            if (nfiles == 3) {
                op_log(OP_LOG_ERROR, "one RENDER, one REFERENCE and one VARIANCE: %s is a fourth",
                       a);
                return 0;
            }
            files[nfiles++] = a;
            continue;
        }
        i++;
    }
    if (nfiles != 3 || !o->spp) {
        op_log(OP_LOG_ERROR, "need --spp N and the files RENDER REFERENCE VARIANCE "
                             "(--help for the usage)");
        return 0;
    }
    o->render = files[0];
    o->reference = files[1];
    o->variance = files[2];
    return 1;
}

/* Reads path into img; 0 after printing why when it cannot be read or is an 8-bit file. */
static int read_image(const char *what, const char *path, op_image *img)
{
    op_error err = {0};
    int encoded = 0;
    if (op_image_read_stored(path, img, &encoded, &err) != OP_OK) {
        op_log(OP_LOG_ERROR, "%s %s", what, err.message);
        return 0;
    }
    if (encoded) {
        op_log(OP_LOG_ERROR, "%s %s: an 8-bit image (clamped and quantized): write the render "
                             "as .exr or .pfm", what, path);
        return 0;
    }
    return 1;
}

/* The colour channels of an image that compares: 1 (grey) or 3 (RGB, RGBA's alpha ignored). */
static int colour_channels(const op_image *img)
{
    return img->channels == 1 ? 1 : 3;
}

/* 1 when every colour sample of img is finite; else 0 after printing the first that is not. */
static int all_finite(const char *what, const char *path, const op_image *img)
{
    int cc = colour_channels(img);
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++)
            for (int c = 0; c < cc; c++)
                if (!isfinite(img->pixels[((size_t)y * img->width + x) * img->channels + c])) {
                    op_log(OP_LOG_ERROR, "%s %s: pixel (%d, %d) channel %d is not finite", what,
                           path, x, y, c);
                    return 0;
                }
    return 1;
}

/* sRGB (Rec. 709 primaries) to CIE XYZ, the matrix Mitsuba's moment integrator and render
 * tests use (mitsuba3 include/mitsuba/core/spectrum.h, srgb_to_xyz). */
static const double srgb_to_xyz[3][3] = {{0.412453, 0.357580, 0.180423},
                                         {0.212671, 0.715160, 0.072169},
                                         {0.019334, 0.119193, 0.950227}};

/* Colour sample c of pixel (x, y) of img in the test's space: the stored channel, or with xyz
 * set and three colour channels, its XYZ component c. */
static double sample(const op_image *img, int x, int y, int c, int xyz)
{
    const float *p = img->pixels + ((size_t)y * img->width + x) * img->channels;
    if (!xyz || img->channels == 1)
        return p[c];
    return srgb_to_xyz[c][0] * p[0] + srgb_to_xyz[c][1] * p[1] + srgb_to_xyz[c][2] * p[2];
}

/* The two-sided p-value of a standard normal statistic z. */
static double two_sided_p(double z)
{
    return erfc(fabs(z) / sqrt(2.0));
}

/* The |z| whose two-sided p-value is p (0 < p < 1), by bisection on erfc. */
static double z_limit(double p)
{
    double lo = 0, hi = 40;
    for (int i = 0; i < 200; i++) {
        double mid = 0.5 * (lo + hi);
        if (two_sided_p(mid) > p)
            lo = mid;
        else
            hi = mid;
    }
    return 0.5 * (lo + hi);
}

/* One block-channel test. */
typedef struct block_test {
    int bx, by, c;         /* block column and row, channel */
    double z, p, mean_ref; /* statistic, p-value, reference mean of the block */
    double sigma;          /* standard deviation of the block's difference of means */
    double diff;           /* mean of RENDER minus mean of REFERENCE */
} block_test;

static int by_abs_z_descending(const void *a, const void *b)
{
    double x = fabs(((const block_test *)a)->z), y = fabs(((const block_test *)b)->z);
    return (x < y) - (x > y);
}

static int compare_doubles(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, size_t n)
{
    qsort(v, n, sizeof *v, compare_doubles);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static const char *channel_name(int c, int cc, int xyz)
{
    static const char *const names[2][3] = {{"R", "G", "B"}, {"X", "Y", "Z"}};
    return cc == 1 ? "grey" : names[xyz][c];
}

/* Runs the test of o on the images and prints its figures; returns the exit status. */
static int compare(const options *o, const op_image *ren, const op_image *ref,
                   const op_image *var)
{
    int cc = colour_channels(ref), xyz = o->xyz && cc == 3, B = (int)o->block;
    int nbx = (ren->width + B - 1) / B, nby = (ren->height + B - 1) / B;
    size_t m = (size_t)nbx * nby * cc;
    block_test *t = malloc(m * sizeof *t);
    double *sig_rel = malloc(m * sizeof *sig_rel);
    if (!t || !sig_rel) {
        op_log(OP_LOG_ERROR, "out of memory");
        free(t);
        free(sig_rel);
        return 2;
    }
    double noise = 1.0 / (double)o->spp + (o->ref_spp ? 1.0 / (double)o->ref_spp : 0.0);
    double abs_err = 0, signed_err = 0, abs_ref = 0, signed_ref = 0;
    size_t nonfinite = 0, k = 0;
    for (int by = 0; by < nby; by++)
        for (int bx = 0; bx < nbx; bx++)
            for (int c = 0; c < cc; c++) {
                double sr = 0, sf = 0, sv = 0;
                int n = 0;
                for (int y = by * B; y < (by + 1) * B && y < ren->height; y++)
                    for (int x = bx * B; x < (bx + 1) * B && x < ren->width; x++) {
                        int rx = x + o->crop_x, ry = y + o->crop_y;
                        double r = sample(ren, x, y, c, xyz), f = sample(ref, rx, ry, c, xyz);
                        double v = sample(var, rx, ry, c, xyz);
                        if (!isfinite(r))
                            nonfinite++;
                        sr += r;
                        sf += f;
                        sv += v > o->var_floor ? v : o->var_floor;
                        abs_err += fabs(r - f);
                        signed_err += r - f;
                        abs_ref += fabs(f);
                        signed_ref += f;
                        n++;
                    }
                block_test *b = &t[k++];
                b->bx = bx;
                b->by = by;
                b->c = c;
                b->diff = (sr - sf) / n;
                b->mean_ref = sf / n;
                b->sigma = sqrt(sv * noise) / n;
                b->z = isfinite(b->diff) ? b->diff / b->sigma : INFINITY;
                b->p = two_sided_p(b->z);
            }
    /* Sidak: each of the m tests at 1 - (1 - alpha)^(1/m), computed without cancellation. */
    double level = -expm1(log1p(-o->alpha) / (double)m), limit = z_limit(level);
    size_t failing = 0, failing_blocks = 0, nrel = 0;
    const block_test *worst = &t[0];
    for (size_t i = 0; i < m; i++) {
        failing += t[i].p < level;
        if (t[i].c == 0) {
            int any = 0;
            for (int c = 0; c < cc; c++)
                any |= t[i + (size_t)c].p < level;
            failing_blocks += any;
        }
        if (fabs(t[i].z) > fabs(worst->z))
            worst = &t[i];
        if (t[i].mean_ref > 0)
            sig_rel[nrel++] = t[i].sigma / t[i].mean_ref;
    }
    double p_min = worst->p;
    double p_family = p_min > 0 ? -expm1((double)m * log1p(-p_min)) : 0;
    printf("render: %s (%d x %d at %ld spp", o->render, ren->width, ren->height, o->spp);
    if (o->cropped)
        printf(", the window at %d, %d of the reference", o->crop_x, o->crop_y);
    printf(")\nreference: %s (%d x %d", o->reference, ref->width, ref->height);
    if (o->ref_spp)
        printf(" at %ld spp", o->ref_spp);
    printf("), variance of one sample: %s\n", o->variance);
    printf("space: %s\n", cc == 1 ? "grey" : xyz ? "xyz" : "rgb");
    printf("blocks: %d x %d of %ld x %ld pixels, %zu tests (blocks x channels)\n", nbx, nby,
           o->block, o->block, m);
    printf("alpha: %g family-wise; Sidak per-test level %.4g, |z| limit %.3f\n", o->alpha, level,
           limit);
    printf("max |z|: %.3f at block (%d, %d) channel %s, pixels x %d..%d, y %d..%d\n",
           fabs(worst->z), worst->bx, worst->by, channel_name(worst->c, cc, xyz),
           worst->bx * B, (worst->bx + 1) * B < ren->width ? (worst->bx + 1) * B - 1
                                                            : ren->width - 1,
           worst->by * B, (worst->by + 1) * B < ren->height ? (worst->by + 1) * B - 1
                                                             : ren->height - 1);
    printf("min p: %.4g (family-wise, Sidak-adjusted: %.4g)\n", p_min, p_family);
    printf("failing: %zu of %zu tests, %zu of %d blocks\n", failing, m, failing_blocks,
           nbx * nby);
    if (nonfinite)
        printf("non-finite render samples: %zu\n", nonfinite);
    printf("mean relative error: %.4g (sum |render - reference| / sum |reference|)\n",
           abs_ref > 0 ? abs_err / abs_ref : (abs_err > 0 ? INFINITY : 0));
    printf("relative bias: %+.4g (sum (render - reference) / sum reference)\n",
           signed_ref != 0 ? signed_err / signed_ref : (signed_err != 0 ? INFINITY : 0));
    if (nrel)
        printf("resolution: a bias of %.3g %% of a median block's mean fails that block "
               "half the time\n", 100 * limit * median(sig_rel, nrel));
    qsort(t, m, sizeof *t, by_abs_z_descending);
    for (size_t i = 0; i < m && i < 5 && t[i].p < level; i++)
        printf("worst: block (%d, %d) channel %s: z %+.2f, render mean %.5g, reference mean "
               "%.5g (%+.2f %%)\n",
               t[i].bx, t[i].by, channel_name(t[i].c, cc, xyz), t[i].z,
               t[i].mean_ref + t[i].diff, t[i].mean_ref,
               t[i].mean_ref != 0 ? 100 * t[i].diff / fabs(t[i].mean_ref) : 0.0);
    printf("result: %s\n", failing ? "fail" : "pass");
    free(t);
    free(sig_rel);
    return failing ? 1 : 0;
}

int main(int argc, char **argv)
{
    options o;
    int parsed = parse_options(argc, argv, &o);
    if (parsed <= 0)
        return parsed < 0 ? 0 : 2;
    op_image ren = {0}, ref = {0}, var = {0};
    int rc = 2;
    if (!read_image("render", o.render, &ren) || !read_image("reference", o.reference, &ref) ||
        !read_image("variance", o.variance, &var))
        goto done;
    if (!all_finite("reference", o.reference, &ref) || !all_finite("variance", o.variance, &var))
        goto done;
    if (var.width != ref.width || var.height != ref.height) {
        op_log(OP_LOG_ERROR, "the variance image is %d x %d, the reference %d x %d", var.width,
               var.height, ref.width, ref.height);
        goto done;
    }
    if (colour_channels(&ren) != colour_channels(&ref) ||
        colour_channels(&var) != colour_channels(&ref)) {
        op_log(OP_LOG_ERROR, "render, reference and variance have %d, %d and %d channels: "
                             "grey compares only with grey", ren.channels, ref.channels,
               var.channels);
        goto done;
    }
    if (!o.cropped && (ren.width != ref.width || ren.height != ref.height)) {
        op_log(OP_LOG_ERROR, "the render is %d x %d, the reference %d x %d (a cropped render "
                             "needs --crop X,Y)", ren.width, ren.height, ref.width, ref.height);
        goto done;
    }
    if ((long)o.crop_x + ren.width > ref.width || (long)o.crop_y + ren.height > ref.height) {
        op_log(OP_LOG_ERROR, "the render (%d x %d) at %d, %d does not fit in the reference "
                             "(%d x %d)", ren.width, ren.height, o.crop_x, o.crop_y, ref.width,
               ref.height);
        goto done;
    }
    rc = compare(&o, &ren, &ref, &var);
done:
    op_image_free(&ren);
    op_image_free(&ref);
    op_image_free(&var);
    return rc;
}
