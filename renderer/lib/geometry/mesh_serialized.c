/* mesh_serialized.c - Mitsuba's serialized meshes (format versions 3 and 4) over the mapped
 * file. A file is a sequence of meshes, each a 4-byte header (0x041C, version) and a zlib
 * stream (flags, the name in version 4, 64-bit vertex and triangle counts, the arrays), then
 * a dictionary of the meshes' offsets and their count. The stream is inflated straight into
 * the mesh's arrays; every count and offset is checked against the file before it is used,
 * the counts also against what the compressed bytes can expand to (deflate's ratio), so a
 * hostile file cannot make it allocate or read out of bounds. */
#include "geometry/mesh_internal.h"

#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#define SER_MAGIC 0x041C
#define SER_MAGIC_SWAPPED 0x1C04 /* files of Mitsuba before 0.3 */
#define FLAG_NORMALS 0x0001u
#define FLAG_UVS 0x0002u
#define FLAG_COLORS 0x0008u
#define FLAG_SINGLE 0x1000u
#define FLAG_DOUBLE 0x2000u
/* The most bytes deflate can expand one compressed byte to (258-byte matches in 2 bits). */
#define DEFLATE_MAX_RATIO 1032u
/* The bytes inflated per call: avail_out is an unsigned int. */
#define INFLATE_CHUNK (1u << 30)

typedef struct ser_reader {
    const char *path;
    uint32_t index; /* the shape index asked for, named in every message */
    op_error *err;
    const unsigned char *data;
    size_t size;
    int version;
    z_stream z;
    int z_open;
    size_t in_pos, in_end; /* the compressed bytes not yet given to zlib */
} ser_reader;

typedef struct ser_header {
    uint32_t flags;
    uint64_t nverts, ntris;
} ser_header;

/* Returns the status of call when it fails. */
#define TRY(call)                                                                                  \
    do {                                                                                           \
        op_status try_st_ = (call);                                                                \
        if (try_st_ != OP_OK)                                                                      \
            return try_st_;                                                                        \
    } while (0)

static op_status fail(ser_reader *r, op_status st, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

static op_status fail(ser_reader *r, op_status st, const char *fmt, ...)
{
    char msg[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return op_error_set(r->err, st, "%s: shape index %u: %s", r->path, r->index, msg);
}

static uint64_t get_le(const unsigned char *p, int n)
{
    uint64_t v = 0;
    for (int i = n - 1; i >= 0; i--)
        v = v << 8 | p[i];
    return v;
}

static int host_is_le(void)
{
    const uint16_t one = 1;
    unsigned char b;
    memcpy(&b, &one, 1);
    return b == 1;
}

/* Little-endian words of size bytes in place to the host's order. */
static void words_to_host(void *p, size_t n, int size)
{
    if (host_is_le())
        return;
    unsigned char *b = p;
    for (size_t i = 0; i < n; i++, b += size)
        for (int k = 0; k < size / 2; k++) {
            unsigned char t = b[k];
            b[k] = b[size - 1 - k];
            b[size - 1 - k] = t;
        }
}

/* Checks the mesh header (format and version) at byte at. */
static op_status check_header(ser_reader *r, size_t at, const char *where)
{
    unsigned magic = (unsigned)get_le(r->data + at, 2);
    unsigned version = (unsigned)get_le(r->data + at + 2, 2);
    if (magic == SER_MAGIC_SWAPPED)
        return fail(r, OP_ERR_FORMAT, "%s was written by Mitsuba before 0.3 (header 0x1C04); "
                    "export it again with a current Mitsuba", where);
    if (magic != SER_MAGIC)
        return fail(r, OP_ERR_FORMAT, "%s has no serialized mesh header (0x%04X, not 0x041C)",
                    where, magic);
    if (version != 3 && version != 4)
        return fail(r, OP_ERR_FORMAT, "%s is format version %u (versions 3 and 4 are read)",
                    where, version);
    if (r->version && (int)version != r->version)
        return fail(r, OP_ERR_FORMAT, "%s is format version %u, the file's first mesh %d",
                    where, version, r->version);
    r->version = (int)version;
    return OP_OK;
}

/* The byte offset of the mesh r->index: 0 for the first (as Mitsuba, which needs no
 * dictionary for it), else the dictionary's entry, checked to lie within the meshes and to
 * start with a header. */
static op_status locate(ser_reader *r, size_t *offset)
{
    if (r->size < 4)
        return fail(r, OP_ERR_FORMAT, "the file is %zu bytes, too short for a serialized mesh",
                    r->size);
    TRY(check_header(r, 0, "the file"));
    *offset = 0;
    if (r->index == 0)
        return OP_OK;
    size_t entry = r->version == 4 ? 8 : 4;
    uint64_t count = r->size >= 8 ? get_le(r->data + r->size - 4, 4) : 0;
    /* the dictionary and the first mesh's header fit in the file */
    if (count == 0 || count > (r->size - 8) / entry)
        return fail(r, OP_ERR_FORMAT, "the mesh dictionary at the end of the file is missing or "
                    "damaged (it counts %llu meshes in %zu bytes)", (unsigned long long)count,
                    r->size);
    if (r->index >= count)
        return fail(r, OP_ERR_INPUT, "out of range: the file holds %llu meshes (shape index 0 "
                    "to %llu)", (unsigned long long)count, (unsigned long long)(count - 1));
    size_t dict = r->size - 4 - (size_t)count * entry;
    uint64_t off = get_le(r->data + dict + (size_t)r->index * entry, (int)entry);
    if (off > dict - 4)
        return fail(r, OP_ERR_FORMAT, "the dictionary's offset %llu lies beyond the meshes "
                    "(which end at byte %zu)", (unsigned long long)off, dict);
    char where[64];
    snprintf(where, sizeof where, "the mesh at byte %llu", (unsigned long long)off);
    TRY(check_header(r, (size_t)off, where));
    *offset = (size_t)off;
    return OP_OK;
}

/* Inflates the next n bytes of the mesh's stream into dst; what names them in messages. */
static op_status zread(ser_reader *r, void *dst, size_t n, const char *what)
{
    unsigned char *out = dst;
    while (n > 0) {
        unsigned chunk = n < INFLATE_CHUNK ? (unsigned)n : INFLATE_CHUNK;
        r->z.next_out = out;
        r->z.avail_out = chunk;
        while (r->z.avail_out > 0) {
            if (r->z.avail_in == 0 && r->in_pos < r->in_end) {
                size_t left = r->in_end - r->in_pos;
                r->z.next_in = (unsigned char *)(uintptr_t)(r->data + r->in_pos);
                r->z.avail_in = left < INFLATE_CHUNK ? (unsigned)left : INFLATE_CHUNK;
                r->in_pos += r->z.avail_in;
            }
            int ret = inflate(&r->z, Z_NO_FLUSH);
            if (ret == Z_STREAM_END && r->z.avail_out > 0)
                return fail(r, OP_ERR_FORMAT, "the mesh's compressed data ends before its %s",
                            what);
            if (ret == Z_MEM_ERROR)
                return op_error_set(r->err, OP_ERR_NOMEM, "%s: out of memory", r->path);
            if (ret == Z_DATA_ERROR || ret == Z_NEED_DICT || ret == Z_STREAM_ERROR)
                return fail(r, OP_ERR_FORMAT, "the mesh's compressed data is corrupt (in its %s: "
                            "%s)", what, r->z.msg ? r->z.msg : "zlib refuses it");
            if (ret == Z_BUF_ERROR && r->z.avail_in == 0 && r->in_pos == r->in_end)
                return fail(r, OP_ERR_FORMAT, "the file ends early (in the mesh's %s)", what);
        }
        out += chunk;
        n -= chunk;
    }
    return OP_OK;
}

/* Reads the mesh's flags, name and counts, and refuses counts that no mesh or no file of
 * this size can hold. */
static op_status read_header(ser_reader *r, size_t offset, ser_header *h)
{
    if (inflateInit(&r->z) != Z_OK)
        return op_error_set(r->err, OP_ERR_NOMEM, "%s: out of memory", r->path);
    r->z_open = 1;
    r->in_pos = offset + 4;
    r->in_end = r->size;
    unsigned char b[8];
    TRY(zread(r, b, 4, "flags"));
    h->flags = (uint32_t)get_le(b, 4);
    if (r->version == 4) /* the name, NUL-terminated; not kept */
        do
            TRY(zread(r, b, 1, "name"));
        while (b[0] != 0);
    TRY(zread(r, b, 8, "vertex count"));
    h->nverts = get_le(b, 8);
    TRY(zread(r, b, 8, "triangle count"));
    h->ntris = get_le(b, 8);
    if ((h->flags & FLAG_SINGLE) && (h->flags & FLAG_DOUBLE))
        return fail(r, OP_ERR_FORMAT, "its flags 0x%X claim both single and double precision",
                    h->flags);
    /* (a mesh of more than 2^32 vertices stores 64-bit indices: refused here by its count) */
    if (h->nverts > OP_MESH_MAX_COUNT || h->ntris > OP_MESH_MAX_COUNT)
        return fail(r, OP_ERR_FORMAT, "%llu vertices and %llu triangles: a mesh holds at most "
                    "%u of each", (unsigned long long)h->nverts, (unsigned long long)h->ntris,
                    OP_MESH_MAX_COUNT);
    uint64_t fsize = (h->flags & FLAG_DOUBLE) ? 8 : 4;
    uint64_t per_vertex = 3 + ((h->flags & FLAG_NORMALS) ? 3 : 0) +
                          ((h->flags & FLAG_UVS) ? 2 : 0) + ((h->flags & FLAG_COLORS) ? 3 : 0);
    uint64_t need = h->nverts * per_vertex * fsize + h->ntris * 12;
    uint64_t left = (uint64_t)(r->in_end - r->in_pos) + r->z.avail_in;
    if (need > left * DEFLATE_MAX_RATIO)
        return fail(r, OP_ERR_FORMAT, "%llu vertices and %llu triangles (%llu bytes) cannot come "
                    "from the %llu compressed bytes left in the file",
                    (unsigned long long)h->nverts, (unsigned long long)h->ntris,
                    (unsigned long long)need, (unsigned long long)left);
    return OP_OK;
}

/* Reads n values of the stream's precision into dst as floats (dst NULL: skips them), each
 * finite and within float range; what names them, dim the values per vertex. */
static op_status read_floats(ser_reader *r, float *dst, size_t n, int dbl, int dim,
                             const char *what)
{
    if (!dbl && dst) {
        TRY(zread(r, dst, n * sizeof(float), what));
        words_to_host(dst, n, 4);
        for (size_t i = 0; i < n; i++)
            if (!isfinite(dst[i]))
                return fail(r, OP_ERR_FORMAT, "vertex %zu: a value of its %s is not finite",
                            i / (size_t)dim, what);
        return OP_OK;
    }
    double buf[1024];
    size_t size = dbl ? 8 : 4;
    for (size_t done = 0; done < n;) {
        size_t k = n - done < 1024 ? n - done : 1024;
        TRY(zread(r, buf, k * size, what));
        if (!dst) {
            done += k;
            continue;
        }
        words_to_host(buf, k, 8);
        for (size_t i = 0; i < k; i++, done++) {
            double v;
            memcpy(&v, &buf[i], sizeof v);
            if (!isfinite(v) || fabs(v) > FLT_MAX)
                return fail(r, OP_ERR_FORMAT, "vertex %zu: a value of its %s (%g) is not a "
                            "finite float", done / (size_t)dim, what, v);
            dst[done] = (float)v;
        }
    }
    return OP_OK;
}

static op_status read_arrays(ser_reader *r, const ser_header *h, op_mesh *m)
{
    size_t nv = (size_t)h->nverts, nt = (size_t)h->ntris;
    int dbl = (h->flags & FLAG_DOUBLE) != 0;
    m->positions = malloc(nv * 3 * sizeof(float) + 1);
    m->normals = (h->flags & FLAG_NORMALS) ? malloc(nv * 3 * sizeof(float) + 1) : NULL;
    m->uvs = (h->flags & FLAG_UVS) ? malloc(nv * 2 * sizeof(float) + 1) : NULL;
    m->indices = malloc(nt * 3 * sizeof(uint32_t) + 1);
    if (!m->positions || !m->indices || ((h->flags & FLAG_NORMALS) && !m->normals) ||
        ((h->flags & FLAG_UVS) && !m->uvs))
        return op_error_set(r->err, OP_ERR_NOMEM, "%s: out of memory", r->path);
    m->nverts = (uint32_t)nv;
    m->ntris = (uint32_t)nt;
    TRY(read_floats(r, m->positions, 3 * nv, dbl, 3, "position"));
    if (m->normals)
        TRY(read_floats(r, m->normals, 3 * nv, dbl, 3, "normal"));
    if (m->uvs)
        TRY(read_floats(r, m->uvs, 2 * nv, dbl, 2, "texture coordinates"));
    if (h->flags & FLAG_COLORS) /* vertex colours: not used */
        TRY(read_floats(r, NULL, 3 * nv, dbl, 3, "colour"));
    TRY(zread(r, m->indices, nt * 3 * sizeof(uint32_t), "triangle indices"));
    words_to_host(m->indices, 3 * nt, 4);
    for (size_t i = 0; i < 3 * nt; i++)
        if (m->indices[i] >= m->nverts)
            return fail(r, OP_ERR_FORMAT, "triangle %zu: vertex index %u is out of range (%u "
                        "vertices)", i / 3, m->indices[i], m->nverts);
    return OP_OK;
}

/* Maps path and reads the header of its mesh index; on success the caller calls close_reader. */
static op_status open_reader(const char *path, uint32_t index, op_error *err, op_file_view *f,
                             ser_reader *r, ser_header *h)
{
    memset(r, 0, sizeof *r);
    r->path = path;
    r->index = index;
    r->err = err;
    TRY(op_file_map(path, f, err));
    r->data = f->data ? f->data : (const unsigned char *)"";
    r->size = f->size;
    size_t offset;
    op_status st = locate(r, &offset);
    if (st == OP_OK)
        st = read_header(r, offset, h);
    if (st != OP_OK) {
        if (r->z_open)
            inflateEnd(&r->z);
        op_file_unmap(f);
    }
    return st;
}

static void close_reader(ser_reader *r, op_file_view *f)
{
    inflateEnd(&r->z);
    op_file_unmap(f);
}

op_status op_mesh_serialized_counts(const char *path, uint32_t shape_index, uint64_t *vertices,
                                    uint64_t *triangles, op_error *err)
{
    *vertices = *triangles = 0;
    op_file_view f;
    ser_reader r;
    ser_header h;
    TRY(open_reader(path, shape_index, err, &f, &r, &h));
    close_reader(&r, &f);
    *vertices = h.nverts;
    *triangles = h.ntris;
    return OP_OK;
}

op_status op_mesh_load_serialized(const char *path, uint32_t shape_index, op_mesh *out,
                                  op_error *err)
{
    memset(out, 0, sizeof *out);
    op_file_view f;
    ser_reader r;
    ser_header h;
    TRY(open_reader(path, shape_index, err, &f, &r, &h));
    op_status st = read_arrays(&r, &h, out);
    close_reader(&r, &f);
    if (st != OP_OK)
        op_mesh_free(out);
    return st;
}
