/* factor_cmd.c - `opaline-factor factor`: reads a raw dataset, runs a method's entry of the
 * method table (fit_table.h) to turn it into a material, checks the result by reading it back
 * through libopaline, and reports. */
#include "commands.h"
#include "fit_table.h"
#include "opaline.h"
#include "opaline_image.h"
#include "opaline_material.h"
#include "opaline_material_write.h"
#include "preprocess.h"
#include "report.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>


/* The arguments before any option is read: every method-specific option "not given" (-1). */
static void args_blank(factor_args *a)
{
    memset(a, 0, sizeof *a);
    a->method = OP_METHOD_COUNT;
    a->terms = -1;
    a->degree = -1;
    a->clusters = a->km = a->iters = -1;
    a->homog_exp = -1;
    a->shift = 1;
    a->log_a = 100.0;
    a->log_b = 1.0;
    a->svd = op_rsvd_defaults();
    a->block_rows = -1;
}

/* "svd 10, tucker 15, ...": each method's default -T, from its entry's defaults(). */
static void terms_defaults(char *buf, size_t n)
{
    const fit_method *fm;
    size_t len = 0;
    buf[0] = '\0';
    for (size_t i = 0; (fm = op_fit_method(i)) != NULL && len < n; i++) {
        factor_args t;
        op_error e = {0};
        args_blank(&t);
        t.method = fm->method;
        if (fm->defaults(&t, &e) != OP_OK || t.terms <= 0)
            continue;
        int k = snprintf(buf + len, n - len, "%s%s %s%d", len ? ", " : "",
                         op_method_name(fm->method), fm->terms_help, t.terms);
        len += k > 0 ? (size_t)k : 0;
    }
}

static void usage(FILE *f)
{
    char names[128], terms[256];
    op_fit_names(0, "|", "|", names, sizeof names);
    terms_defaults(terms, sizeof terms);
    fprintf(f,
            "usage: opaline-factor factor IN.opm -o OUT.opm --method %s [options]\n"
            "  -T N               terms (%s)\n"
            "  -P N               tucker polynomial degree (default 7)\n"
            "  -C N               kcta clusters (default 8)\n"
            "  --km N             kcta clusters mixed per row, K_m (default 2)\n"
            "  --iters N          kcta iterations (default 10), nmf HALS iterations (default "
            "200)\n"
            "  --homog-exp E      nmf factors Rd / H^E, H the homogeneous approximation, E in "
            "[0, 1]\n"
            "                     (default 1: Peers et al.'s division; 0 factors Rd itself)\n"
            "  --log-a A          svd transform R''' = ln(R'/A + B): scale A > 0 (default 100)\n"
            "  --log-b B          svd transform offset B > 0 (default 1)\n"
            "  --no-shift         do not shift and normalize rows (paper section 4.1)\n"
            "  --report R.json    write the report as JSON\n"
            "  --albedo-png A.png write the albedo map as an sRGB PNG thumbnail\n"
            "  --sanitize         replace NaN and infinite dataset values by 0 (else an error)\n"
            "  --name NAME        material name (default: the dataset's)\n"
            "  --precision single|double  arithmetic of the randomized SVD (default single)\n"
            "  --power-iters Q    randomized SVD power iterations, at most (default 4)\n"
            "  --power-tol E      stop them once the squared rank-T error estimate improves by\n"
            "                     less than E of itself (default 1e-2; 0: always Q)\n"
            "  --oversample P     randomized SVD oversampling (default 10)\n"
            "  --exact-svd        full LAPACK SVD instead of the randomized one (slow)\n"
            "  --block-rows N     svd: read the dataset in passes of N rows, never whole in\n"
            "                     memory (default: so when it is larger than half the physical\n"
            "                     memory, in blocks of about 64 MiB; 0: never)\n"
            "  -t THREADS         threads of the preprocessing, the passes of the SVD and of\n"
            "                     K-CTA over an in-memory matrix and the evaluation (default:\n"
            "                     all cores; the streamed SVD's products use OpenBLAS's:\n"
            "                     OPENBLAS_NUM_THREADS)\n"
            "  -v / -q            more / less output on stderr\n",
            names, terms);
}


static op_status parse_number(const char *opt, const char *val, double lo, double hi,
                              double *out, op_error *err)
{
    char *end;
    errno = 0;
    double v = val ? strtod(val, &end) : 0;
    if (!val || errno || end == val || *end || !(v >= lo && v <= hi))
        return op_error_set(err, OP_ERR_INPUT, "%s needs a number in [%g, %g], got '%s'", opt, lo,
                            hi, val ? val : "(nothing)");
    *out = v;
    return OP_OK;
}

static op_status parse_args(int argc, char **argv, factor_args *a, op_error *err)
{
    args_blank(a);
    /* The options taking a number in [lo, hi]: a whole one into ival, or any into dval. */
    const struct {
        const char *name;
        double lo, hi;
        int *ival;
        double *dval;
    } num[] = {
        {"-T", 1, 4096, &a->terms, NULL},
        {"-P", 0, 20, &a->degree, NULL},
        {"-C", 1, 65536, &a->clusters, NULL},
        {"--km", 1, 64, &a->km, NULL},
        {"--iters", 1, 10000, &a->iters, NULL},
        {"--homog-exp", 0, 1, NULL, &a->homog_exp},
        {"--log-a", 1e-30, 1e30, NULL, &a->log_a},
        {"--log-b", 1e-30, 1e30, NULL, &a->log_b},
        {"--power-iters", 0, 100, &a->svd.power_iters, NULL},
        {"--power-tol", 0, 1, NULL, &a->svd.power_tol},
        {"--oversample", 0, 1000, &a->svd.oversample, NULL},
        {"-t", 1, 1024, &a->threads, NULL},
        {"--block-rows", 0, 1 << 30, &a->block_rows, NULL},
    };
    for (int i = 1; i < argc; i++) {
        const char *o = argv[i], *val = i + 1 < argc ? argv[i + 1] : NULL;
        size_t k = 0;
        while (k < sizeof num / sizeof num[0] && strcmp(o, num[k].name) != 0)
            k++;
        if (k < sizeof num / sizeof num[0]) {
            double d = 0;
            op_status st = parse_number(o, val, num[k].lo, num[k].hi, &d, err);
            if (st != OP_OK)
                return st;
            i++;
            if (num[k].dval)
                *num[k].dval = d;
            else if (d != floor(d))
                return op_error_set(err, OP_ERR_INPUT, "%s needs a whole number, got '%s'", o,
                                    val);
            else
                *num[k].ival = (int)d;
            continue;
        }
        if (!strcmp(o, "-o") || !strcmp(o, "--report") || !strcmp(o, "--albedo-png") ||
            !strcmp(o, "--name") || !strcmp(o, "--method") || !strcmp(o, "--precision")) {
            if (!val)
                return op_error_set(err, OP_ERR_INPUT, "%s needs a value", o);
            i++;
            if (!strcmp(o, "-o"))
                a->output = val;
            else if (!strcmp(o, "--report"))
                a->report = val;
            else if (!strcmp(o, "--albedo-png"))
                a->albedo_png = val;
            else if (!strcmp(o, "--name"))
                a->name = val;
            else if (!strcmp(o, "--method")) {
                a->method = op_method_from_name(val);
                if (!op_fit_find(a->method)) {
                    char names[128];
                    op_fit_names(0, ", ", " or ", names, sizeof names);
                    return op_error_set(err, OP_ERR_INPUT, "--method must be %s, not '%s'", names,
                                        val);
                }
            } else if (!strcmp(val, "single") || !strcmp(val, "double")) {
                a->svd.precision = !strcmp(val, "double") ? OP_SVD_DOUBLE : OP_SVD_SINGLE;
            } else {
                return op_error_set(err, OP_ERR_INPUT, "--precision must be single or double");
            }
        } else if (!strcmp(o, "-v") || !strcmp(o, "-q")) {
            op_log_set_level(o[1] == 'v' ? OP_LOG_DEBUG : OP_LOG_WARN);
        } else if (!strcmp(o, "--exact-svd")) {
            a->svd.exact = 1;
        } else if (!strcmp(o, "--no-shift")) {
            a->shift = 0;
        } else if (!strcmp(o, "--sanitize")) {
            a->sanitize = 1;
        } else if (o[0] == '-' && o[1]) {
            return op_error_set(err, OP_ERR_INPUT, "unknown option '%s'", o);
        } else if (!a->input) {
            a->input = o;
        } else {
            return op_error_set(err, OP_ERR_INPUT, "unexpected argument '%s'", o);
        }
    }
    if (!a->input || !a->output || a->method == OP_METHOD_COUNT)
        return op_error_set(err, OP_ERR_INPUT, "need IN.opm, -o OUT.opm and --method");
    /* The options only some methods take: refused by the others, naming those that take them. */
    const struct {
        unsigned option;
        int given;
        const char *what;
    } only[] = {
        {FIT_OPT_CLUSTERS, a->clusters >= 0 || a->km >= 0, "-C and --km apply"},
        {FIT_OPT_ITERS, a->iters >= 0, "--iters applies"},
        {FIT_OPT_HOMOG, a->homog_exp >= 0, "--homog-exp applies"},
        {FIT_OPT_BLOCK_ROWS, a->block_rows > 0, "--block-rows applies"},
    };
    const fit_method *fm = op_fit_find(a->method);
    for (size_t k = 0; k < sizeof only / sizeof only[0]; k++)
        if (only[k].given && !(fm->options & only[k].option)) {
            char names[128];
            op_fit_names(only[k].option, ", ", " and ", names, sizeof names);
            return op_error_set(err, OP_ERR_INPUT, "%s to --method %s only", only[k].what, names);
        }
    return fm->defaults(a, err);
}

/* Rows per pass over the dataset for a: 0 when it is read whole. */
static int64_t stream_rows(const factor_args *a, uint64_t file_bytes, int cols)
{
    if (a->block_rows >= 0 || !(op_fit_find(a->method)->options & FIT_OPT_BLOCK_ROWS) ||
        a->svd.exact)
        return a->block_rows > 0 ? a->block_rows : 0;
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    if (pages <= 0 || page <= 0 || file_bytes <= (uint64_t)pages * (uint64_t)page / 2)
        return 0;
    int64_t rows = ((int64_t)64 << 20) / ((int64_t)cols * (int64_t)sizeof(float));
    return rows > 0 ? rows : 1;
}

/* op_prep_scan of channel c; streaming, in passes whose pages are released after. */
static void scan_channel(const dataset *ds, int c, op_prep_counts *n)
{
    uint64_t count = (uint64_t)ds->rows * (uint64_t)ds->cols;
    if (!ds->block_rows) {
        op_prep_scan(ds->rd[c], count, n);
        return;
    }
    uint64_t per = (uint64_t)ds->block_rows * (uint64_t)ds->cols;
    memset(n, 0, sizeof *n);
    n->first_nonfinite = -1;
    for (uint64_t at = 0; at < count; at += per) {
        uint64_t len = count - at < per ? count - at : per;
        op_prep_counts part;
        op_prep_scan(ds->rd[c] + at, len, &part);
        if (n->first_nonfinite < 0 && part.first_nonfinite >= 0)
            n->first_nonfinite = (int64_t)at + part.first_nonfinite;
        n->nonfinite += part.nonfinite;
        n->negative += part.negative;
        op_material_release(ds->file, ds->rd[c] + at, len * sizeof(float));
    }
}

/* Opens the dataset and checks its values (unless the method counts them itself): non-finite
 * ones are an error naming the first, unless sanitize is set (they then count as 0). */
static op_status load_dataset(const factor_args *a, dataset *ds, op_factor_report *rep,
                              op_error *err)
{
    uint64_t file_bytes = 0;
    int fd;
    op_status st = op_file_open(a->input, &fd, &file_bytes, err);
    if (st != OP_OK)
        return st;
    close(fd);
    /* Whether to stream is decided from the file's size, before it is read: a whole read of a
     * file larger than memory is what streaming avoids. */
    int stream = stream_rows(a, file_bytes, 1) > 0;
    st = stream ? op_material_open_streaming(a->input, &ds->file, err)
                : op_material_open_container(a->input, &ds->file, err);
    if (st != OP_OK)
        return st;
    ds->info = *op_material_get_info(ds->file);
    if (ds->info.method != OP_METHOD_RAW)
        return op_error_set(err, OP_ERR_INPUT, "%s: is a %s material, not a dataset (method raw)",
                            a->input, op_method_name(ds->info.method));
    ds->rows = op_material_rows(ds->file);
    ds->cols = op_material_cols(ds->file);
    ds->block_rows = stream ? stream_rows(a, file_bytes, ds->cols) : 0;
    if (ds->block_rows)
        op_log(OP_LOG_INFO, "%s: read in passes of %lld rows (%.1f MiB), never whole in memory",
               a->input, (long long)ds->block_rows,
               (double)ds->block_rows * ds->cols * sizeof(float) / 1048576.0);
    uint64_t count = (uint64_t)ds->rows * (uint64_t)ds->cols;
    uint32_t crc = 0;
    /* a method that counts the values in its first pass over them spares a pass here */
    int counted = op_fit_find(a->method)->counts_values && !ds->block_rows;
    for (int c = 0; c < ds->info.channels; c++) {
        char tag[16];
        uint64_t bytes = 0;
        op_channel_tag(tag, sizeof tag, OP_RAW_SECTION, &ds->info, c);
        ds->rd[c] = op_material_section(ds->file, tag, &bytes);
        if (!ds->rd[c])
            return op_error_set(err, OP_ERR_FORMAT, "%s: section '%s' is missing", a->input, tag);
        if (bytes != count * sizeof(float))
            return op_error_set(err, OP_ERR_FORMAT, "%s: section '%s' holds %llu bytes, expected "
                                "%llu", a->input, tag, (unsigned long long)bytes,
                                (unsigned long long)(count * sizeof(float)));
        /* The dataset's CRC from its sections' verified ones: no second pass over the data. */
        crc = op_crc32_combine(crc, op_material_section_crc(ds->file, tag), bytes);
        if (counted)
            continue;
        op_prep_counts n;
        scan_channel(ds, c, &n);
        if (n.nonfinite && !a->sanitize)
            return op_fit_nonfinite_error(a, ds, c, &n, err);
        rep->nonfinite_replaced += n.nonfinite;
        rep->negative_values += n.negative;
    }
    if (!counted)
        op_fit_log_counts(a, rep);
    rep->dataset_crc = crc;
    return OP_OK;
}


/* Reads the material back through libopaline and compares every row with the dataset; fills
 * the error figures of rep and the albedo map (channels x rows). */
typedef struct eval_job {
    const op_material *m;
    const dataset *ds;
    int64_t rows_per_task;
    int tasks_per_channel;
    float *rowbuf;         /* one row of cols floats per thread */
    op_error_accum *parts; /* per task */
    float *albedo;
    op_progress *prog;
} eval_job;

/* Evaluates one block of rows of one channel against the dataset (one op_parallel_for task). */
static void eval_task(void *user, int task, int thread)
{
    const eval_job *j = user;
    const dataset *ds = j->ds;
    int c = task / j->tasks_per_channel, w = ds->info.width;
    int64_t r0 = (int64_t)(task % j->tasks_per_channel) * j->rows_per_task;
    int64_t r1 = r0 + j->rows_per_task < ds->rows ? r0 + j->rows_per_task : ds->rows;
    float *row = j->rowbuf + (size_t)thread * (size_t)ds->cols;
    for (int64_t r = r0; r < r1; r++) {
        op_material_eval_row(j->m, c, (int)(r % w), (int)(r / w), row);
        op_error_accum_add(&j->parts[task], ds->rd[c] + r * ds->cols, row, ds->cols);
        double sum = 0;
        for (int k = 0; k < ds->cols; k++)
            sum += row[k];
        j->albedo[c * ds->rows + r] = (float)sum;
    }
    if (ds->block_rows)
        op_material_release(ds->file, ds->rd[c] + r0 * ds->cols,
                            (size_t)(r1 - r0) * (size_t)ds->cols * sizeof(float));
    op_progress_advance(j->prog, (uint64_t)(r1 - r0));
}

static op_status evaluate(const char *path, const dataset *ds, int threads, op_factor_report *rep,
                          float *albedo, op_error *err)
{
    op_material *m;
    op_status st = op_material_open(path, &m, err);
    if (st != OP_OK)
        return op_error_prefix(err, "reading back the new material: ");
    /* Fixed blocks of rows, merged in order: the figures do not depend on the thread count. */
    eval_job j = {.m = m, .ds = ds, .albedo = albedo};
    j.rows_per_task = 1 + (int64_t)(262144 / ds->cols);
    j.tasks_per_channel = (int)((ds->rows + j.rows_per_task - 1) / j.rows_per_task);
    int tasks = j.tasks_per_channel * ds->info.channels;
    int nthreads = op_parallel_threads(threads);
    j.rowbuf = malloc((size_t)nthreads * (size_t)ds->cols * sizeof *j.rowbuf);
    j.parts = calloc((size_t)tasks, sizeof *j.parts);
    if (!j.rowbuf || !j.parts)
        st = op_error_set(err, OP_ERR_NOMEM, "out of memory");
    j.prog = op_progress_begin("evaluate", (uint64_t)ds->info.channels * (uint64_t)ds->rows,
                               NULL, NULL);
    if (st == OP_OK)
        st = op_parallel_for(nthreads, tasks, eval_task, &j, NULL, err);
    op_progress_end(j.prog);
    op_error_accum acc = {0};
    for (int t = 0; st == OP_OK && t < tasks; t++)
        op_error_accum_merge(&acc, &j.parts[t]);
    op_error_accum_finish(&acc, rep);
    free(j.rowbuf);
    free(j.parts);
    op_material_close(m);
    for (int64_t i = 0; st == OP_OK && i < ds->rows * ds->info.channels; i++)
        if (!isfinite(albedo[i]))
            return op_error_set(err, OP_ERR_NUMERIC, "albedo of row %lld is not finite",
                                (long long)(i % ds->rows));
    return st;
}

/* The albedo map as an sRGB PNG, box-filtered down to at most 512 pixels on a side, scaled so
 * that its brightest value is at most 1. */
static op_status write_albedo_png(const char *path, const dataset *ds, const float *albedo,
                                  op_error *err)
{
    int w = ds->info.width, h = ds->info.height, ch = ds->info.channels;
    int f = 1;
    while ((w + f - 1) / f > 512 || (h + f - 1) / f > 512)
        f++;
    op_image img;
    op_status st = op_image_alloc(&img, (w + f - 1) / f, (h + f - 1) / f, ch, err);
    if (st != OP_OK)
        return st;
    float peak = 0;
    for (int y = 0; y < img.height; y++)
        for (int x = 0; x < img.width; x++)
            for (int c = 0; c < ch; c++) {
                double sum = 0;
                int n = 0;
                for (int yy = y * f; yy < h && yy < (y + 1) * f; yy++)
                    for (int xx = x * f; xx < w && xx < (x + 1) * f; xx++, n++)
                        sum += albedo[(int64_t)c * ds->rows + (int64_t)yy * w + xx];
                float v = (float)(sum / n);
                img.pixels[((size_t)y * img.width + x) * ch + c] = v;
                peak = v > peak ? v : peak;
            }
    float stops = peak > 1.0f ? -log2f(peak) : 0.0f;
    st = op_image_write_png(path, &img, stops, err);
    op_image_free(&img);
    return st;
}

/* The median of n values (sorts them). */
static double median(double *v, int n)
{
    for (int i = 1; i < n; i++)
        for (int j = i; j > 0 && v[j] < v[j - 1]; j--) {
            double t = v[j];
            v[j] = v[j - 1];
            v[j - 1] = t;
        }
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* Times op_material_eval at pseudo-random arguments and the albedo map of m. */
static op_status time_evaluation(const op_material *m, op_factor_report *rep, op_error *err)
{
    enum { N = 1 << 16 }; /* 2 x 3 passes of 65536 calls: about 0.02 s of the command */
    const op_material_info *in = op_material_get_info(m);
    int h = in->kernel / 2;
    int32_t *args = malloc((size_t)N * 5 * sizeof *args);
    float *albedo = malloc((size_t)in->width * (size_t)in->height * (size_t)in->channels *
                           sizeof *albedo);
    if (!args || !albedo) {
        free(args);
        free(albedo);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    }
    uint64_t x = 0x2545f4914f6cdd1dull;
    for (int i = 0; i < N * 5; i++) {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        uint32_t r = (uint32_t)(x >> 32);
        int k = i % 5;
        args[i] = k == 0   ? (int32_t)(r % (uint32_t)in->channels)
                  : k == 1 ? (int32_t)(r % (uint32_t)in->width)
                  : k == 2 ? (int32_t)(r % (uint32_t)in->height)
                           : (int32_t)(r % (uint32_t)in->kernel) - h;
    }
    /* Coherent: 64 offsets per incident pixel, as a renderer gathers a kernel; random: every
     * argument independent, so nearly every call misses the caches. Each is the median of
     * REPEATS passes (the machines are shared and noisy). */
    enum { REPEATS = 3 };
    double coherent_ns[REPEATS], random_ns[REPEATS], sum = 0;
    for (int k = 0; k < REPEATS; k++) {
        double t = op_monotonic_seconds();
        for (int i = 0; i < N; i++) {
            const int32_t *a = args + 5 * (i & ~63), *d = args + 5 * i;
            sum += op_material_eval(m, a[0], a[1], a[2], d[3], d[4]);
        }
        coherent_ns[k] = (op_monotonic_seconds() - t) * 1e9 / N;
        t = op_monotonic_seconds();
        for (int i = 0; i < N; i++) {
            const int32_t *a = args + 5 * i;
            sum += op_material_eval(m, a[0], a[1], a[2], a[3], a[4]);
        }
        random_ns[k] = (op_monotonic_seconds() - t) * 1e9 / N;
    }
    rep->eval_ns = median(coherent_ns, REPEATS);
    rep->eval_random_ns = median(random_ns, REPEATS);
    double t = op_monotonic_seconds();
    op_status st = op_material_albedo_map(m, albedo, err);
    rep->albedo_map_seconds = op_monotonic_seconds() - t;
    op_log(OP_LOG_DEBUG, "evaluation checksum %g", sum);
    free(args);
    free(albedo);
    return st;
}

static int fail(op_status st, const op_error *err)
{
    op_log(OP_LOG_ERROR, "%s", err->message);
    return op_exit_code(st);
}

int op_cmd_factor(int argc, char **argv)
{
    for (int i = 1; i < argc; i++)
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            usage(stdout);
            return 0;
        }
    op_error err = {0};
    factor_args a;
    op_status st = parse_args(argc, argv, &a, &err);
    if (st != OP_OK) {
        usage(stderr);
        return fail(st, &err);
    }
    /* Every output writable and none of them another or the dataset, before any work. */
    const char *outputs[3] = {a.output}, *inputs[1] = {a.input};
    int noutputs = 1;
    if (a.report)
        outputs[noutputs++] = a.report;
    if (a.albedo_png)
        outputs[noutputs++] = a.albedo_png;
    if ((st = op_output_check(outputs, noutputs, inputs, 1, &err)) != OP_OK)
        return fail(st, &err);
    double t0 = op_monotonic_seconds(), t = t0;
    op_factor_report rep = {0};
    dataset ds = {0};
    float *albedo = NULL;
    op_material_writer *writer = NULL;
    op_output *report = NULL;
    st = load_dataset(&a, &ds, &rep, &err);
    if (st != OP_OK)
        goto done;
    op_report_stage(&rep, "load", op_monotonic_seconds() - t);

    int64_t mn = ds.rows < ds.cols ? ds.rows : ds.cols;
    int terms = a.terms;
    if (terms > mn) {
        op_log(OP_LOG_WARN, "-T %d exceeds the rank bound min(rows, columns) = %lld; using %lld",
               terms, (long long)mn, (long long)mn);
        terms = (int)mn;
    }
    const fit_method *fm = op_fit_find(a.method);
    op_material_info info = ds.info;
    info.method = a.method;
    info.terms = terms;
    info.degree = a.degree;
    info.clusters = 0;
    info.shifted = a.shift;
    info.log_a = info.log_b = 0.0;
    info.dataset_crc = rep.dataset_crc;
    if (fm->describe && (st = fm->describe(&a, &ds, &info, &err)) != OP_OK)
        goto done;
    if (a.name)
        snprintf(info.name, sizeof info.name, "%s", a.name);
    for (char *p = info.name; *p; p++) /* META is one key=value per line */
        if (*p == '\n' || *p == '\r')
            *p = ' ';

    /* Opened before the work, so that an output that cannot be written fails at once. */
    if ((st = op_material_writer_open(a.output, &info, &writer, &err)) != OP_OK)
        goto done;
    t = op_monotonic_seconds();
    fit_job job = {.a = &a, .ds = &ds, .info = &info, .w = writer, .rep = &rep};
    if ((st = fm->fit(&job, &err)) != OP_OK)
        goto done;
    if (job.prep_seconds > 0)
        op_report_stage(&rep, "preprocess", job.prep_seconds);
    op_report_stage(&rep, "factor", op_monotonic_seconds() - t - job.prep_seconds);

    /* The fit wrote its sections; complete the file without the albedo map and read it back
     * (still under its temporary name) to measure it and the errors; then add the map. Every
     * output is put in place only at the end, the material last: an interruption or a failure
     * before leaves the old files. */
    t = op_monotonic_seconds();
    uint64_t albedo_count = (uint64_t)ds.rows * (uint64_t)ds.info.channels;
    albedo = op_fit_alloc(albedo_count * sizeof *albedo);
    if (!albedo) {
        st = op_error_set(&err, OP_ERR_NOMEM, "out of memory");
        goto done;
    }
    const char *pending;
    if ((st = op_material_writer_finish(writer, &pending, &err)) != OP_OK)
        goto done;
    op_report_stage(&rep, "write", op_monotonic_seconds() - t);
    t = op_monotonic_seconds();
    st = evaluate(pending, &ds, a.threads, &rep, albedo, &err);
    if (st != OP_OK)
        goto done;
    op_report_stage(&rep, "evaluate", op_monotonic_seconds() - t);
    t = op_monotonic_seconds();
    if (fm->albedo && ((st = op_write_albedo(writer, &info, albedo, &err)) != OP_OK ||
                       (st = op_material_writer_finish(writer, &pending, &err)) != OP_OK))
        goto done;
    op_report_stage(&rep, "finish", op_monotonic_seconds() - t);

    op_material *out;
    if ((st = op_material_open(pending, &out, &err)) != OP_OK) {
        op_error_prefix(&err, "reading back the new material: ");
        goto done;
    }
    rep.size_bytes = op_material_file_size(out);
    st = time_evaluation(out, &rep, &err);
    op_material_close(out);
    if (st != OP_OK)
        goto done;
    snprintf(rep.name, sizeof rep.name, "%s", info.name);
    snprintf(rep.method, sizeof rep.method, "%s", op_method_name(a.method));
    snprintf(rep.input, sizeof rep.input, "%s", a.input);
    snprintf(rep.output, sizeof rep.output, "%s", a.output);
    rep.width = info.width;
    rep.height = info.height;
    rep.kernel = info.kernel;
    rep.channels = info.channels;
    rep.terms = info.terms;
    rep.degree = info.degree;
    rep.shifted = info.shifted;
    rep.log_a = info.log_a;
    rep.log_b = info.log_b;
    rep.original_bytes = (uint64_t)ds.rows * (uint64_t)ds.cols * (uint64_t)ds.info.channels * 4u;
    rep.compression_ratio = (double)rep.original_bytes / (double)rep.size_bytes;
    rep.total_seconds = op_monotonic_seconds() - t0;
    rep.peak_memory_bytes = op_peak_memory_bytes();
    op_report_print(&rep, stdout);
    if (fflush(stdout) != 0 || ferror(stdout)) {
        st = op_error_set(&err, OP_ERR_IO, "stdout: cannot write the report: %s",
                          strerror(errno ? errno : EIO));
        goto done;
    }
    /* The png, the report and the material are put in place together, or none of them. */
    op_output_group_begin();
    if (a.report && (st = op_report_write_json(&rep, a.report, &report, &err)) != OP_OK)
        goto done;
    if (a.albedo_png && (st = write_albedo_png(a.albedo_png, &ds, albedo, &err)) != OP_OK)
        goto done;
    if (report) {
        st = op_output_commit(report, &err);
        report = NULL;
        if (st != OP_OK)
            goto done;
    }
    st = op_material_writer_commit(writer, &err);
    writer = NULL;
    if (st == OP_OK)
        st = op_output_group_commit(&err);

done:
    op_output_group_abort(); /* what a failure left pending; nothing after a commit */
    op_output_abort(report);
    op_material_writer_abort(writer);
    free(albedo);
    op_material_close(ds.file);
    return st == OP_OK ? 0 : fail(st, &err);
}
