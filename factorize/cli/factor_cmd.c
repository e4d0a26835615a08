/* factor_cmd.c - `opaline-factor factor`: turns a raw dataset into a material (svd, tucker,
 * kcta, nmf or raw), checks the result by reading it back through libopaline, and reports. */
#include "commands.h"
#include "kcta.h"
#include "nmf.h"
#include "opaline.h"
#include "preprocess.h"
#include "report.h"
#include "rsvd.h"
#include "tucker.h"


#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define MAX_SECTIONS 32

/* What the command was asked to do. */
typedef struct factor_args {
    const char *input, *output, *report, *albedo_png, *name;
    op_method method;
    int terms, degree, shift, sanitize;
    int threads; /* preprocessing threads (0: all cores) */
    int clusters, km, iters; /* kcta's C and K_m; kcta's or nmf's iterations (-1: default) */
    double homog_exp;        /* nmf: the remainder is Rd / H^homog_exp */
    double log_a, log_b;
    op_rsvd_options svd;
    int block_rows; /* svd from a dataset streamed in blocks of this many rows: > 0 given, 0
                       never, -1 when the dataset is larger than half the physical memory */
} factor_args;

/* The sections of the material being written; data is owned by the list. */
typedef struct section_list {
    int n;
    char tag[MAX_SECTIONS][9];
    void *data[MAX_SECTIONS];
    uint64_t bytes[MAX_SECTIONS];
} section_list;

/* The dataset as read: its META and one read-only rows x cols matrix per channel. */
typedef struct dataset {
    op_material *file;
    op_material_info info;
    int64_t rows;
    int cols;
    const float *rd[3];
    int64_t block_rows; /* > 0: read in passes of this many rows, pages released after each */
} dataset;

static void usage(FILE *f)
{
    fprintf(f,
            "usage: opaline-factor factor IN.opm -o OUT.opm --method svd|tucker|kcta|nmf|raw "
            "[options]\n"
            "  -T N               terms (svd 10, tucker 15, kcta rank per cluster 4, nmf rank "
            "10)\n"
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
            "  -t THREADS         preprocessing and evaluation threads (default: all cores;\n"
            "                     the SVD uses OpenBLAS's own: OPENBLAS_NUM_THREADS)\n"
            "  -v / -q            more / less output on stderr\n");
}

static void sections_free(section_list *s)
{
    for (int i = 0; i < s->n; i++)
        free(s->data[i]);
    s->n = 0;
}

/* Takes ownership of data (freed by sections_free even when this fails). */
static op_status sections_add(section_list *s, const char *tag, void *data, uint64_t bytes,
                              op_error *err)
{
    if (s->n == MAX_SECTIONS) {
        free(data);
        return op_error_set(err, OP_ERR_INTERNAL, "too many sections");
    }
    snprintf(s->tag[s->n], sizeof s->tag[0], "%.8s", tag);
    s->data[s->n] = data;
    s->bytes[s->n++] = bytes;
    return OP_OK;
}

/* Hands data to s as section tag when st is OP_OK, else frees it; returns the resulting status.
 * Chained calls thus pass on the first failure and free everything after it. */
static op_status sections_add_if(section_list *s, op_status st, const char *tag, void *data,
                                 uint64_t bytes, op_error *err)
{
    if (st != OP_OK) {
        free(data);
        return st;
    }
    return sections_add(s, tag, data, bytes, err);
}

/* sections_add_if for channel c's section prefix + "R"/"G"/"B" (or "Y"). */
static op_status channel_add_if(section_list *s, op_status st, const char *prefix,
                                const dataset *ds, int c, void *data, uint64_t bytes,
                                op_error *err)
{
    char tag[16];
    op_channel_tag(tag, sizeof tag, prefix, &ds->info, c);
    return sections_add_if(s, st, tag, data, bytes, err);
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
                if (a->method == OP_METHOD_COUNT)
                    return op_error_set(err, OP_ERR_INPUT,
                                        "--method must be svd, tucker, kcta, nmf or raw, not "
                                        "'%s'", val);
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
    if (a->terms < 0)
        a->terms = a->method == OP_METHOD_TUCKER ? 15
                   : a->method == OP_METHOD_SVD  ? 10
                   : a->method == OP_METHOD_KCTA ? op_kcta_defaults().terms
                   : a->method == OP_METHOD_NMF  ? op_nmf_defaults().rank
                                                 : 0;
    if (a->method == OP_METHOD_KCTA) {
        op_kcta_options k = op_kcta_defaults();
        a->clusters = a->clusters < 0 ? k.clusters : a->clusters;
        a->km = a->km < 0 ? k.km : a->km;
        a->iters = a->iters < 0 ? k.max_iters : a->iters;
        if (a->km > a->clusters)
            return op_error_set(err, OP_ERR_INPUT, "--km %d exceeds the %d clusters (-C)", a->km,
                                a->clusters);
        if (a->iters > OP_KCTA_MAX_HISTORY)
            return op_error_set(err, OP_ERR_INPUT, "kcta takes at most %d iterations",
                                OP_KCTA_MAX_HISTORY);
    } else if ((a->clusters >= 0 || a->km >= 0)) {
        return op_error_set(err, OP_ERR_INPUT, "-C and --km apply to --method kcta only");
    }
    if (a->method == OP_METHOD_NMF) {
        a->iters = a->iters < 0 ? op_nmf_defaults().max_iter : a->iters;
        a->homog_exp = a->homog_exp < 0 ? 1.0 : a->homog_exp;
        a->shift = 0; /* the homogeneous approximation takes the place of shifting */
    } else if (a->method != OP_METHOD_KCTA && a->iters >= 0) {
        return op_error_set(err, OP_ERR_INPUT, "--iters applies to --method kcta and nmf only");
    }
    if (a->method != OP_METHOD_NMF && a->homog_exp >= 0)
        return op_error_set(err, OP_ERR_INPUT, "--homog-exp applies to --method nmf only");
    if (a->degree < 0)
        a->degree = a->method == OP_METHOD_TUCKER ? 7 : 0;
    if (a->method == OP_METHOD_RAW)
        a->terms = a->degree = 0;
    if (a->method != OP_METHOD_TUCKER)
        a->degree = 0;
    if (a->block_rows > 0 && a->method != OP_METHOD_SVD)
        return op_error_set(err, OP_ERR_INPUT, "--block-rows applies to --method svd only");
    if (a->block_rows > 0 && a->svd.exact)
        return op_error_set(err, OP_ERR_INPUT, "--block-rows needs the randomized SVD, not "
                            "--exact-svd");
    return OP_OK;
}

/* Rows per pass over the dataset for a: 0 when it is read whole. */
static int64_t stream_rows(const factor_args *a, uint64_t file_bytes, int cols)
{
    if (a->block_rows >= 0 || a->method != OP_METHOD_SVD || a->svd.exact)
        return a->block_rows > 0 ? a->block_rows : 0;
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    if (pages <= 0 || page <= 0 || file_bytes <= (uint64_t)pages * (uint64_t)page / 2)
        return 0;
    int64_t rows = ((int64_t)64 << 20) / ((int64_t)cols * (int64_t)sizeof(float));
    return rows > 0 ? rows : 1;
}

/* Opens the dataset and checks its values: non-finite ones are an error naming the first,
 * unless sanitize is set (they then count as 0). */
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
    for (int c = 0; c < ds->info.channels; c++) {
        char tag[16];
        uint64_t bytes = 0;
        op_channel_tag(tag, sizeof tag, "RD.", &ds->info, c);
        ds->rd[c] = op_material_section(ds->file, tag, &bytes);
        if (!ds->rd[c])
            return op_error_set(err, OP_ERR_FORMAT, "%s: section '%s' is missing", a->input, tag);
        if (bytes != count * sizeof(float))
            return op_error_set(err, OP_ERR_FORMAT, "%s: section '%s' holds %llu bytes, expected "
                                "%llu", a->input, tag, (unsigned long long)bytes,
                                (unsigned long long)(count * sizeof(float)));
        /* The dataset's CRC from its sections' verified ones: no second pass over the data. */
        crc = op_crc32_combine(crc, op_material_section_crc(ds->file, tag), bytes);
        op_prep_counts n;
        scan_channel(ds, c, &n);
        if (n.nonfinite && !a->sanitize) {
            int64_t i = n.first_nonfinite;
            float v = ds->rd[c][i];
            return op_error_set(err, OP_ERR_INPUT,
                                "%s: section '%s' value %lld (row %lld, column %lld) is %s; %llu "
                                "values are not finite (--sanitize replaces them by 0)",
                                a->input, tag, (long long)i, (long long)(i / ds->cols),
                                (long long)(i % ds->cols), isnan(v) ? "NaN" : "infinite",
                                (unsigned long long)n.nonfinite);
        }
        rep->nonfinite_replaced += n.nonfinite;
        rep->negative_values += n.negative;
    }
    if (rep->nonfinite_replaced)
        op_log(OP_LOG_WARN, "%s: replaced %llu non-finite values by 0 (--sanitize)", a->input,
               (unsigned long long)rep->nonfinite_replaced);
    if (rep->negative_values)
        op_log(OP_LOG_INFO, "%s: %llu negative values (noise) are factored as 0", a->input,
               (unsigned long long)rep->negative_values);
    rep->dataset_crc = crc;
    return OP_OK;
}

static void *alloc_or_null(uint64_t bytes)
{
    return bytes > (uint64_t)SIZE_MAX ? NULL : malloc(bytes ? (size_t)bytes : 1);
}

/* Allocates one rows x cols float matrix of ds into *mat. */
static op_status alloc_matrix(const dataset *ds, float **mat, op_error *err)
{
    *mat = alloc_or_null((uint64_t)ds->rows * (uint64_t)ds->cols * sizeof **mat);
    if (!*mat)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for a %lld x %d matrix",
                            (long long)ds->rows, ds->cols);
    return OP_OK;
}

/* Writes channel c of ds, rows shifted and normalized (paper section 4.1) when a->shift, and
 * log-transformed as the svd method does when with_log, into mat (rows x cols). The per-row
 * shifts and maxima go to *shift and *max, owned by the caller (both NULL when not shifted). */
static op_status prepare_channel(const factor_args *a, const dataset *ds, int c, int with_log,
                                 float *mat, uint32_t **shift, float **max, op_error *err)
{
    int64_t rows = ds->rows;
    *shift = NULL;
    *max = NULL;
    if (a->shift) {
        *shift = alloc_or_null((uint64_t)rows * sizeof **shift);
        *max = alloc_or_null((uint64_t)rows * sizeof **max);
        if (!*shift || !*max) {
            free(*shift);
            free(*max);
            *shift = NULL;
            *max = NULL;
            return op_error_set(err, OP_ERR_NOMEM, "out of memory");
        }
    }
    op_status st = op_prep_rows(ds->rd[c], rows, ds->cols, *shift, *max, with_log ? a->log_a : 0,
                                a->log_b, a->threads, mat, err);
    if (st != OP_OK) {
        free(*shift);
        free(*max);
        *shift = NULL;
        *max = NULL;
    }
    return st;
}

/* Hands channel c's per-row shifts and maxima to out as "SHIFT.c" and "MAX.c" when st is OP_OK
 * (else frees them); returns the resulting status. Accepts NULL (not shifted). */
static op_status add_peaks(section_list *out, const dataset *ds, int c, uint32_t *shift,
                           float *max, op_status st, op_error *err)
{
    uint64_t rows = (uint64_t)ds->rows;
    if (!shift) {
        free(max);
        return st;
    }
    st = channel_add_if(out, st, "SHIFT.", ds, c, shift, rows * sizeof *shift, err);
    return channel_add_if(out, st, "MAX.", ds, c, max, rows * sizeof *max, err);
}

/* The raw method: the cleaned dataset itself. */
static op_status factor_raw(const dataset *ds, section_list *out, op_error *err)
{
    uint64_t count = (uint64_t)ds->rows * (uint64_t)ds->cols;
    for (int c = 0; c < ds->info.channels; c++) {
        float *v = alloc_or_null(count * sizeof *v);
        if (!v)
            return op_error_set(err, OP_ERR_NOMEM, "out of memory");
        for (uint64_t i = 0; i < count; i++)
            v[i] = op_prep_clean(ds->rd[c][i]);
        op_status st = channel_add_if(out, OP_OK, "RD.", ds, c, v, count * sizeof *v, err);
        if (st != OP_OK)
            return st;
    }
    return OP_OK;
}

/* Rows of the transformed matrix of channel c, for the SVD: from mat (rows x cols) when it is
 * in memory, else preprocessed from the dataset one block at a time (op_row_source). */
typedef struct svd_rows {
    const factor_args *a;
    const dataset *ds;
    int c;
    const float *mat;
    const uint32_t *shift;
    const float *max;
} svd_rows;

static op_status fetch_rows(void *user, int64_t r0, int64_t count, float *dst, op_error *err)
{
    const svd_rows *s = user;
    const dataset *ds = s->ds;
    const float *src = ds->rd[s->c] + r0 * ds->cols;
    op_status st = op_prep_rows_given_peaks(src, count, ds->cols, s->shift ? s->shift + r0 : NULL,
                                            s->max ? s->max + r0 : NULL, s->a->log_a,
                                            s->a->log_b, s->a->threads, dst, err);
    op_material_release(ds->file, src, (size_t)count * (size_t)ds->cols * sizeof *src);
    return st;
}

/* Row r of the transformed matrix into *row: in mat, or fetched into buf (cols floats). */
static op_status svd_row(const svd_rows *s, int64_t r, float *buf, const float **row,
                         op_error *err)
{
    *row = s->mat ? s->mat + r * s->ds->cols : buf;
    return s->mat ? OP_OK : fetch_rows((void *)s, r, 1, buf, err);
}

/* Refuses --log-a/--log-b that make ln(R'/A + B) lose channel c's data: the transformed matrix
 * (rows x cols, float) must be finite, map back to the preprocessed values within 1e-3
 * (relative, over up to 4096 sampled rows), and stay within [1e-15, 60] in magnitude, so that
 * the float SVD neither underflows nor the reconstruction A e^x overflows its checks. */
static op_status check_log_transform(const factor_args *a, const svd_rows *t, op_error *err)
{
    const dataset *ds = t->ds;
    const uint32_t *shift = t->shift;
    const float *max = t->max;
    int c = t->c;
    int64_t rows = ds->rows, step = rows > 4096 ? rows / 4096 : 1, done = 0;
    int n = ds->cols;
    double err2 = 0, ref2 = 0, xmax = 0;
    int finite = 1;
    float *buf = t->mat ? NULL : malloc((size_t)n * sizeof *buf);
    if (!t->mat && !buf)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    for (int64_t r = 0; r < rows; r += step) {
        const float *row;
        op_status st = svd_row(t, r, buf, &row, err);
        if (st != OP_OK) {
            free(buf);
            return st;
        }
        int s = shift ? (int)shift[r] : 0;
        double mx = max ? max[r] : 1.0;
        for (int j = 0; j < n; j++) {
            int col = j + s < n ? j + s : j + s - n;
            double v = mx > 0 ? op_prep_clean(ds->rd[c][r * n + col]) / mx : 0.0;
            double x = row[j];
            finite &= isfinite(x);
            double back = a->log_a * expm1(x) + a->log_a * (1.0 - a->log_b);
            err2 += (back - v) * (back - v);
            ref2 += v * v;
            xmax = fmax(xmax, fabs(x));
        }
        if (!t->mat) { /* streaming: a row is less than a page, but each read maps the pages
                          around it (fault-around): release up to the next sampled row, or the
                          samples would map the whole channel */
            int64_t end = r + step < rows ? r + step : rows;
            op_material_release(ds->file, ds->rd[c] + done * n,
                                (size_t)(end - done) * (size_t)n * sizeof(float));
            done = end;
        }
    }
    const char *why = !finite                         ? "some values are infinite"
                      : ref2 > 0 && xmax < 1e-15       ? "its values underflow single precision"
                      : xmax > 60                      ? "its values are too large"
                      : ref2 > 0 && err2 > 1e-6 * ref2 ? "it does not map back within 1e-3"
                                                       : NULL;
    free(buf);
    if (why)
        return op_error_set(err, OP_ERR_INPUT, "--log-a %g --log-b %g: the transform ln(R/A + B) "
                            "loses channel %d's data (%s); choose A near the data's scale (the "
                            "default is 100) and B = 1", a->log_a, a->log_b, c, why);
    return OP_OK;
}

/* Streaming: channel c's per-row shifts and maxima (when a->shift; else both NULL), found in
 * passes of ds->block_rows rows whose pages are released after. */
static op_status stream_peaks(const factor_args *a, const dataset *ds, int c, uint32_t **shift,
                              float **max, op_error *err)
{
    *shift = NULL;
    *max = NULL;
    if (!a->shift)
        return OP_OK;
    *shift = alloc_or_null((uint64_t)ds->rows * sizeof **shift);
    *max = alloc_or_null((uint64_t)ds->rows * sizeof **max);
    if (!*shift || !*max) {
        free(*shift);
        free(*max);
        *shift = NULL;
        *max = NULL;
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    }
    for (int64_t r0 = 0; r0 < ds->rows; r0 += ds->block_rows) {
        int64_t nb = ds->rows - r0 < ds->block_rows ? ds->rows - r0 : ds->block_rows;
        const float *src = ds->rd[c] + r0 * ds->cols;
        op_prep_find_peaks(src, nb, ds->cols, *shift + r0, *max + r0);
        op_material_release(ds->file, src, (size_t)nb * (size_t)ds->cols * sizeof *src);
    }
    return OP_OK;
}

/* The svd method, channel by channel: preprocess, log transform, truncated SVD (in memory, or
 * streaming: every product with the matrix a pass that preprocesses the dataset's rows). */
static op_status factor_svd(const factor_args *a, const dataset *ds, int terms,
                            section_list *out, double *prep_seconds, op_error *err)
{
    int64_t rows = ds->rows;
    int cols = ds->cols;
    float *mat = NULL;
    op_status st = ds->block_rows ? OP_OK : alloc_matrix(ds, &mat, err);
    if (st != OP_OK)
        return st;
    op_progress *prog = op_progress_begin(
        "svd", (uint64_t)ds->info.channels *
                   (1 + op_rsvd_progress_units(rows, cols, terms, &a->svd)), NULL, NULL);
    for (int c = 0; c < ds->info.channels && st == OP_OK; c++) {
        uint32_t *shift = NULL;
        float *max = NULL;
        double t0 = op_monotonic_seconds();
        st = ds->block_rows ? stream_peaks(a, ds, c, &shift, &max, err)
                            : prepare_channel(a, ds, c, 1, mat, &shift, &max, err);
        svd_rows t = {a, ds, c, mat, shift, max};
        if (st == OP_OK)
            st = check_log_transform(a, &t, err);
        if (ds->block_rows) /* its sampled rows (and the pages the kernel mapped around them) */
            op_material_release(ds->file, ds->rd[c],
                                (size_t)rows * (size_t)cols * sizeof *ds->rd[c]);
        if (st != OP_OK) {
            free(shift);
            free(max);
        }
        if (st != OP_OK)
            break;
        op_progress_advance(prog, 1);
        double t1 = op_monotonic_seconds();
        *prep_seconds += t1 - t0;
        float *us = alloc_or_null((uint64_t)rows * (uint64_t)terms * sizeof *us);
        float *v = alloc_or_null((uint64_t)cols * (uint64_t)terms * sizeof *v);
        if (!us || !v)
            st = op_error_set(err, OP_ERR_NOMEM, "out of memory");
        op_row_source src = {fetch_rows, &t, ds->block_rows};
        if (st == OP_OK)
            st = ds->block_rows
                     ? op_rsvd_rows(&src, rows, cols, terms, &a->svd, us, v, NULL, prog, err)
                     : op_rsvd(mat, rows, cols, terms, &a->svd, us, v, NULL, prog, err);
        op_log(OP_LOG_DEBUG, "channel %d: preprocessing %.3f s, SVD of %lld x %d to rank %d "
               "%.3f s", c, t1 - t0, (long long)rows, cols, terms, op_monotonic_seconds() - t1);
        if (st != OP_OK) {
            op_error_prefix(err, "channel %d: ", c);
            free(us);
            free(v);
            free(shift);
            free(max);
            break;
        }
        st = channel_add_if(out, st, "U.", ds, c, us,
                            (uint64_t)rows * (uint64_t)terms * sizeof *us, err);
        st = channel_add_if(out, st, "V.", ds, c, v, (uint64_t)cols * (uint64_t)terms * sizeof *v,
                            err);
        st = add_peaks(out, ds, c, shift, max, st, err);
    }
    op_progress_end(prog);
    free(mat);
    return st;
}

/* The tucker method: the factors of tucker.c as sections. */
static op_status factor_tucker(const factor_args *a, const dataset *ds, int terms,
                               section_list *out, op_factor_report *rep, op_error *err)
{
    op_tucker_result t;
    op_status st = op_tucker_factor(ds->rd, ds->info.channels, ds->rows, ds->cols, terms,
                                    a->degree, a->shift, &a->svd, a->threads, &t, err);
    if (st != OP_OK)
        return st;
    rep->has_fit = 1;
    rep->fit_condition = t.fit.cond_max;
    rep->fit_coef_max = t.fit.coef_max;
    rep->fit_storage_error = t.fit.data_sq > 0 ? sqrt(t.fit.storage_sq / t.fit.data_sq) : 0.0;
    if (rep->fit_storage_error > 1e-4)
        op_log(OP_LOG_WARN, "tucker: storing the colour fit as float32 changes it by %.2g "
               "(relative), more than 1e-4", rep->fit_storage_error);
    if (!(rep->fit_condition < 1e10))
        op_log(OP_LOG_WARN, "tucker: a colour fit is ill-conditioned (condition %.3g)",
               rep->fit_condition);
    /* Every factor goes to out (or is freed): t holds nothing afterwards. */
    uint64_t rows = (uint64_t)ds->rows, np = (uint64_t)a->degree + 1;
    st = sections_add_if(out, st, "U", t.u, rows * (uint64_t)terms * sizeof(float), err);
    st = sections_add_if(out, st, "V", t.v,
                         (uint64_t)ds->cols * (uint64_t)terms * sizeof(float), err);
    st = sections_add_if(out, st, "RANGE", t.range, rows * 2 * sizeof(float), err);
    st = sections_add_if(out, st, "BETA", t.beta,
                         (uint64_t)ds->info.channels * rows * np * sizeof(float), err);
    if (t.shift)
        st = sections_add_if(out, st, "SHIFT", t.shift, rows * sizeof(uint32_t), err);
    if (t.max)
        st = sections_add_if(out, st, "MAX", t.max, rows * sizeof(float), err);
    return st;
}

/* The kcta method, channel by channel: preprocess (shift and normalize, no log transform: the
 * clusters are linear subspaces), then K-CTA (kcta.h). *clusters may be lowered to the rows. */
static op_status factor_kcta(const factor_args *a, const dataset *ds, int terms, int clusters,
                             section_list *out, double *prep_seconds, op_error *err)
{
    int64_t rows = ds->rows;
    int cols = ds->cols;
    float *mat = NULL;
    op_status st = alloc_matrix(ds, &mat, err);
    if (st != OP_OK)
        return st;
    op_kcta_options opt = op_kcta_defaults();
    opt.clusters = clusters;
    opt.km = a->km;
    opt.terms = terms;
    opt.max_iters = a->iters;
    opt.svd = a->svd;
    int wide = clusters > 65536 ? 4 : 2;
    op_progress *prog = op_progress_begin(
        "kcta", (uint64_t)ds->info.channels * (uint64_t)(1 + opt.max_iters), NULL, NULL);
    for (int c = 0; c < ds->info.channels && st == OP_OK; c++) {
        uint32_t *shift = NULL;
        float *max = NULL;
        double t0 = op_monotonic_seconds();
        st = prepare_channel(a, ds, c, 0, mat, &shift, &max, err);
        if (st != OP_OK)
            break;
        double t1 = op_monotonic_seconds();
        *prep_seconds += t1 - t0;
        op_kcta_model md;
        st = op_kcta_factor(mat, rows, cols, &opt, &md, prog, err);
        if (st != OP_OK) {
            op_error_prefix(err, "channel %d: ", c);
            free(shift);
            free(max);
            break;
        }
        double norm = 0;
        for (uint64_t q = 0; q < (uint64_t)rows * (uint64_t)cols; q++)
            norm += (double)mat[q] * mat[q];
        op_log(OP_LOG_INFO, "kcta channel %d: %d iteration(s)%s, %d empty cluster(s) split, "
               "relative error %.4g of the preprocessed matrix (%.3f s)", c, md.iterations,
               md.restored ? " (one more raised the error and was undone)" : "", md.splits,
               norm > 0 ? sqrt(md.history[md.nhistory - 1] / norm) : 0.0, op_monotonic_seconds() - t1);
        uint64_t nidx = (uint64_t)rows * (uint64_t)md.km;
        void *idx = alloc_or_null(nidx * (uint64_t)wide);
        if (!idx) {
            op_kcta_free(&md);
            free(shift);
            free(max);
            st = op_error_set(err, OP_ERR_NOMEM, "out of memory");
            break;
        }
        for (uint64_t q = 0; q < nidx; q++) {
            if (wide == 2)
                ((uint16_t *)idx)[q] = (uint16_t)md.idx[q];
            else
                ((uint32_t *)idx)[q] = md.idx[q];
        }
        free(md.idx);
        st = channel_add_if(out, st, "BASIS.", ds, c, md.basis,
                            (uint64_t)clusters * (uint64_t)cols * (uint64_t)terms * sizeof(float),
                            err);
        st = channel_add_if(out, st, "KIDX.", ds, c, idx, nidx * (uint64_t)wide, err);
        st = channel_add_if(out, st, "KCOEF.", ds, c, md.coef,
                            nidx * (uint64_t)terms * sizeof(float), err);
        st = add_peaks(out, ds, c, shift, max, st, err);
    }
    op_progress_end(prog);
    free(mat);
    if (st == OP_OK) {
        uint32_t *par = alloc_or_null(2 * sizeof *par);
        if (!par)
            return op_error_set(err, OP_ERR_NOMEM, "out of memory");
        par[0] = (uint32_t)a->km;
        par[1] = (uint32_t)wide;
        st = sections_add(out, "KCTA", par, 2 * sizeof *par, err);
    }
    return st;
}

/* The nmf method, channel by channel: the homogeneous approximation, the remainder, HALS. */
static op_status factor_nmf(const factor_args *a, const dataset *ds, int terms,
                            section_list *out, double *prep_seconds, op_error *err)
{
    int64_t rows = ds->rows;
    int cols = ds->cols;
    float *q = NULL;
    op_status st = alloc_matrix(ds, &q, err);
    if (st != OP_OK)
        return st;
    op_nmf_options opt = op_nmf_defaults();
    opt.rank = terms;
    opt.max_iter = a->iters;
    opt.svd = a->svd;
    op_progress *prog = op_progress_begin(
        "nmf", (uint64_t)ds->info.channels * (uint64_t)opt.max_iter, NULL, NULL);
    for (int c = 0; c < ds->info.channels && st == OP_OK; c++) {
        double t0 = op_monotonic_seconds();
        float *prof = alloc_or_null((uint64_t)cols * sizeof *prof);
        float *scale = alloc_or_null((uint64_t)rows * sizeof *scale);
        float *w = alloc_or_null((uint64_t)rows * (uint64_t)terms * sizeof *w);
        float *h = alloc_or_null((uint64_t)cols * (uint64_t)terms * sizeof *h);
        if (!prof || !scale || !w || !h) {
            free(prof);
            free(scale);
            free(w);
            free(h);
            st = op_error_set(err, OP_ERR_NOMEM, "out of memory");
            break;
        }
        op_nmf_homogeneous(ds->rd[c], rows, ds->info.kernel, a->homog_exp, prof, scale);
        op_nmf_remainder(ds->rd[c], rows, cols, prof, scale, q);
        double t1 = op_monotonic_seconds();
        *prep_seconds += t1 - t0;
        op_nmf_stats ns;
        st = op_nmf_hals(q, rows, cols, &opt, w, h, &ns, prog, err);
        if (st == OP_OK)
            op_log(OP_LOG_INFO, "nmf channel %d: %d HALS iteration(s), %s; remainder relative "
                   "error %.4g (NNDSVD start %.4g) (%.3f s)", c, ns.iterations,
                   ns.converged ? "converged" : "stopped at --iters",
                   ns.norm > 0 ? sqrt(ns.objective / ns.norm) : 0.0,
                   ns.norm > 0 ? sqrt(ns.initial / ns.norm) : 0.0, op_monotonic_seconds() - t1);
        else
            op_error_prefix(err, "channel %d: ", c);
        st = channel_add_if(out, st, "PROF.", ds, c, prof, (uint64_t)cols * sizeof *prof, err);
        st = channel_add_if(out, st, "SCALE.", ds, c, scale, (uint64_t)rows * sizeof *scale,
                            err);
        st = channel_add_if(out, st, "W.", ds, c, w,
                            (uint64_t)rows * (uint64_t)terms * sizeof *w, err);
        st = channel_add_if(out, st, "H.", ds, c, h,
                            (uint64_t)cols * (uint64_t)terms * sizeof *h, err);
    }
    op_progress_end(prog);
    free(q);
    return st;
}

/* Adds the sections of s to w. */
static op_status write_sections(op_material_writer *w, const section_list *s, op_error *err)
{
    op_status st = OP_OK;
    for (int i = 0; i < s->n && st == OP_OK; i++)
        st = op_material_writer_add(w, s->tag[i], s->data[i], s->bytes[i], err);
    return st;
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
    enum { N = 1 << 18 }; /* 2 x 5 passes of 262144 calls: about 0.3 s of the command */
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
    enum { REPEATS = 5 };
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
    double t0 = op_monotonic_seconds(), t = t0;
    op_factor_report rep = {0};
    dataset ds = {0};
    section_list secs = {0};
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
    int clusters = a.clusters;
    if (a.method == OP_METHOD_KCTA && clusters > ds.rows) {
        op_log(OP_LOG_WARN, "-C %d exceeds the %lld rows; using %lld", clusters,
               (long long)ds.rows, (long long)ds.rows);
        clusters = (int)ds.rows;
    }
    if (a.method == OP_METHOD_KCTA && a.km > clusters) {
        st = op_error_set(&err, OP_ERR_INPUT, "--km %d exceeds the %d clusters", a.km, clusters);
        goto done;
    }
    op_material_info info = ds.info;
    info.method = a.method;
    info.terms = terms;
    info.degree = a.degree;
    info.clusters = a.method == OP_METHOD_KCTA ? clusters : 0;
    info.shifted = a.method == OP_METHOD_RAW ? 0 : a.shift;
    info.log_a = a.method == OP_METHOD_SVD ? a.log_a : 0.0;
    info.log_b = a.method == OP_METHOD_SVD ? a.log_b : 0.0;
    info.dataset_crc = rep.dataset_crc;
    if (a.name)
        snprintf(info.name, sizeof info.name, "%s", a.name);
    for (char *p = info.name; *p; p++) /* META is one key=value per line */
        if (*p == '\n' || *p == '\r')
            *p = ' ';

    /* Opened before the work, so that an output that cannot be written fails at once. */
    if ((st = op_material_writer_open(a.output, &info, &writer, &err)) != OP_OK)
        goto done;
    t = op_monotonic_seconds();
    double prep = 0;
    if (a.method == OP_METHOD_SVD)
        st = factor_svd(&a, &ds, terms, &secs, &prep, &err);
    else if (a.method == OP_METHOD_TUCKER)
        st = factor_tucker(&a, &ds, terms, &secs, &rep, &err);
    else if (a.method == OP_METHOD_KCTA)
        st = factor_kcta(&a, &ds, terms, clusters, &secs, &prep, &err);
    else if (a.method == OP_METHOD_NMF)
        st = factor_nmf(&a, &ds, terms, &secs, &prep, &err);
    else
        st = factor_raw(&ds, &secs, &err);
    if (st != OP_OK)
        goto done;
    if (prep > 0)
        op_report_stage(&rep, "preprocess", prep);
    op_report_stage(&rep, "factor", op_monotonic_seconds() - t - prep);

    /* Write without the albedo map and read the file back (still under its temporary name) to
     * measure it and the errors; then add the map. Every output is put in place only at the
     * end, the material last: an interruption or a failure before leaves the old files. */
    t = op_monotonic_seconds();
    uint64_t albedo_count = (uint64_t)ds.rows * (uint64_t)ds.info.channels;
    albedo = alloc_or_null(albedo_count * sizeof *albedo);
    if (!albedo) {
        st = op_error_set(&err, OP_ERR_NOMEM, "out of memory");
        goto done;
    }
    const char *pending;
    if ((st = write_sections(writer, &secs, &err)) != OP_OK ||
        (st = op_material_writer_finish(writer, &pending, &err)) != OP_OK)
        goto done;
    op_report_stage(&rep, "write", op_monotonic_seconds() - t);
    t = op_monotonic_seconds();
    st = evaluate(pending, &ds, a.threads, &rep, albedo, &err);
    if (st != OP_OK)
        goto done;
    op_report_stage(&rep, "evaluate", op_monotonic_seconds() - t);
    t = op_monotonic_seconds();
    if (a.method != OP_METHOD_RAW &&
        ((st = op_material_writer_add(writer, "ALBEDO", albedo, albedo_count * sizeof *albedo,
                                      &err)) != OP_OK ||
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

done:
    op_output_abort(report);
    op_material_writer_abort(writer);
    free(albedo);
    sections_free(&secs);
    op_material_close(ds.file);
    return st == OP_OK ? 0 : fail(st, &err);
}
