/* import_cmd.c - `opaline-factor import IN.npy [--sidecar IN.json] -o OUT.opm`: brings measured
 * data into opaline. IN.npy holds a float32 or float64 array of shape (3, H, W, K, K) in C
 * order: channel (R, G, B), incident row y, incident column x, kernel row dy + K/2, kernel
 * column dx + K/2. The JSON sidecar gives the physical size: {"size_cm": [X, Y]} and may add
 * "name" and "source" strings. Values must be finite with rows summing to at most 1; small
 * negative values (measurement noise) are clamped to 0 with a warning. */
#include "commands.h"
#include "dataset.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------ .npy header */

typedef struct npy_header {
    int itemsize;        /* 4 or 8 */
    int big_endian;
    int ndim;
    long long shape[8];
    long data_offset;
} npy_header;

/* Finds 'key': in the header dict and returns the text after the colon, or NULL. */
static const char *dict_value(const char *hdr, const char *key)
{
    char pat[32];
    for (int q = 0; q < 2; q++) {
        snprintf(pat, sizeof pat, q ? "\"%s\"" : "'%s'", key);
        const char *p = strstr(hdr, pat);
        if (p) {
            p += strlen(pat);
            while (*p == ' ')
                p++;
            if (*p != ':')
                return NULL;
            p++;
            while (*p == ' ')
                p++;
            return p;
        }
    }
    return NULL;
}

static op_status npy_read_header(FILE *f, const char *path, npy_header *h, op_error *err)
{
    unsigned char pre[12];
    memset(h, 0, sizeof *h);
    if (fread(pre, 1, 10, f) != 10 || memcmp(pre, "\x93NUMPY", 6) != 0)
        return op_error_set(err, OP_ERR_FORMAT, "%s: not a NumPy .npy file (bad magic)", path);
    unsigned major = pre[6];
    unsigned long hlen;
    long start;
    if (major == 1) {
        hlen = pre[8] | (unsigned long)pre[9] << 8;
        start = 10;
    } else if (major == 2 || major == 3) {
        if (fread(pre + 10, 1, 2, f) != 2)
            return op_error_set(err, OP_ERR_FORMAT, "%s: truncated .npy header", path);
        hlen = pre[8] | (unsigned long)pre[9] << 8 | (unsigned long)pre[10] << 16 |
               (unsigned long)pre[11] << 24;
        start = 12;
    } else {
        return op_error_set(err, OP_ERR_FORMAT, "%s: .npy format version %u is not supported",
                            path, major);
    }
    if (hlen == 0 || hlen > 65536)
        return op_error_set(err, OP_ERR_FORMAT, "%s: .npy header of %lu bytes", path, hlen);
    char *hdr = malloc(hlen + 1);
    if (!hdr)
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    if (fread(hdr, 1, hlen, f) != hlen) {
        free(hdr);
        return op_error_set(err, OP_ERR_FORMAT, "%s: truncated .npy header", path);
    }
    hdr[hlen] = '\0';
    h->data_offset = start + (long)hlen;
    op_status st = OP_OK;
    const char *descr = dict_value(hdr, "descr"), *fo = dict_value(hdr, "fortran_order"),
               *shape = dict_value(hdr, "shape");
    if (!descr || !fo || !shape) {
        st = op_error_set(err, OP_ERR_FORMAT, "%s: .npy header lacks descr, fortran_order or "
                                              "shape: %s", path, hdr);
        goto done;
    }
    char q = descr[0];
    char d[8] = {0};
    if ((q == '\'' || q == '"') && strchr(descr + 1, q) && strchr(descr + 1, q) - descr - 1 < 7)
        memcpy(d, descr + 1, (size_t)(strchr(descr + 1, q) - descr - 1));
    if (!strcmp(d, "<f4") || !strcmp(d, "=f4") || !strcmp(d, ">f4"))
        h->itemsize = 4;
    else if (!strcmp(d, "<f8") || !strcmp(d, "=f8") || !strcmp(d, ">f8"))
        h->itemsize = 8;
    else {
        st = op_error_set(err, OP_ERR_INPUT, "%s: dtype '%s' is not supported (need float32 or "
                                             "float64)", path, d);
        goto done;
    }
    h->big_endian = d[0] == '>';
    if (strncmp(fo, "False", 5) != 0) {
        st = op_error_set(err, OP_ERR_INPUT, "%s: Fortran-ordered array: save it in C order "
                                             "(numpy.ascontiguousarray)", path);
        goto done;
    }
    if (*shape != '(') {
        st = op_error_set(err, OP_ERR_FORMAT, "%s: bad shape in .npy header", path);
        goto done;
    }
    const char *p = shape + 1;
    for (;;) {
        while (*p == ' ' || *p == ',')
            p++;
        if (*p == ')')
            break;
        char *end;
        errno = 0;
        long long v = strtoll(p, &end, 10);
        if (end == p || errno || v < 0 || h->ndim >= 8) {
            st = op_error_set(err, OP_ERR_FORMAT, "%s: bad shape in .npy header", path);
            goto done;
        }
        h->shape[h->ndim++] = v;
        p = end;
        while (*p == ' ')
            p++;
        if (*p != ',' && *p != ')') {
            st = op_error_set(err, OP_ERR_FORMAT, "%s: bad shape in .npy header", path);
            goto done;
        }
    }
done:
    free(hdr);
    return st;
}

/* ------------------------------------------------------------ JSON sidecar */

/* A small strict JSON reader: enough to pick the top-level keys of the sidecar. */
typedef struct json {
    const char *p, *base, *path;
    op_error *err;
} json;

static void json_ws(json *j)
{
    while (*j->p == ' ' || *j->p == '\t' || *j->p == '\n' || *j->p == '\r')
        j->p++;
}

static op_status json_fail(json *j, const char *what)
{
    return op_error_set(j->err, OP_ERR_INPUT, "%s: bad JSON at byte %ld: %s", j->path,
                        (long)(j->p - j->base), what);
}

/* Reads a string into buf (n bytes, truncated); non-ASCII escapes become '?'. */
static op_status json_string(json *j, char *buf, size_t n)
{
    if (*j->p != '"')
        return json_fail(j, "expected a string");
    j->p++;
    size_t k = 0;
    while (*j->p && *j->p != '"') {
        char c = *j->p++;
        if ((unsigned char)c < 0x20)
            return json_fail(j, "control character in a string");
        if (c == '\\') {
            char e = *j->p++;
            switch (e) {
            case '"': case '\\': case '/': c = e; break;
            case 'b': case 'f': case 'n': case 'r': case 't': c = ' '; break;
            case 'u':
                for (int i = 0; i < 4; i++)
                    if (!strchr("0123456789abcdefABCDEF", *j->p++) || !j->p[-1])
                        return json_fail(j, "bad \\u escape");
                c = '?';
                break;
            default: return json_fail(j, "bad escape");
            }
        }
        if (buf && k + 1 < n)
            buf[k++] = c;
    }
    if (*j->p != '"')
        return json_fail(j, "unterminated string");
    j->p++;
    if (buf && n)
        buf[k] = '\0';
    return OP_OK;
}

static op_status json_number(json *j, double *out)
{
    char *end;
    if (!strchr("-0123456789", *j->p))
        return json_fail(j, "expected a number");
    double v = strtod(j->p, &end);
    if (end == j->p)
        return json_fail(j, "expected a number");
    j->p = end;
    if (out)
        *out = v;
    return OP_OK;
}

static op_status json_skip(json *j, int depth)
{
    json_ws(j);
    if (depth > 32)
        return json_fail(j, "nested too deeply");
    if (*j->p == '"')
        return json_string(j, NULL, 0);
    if (*j->p == '{' || *j->p == '[') {
        char close = *j->p == '{' ? '}' : ']';
        int obj = close == '}';
        j->p++;
        json_ws(j);
        if (*j->p == close) {
            j->p++;
            return OP_OK;
        }
        for (;;) {
            json_ws(j);
            if (obj) {
                if (json_string(j, NULL, 0) != OP_OK)
                    return j->err ? j->err->status : OP_ERR_INPUT;
                json_ws(j);
                if (*j->p++ != ':')
                    return json_fail(j, "expected ':'");
            }
            op_status st = json_skip(j, depth + 1);
            if (st != OP_OK)
                return st;
            json_ws(j);
            if (*j->p == ',') {
                j->p++;
                continue;
            }
            if (*j->p++ == close)
                return OP_OK;
            return json_fail(j, "expected ',' or a closing bracket");
        }
    }
    static const char *words[] = {"true", "false", "null"};
    for (int i = 0; i < 3; i++)
        if (!strncmp(j->p, words[i], strlen(words[i]))) {
            j->p += strlen(words[i]);
            return OP_OK;
        }
    return json_number(j, NULL);
}

typedef struct sidecar {
    double size_x_cm, size_y_cm;
    int have_size;
    char name[128], source[96];
} sidecar;

static op_status read_sidecar(const char *path, sidecar *sc, op_error *err)
{
    memset(sc, 0, sizeof *sc);
    FILE *f = fopen(path, "rb");
    if (!f)
        return op_error_set(err, OP_ERR_INPUT, "%s: cannot open the JSON sidecar (%s); it must "
                                               "give the physical size: {\"size_cm\": [X, Y]}",
                            path, strerror(errno));
    char *text = malloc(65537);
    size_t n = text ? fread(text, 1, 65536, f) : 0;
    int more = text && fgetc(f) != EOF;
    fclose(f);
    if (!text)
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    if (more) {
        free(text);
        return op_error_set(err, OP_ERR_INPUT, "%s: sidecar larger than 64 KiB", path);
    }
    text[n] = '\0';
    if (strlen(text) != n) {
        free(text);
        return op_error_set(err, OP_ERR_INPUT, "%s: NUL byte in the sidecar", path);
    }
    json j = {text, text, path, err};
    op_status st = OP_OK;
    json_ws(&j);
    if (*j.p++ != '{') {
        st = json_fail(&j, "the sidecar must be a JSON object");
        goto out;
    }
    json_ws(&j);
    if (*j.p == '}')
        j.p++;
    else
        for (;;) {
            char key[64];
            json_ws(&j);
            if ((st = json_string(&j, key, sizeof key)) != OP_OK)
                goto out;
            json_ws(&j);
            if (*j.p++ != ':') {
                st = json_fail(&j, "expected ':'");
                goto out;
            }
            json_ws(&j);
            if (!strcmp(key, "size_cm")) {
                if (*j.p++ != '[') {
                    st = json_fail(&j, "size_cm must be [X, Y]");
                    goto out;
                }
                json_ws(&j);
                if ((st = json_number(&j, &sc->size_x_cm)) != OP_OK)
                    goto out;
                json_ws(&j);
                if (*j.p++ != ',') {
                    st = json_fail(&j, "size_cm must be [X, Y]");
                    goto out;
                }
                json_ws(&j);
                if ((st = json_number(&j, &sc->size_y_cm)) != OP_OK)
                    goto out;
                json_ws(&j);
                if (*j.p++ != ']') {
                    st = json_fail(&j, "size_cm must be [X, Y]");
                    goto out;
                }
                sc->have_size = 1;
            } else if (!strcmp(key, "name")) {
                if ((st = json_string(&j, sc->name, sizeof sc->name)) != OP_OK)
                    goto out;
            } else if (!strcmp(key, "source")) {
                if ((st = json_string(&j, sc->source, sizeof sc->source)) != OP_OK)
                    goto out;
            } else {
                op_log(OP_LOG_WARN, "%s: ignoring unknown key '%s'", path, key);
                if ((st = json_skip(&j, 0)) != OP_OK)
                    goto out;
            }
            json_ws(&j);
            if (*j.p == ',') {
                j.p++;
                continue;
            }
            if (*j.p++ == '}')
                break;
            st = json_fail(&j, "expected ',' or '}'");
            goto out;
        }
    json_ws(&j);
    if (*j.p) {
        st = json_fail(&j, "text after the object");
        goto out;
    }
    if (!sc->have_size)
        st = op_error_set(err, OP_ERR_INPUT, "%s: no \"size_cm\": [X, Y] (the physical size in "
                                             "cm)", path);
    else if (!(sc->size_x_cm > 0) || !(sc->size_y_cm > 0) || !isfinite(sc->size_x_cm) ||
             !isfinite(sc->size_y_cm))
        st = op_error_set(err, OP_ERR_INPUT, "%s: size_cm %g x %g must be positive", path,
                          sc->size_x_cm, sc->size_y_cm);
out:
    free(text);
    return st;
}

/* ------------------------------------------------------------ the import */

static double load_value(const unsigned char *b, int itemsize, int big_endian)
{
    unsigned char t[8];
    for (int i = 0; i < itemsize; i++)
        t[i] = big_endian ? b[itemsize - 1 - i] : b[i];
    if (itemsize == 4) {
        float v;
        memcpy(&v, t, 4);
        return v;
    }
    double v;
    memcpy(&v, t, 8);
    return v;
}

/* Reads path into d (allocated here) after checking its header; d's sizes come from the shape. */
static op_status read_npy(const char *path, op_dataset *d, op_error *err)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return op_error_set(err, OP_ERR_INPUT, "%s: cannot open (%s)", path, strerror(errno));
    npy_header h;
    op_status st = npy_read_header(f, path, &h, err);
    if (st == OP_OK && (h.ndim != 5 || h.shape[0] != 3 || h.shape[3] != h.shape[4])) {
        char s[128] = "";
        for (int i = 0; i < h.ndim; i++)
            snprintf(s + strlen(s), sizeof s - strlen(s), "%s%lld", i ? ", " : "", h.shape[i]);
        st = op_error_set(err, OP_ERR_INPUT, "%s: shape (%s) is not (3, H, W, K, K)", path, s);
    }
    if (st == OP_OK && (h.shape[1] < 1 || h.shape[2] < 1 || h.shape[1] > 65535 ||
                        h.shape[2] > 65535 || h.shape[1] * h.shape[2] > (1LL << 26)))
        st = op_error_set(err, OP_ERR_INPUT, "%s: %lld x %lld incident pixels: each must be 1 to "
                                             "65535", path, h.shape[2], h.shape[1]);
    if (st == OP_OK && (h.shape[3] < 1 || h.shape[3] % 2 == 0 || h.shape[3] > 4095))
        st = op_error_set(err, OP_ERR_INPUT, "%s: kernel %lld must be odd, 1 to 4095", path,
                          h.shape[3]);
    if (st != OP_OK) {
        fclose(f);
        return st;
    }
    int H = (int)h.shape[1], W = (int)h.shape[2], K = (int)h.shape[3];
    uint64_t per_channel = (uint64_t)H * (uint64_t)W * (uint64_t)K * (uint64_t)K;
    if (fseek(f, 0, SEEK_END) != 0 || ftell(f) < 0) {
        fclose(f);
        return op_error_set(err, OP_ERR_IO, "%s: cannot seek", path);
    }
    uint64_t expect = (uint64_t)h.data_offset + 3 * per_channel * (uint64_t)h.itemsize;
    uint64_t size = (uint64_t)ftell(f);
    if (size != expect) {
        fclose(f);
        return op_error_set(err, OP_ERR_INPUT, "%s: %llu bytes, but a (3, %d, %d, %d, %d) "
                                               "float%d array takes %llu", path,
                            (unsigned long long)size, H, W, K, K, 8 * h.itemsize,
                            (unsigned long long)expect);
    }
    fseek(f, h.data_offset, SEEK_SET);
    st = op_dataset_alloc(d, W, H, K, 0, err);
    if (st != OP_OK) {
        fclose(f);
        return st;
    }
    enum { CHUNK = 1 << 16 };
    unsigned char *buf = malloc((size_t)CHUNK * (size_t)h.itemsize);
    uint64_t negatives = 0;
    double most_negative = 0;
    if (!buf)
        st = op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    for (int c = 0; c < 3 && st == OP_OK; c++)
        for (uint64_t i = 0; i < per_channel && st == OP_OK;) {
            size_t n = per_channel - i < CHUNK ? (size_t)(per_channel - i) : CHUNK;
            if (fread(buf, (size_t)h.itemsize, n, f) != n) {
                st = op_error_set(err, OP_ERR_IO, "%s: read failed", path);
                break;
            }
            for (size_t k = 0; k < n; k++, i++) {
                double v = load_value(buf + k * (size_t)h.itemsize, h.itemsize, h.big_endian);
                float fv = (float)v;
                if (!isfinite(v) || !isfinite(fv)) {
                    uint64_t row = i / ((uint64_t)K * K), col = i % ((uint64_t)K * K);
                    st = op_error_set(err, OP_ERR_INPUT,
                                      "%s: value [%d, %d, %d, %d, %d] = %g is not a finite "
                                      "float32", path, c, (int)(row / (uint64_t)W),
                                      (int)(row % (uint64_t)W), (int)(col / (uint64_t)K),
                                      (int)(col % (uint64_t)K), v);
                    break;
                }
                if (fv < 0) {
                    negatives++;
                    if (v < most_negative)
                        most_negative = v;
                    fv = 0;
                }
                d->rd[c][i] = fv;
            }
        }
    free(buf);
    fclose(f);
    if (st == OP_OK && negatives)
        op_log(OP_LOG_WARN, "%s: %llu negative value(s) (as low as %g) clamped to 0", path,
               (unsigned long long)negatives, most_negative);
    if (st != OP_OK)
        op_dataset_free(d);
    return st;
}

static void import_usage(FILE *f)
{
    fprintf(f,
            "usage: opaline-factor import IN.npy [--sidecar IN.json] -o OUT.opm\n\n"
            "IN.npy: float32 or float64, shape (3, H, W, K, K) in C order: channel R,G,B, incident\n"
            "row y, incident column x, exit row dy + K/2, exit column dx + K/2; each value the\n"
            "fraction of the power entering pixel (x, y) that leaves through (x + dx, y + dy).\n"
            "IN.json (default: IN with .npy replaced by .json):\n"
            "  {\"size_cm\": [X, Y], \"name\": \"MyMarble\", \"source\": \"free text\"}\n"
            "size_cm is required; rows must sum to at most 1 and values be finite (negative\n"
            "noise is clamped to 0 with a warning). See docs/datasets.md.\n");
}

static void clean_text(char *s)
{
    for (; *s; s++)
        if ((unsigned char)*s < 0x20 || *s == 0x7f)
            *s = ' ';
}

int op_cmd_import(int argc, char **argv)
{
    const char *in = NULL, *side = NULL, *out = NULL;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            import_usage(stdout);
            return 0;
        }
        if (!strcmp(argv[i], "-o") || !strcmp(argv[i], "--sidecar")) {
            if (i + 1 >= argc) {
                op_log(OP_LOG_ERROR, "import: option %s needs a value", argv[i]);
                return 2;
            }
            *(argv[i][1] == 'o' ? &out : &side) = argv[i + 1];
            i++;
        } else if (argv[i][0] == '-' || in) {
            op_log(OP_LOG_ERROR, "import: unexpected argument '%s' (see --help)", argv[i]);
            return 2;
        } else {
            in = argv[i];
        }
    }
    if (!in || !out) {
        import_usage(stderr);
        return 2;
    }
    char side_buf[4096];
    if (!side) {
        size_t n = strlen(in);
        if (n >= 4 && !strcmp(in + n - 4, ".npy"))
            snprintf(side_buf, sizeof side_buf, "%.*s.json", (int)(n - 4), in);
        else
            snprintf(side_buf, sizeof side_buf, "%s.json", in);
        side = side_buf;
    }
    op_error err = {0};
    sidecar sc;
    op_dataset d;
    op_status st = read_sidecar(side, &sc, &err);
    if (st == OP_OK)
        st = read_npy(in, &d, &err);
    if (st == OP_OK) {
        d.size_x_cm = sc.size_x_cm;
        d.size_y_cm = sc.size_y_cm;
        if (sc.name[0]) {
            snprintf(d.name, sizeof d.name, "%s", sc.name);
        } else {
            const char *base = strrchr(in, '/') ? strrchr(in, '/') + 1 : in;
            snprintf(d.name, sizeof d.name, "%.*s",
                     (int)(strlen(base) > 4 && !strcmp(base + strlen(base) - 4, ".npy")
                               ? strlen(base) - 4 : strlen(base)), base);
        }
        snprintf(d.generator, sizeof d.generator, "import%s%s", sc.source[0] ? " " : "",
                 sc.source);
        clean_text(d.name);
        clean_text(d.generator);
        st = op_dataset_check(&d, &err);
        if (st != OP_OK)
            op_error_prefix(&err, "%s: ", in);
        else
            st = op_dataset_write(&d, out, &err);
        op_dataset_free(&d);
    }
    if (st != OP_OK) {
        op_log(OP_LOG_ERROR, "import: %s", err.message);
        return op_exit_code(st);
    }
    op_log(OP_LOG_INFO, "import: wrote %s", out);
    return 0;
}
