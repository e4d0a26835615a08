/* material_file.c - the one module that reads and writes the ".opm" container: header, section
 * table, checksums, META; the methods are material.c's.
 *
 * Layout (all integers little-endian; docs/formats.md is the specification):
 *   header, 64 bytes: magic "OPALINEM", u32 version, u32 section count, u64 file size,
 *                     u64 table offset, u32 table CRC-32, u32 header CRC-32 (of bytes 0..35)
 *   sections, each starting at a multiple of 64 bytes
 *   section table: per section tag[8], u64 offset, u64 size, u32 CRC-32, u32 reserved (0)
 * Section "META" is UTF-8 text, one "key=value" per line, describing the material. */
#include "material_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <libdeflate.h>
#include <zlib.h>

#if __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "opaline maps little-endian float sections directly; port material_file.c first"
#endif

#define OPM_MAGIC "OPALINEM"
#define OPM_VERSION 1u
#define OPM_HEADER_SIZE 64u
#define OPM_ENTRY_SIZE 32u
#define OPM_ALIGN 64u
#define OPM_MAX_SECTIONS 4096u

#ifndef OPALINE_VERSION_STRING
#define OPALINE_VERSION_STRING "unknown"
#endif

const char *op_version(void)
{
    return OPALINE_VERSION_STRING;
}

/* Buffers from 64 MiB on are checksummed in 16 MiB blocks on every core, combined in order. */
enum { CRC_BLOCK = 16 << 20, CRC_MAX_BLOCKS = 1 << 16 };
typedef struct crc_job {
    const unsigned char *data;
    size_t n, block;
    uint32_t *parts;
} crc_job;

static void crc_task(void *user, int task, int thread)
{
    const crc_job *j = user;
    size_t at = (size_t)task * j->block, len = j->n - at < j->block ? j->n - at : j->block;
    (void)thread;
    j->parts[task] = libdeflate_crc32(0, j->data + at, len);
}

uint32_t op_crc32(uint32_t crc, const void *data, size_t n)
{
    crc_job j = {data, n, CRC_BLOCK, NULL};
    while (n / j.block >= CRC_MAX_BLOCKS)
        j.block *= 2;
    int tasks = (int)((n + j.block - 1) / j.block);
    if (n >= 4 * (size_t)CRC_BLOCK && (j.parts = malloc((size_t)tasks * sizeof *j.parts)) &&
        op_parallel_for(0, tasks, crc_task, &j, NULL, NULL) == OP_OK) {
        for (int t = 0; t < tasks; t++) {
            size_t len = n - (size_t)t * j.block < j.block ? n - (size_t)t * j.block : j.block;
            crc = op_crc32_combine(crc, j.parts[t], len);
        }
        free(j.parts);
        return crc;
    }
    free(j.parts);
    return libdeflate_crc32(crc, data, n);
}

uint32_t op_crc32_combine(uint32_t crc_a, uint32_t crc_b, uint64_t bytes_b)
{
    return (uint32_t)crc32_combine(crc_a, crc_b, (z_off_t)bytes_b); /* z_off_t: 64 bits on LP64 */
}

#define METHOD_NAME(id, name) [OP_METHOD_##id] = #name,
static const char *const method_names[OP_METHOD_COUNT] = {OP_METHOD_LIST(METHOD_NAME)};
#undef METHOD_NAME

const char *op_method_name(op_method m)
{
    return (unsigned)m < OP_METHOD_COUNT ? method_names[m] : "unknown";
}

op_method op_method_from_name(const char *name)
{
    for (int i = 0; i < OP_METHOD_COUNT; i++)
        if (strcmp(name, method_names[i]) == 0)
            return (op_method)i;
    return OP_METHOD_COUNT;
}

/* ------------------------------------------------------------ section tags */

static int valid_tag(const char *tag)
{
    size_t n = strnlen(tag, 9);
    if (n < 1 || n > 8)
        return 0;
    for (size_t i = 0; i < n; i++)
        if (tag[i] <= ' ' || tag[i] > '~')
            return 0;
    return 1;
}

/* ------------------------------------------------------------ helpers for methods */

int64_t op_material_rows(const op_material *m)
{
    return (int64_t)m->info.width * m->info.height;
}

int op_material_cols(const op_material *m)
{
    return m->info.kernel * m->info.kernel;
}

void op_channel_tag(char *tag, size_t n, const char *prefix, const op_material_info *info, int c)
{
    static const char rgb[] = "RGB";
    snprintf(tag, n, "%s%c", prefix, info->channels == 1 ? 'Y' : rgb[c]);
}

uint32_t op_material_section_crc(const op_material *m, const char *tag)
{
    for (uint32_t i = 0; i < m->nsections; i++) {
        const unsigned char *e = m->table + (size_t)i * OPM_ENTRY_SIZE;
        if (strncmp((const char *)e, tag, 8) == 0)
            return op_get_le32(e + 24);
    }
    return 0;
}

const void *op_material_section(const op_material *m, const char *tag, uint64_t *bytes)
{
    for (uint32_t i = 0; i < m->nsections; i++) {
        const unsigned char *e = m->table + (size_t)i * OPM_ENTRY_SIZE;
        if (strncmp((const char *)e, tag, 8) == 0) {
            if (bytes)
                *bytes = op_get_le64(e + 16);
            return m->base + op_get_le64(e + 8);
        }
    }
    return NULL;
}

/* ------------------------------------------------------------ META text */

static op_status parse_int(const char *path, const char *key, const char *val, int lo, int hi,
                           int *out, op_error *err)
{
    char *end;
    errno = 0;
    long v = strtol(val, &end, 10);
    if (errno || end == val || *end || v < lo || v > hi)
        return op_error_set(err, OP_ERR_FORMAT, "%s: META '%s' = '%s' is not an integer in [%d, %d]",
                            path, key, val, lo, hi);
    *out = (int)v;
    return OP_OK;
}

static op_status parse_double(const char *path, const char *key, const char *val, double *out,
                              op_error *err)
{
    char *end;
    errno = 0;
    double v = strtod(val, &end);
    if (errno || end == val || *end || !isfinite(v))
        return op_error_set(err, OP_ERR_FORMAT, "%s: META '%s' = '%s' is not a finite number",
                            path, key, val);
    *out = v;
    return OP_OK;
}

/* Parses META: one "key=value" per line, lines ended by LF or CRLF. */
static op_status parse_meta(const char *path, const char *text, uint64_t n, op_material_info *info,
                            op_error *err)
{
    memset(info, 0, sizeof *info);
    info->method = OP_METHOD_COUNT;
    char line[512];
    uint64_t pos = 0;
    int lineno = 0, have_dims = 0;
    op_status st = OP_OK;
    while (pos < n && st == OP_OK) {
        uint64_t end = pos;
        while (end < n && text[end] != '\n')
            end++;
        lineno++;
        if (end - pos >= sizeof line)
            return op_error_set(err, OP_ERR_FORMAT, "%s: META line %d is too long", path, lineno);
        memcpy(line, text + pos, end - pos);
        line[end - pos] = '\0';
        if (end > pos && text[end - 1] == '\r') /* CRLF line ends, from an editor */
            line[end - pos - 1] = '\0';
        pos = end + 1;
        if (!line[0])
            continue;
        char *eq = strchr(line, '=');
        if (!eq)
            return op_error_set(err, OP_ERR_FORMAT, "%s: META line %d has no '='", path, lineno);
        *eq = '\0';
        const char *k = line, *v = eq + 1;
        if (!strcmp(k, "method")) {
            info->method = op_method_from_name(v);
            if (info->method == OP_METHOD_COUNT)
                st = op_error_set(err, OP_ERR_FORMAT, "%s: unknown method '%s'", path, v);
        } else if (!strcmp(k, "width")) {
            st = parse_int(path, k, v, 1, 1 << 20, &info->width, err);
            have_dims |= 1;
        } else if (!strcmp(k, "height")) {
            st = parse_int(path, k, v, 1, 1 << 20, &info->height, err);
            have_dims |= 2;
        } else if (!strcmp(k, "kernel")) {
            st = parse_int(path, k, v, 1, 4095, &info->kernel, err);
            have_dims |= 4;
        } else if (!strcmp(k, "channels")) {
            st = parse_int(path, k, v, 1, 3, &info->channels, err);
            have_dims |= 8;
        } else if (!strcmp(k, "size_x_cm")) {
            st = parse_double(path, k, v, &info->size_x_cm, err);
        } else if (!strcmp(k, "size_y_cm")) {
            st = parse_double(path, k, v, &info->size_y_cm, err);
        } else if (!strcmp(k, "terms")) {
            st = parse_int(path, k, v, 0, 1 << 16, &info->terms, err);
        } else if (!strcmp(k, "degree")) {
            st = parse_int(path, k, v, 0, 64, &info->degree, err);
        } else if (!strcmp(k, "clusters")) {
            st = parse_int(path, k, v, 0, 1 << 20, &info->clusters, err);
        } else if (!strcmp(k, "shifted")) {
            st = parse_int(path, k, v, 0, 1, &info->shifted, err);
        } else if (!strcmp(k, "log_a")) {
            st = parse_double(path, k, v, &info->log_a, err);
        } else if (!strcmp(k, "log_b")) {
            st = parse_double(path, k, v, &info->log_b, err);
        } else if (!strcmp(k, "dataset_crc")) {
            char *e;
            errno = 0;
            unsigned long long c = strtoull(v, &e, 16);
            if (errno || e == v || *e || c > 0xffffffffull)
                st = op_error_set(err, OP_ERR_FORMAT, "%s: META dataset_crc '%s' is invalid", path, v);
            info->dataset_crc = (uint32_t)c;
        } else if (!strcmp(k, "name")) {
            snprintf(info->name, sizeof info->name, "%s", v);
        } else if (!strcmp(k, "generator")) {
            snprintf(info->generator, sizeof info->generator, "%s", v);
        } else if (!strcmp(k, "tool_version")) {
            snprintf(info->tool_version, sizeof info->tool_version, "%s", v);
        }
        /* Unknown keys are allowed: newer writers may add descriptive fields. */
    }
    if (st != OP_OK)
        return st;
    if (info->method == OP_METHOD_COUNT || have_dims != 15)
        return op_error_set(err, OP_ERR_FORMAT,
                            "%s: META lacks method, width, height, kernel or channels", path);
    if (info->kernel % 2 == 0)
        return op_error_set(err, OP_ERR_FORMAT, "%s: kernel %d is not odd", path, info->kernel);
    if (info->channels != 1 && info->channels != 3)
        return op_error_set(err, OP_ERR_FORMAT, "%s: %d channels (need 1 or 3)", path,
                            info->channels);
    if (!(info->size_x_cm > 0) || !(info->size_y_cm > 0))
        return op_error_set(err, OP_ERR_FORMAT, "%s: physical size must be positive", path);
    if ((int64_t)info->width * info->height > ((int64_t)1 << 32))
        return op_error_set(err, OP_ERR_FORMAT, "%s: %d x %d pixels is too many", path,
                            info->width, info->height);
    return OP_OK;
}

static size_t format_meta(const op_material_info *info, char *buf, size_t n)
{
    return (size_t)snprintf(
        buf, n,
        "method=%s\nwidth=%d\nheight=%d\nkernel=%d\nchannels=%d\nsize_x_cm=%.17g\n"
        "size_y_cm=%.17g\nterms=%d\ndegree=%d\nclusters=%d\nshifted=%d\nlog_a=%.17g\n"
        "log_b=%.17g\ndataset_crc=%08x\nname=%s\ngenerator=%s\ntool_version=%s\n",
        op_method_name(info->method), info->width, info->height, info->kernel, info->channels,
        info->size_x_cm, info->size_y_cm, info->terms, info->degree, info->clusters,
        info->shifted, info->log_a, info->log_b, (unsigned)info->dataset_crc, info->name,
        info->generator, op_version());
}

/* ------------------------------------------------------------ reading */

/* Whether a stored checksum matches the computed one. Fuzzing builds (the libFuzzer convention
 * FUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION) accept any, so mutations reach the checks behind. */
static int checksum_ok(uint32_t stored, uint32_t computed)
{
#ifdef FUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION
    (void)stored;
    (void)computed;
    return 1;
#else
    return stored == computed;
#endif
}

/* Checks entry i of the section table (at e; the table starts at byte `table`): its tag (1 to
 * 8 printable ASCII characters, NUL-padded, not used by an earlier entry) and its bounds
 * (aligned, between the header and the table). */
static op_status check_entry(const op_material *m, uint32_t i, const unsigned char *e,
                             uint64_t table, op_error *err)
{
    const char *path = m->path;
    char tag[9], shown[8 * 4 + 1]; /* the tag, and as text with control bytes escaped */
    size_t len = strnlen((const char *)e, 8);
    memcpy(tag, e, len);
    tag[len] = '\0';
    op_text_escape(shown, sizeof shown, tag);
    if (len == 0)
        return op_error_set(err, OP_ERR_FORMAT, "%s: section %u has an empty tag", path, i);
    for (size_t j = 0; j < 8; j++)
        if (j < len ? e[j] <= ' ' || e[j] > '~' : e[j] != 0)
            return op_error_set(err, OP_ERR_FORMAT, "%s: section %u tag '%s': byte %zu is %s (a "
                                "tag is 1 to 8 printable ASCII characters padded with zero bytes)",
                                path, i, shown, j, j < len ? "not a printable ASCII character"
                                                           : "not a zero byte");
    for (uint32_t j = 0; j < i; j++)
        if (!memcmp(e, m->table + (size_t)j * OPM_ENTRY_SIZE, 8))
            return op_error_set(err, OP_ERR_FORMAT, "%s: sections %u and %u have the same tag "
                                "'%s'", path, j, i, shown);
    uint64_t off = op_get_le64(e + 8), size = op_get_le64(e + 16);
    if (off % OPM_ALIGN)
        return op_error_set(err, OP_ERR_FORMAT, "%s: section '%s' starts at byte %llu, not a "
                            "multiple of %u", path, shown, (unsigned long long)off, OPM_ALIGN);
    if (off < OPM_HEADER_SIZE || off > table)
        return op_error_set(err, OP_ERR_FORMAT, "%s: section '%s' starts at byte %llu, outside "
                            "the data between the header (%u bytes) and the section table (byte "
                            "%llu)", path, shown, (unsigned long long)off, OPM_HEADER_SIZE,
                            (unsigned long long)table);
    if (size > table - off)
        return op_error_set(err, OP_ERR_FORMAT, "%s: section '%s' (%llu bytes from byte %llu) runs "
                            "into the section table at byte %llu", path, shown,
                            (unsigned long long)size, (unsigned long long)off,
                            (unsigned long long)table);
    return OP_OK;
}

/* The CRC-32 of a section; streaming, in pieces of 64 MiB released once read. */
static uint32_t section_crc(const op_material *m, const unsigned char *p, uint64_t size)
{
    if (!m->streaming)
        return op_crc32(0, p, (size_t)size);
    const uint64_t piece = (uint64_t)64 << 20;
    uint32_t crc = 0;
    for (uint64_t at = 0; at < size; at += piece) {
        size_t n = (size_t)(size - at < piece ? size - at : piece);
        crc = op_crc32(crc, p + at, n);
        op_file_release(&m->file, p + at, n);
    }
    return crc;
}

static op_status check_container(op_material *m, op_error *err)
{
    const unsigned char *b = m->base;
    const char *path = m->path;
    if (m->size < OPM_HEADER_SIZE || memcmp(b, OPM_MAGIC, 8) != 0)
        return op_error_set(err, OP_ERR_FORMAT, "%s: not an opaline material file", path);
    if (!checksum_ok(op_get_le32(b + 36), op_crc32(0, b, 36)))
        return op_error_set(err, OP_ERR_FORMAT, "%s: header checksum mismatch (corrupt file)",
                            path);
    uint32_t version = op_get_le32(b + 8);
    if (version != OPM_VERSION)
        return op_error_set(err, OP_ERR_FORMAT,
                            "%s: format version %u, this opaline reads version %u", path, version,
                            OPM_VERSION);
    uint32_t count = op_get_le32(b + 12);
    uint64_t declared = op_get_le64(b + 16), table = op_get_le64(b + 24);
    if (declared != m->size)
        return op_error_set(err, OP_ERR_FORMAT,
                            "%s: file is %llu bytes but its header says %llu (truncated?)", path,
                            (unsigned long long)m->size, (unsigned long long)declared);
    if (count == 0 || count > OPM_MAX_SECTIONS)
        return op_error_set(err, OP_ERR_FORMAT, "%s: the header counts %u sections (need 1 to %u)",
                            path, count, OPM_MAX_SECTIONS);
    if (table < OPM_HEADER_SIZE || table > m->size || (m->size - table) / OPM_ENTRY_SIZE < count)
        return op_error_set(err, OP_ERR_FORMAT, "%s: the section table (%u entries at byte %llu) "
                            "does not lie between the header and the end of the %llu-byte file",
                            path, count, (unsigned long long)table, (unsigned long long)m->size);
    if (!checksum_ok(op_get_le32(b + 32), op_crc32(0, b + table, (size_t)count * OPM_ENTRY_SIZE)))
        return op_error_set(err, OP_ERR_FORMAT, "%s: section table checksum mismatch", path);
    m->table = b + table;
    m->nsections = count;
    for (uint32_t i = 0; i < count; i++) {
        const unsigned char *e = m->table + (size_t)i * OPM_ENTRY_SIZE;
        op_status st = check_entry(m, i, e, table, err);
        if (st != OP_OK)
            return st;
        uint64_t off = op_get_le64(e + 8), size = op_get_le64(e + 16);
        if (!checksum_ok(op_get_le32(e + 24), section_crc(m, b + off, size)))
            return op_error_set(err, OP_ERR_FORMAT,
                                "%s: section '%.8s' checksum mismatch (corrupt file)", path,
                                (const char *)e);
    }
    return OP_OK;
}

/* Frees what open_container made; the method's state must be gone already. */
void op_material_free_container(op_material *m)
{
    if (!m)
        return;
    op_file_unmap(&m->file);
    free(m);
}

static op_status open_container(const char *path, int streaming, op_material **out,
                                op_error *err)
{
    *out = NULL;
    op_material *m = calloc(1, sizeof *m);
    if (!m)
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    m->streaming = streaming;
    snprintf(m->path, sizeof m->path, "%s", path);
    op_status st = op_file_map(path, &m->file, err);
    if (st != OP_OK) {
        free(m);
        return st;
    }
    m->base = m->file.data;
    m->size = m->file.size;
    st = check_container(m, err);
    uint64_t meta_n = 0;
    const char *meta = st == OP_OK ? op_material_section(m, "META", &meta_n) : NULL;
    if (st == OP_OK && !meta)
        st = op_error_set(err, OP_ERR_FORMAT, "%s: section 'META' is missing", path);
    if (st == OP_OK)
        st = parse_meta(path, meta, meta_n, &m->info, err);
    if (st != OP_OK) {
        op_material_free_container(m);
        return st;
    }
    *out = m;
    return OP_OK;
}

op_status op_material_open_container(const char *path, op_material **out, op_error *err)
{
    return open_container(path, 0, out, err);
}

op_status op_material_open_streaming(const char *path, op_material **out, op_error *err)
{
    return open_container(path, 1, out, err);
}

void op_material_release(const op_material *m, const void *p, size_t n)
{
    op_file_release(&m->file, p, n);
}

const op_material_info *op_material_get_info(const op_material *m)
{
    return &m->info;
}

uint64_t op_material_file_size(const op_material *m)
{
    return m->size;
}

/* ------------------------------------------------------------ writing */

struct op_material_writer {
    op_output *out;
    uint64_t pos; /* end of the sections: where the next one, or the table, goes */
    uint64_t at;  /* the stream's position */
    unsigned char *table;
    uint64_t *filled; /* per section: bytes written so far (reserved sections fill in pieces) */
    uint32_t count, capacity;
};

/* Writes n bytes at offset off of the file, seeking first when the stream is elsewhere. */
static op_status put(op_material_writer *w, uint64_t off, const void *data, size_t n,
                     op_error *err)
{
    if (w->at != off) {
        FILE *f = op_output_stream(w->out);
        if (fflush(f) != 0 || fseeko(f, (off_t)off, SEEK_SET) != 0)
            return op_error_set(err, OP_ERR_IO, "cannot write material: %s", strerror(errno));
        w->at = off;
    }
    op_output_write(w->out, data, n);
    w->at += n;
    return OP_OK;
}

static op_status pad_to_alignment(op_material_writer *w, op_error *err)
{
    static const unsigned char zeros[OPM_ALIGN];
    uint64_t pad = (OPM_ALIGN - w->pos % OPM_ALIGN) % OPM_ALIGN;
    op_status st = put(w, w->pos, zeros, (size_t)pad, err);
    w->pos += pad;
    return st;
}

/* A new table entry for section tag of `bytes` bytes at the end of the sections. */
static op_status new_entry(op_material_writer *w, const char *tag, uint64_t bytes,
                           unsigned char **entry, op_error *err)
{
    if (!valid_tag(tag))
        return op_error_set(err, OP_ERR_INTERNAL, "invalid section tag '%s'", tag);
    for (uint32_t j = 0; j < w->count; j++)
        if (!strncmp((const char *)w->table + (size_t)j * OPM_ENTRY_SIZE, tag, 8))
            return op_error_set(err, OP_ERR_INTERNAL, "section '%s' added twice", tag);
    if (w->count == w->capacity) {
        uint32_t cap = w->capacity ? 2 * w->capacity : 16;
        if (cap > OPM_MAX_SECTIONS)
            return op_error_set(err, OP_ERR_INTERNAL, "too many sections");
        unsigned char *t = realloc(w->table, (size_t)cap * OPM_ENTRY_SIZE);
        if (t)
            w->table = t;
        uint64_t *f = t ? realloc(w->filled, (size_t)cap * sizeof *f) : NULL;
        if (!f)
            return op_error_set(err, OP_ERR_NOMEM, "out of memory");
        w->filled = f;
        w->capacity = cap;
    }
    op_status st = pad_to_alignment(w, err);
    if (st != OP_OK)
        return st;
    unsigned char *e = w->table + (size_t)w->count * OPM_ENTRY_SIZE;
    memset(e, 0, OPM_ENTRY_SIZE);
    memcpy(e, tag, strnlen(tag, 8));
    op_put_le64(e + 8, w->pos);
    op_put_le64(e + 16, bytes);
    w->filled[w->count++] = 0;
    w->pos += bytes;
    *entry = e;
    return OP_OK;
}

op_status op_material_writer_open(const char *path, const op_material_info *info,
                                  op_material_writer **out, op_error *err)
{
    *out = NULL;
    op_material_writer *w = calloc(1, sizeof *w);
    if (!w)
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    op_status st = op_output_open(path, &w->out, err);
    if (st != OP_OK) {
        free(w);
        return st;
    }
    unsigned char header[OPM_HEADER_SIZE] = {0}; /* rewritten by commit */
    op_output_write(w->out, header, sizeof header);
    w->pos = w->at = OPM_HEADER_SIZE;
    char meta[4096];
    size_t n = format_meta(info, meta, sizeof meta);
    *out = w;
    st = op_material_writer_add(w, "META", meta, n, err);
    if (st != OP_OK) {
        op_material_writer_abort(w);
        *out = NULL;
    }
    return st;
}

op_status op_material_writer_add(op_material_writer *w, const char *tag, const void *data,
                                 uint64_t bytes, op_error *err)
{
    unsigned char *e;
    op_status st = new_entry(w, tag, bytes, &e, err);
    if (st != OP_OK)
        return st;
    op_put_le32(e + 24, op_crc32(0, data, (size_t)bytes));
    w->filled[w->count - 1] = bytes;
    return put(w, op_get_le64(e + 8), data, (size_t)bytes, err);
}

op_status op_material_writer_reserve(op_material_writer *w, const char *tag, uint64_t bytes,
                                     op_error *err)
{
    unsigned char *e;
    return new_entry(w, tag, bytes, &e, err);
}

op_status op_material_writer_fill(op_material_writer *w, const char *tag, const void *data,
                                  size_t n, op_error *err)
{
    for (uint32_t j = 0; j < w->count; j++) {
        unsigned char *e = w->table + (size_t)j * OPM_ENTRY_SIZE;
        if (strncmp((const char *)e, tag, 8))
            continue;
        if (n > op_get_le64(e + 16) - w->filled[j])
            return op_error_set(err, OP_ERR_INTERNAL, "section '%s' overfilled", tag);
        op_put_le32(e + 24, op_crc32(op_get_le32(e + 24), data, n));
        op_status st = put(w, op_get_le64(e + 8) + w->filled[j], data, n, err);
        w->filled[j] += n;
        return st;
    }
    return op_error_set(err, OP_ERR_INTERNAL, "section '%s' was not reserved", tag);
}

op_status op_material_writer_set_info(op_material_writer *w, const op_material_info *info,
                                      op_error *err)
{
    char meta[4096];
    size_t n = format_meta(info, meta, sizeof meta);
    unsigned char *e = w->table; /* META is the first section */
    if (n != op_get_le64(e + 16))
        return op_error_set(err, OP_ERR_INTERNAL, "META changed its length (%zu to %zu bytes)",
                            (size_t)op_get_le64(e + 16), n);
    op_put_le32(e + 24, op_crc32(0, meta, n));
    return put(w, op_get_le64(e + 8), meta, n, err);
}

/* Writes the section table after the sections and the header that points to it: the file is
 * then complete. */
static op_status write_table_and_header(op_material_writer *w, op_error *err)
{
    for (uint32_t j = 0; j < w->count; j++) {
        const unsigned char *e = w->table + (size_t)j * OPM_ENTRY_SIZE;
        if (w->filled[j] != op_get_le64(e + 16))
            return op_error_set(err, OP_ERR_INTERNAL, "section '%.8s' has %llu of its %llu bytes",
                                (const char *)e, (unsigned long long)w->filled[j],
                                (unsigned long long)op_get_le64(e + 16));
    }
    uint64_t end = w->pos;
    op_status st = pad_to_alignment(w, err);
    uint64_t table = w->pos;
    w->pos = end; /* sections added after finish go where the table was */
    size_t table_bytes = (size_t)w->count * OPM_ENTRY_SIZE;
    if (st == OP_OK)
        st = put(w, table, w->table, table_bytes, err);
    uint64_t total = table + table_bytes;
    unsigned char header[OPM_HEADER_SIZE] = {0};
    memcpy(header, OPM_MAGIC, 8);
    op_put_le32(header + 8, OPM_VERSION);
    op_put_le32(header + 12, w->count);
    op_put_le64(header + 16, total);
    op_put_le64(header + 24, table);
    op_put_le32(header + 32, op_crc32(0, w->table, table_bytes));
    op_put_le32(header + 36, op_crc32(0, header, 36));
    return st != OP_OK ? st : put(w, 0, header, sizeof header, err);
}

op_status op_material_writer_finish(op_material_writer *w, const char **tmp_path, op_error *err)
{
    *tmp_path = NULL;
    op_status st = write_table_and_header(w, err);
    return st != OP_OK ? st : op_output_pending(w->out, tmp_path, err);
}

op_status op_material_writer_commit(op_material_writer *w, op_error *err)
{
    op_status st = write_table_and_header(w, err);
    if (st != OP_OK)
        op_output_abort(w->out);
    else
        st = op_output_commit(w->out, err);
    free(w->table);
    free(w->filled);
    free(w);
    return st;
}

void op_material_writer_abort(op_material_writer *w)
{
    if (!w)
        return;
    op_output_abort(w->out);
    free(w->table);
    free(w->filled);
    free(w);
}
