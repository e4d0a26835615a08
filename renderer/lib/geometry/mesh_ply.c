/* mesh_ply.c - Stanford PLY reader (ascii, binary little and big endian) over the
 * memory-mapped file. Every count is checked against the bytes that remain before anything
 * is allocated, so a hostile header cannot make it allocate or read out of bounds. */
#include "geometry/mesh_internal.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_ELEMENTS 64
#define MAX_PROPS 128
#define MAX_HEADER (1 << 20)

typedef enum ptype { T_I8, T_U8, T_I16, T_U16, T_I32, T_U32, T_F32, T_F64, T_BAD } ptype;

static const int type_size[] = {1, 1, 2, 2, 4, 4, 4, 8};

/* What a property feeds: a vertex coordinate, normal or uv component, or the face list. */
enum { R_NONE = -1, R_X = 0, R_NX = 3, R_U = 6, R_INDICES = 8 };

typedef struct prop {
    char name[64];
    int is_list;
    ptype type, count_type;
    int role;
} prop;

typedef struct element {
    char name[64];
    uint64_t count;
    prop props[MAX_PROPS];
    int nprops;
} element;

typedef enum pformat { F_ASCII, F_LE, F_BE } pformat;

typedef struct ply_state {
    const char *path;
    op_error *err;
    const char *p, *end; /* the data being read */
    long line;           /* ascii: the current line */
    pformat format;
    int swap;            /* binary data in the other byte order than the host's */
    const char *elem_name;
    uint64_t elem_index; /* binary: the instance being read, for messages */
} ply_state;

static ptype parse_type(const char *s)
{
    static const struct {
        const char *name;
        ptype t;
    } names[] = {{"char", T_I8},     {"int8", T_I8},     {"uchar", T_U8},   {"uint8", T_U8},
                 {"short", T_I16},   {"int16", T_I16},   {"ushort", T_U16}, {"uint16", T_U16},
                 {"int", T_I32},     {"int32", T_I32},   {"uint", T_U32},   {"uint32", T_U32},
                 {"float", T_F32},   {"float32", T_F32}, {"double", T_F64}, {"float64", T_F64}};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (strcmp(s, names[i].name) == 0)
            return names[i].t;
    return T_BAD;
}

static op_status fail(ply_state *s, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* An error at the current line (ascii) or element instance (binary). */
static op_status fail(ply_state *s, const char *fmt, ...)
{
    char msg[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (s->format == F_ASCII || !s->elem_name)
        return op_error_set(s->err, OP_ERR_FORMAT, "%s:%ld: %s", s->path, s->line, msg);
    return op_error_set(s->err, OP_ERR_FORMAT, "%s: %s %llu: %s", s->path, s->elem_name,
                        (unsigned long long)s->elem_index, msg);
}

/* ---------------------------------------------------------------- header */

/* The next header line's words (at most max, each < 64 chars); 0 when the header ends early. */
static int header_line(ply_state *s, char words[][64], int max, int *nwords)
{
    if (s->p >= s->end)
        return 0;
    const char *eol = memchr(s->p, '\n', (size_t)(s->end - s->p));
    if (!eol)
        return 0;
    s->line++;
    int n = 0;
    const char *q = s->p;
    while (q < eol) {
        while (q < eol && (*q == ' ' || *q == '\t' || *q == '\r'))
            q++;
        if (q == eol)
            break;
        const char *w = q;
        while (q < eol && !(*q == ' ' || *q == '\t' || *q == '\r'))
            q++;
        if (n < max) {
            size_t len = (size_t)(q - w) < 63 ? (size_t)(q - w) : 63;
            memcpy(words[n], w, len);
            words[n][len] = '\0';
        }
        n++;
    }
    *nwords = n;
    s->p = eol + 1;
    return 1;
}

static int prop_role(const char *elem, const char *name, int is_list)
{
    static const char *names[8][4] = {{"x"}, {"y"}, {"z"}, {"nx"}, {"ny"}, {"nz"},
                                      {"u", "s", "texture_u", "texture_s"},
                                      {"v", "t", "texture_v", "texture_t"}};
    if (strcmp(elem, "vertex") == 0 && !is_list) {
        for (int r = 0; r < 8; r++)
            for (int k = 0; k < 4 && names[r][k]; k++)
                if (strcmp(name, names[r][k]) == 0)
                    return r;
    }
    if (strcmp(elem, "face") == 0 && is_list &&
        (strcmp(name, "vertex_indices") == 0 || strcmp(name, "vertex_index") == 0))
        return R_INDICES;
    return R_NONE;
}

static op_status read_header(ply_state *s, element *elems, int *nelems)
{
    char w[8][64];
    int n;
    *nelems = 0;
    if (s->end - s->p < 4 || memcmp(s->p, "ply", 3) != 0 || (s->p[3] != '\n' && s->p[3] != '\r'))
        return op_error_set(s->err, OP_ERR_FORMAT, "%s: not a PLY file (no 'ply' magic line)",
                            s->path);
    const char *start = s->p;
    header_line(s, w, 8, &n);
    int have_format = 0;
    for (;;) {
        if (s->p - start > MAX_HEADER || !header_line(s, w, 8, &n))
            return fail(s, "the header has no end_header line");
        if (n == 0 || strcmp(w[0], "comment") == 0 || strcmp(w[0], "obj_info") == 0)
            continue;
        if (strcmp(w[0], "end_header") == 0)
            break;
        if (strcmp(w[0], "format") == 0) {
            if (n != 3)
                return fail(s, "bad format line");
            if (strcmp(w[1], "ascii") == 0)
                s->format = F_ASCII;
            else if (strcmp(w[1], "binary_little_endian") == 0)
                s->format = F_LE;
            else if (strcmp(w[1], "binary_big_endian") == 0)
                s->format = F_BE;
            else
                return fail(s, "unknown format '%s'", w[1]);
            if (strcmp(w[2], "1.0") != 0)
                return fail(s, "unsupported PLY version '%s'", w[2]);
            have_format = 1;
        } else if (strcmp(w[0], "element") == 0) {
            if (n != 3)
                return fail(s, "bad element line");
            if (*nelems == MAX_ELEMENTS)
                return fail(s, "more than %d elements", MAX_ELEMENTS);
            element *e = &elems[(*nelems)++];
            memset(e, 0, sizeof *e);
            snprintf(e->name, sizeof e->name, "%s", w[1]);
            char *endp;
            errno = 0;
            unsigned long long c = strtoull(w[2], &endp, 10);
            if (*endp || errno || w[2][0] == '-' || c > OP_MESH_MAX_COUNT)
                return fail(s, "bad element count '%s'", w[2]);
            e->count = c;
        } else if (strcmp(w[0], "property") == 0) {
            if (*nelems == 0)
                return fail(s, "property before any element");
            element *e = &elems[*nelems - 1];
            if (e->nprops == MAX_PROPS)
                return fail(s, "more than %d properties", MAX_PROPS);
            prop *pr = &e->props[e->nprops];
            memset(pr, 0, sizeof *pr);
            if (n == 3) {
                pr->type = parse_type(w[1]);
                snprintf(pr->name, sizeof pr->name, "%s", w[2]);
            } else if (n == 5 && strcmp(w[1], "list") == 0) {
                pr->is_list = 1;
                pr->count_type = parse_type(w[2]);
                pr->type = parse_type(w[3]);
                snprintf(pr->name, sizeof pr->name, "%s", w[4]);
                if (pr->count_type == T_BAD || pr->count_type == T_F32 || pr->count_type == T_F64)
                    return fail(s, "bad list count type '%s'", w[2]);
            } else {
                return fail(s, "bad property line");
            }
            if (pr->type == T_BAD)
                return fail(s, "unknown property type");
            pr->role = prop_role(e->name, pr->name, pr->is_list);
            if (pr->role == R_INDICES && (pr->type == T_F32 || pr->type == T_F64))
                return fail(s, "vertex indices must be integers");
            e->nprops++;
        } else {
            return fail(s, "unknown header line '%s'", w[0]);
        }
    }
    if (!have_format)
        return fail(s, "the header has no format line");
    int host_le = 1;
    {
        const uint16_t one = 1;
        unsigned char b;
        memcpy(&b, &one, 1);
        host_le = b == 1;
    }
    s->swap = (s->format == F_LE && !host_le) || (s->format == F_BE && host_le);
    s->line++; /* ascii data starts on the line after end_header */
    return OP_OK;
}

/* ---------------------------------------------------------------- values */

/* Reads one value of type t as a double. */
static op_status read_value(ply_state *s, ptype t, double *out)
{
    if (s->format == F_ASCII) {
        while (s->p < s->end && (*s->p == ' ' || *s->p == '\t' || *s->p == '\r' || *s->p == '\n')) {
            if (*s->p == '\n')
                s->line++;
            s->p++;
        }
        char tok[80];
        size_t k = 0;
        while (s->p < s->end && !(*s->p == ' ' || *s->p == '\t' || *s->p == '\r' || *s->p == '\n')) {
            if (k + 1 < sizeof tok)
                tok[k++] = *s->p;
            s->p++;
        }
        tok[k] = '\0';
        if (k == 0)
            return fail(s, "the file ends early (in %s data)", s->elem_name);
        char *e;
        errno = 0;
        double v = t >= T_F32 ? strtod(tok, &e) : (double)strtoll(tok, &e, 10);
        if (*e || errno == ERANGE || !isfinite(v))
            return fail(s, "bad number '%s'", tok);
        *out = v;
        return OP_OK;
    }
    int size = type_size[t];
    if (s->end - s->p < size)
        return fail(s, "the file ends early");
    unsigned char b[8];
    memcpy(b, s->p, (size_t)size);
    s->p += size;
    if (s->swap)
        for (int i = 0; i < size / 2; i++) {
            unsigned char tmp = b[i];
            b[i] = b[size - 1 - i];
            b[size - 1 - i] = tmp;
        }
    switch (t) {
    case T_I8: *out = (int8_t)b[0]; break;
    case T_U8: *out = b[0]; break;
    case T_I16: { int16_t v; memcpy(&v, b, 2); *out = v; break; }
    case T_U16: { uint16_t v; memcpy(&v, b, 2); *out = v; break; }
    case T_I32: { int32_t v; memcpy(&v, b, 4); *out = v; break; }
    case T_U32: { uint32_t v; memcpy(&v, b, 4); *out = v; break; }
    case T_F32: { float v; memcpy(&v, b, 4); *out = v; break; }
    case T_F64: { double v; memcpy(&v, b, 8); *out = v; break; }
    default: return fail(s, "bad type");
    }
    if (!isfinite(*out))
        return fail(s, "a value is not finite");
    return OP_OK;
}

/* The fewest bytes one instance of e can take: guards counts against the file size. */
static uint64_t min_record_bytes(const ply_state *s, const element *e)
{
    uint64_t n = 0;
    for (int i = 0; i < e->nprops; i++)
        n += s->format == F_ASCII ? 2 : (uint64_t)type_size[e->props[i].is_list ? e->props[i].count_type
                                                                               : e->props[i].type];
    return n ? n : 1;
}

/* Checks a list length: a whole number whose items can fit in the bytes left. */
static op_status check_list(ply_state *s, double cnt, ptype item)
{
    if (cnt < 0 || cnt != floor(cnt))
        return fail(s, "bad list length %g", cnt);
    double least = s->format == F_ASCII ? 2.0 : (double)type_size[item];
    if (cnt * least > (double)(s->end - s->p) + 1)
        return fail(s, "the file ends early (a list of %g items)", cnt);
    return OP_OK;
}

/* ---------------------------------------------------------------- elements */

typedef struct tri_vec {
    uint32_t *p;
    size_t n, cap; /* in indices */
} tri_vec;

static op_status read_vertices(ply_state *s, const element *e, op_mesh *m)
{
    int have[8] = {0};
    for (int i = 0; i < e->nprops; i++)
        if (e->props[i].role >= 0 && e->props[i].role < 8)
            have[e->props[i].role] = 1;
    if (!have[0] || !have[1] || !have[2])
        return fail(s, "the vertex element lacks x, y or z");
    int normals = have[3] && have[4] && have[5], uvs = have[6] && have[7];
    size_t nv = (size_t)e->count;
    m->positions = malloc(nv * 3 * sizeof(float) + 1);
    m->normals = normals ? malloc(nv * 3 * sizeof(float) + 1) : NULL;
    m->uvs = uvs ? malloc(nv * 2 * sizeof(float) + 1) : NULL;
    if (!m->positions || (normals && !m->normals) || (uvs && !m->uvs))
        return op_error_set(s->err, OP_ERR_NOMEM, "%s: out of memory", s->path);
    m->nverts = (uint32_t)nv;
    for (size_t v = 0; v < nv; v++) {
        s->elem_index = v;
        for (int i = 0; i < e->nprops; i++) {
            const prop *pr = &e->props[i];
            double val, cnt;
            op_status st;
            if (pr->is_list) { /* skipped */
                if ((st = read_value(s, pr->count_type, &cnt)) != OP_OK)
                    return st;
                if ((st = check_list(s, cnt, pr->type)) != OP_OK)
                    return st;
                for (long k = 0; k < (long)cnt; k++)
                    if ((st = read_value(s, pr->type, &val)) != OP_OK)
                        return st;
                continue;
            }
            if ((st = read_value(s, pr->type, &val)) != OP_OK)
                return st;
            if (val > 3.4e38 || val < -3.4e38)
                return fail(s, "value %g is beyond float range", val);
            int r = pr->role;
            if (r >= R_X && r < R_NX)
                m->positions[3 * v + (size_t)r] = (float)val;
            else if (r >= R_NX && r < R_U && normals)
                m->normals[3 * v + (size_t)(r - R_NX)] = (float)val;
            else if (r >= R_U && r < R_INDICES && uvs)
                m->uvs[2 * v + (size_t)(r - R_U)] = (float)val;
        }
    }
    return OP_OK;
}

static op_status read_faces(ply_state *s, const element *e, uint64_t nverts, int have_vertices,
                            tri_vec *tris)
{
    int have_list = 0;
    for (int i = 0; i < e->nprops; i++)
        have_list |= e->props[i].role == R_INDICES;
    if (!have_list)
        return fail(s, "the face element has no vertex_indices list");
    if (!have_vertices)
        return fail(s, "the file has faces but no vertex element");
    uint32_t poly[3];
    for (uint64_t f = 0; f < e->count; f++) {
        s->elem_index = f;
        for (int i = 0; i < e->nprops; i++) {
            const prop *pr = &e->props[i];
            double val, cnt;
            op_status st;
            if (!pr->is_list) {
                if ((st = read_value(s, pr->type, &val)) != OP_OK)
                    return st;
                continue;
            }
            if ((st = read_value(s, pr->count_type, &cnt)) != OP_OK)
                return st;
            if ((st = check_list(s, cnt, pr->type)) != OP_OK)
                return st;
            long n = (long)cnt;
            if (pr->role == R_INDICES && n < 3)
                return fail(s, "a face needs at least three vertices, not %ld", n);
            for (long k = 0; k < n; k++) {
                if ((st = read_value(s, pr->type, &val)) != OP_OK)
                    return st;
                if (pr->role != R_INDICES)
                    continue;
                if (val < 0 || val >= (double)nverts || val != floor(val))
                    return fail(s, "vertex index %g is out of range (%llu vertices)", val,
                                (unsigned long long)nverts);
                uint32_t idx = (uint32_t)val;
                if (k < 2) {
                    poly[k] = idx;
                    continue;
                }
                poly[2] = idx;
                if (tris->n + 3 > tris->cap) { /* fan around the first vertex */
                    size_t nc = tris->cap ? tris->cap * 2 : 3 * 1024;
                    if (nc / 3 > OP_MESH_MAX_COUNT)
                        return fail(s, "too many triangles");
                    uint32_t *np = realloc(tris->p, nc * sizeof *np);
                    if (!np)
                        return op_error_set(s->err, OP_ERR_NOMEM, "%s: out of memory", s->path);
                    tris->p = np;
                    tris->cap = nc;
                }
                memcpy(&tris->p[tris->n], poly, sizeof poly);
                tris->n += 3;
                poly[1] = idx;
            }
        }
    }
    return OP_OK;
}

static op_status skip_element(ply_state *s, const element *e)
{
    for (uint64_t k = 0; k < e->count; k++) {
        s->elem_index = k;
        for (int i = 0; i < e->nprops; i++) {
            const prop *pr = &e->props[i];
            double val, cnt = 1;
            op_status st;
            if (pr->is_list) {
                if ((st = read_value(s, pr->count_type, &cnt)) != OP_OK)
                    return st;
                if ((st = check_list(s, cnt, pr->type)) != OP_OK)
                    return st;
            }
            for (long j = 0; j < (long)cnt; j++)
                if ((st = read_value(s, pr->type, &val)) != OP_OK)
                    return st;
        }
    }
    return OP_OK;
}

/* Maps path and reads its header into elems (allocated, *nelems of them) with s set to read
 * the data after it. On failure everything is released; else the caller frees elems and
 * unmaps f. */
static op_status ply_open(const char *path, op_error *err, op_file_view *f, ply_state *s,
                          element **elems, int *nelems)
{
    *nelems = 0;
    op_status st = op_file_map(path, f, err);
    if (st != OP_OK)
        return st;
    *elems = malloc(MAX_ELEMENTS * sizeof **elems);
    memset(s, 0, sizeof *s);
    s->path = path;
    s->err = err;
    s->p = f->data ? (const char *)f->data : "";
    s->end = s->p + f->size;
    st = *elems ? read_header(s, *elems, nelems)
                : op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    if (st != OP_OK) {
        free(*elems);
        op_file_unmap(f);
    }
    return st;
}

op_status op_mesh_ply_counts(const char *path, uint64_t *vertices, uint64_t *faces,
                             op_error *err)
{
    *vertices = *faces = 0;
    op_file_view f;
    ply_state s;
    element *elems;
    int nelems;
    op_status st = ply_open(path, err, &f, &s, &elems, &nelems);
    if (st != OP_OK)
        return st;
    for (int i = 0; i < nelems; i++) {
        if (strcmp(elems[i].name, "vertex") == 0)
            *vertices = elems[i].count;
        else if (strcmp(elems[i].name, "face") == 0)
            *faces = elems[i].count;
    }
    free(elems);
    op_file_unmap(&f);
    return OP_OK;
}

op_status op_mesh_load_ply(const char *path, op_mesh *out, op_error *err)
{
    memset(out, 0, sizeof *out);
    op_file_view f;
    ply_state s;
    element *elems;
    int nelems;
    op_status st = ply_open(path, err, &f, &s, &elems, &nelems);
    if (st != OP_OK)
        return st;
    tri_vec tris = {NULL, 0, 0};
    uint64_t nverts = 0;
    int vertex_elem = -1;
    for (int i = 0; i < nelems && st == OP_OK; i++)
        if (strcmp(elems[i].name, "vertex") == 0) {
            if (vertex_elem >= 0)
                st = fail(&s, "two vertex elements");
            vertex_elem = i;
            nverts = elems[i].count;
        }
    for (int i = 0; i < nelems && st == OP_OK; i++) {
        const element *e = &elems[i];
        s.elem_name = e->name;
        /* (+1: the last ascii value needs no separator after it) */
        if (e->count > ((uint64_t)(s.end - s.p) + 1) / min_record_bytes(&s, e)) {
            st = fail(&s, "%llu %s records cannot fit in the %zu bytes left",
                      (unsigned long long)e->count, e->name, (size_t)(s.end - s.p));
            break;
        }
        if (i == vertex_elem)
            st = read_vertices(&s, e, out);
        else if (strcmp(e->name, "face") == 0)
            st = read_faces(&s, e, nverts, vertex_elem >= 0, &tris);
        else
            st = skip_element(&s, e);
    }
    s.elem_name = NULL;
    if (st == OP_OK && vertex_elem < 0)
        st = op_error_set(err, OP_ERR_FORMAT, "%s: the file has no vertex element", path);
    if (st == OP_OK && tris.n == 0)
        st = op_error_set(err, OP_ERR_FORMAT, "%s: the file has no faces", path);
    free(elems);
    op_file_unmap(&f);
    if (st != OP_OK) {
        free(tris.p);
        op_mesh_free(out);
        return st;
    }
    out->indices = tris.p;
    out->ntris = (uint32_t)(tris.n / 3);
    return OP_OK;
}
