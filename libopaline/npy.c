/* npy.c - NumPy .npy headers, read and written (opaline.h): the datasets `opaline-factor import`
 * reads, the arrays mfilm writes. The header is a Python dict literal; only the three keys NumPy
 * always writes are read, by a tolerant scan rather than a Python parser. */
#include "opaline.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

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

/* Parses the dict text hdr (NUL-terminated) into h. */
static op_status parse_dict(const char *hdr, const char *path, op_npy_header *h, op_error *err)
{
    const char *descr = dict_value(hdr, "descr"), *fo = dict_value(hdr, "fortran_order"),
               *shape = dict_value(hdr, "shape");
    if (!descr || !fo || !shape)
        return op_error_set(err, OP_ERR_FORMAT, "%s: .npy header lacks descr, fortran_order or "
                            "shape: %s", path, hdr);
    char q = descr[0];
    char d[8] = {0};
    if ((q == '\'' || q == '"') && strchr(descr + 1, q) && strchr(descr + 1, q) - descr - 1 < 7)
        memcpy(d, descr + 1, (size_t)(strchr(descr + 1, q) - descr - 1));
    if (!strcmp(d, "<f4") || !strcmp(d, "=f4") || !strcmp(d, ">f4"))
        h->itemsize = 4;
    else if (!strcmp(d, "<f8") || !strcmp(d, "=f8") || !strcmp(d, ">f8"))
        h->itemsize = 8;
    else
        return op_error_set(err, OP_ERR_INPUT, "%s: dtype '%s' is not supported (need float32 "
                            "or float64)", path, d);
    h->big_endian = d[0] == '>';
    if (strncmp(fo, "False", 5) != 0)
        return op_error_set(err, OP_ERR_INPUT, "%s: Fortran-ordered array: save it in C order "
                            "(numpy.ascontiguousarray)", path);
    if (*shape != '(')
        return op_error_set(err, OP_ERR_FORMAT, "%s: bad shape in .npy header", path);
    const char *p = shape + 1;
    for (;;) {
        while (*p == ' ' || *p == ',')
            p++;
        if (*p == ')')
            return OP_OK;
        char *end;
        errno = 0;
        long long v = strtoll(p, &end, 10);
        if (end == p || errno || v < 0 || h->ndim >= 8)
            return op_error_set(err, OP_ERR_FORMAT, "%s: bad shape in .npy header", path);
        h->shape[h->ndim++] = v;
        p = end;
        while (*p == ' ')
            p++;
        if (*p != ',' && *p != ')')
            return op_error_set(err, OP_ERR_FORMAT, "%s: bad shape in .npy header", path);
    }
}

op_status op_npy_parse_header(const unsigned char *buf, size_t n, const char *path,
                              op_npy_header *h, op_error *err)
{
    memset(h, 0, sizeof *h);
    if (n < 10 || memcmp(buf, "\x93NUMPY", 6) != 0)
        return op_error_set(err, OP_ERR_FORMAT, "%s: not a NumPy .npy file (bad magic)", path);
    unsigned major = buf[6];
    size_t hlen, start;
    if (major == 1) {
        hlen = buf[8] | (size_t)buf[9] << 8;
        start = 10;
    } else if (major == 2 || major == 3) {
        if (n < 12)
            return op_error_set(err, OP_ERR_FORMAT, "%s: truncated .npy header", path);
        hlen = buf[8] | (size_t)buf[9] << 8 | (size_t)buf[10] << 16 | (size_t)buf[11] << 24;
        start = 12;
    } else {
        return op_error_set(err, OP_ERR_FORMAT, "%s: .npy format version %u is not supported",
                            path, major);
    }
    if (hlen == 0 || hlen > OP_NPY_MAX_HEADER - 12)
        return op_error_set(err, OP_ERR_FORMAT, "%s: .npy header of %zu bytes (1 to %d accepted)",
                            path, hlen, OP_NPY_MAX_HEADER - 12);
    if (n - start < hlen)
        return op_error_set(err, OP_ERR_FORMAT, "%s: truncated .npy header", path);
    char *hdr = malloc(hlen + 1);
    if (!hdr)
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    memcpy(hdr, buf + start, hlen);
    hdr[hlen] = '\0';
    h->data_offset = start + hlen;
    op_status st = parse_dict(hdr, path, h, err);
    free(hdr);
    return st;
}

size_t op_npy_write_header(unsigned char *buf, int ndim, const long long *shape)
{
    /* the dict, its padding and newline after the 10 bytes of magic, version and length */
    char *dict = (char *)buf + 10;
    size_t cap = OP_NPY_HEADER_SIZE - 10, n;
    n = (size_t)snprintf(dict, cap, "{'descr': '<f4', 'fortran_order': False, 'shape': (");
    for (int i = 0; i < ndim; i++)
        n += (size_t)snprintf(dict + n, cap - n, "%s%lld", i ? ", " : "", shape[i]);
    n += (size_t)snprintf(dict + n, cap - n, "%s), }", ndim == 1 ? "," : "");
    size_t total = (10 + n + 1 + 63) / 64 * 64;
    memset(dict + n, ' ', total - 10 - n - 1);
    buf[total - 1] = '\n';
    memcpy(buf, "\x93NUMPY\x01\x00", 8);
    buf[8] = (unsigned char)((total - 10) & 0xff);
    buf[9] = (unsigned char)((total - 10) >> 8);
    return total;
}
