/* import_cmd.c - `opaline-factor import IN.npy [--sidecar IN.json] -o OUT.opm`: brings measured
 * data into opaline. IN.npy holds a float32 or float64 array of shape (3, H, W, K, K) in C
 * order: channel (R, G, B), incident row y, incident column x, kernel row dy + K/2, kernel
 * column dx + K/2. The JSON sidecar gives the physical size: {"size_cm": [X, Y]} and may add
 * "name" and "source" strings. Values must be finite with rows summing to at most 1; small
 * negative values (measurement noise) are clamped to 0 with a warning. */
#include "commands.h"
#include "dataset.h"
#include "sidecar.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* ------------------------------------------------------------ reading the inputs */

/* Reads and parses the sidecar; a message for a file that cannot be read says what it is for. */
static op_status read_sidecar(const char *path, op_sidecar *sc, op_error *err)
{
    char *text;
    size_t n;
    op_status st = op_file_read(path, OP_SIDECAR_MAX_BYTES, &text, &n, err);
    if (st != OP_OK) {
        if (err) {
            char why[sizeof err->message];
            memcpy(why, err->message, sizeof why);
            op_error_set(err, st, "%s (the JSON sidecar, which must give the physical size: "
                         "{\"size_cm\": [X, Y]})", why);
        }
        return st;
    }
    st = op_sidecar_parse(text, n, path, sc, err);
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
    FILE *f;
    uint64_t size;
    op_status st = op_file_open_stream(path, &f, &size, err);
    if (st != OP_OK)
        return st;
    op_npy_header h;
    unsigned char *head = malloc(OP_NPY_MAX_HEADER);
    if (!head) {
        fclose(f);
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    }
    size_t got = fread(head, 1, OP_NPY_MAX_HEADER, f);
    st = ferror(f) ? op_error_set(err, OP_ERR_IO, "%s: read failed", path)
                   : op_npy_parse_header(head, got, path, &h, err);
    free(head);
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
    uint64_t expect = h.data_offset + 3 * per_channel * (uint64_t)h.itemsize;
    if (size != expect) {
        fclose(f);
        return op_error_set(err, OP_ERR_INPUT, "%s: %llu bytes, but a (3, %d, %d, %d, %d) "
                                               "float%d array takes %llu", path,
                            (unsigned long long)size, H, W, K, K, 8 * h.itemsize,
                            (unsigned long long)expect);
    }
    if (fseeko(f, (off_t)h.data_offset, SEEK_SET) != 0) {
        fclose(f);
        return op_error_set(err, OP_ERR_IO, "%s: cannot seek", path);
    }
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
                st = ferror(f) ? op_error_set(err, OP_ERR_IO, "%s: read failed", path)
                               : op_error_set(err, OP_ERR_INPUT, "%s: the file was truncated "
                                              "or changed while in use", path);
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
    op_sidecar sc;
    op_dataset d;
    /* the output writable and neither input, then the input named first checked first, before
     * the (cheap) sidecar and the (long) read */
    const char *inputs[2] = {in, side};
    op_status st = op_output_check(&out, 1, inputs, 2, &err);
    int fd;
    if (st == OP_OK)
        st = op_file_open(in, &fd, NULL, &err);
    if (st == OP_OK) {
        close(fd);
        st = read_sidecar(side, &sc, &err);
    }
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
