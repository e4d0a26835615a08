/* dataset_cmd.c - `opaline-factor dataset NAME -o OUT.opm ...`: makes a synthetic dataset by
 * simulating its measurement (diffusion or Monte Carlo) and writes it as a raw material. */
#include "commands.h"
#include "dataset_generate.h"
#include "dataset_montecarlo.h"
#include "opaline.h"
#include "report.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

static void dataset_usage(FILE *f)
{
    fprintf(f,
            "usage: opaline-factor dataset NAME -o OUT.opm [--pixels WxH] [--kernel K]\n"
            "           [--size-cm XxY] [--generator diffusion|montecarlo] [--photons N]\n"
            "           [--seed S] [-t THREADS] [--media A,B] [--medium NAME] [--eta N]\n\n"
            "Simulates the measurement of a flat heterogeneous translucent sample: for every\n"
            "colour channel and incident pixel, the fraction of the power entering there that\n"
            "leaves through each pixel of a K x K kernel around it (see docs/datasets.md).\n\n"
            "NAME (paper defaults):\n"
            "  chess4x4        277 x 277 pixels, K 29, 12.6 x 12.6 cm, media Marble,Skin1\n"
            "  chess8x8        222 x 222 pixels, K 39, 25.1 x 25.1 cm, media Skimmilk,Potato\n"
            "  marble-closeup  128 x 128 pixels, K 39, 2.6 x 2.6 cm, Marble with Vein veins\n"
            "  veined-marble   213 x 211 pixels, K 29, 13.0 x 13.0 cm, Marble densely veined\n"
            "  homogeneous     64 x 64 pixels, K 29, 5 x 5 cm, medium Marble\n"
            "  carrara-marble  144 x 144 pixels, K 21, 7.2 x 7.2 cm, Marble with Vein veins\n"
            "  jade            128 x 128 pixels, K 21, 5.12 cm, Jade with Marble inclusions\n"
            "  layered-wax     128 x 128 pixels, K 21, 6.4 x 6.4 cm, Cream with RedWax strata\n"
            "  soap            128 x 128 pixels, K 21, 5.12 cm, PinkSoap, Wholemilk swirls\n"
            "  skin            128 x 128 pixels, K 25, 3.84 cm, Skin2, Skin1 pores and veins\n"
            "  (docs/presets.md; media are base,second for --media)\n\n"
            "options:\n"
            "  -o FILE             output raw material (.opm), written atomically\n"
            "  --pixels WxH        incident pixels (a single N means N x N)\n"
            "  --kernel K          odd kernel side, >= 1\n"
            "  --size-cm XxY       physical size of the sample in cm\n"
            "  --generator G       diffusion (fast, default) or montecarlo (reference)\n"
            "  --photons N         Monte Carlo photons per incident pixel and channel (1000)\n"
            "  --seed S            Monte Carlo and vein-noise seed (1)\n"
            "  -t THREADS          worker threads (default: all cores)\n"
            "  --media A,B         the two media (chessboards: squares; veins: base,vein)\n"
            "  --medium NAME       the (base) medium; for homogeneous, the only one\n"
            "  --eta N             one index of refraction for the whole sample (1 to 3;\n"
            "                      default: each medium's own, 1.3, Marble and Vein 1.5:\n"
            "                      montecarlo refracts where they differ, diffusion takes\n"
            "                      the base medium's)\n\n"
            "media (coefficients in 1/mm; docs/datasets.md): %s\n", op_medium_names());
}

/* Parses a whole decimal integer in [lo, hi]. */
static int parse_i64(const char *s, long long lo, long long hi, long long *out)
{
    char *end;
    errno = 0;
    long long v = strtoll(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi)
        return 0;
    *out = v;
    return 1;
}

/* "AxB" (or a single value A meaning A x A) of integers. */
static int parse_pair_int(const char *s, int *a, int *b)
{
    char buf[64], *x;
    long long va, vb;
    snprintf(buf, sizeof buf, "%s", s);
    x = strchr(buf, 'x');
    if (!x)
        x = strchr(buf, 'X');
    if (x)
        *x = '\0';
    if (!parse_i64(buf, INT_MIN, INT_MAX, &va) || !parse_i64(x ? x + 1 : buf, INT_MIN, INT_MAX, &vb))
        return 0;
    *a = (int)va;
    *b = (int)vb;
    return 1;
}

static int parse_pair_double(const char *s, double *a, double *b)
{
    char buf[64], *x, *end;
    snprintf(buf, sizeof buf, "%s", s);
    x = strchr(buf, 'x');
    if (!x)
        x = strchr(buf, 'X');
    if (x)
        *x = '\0';
    *a = strtod(buf, &end);
    if (end == buf || *end)
        return 0;
    const char *second = x ? x + 1 : buf;
    *b = strtod(second, &end);
    return end != second && !*end;
}

static int bad(const char *fmt, const char *what)
{
    op_log(OP_LOG_ERROR, fmt, what);
    return 2;
}

int op_cmd_dataset(int argc, char **argv)
{
    for (int i = 1; i < argc; i++)
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            dataset_usage(stdout);
            return 0;
        }
    if (argc < 2 || argv[1][0] == '-') {
        dataset_usage(stderr);
        return 2;
    }
    op_error err = {0};
    op_dataset_spec spec;
    op_status st = op_dataset_spec_defaults(argv[1], &spec, &err);
    if (st != OP_OK) {
        op_log(OP_LOG_ERROR, "%s", err.message);
        return op_exit_code(st);
    }
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    spec.threads = cores > 0 ? (int)(cores > 256 ? 256 : cores) : 1;
    const char *out_path = NULL, *media_arg = NULL, *medium_arg = NULL;
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        long long n;
        if (!strcmp(a, "-o") || !strcmp(a, "--pixels") || !strcmp(a, "--kernel") ||
            !strcmp(a, "--size-cm") || !strcmp(a, "--generator") || !strcmp(a, "--photons") ||
            !strcmp(a, "--seed") || !strcmp(a, "-t") || !strcmp(a, "--media") ||
            !strcmp(a, "--medium") || !strcmp(a, "--eta")) {
            if (!v)
                return bad("dataset: option %s needs a value", a);
            i++;
        } else {
            return bad("dataset: unknown argument '%s' (see --help)", a);
        }
        if (!strcmp(a, "-o")) {
            out_path = v;
        } else if (!strcmp(a, "--pixels")) {
            if (!parse_pair_int(v, &spec.width, &spec.height))
                return bad("dataset: --pixels '%s' is not WxH", v);
        } else if (!strcmp(a, "--kernel")) {
            if (!parse_i64(v, INT_MIN, INT_MAX, &n))
                return bad("dataset: --kernel '%s' is not an integer", v);
            spec.kernel = (int)n;
        } else if (!strcmp(a, "--size-cm")) {
            if (!parse_pair_double(v, &spec.size_x_cm, &spec.size_y_cm))
                return bad("dataset: --size-cm '%s' is not XxY", v);
        } else if (!strcmp(a, "--generator")) {
            if (!strcmp(v, "diffusion"))
                spec.generator = OP_GEN_DIFFUSION;
            else if (!strcmp(v, "montecarlo"))
                spec.generator = OP_GEN_MONTECARLO;
            else
                return bad("dataset: --generator '%s': use diffusion or montecarlo", v);
        } else if (!strcmp(a, "--photons")) {
            if (!parse_i64(v, 1, (long long)1 << 40, &n))
                return bad("dataset: --photons '%s' must be an integer >= 1", v);
            spec.photons = (uint64_t)n;
        } else if (!strcmp(a, "--seed")) {
            char *end;
            errno = 0;
            unsigned long long s = strtoull(v, &end, 0);
            if (errno || end == v || *end || v[0] == '-')
                return bad("dataset: --seed '%s' is not a non-negative integer", v);
            spec.seed = s;
        } else if (!strcmp(a, "-t")) {
            if (!parse_i64(v, 1, 1024, &n))
                return bad("dataset: -t '%s' must be an integer from 1 to 1024", v);
            spec.threads = (int)n;
        } else if (!strcmp(a, "--media")) {
            media_arg = v;
        } else if (!strcmp(a, "--eta")) {
            char *end;
            errno = 0;
            spec.eta = strtod(v, &end);
            if (errno || end == v || *end || !(spec.eta >= 1.0 && spec.eta <= 3.0))
                return bad("dataset: --eta '%s' must be a number from 1 to 3", v);
        } else {
            medium_arg = v;
        }
    }
    if (!out_path)
        return bad("dataset: %s", "no output file (-o OUT.opm)");
    if (media_arg) {
        char buf[128], *comma;
        snprintf(buf, sizeof buf, "%s", media_arg);
        comma = strchr(buf, ',');
        if (!comma)
            return bad("dataset: --media '%s' is not A,B", media_arg);
        *comma = '\0';
        spec.media[0] = op_medium_lookup(buf);
        spec.media[1] = op_medium_lookup(comma + 1);
        if (!spec.media[0])
            return bad("dataset: unknown medium '%s' (see --help for the list)", buf);
        if (!spec.media[1])
            return bad("dataset: unknown medium '%s' (see --help for the list)", comma + 1);
        if (spec.kind == OP_DS_HOMOGENEOUS && spec.media[0] != spec.media[1])
            return bad("dataset: %s", "homogeneous has one medium: use --medium NAME");
    }
    if (medium_arg) {
        const op_medium *m = op_medium_lookup(medium_arg);
        if (!m)
            return bad("dataset: unknown medium '%s' (see --help for the list)", medium_arg);
        spec.media[0] = m;
        if (spec.kind == OP_DS_HOMOGENEOUS)
            spec.media[1] = m;
    }
    st = op_dataset_spec_check(&spec, &err);
    if (st != OP_OK) {
        op_log(OP_LOG_ERROR, "dataset: %s", err.message);
        return op_exit_code(st);
    }

    double t0 = op_monotonic_seconds();
    op_mc_stats s;
    st = op_dataset_generate_file(&spec, out_path, &s, &err);
    if (st == OP_OK && spec.generator == OP_GEN_MONTECARLO) {
        op_log(OP_LOG_INFO,
               "montecarlo: %llu photons, %llu steps in %.2f s: %.2f M steps/s "
               "(%.2f M steps/s per thread, %d threads)",
               (unsigned long long)s.photons, (unsigned long long)s.steps, s.seconds,
               s.steps_per_second / 1e6, s.steps_per_second / spec.threads / 1e6, spec.threads);
        op_log(OP_LOG_INFO,
               "montecarlo: mean albedo (row sum) R %.4f G %.4f B %.4f; total reflectance "
               "R %.4f G %.4f B %.4f", s.mean_albedo[0], s.mean_albedo[1], s.mean_albedo[2],
               s.total_reflectance[0], s.total_reflectance[1], s.total_reflectance[2]);
        double ratio = (s.mean_rel_se / 0.05) * (s.mean_rel_se / 0.05);
        op_log(OP_LOG_INFO,
               "montecarlo: albedo relative standard error mean %.4f max %.4f; 5%% (mean) needs "
               "about %.0f photons per pixel, about %.1f s at this rate",
               s.mean_rel_se, s.max_rel_se, (double)spec.photons * ratio, s.seconds * ratio);
    }
    if (st != OP_OK) {
        op_log(OP_LOG_ERROR, "dataset: %s", err.message);
        return op_exit_code(st);
    }
    double secs = op_monotonic_seconds() - t0;
    uint64_t bytes = (uint64_t)spec.width * (uint64_t)spec.height * (uint64_t)spec.kernel *
                     (uint64_t)spec.kernel * 12 * (spec.generator == OP_GEN_MONTECARLO ? 2 : 1);
    op_log(OP_LOG_INFO, "dataset %s: %d x %d pixels, K %d, %.4g x %.4g cm, %s generator: %.3g GB "
           "generated and written in %.2f s, in blocks of at most %llu MiB; peak memory %.1f MiB",
           spec.name, spec.width, spec.height, spec.kernel, spec.size_x_cm, spec.size_y_cm,
           spec.generator == OP_GEN_MONTECARLO ? "montecarlo" : "diffusion", bytes / 1e9, secs,
           (unsigned long long)(OP_DATASET_BLOCK_BYTES >> 20), op_peak_memory_bytes() / 1048576.0);
    op_log(OP_LOG_INFO, "wrote %s", out_path);
    return 0;
}
