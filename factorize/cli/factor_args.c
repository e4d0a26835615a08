/* factor_args.c - the command line of `opaline-factor factor` (factor_args.h). */
#include "factor_args.h"
#include "fit_table.h"
#include "opaline.h"
#include "opaline_material.h"

#include <string.h>

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

void op_factor_usage(FILE *f)
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

op_status op_factor_parse_args(int argc, char **argv, factor_args *a, op_error *err)
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
            op_status st = op_parse_number(o, val, num[k].lo, num[k].hi,
                                           num[k].ival ? OP_NUMBER_WHOLE : 0, &d, err);
            if (st != OP_OK)
                return st;
            i++;
            if (num[k].dval)
                *num[k].dval = d;
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
