/* mesh_obj.c - Wavefront OBJ reader: one pass over the memory-mapped file with a hand-written
 * number parser (no per-line allocation), then the (v, vt, vn) corners are unified into
 * mesh vertices through per-position chains. */
#include "geometry/mesh_internal.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* A growable array of fixed-size items. */
typedef struct vec {
    void *p;
    size_t n, cap, item;
} vec;

static int vec_reserve(vec *v, size_t extra)
{
    if (v->n + extra <= v->cap)
        return 1;
    size_t nc = v->cap ? v->cap : 1024;
    while (nc < v->n + extra)
        nc *= 2;
    void *p = realloc(v->p, nc * v->item);
    if (!p)
        return 0;
    v->p = p;
    v->cap = nc;
    return 1;
}

typedef struct corner {
    int32_t v, vt, vn; /* 0-based; -1 when absent */
} corner;

typedef struct obj_state {
    const char *path;
    op_error *err;
    vec pos, tex, nor; /* floats: 3, 2, 3 per entry */
    vec tris;          /* corners, 3 per triangle */
    vec face;          /* the corners of the face being read */
    int64_t max_ref[3];  /* largest positive index used per stream, 0-based */
    long max_line[3];    /* where it was used */
} obj_state;

static const double pow10_table[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                       1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
                                       1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

static int is_space(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

/* Parses [+-]digits[.digits][(e|E)[+-]digits] (or .digits) at *pp before end; the number
 * must be followed by white space or end. Rejects nan, inf and values beyond float range. */
static int parse_float(const char **pp, const char *end, float *out)
{
    const char *p = *pp;
    int neg = 0, any = 0, exp10 = 0;
    uint64_t mant = 0;
    if (p < end && (*p == '+' || *p == '-'))
        neg = *p++ == '-';
    for (; p < end && *p >= '0' && *p <= '9'; p++, any = 1) {
        if (mant < 100000000000000000ull)
            mant = mant * 10 + (uint64_t)(*p - '0');
        else
            exp10++;
    }
    if (p < end && *p == '.') {
        for (p++; p < end && *p >= '0' && *p <= '9'; p++, any = 1)
            if (mant < 100000000000000000ull) {
                mant = mant * 10 + (uint64_t)(*p - '0');
                exp10--;
            }
    }
    if (!any)
        return 0;
    if (p < end && (*p == 'e' || *p == 'E')) {
        p++;
        int eneg = 0, e = 0, edig = 0;
        if (p < end && (*p == '+' || *p == '-'))
            eneg = *p++ == '-';
        for (; p < end && *p >= '0' && *p <= '9'; p++, edig = 1)
            if (e < 100000)
                e = e * 10 + (*p - '0');
        if (!edig)
            return 0;
        exp10 += eneg ? -e : e;
    }
    if (p < end && !is_space(*p) && *p != '\n')
        return 0;
    double v = (double)mant;
    if (mant != 0) {
        if (exp10 >= 0)
            v = exp10 <= 22 ? v * pow10_table[exp10] : v * pow(10.0, exp10);
        else
            v = exp10 >= -22 ? v / pow10_table[-exp10] : v * pow(10.0, exp10);
    }
    if (!(v <= FLT_MAX))
        return 0;
    *out = (float)(neg ? -v : v);
    *pp = p;
    return 1;
}

/* Parses [+-]digits into *out (|value| < 2^31). */
static int parse_int(const char **pp, const char *end, int64_t *out)
{
    const char *p = *pp;
    int neg = 0, any = 0;
    int64_t v = 0;
    if (p < end && (*p == '+' || *p == '-'))
        neg = *p++ == '-';
    for (; p < end && *p >= '0' && *p <= '9'; p++, any = 1) {
        v = v * 10 + (*p - '0');
        if (v > (int64_t)OP_MESH_MAX_COUNT)
            return 0;
    }
    if (!any)
        return 0;
    *out = neg ? -v : v;
    *pp = p;
    return 1;
}

static const char *skip_space(const char *p, const char *end)
{
    while (p < end && is_space(*p))
        p++;
    return p;
}

static op_status fail(obj_state *s, long line, const char *what)
{
    return op_error_set(s->err, OP_ERR_FORMAT, "%s:%ld: %s", s->path, line, what);
}

static op_status nomem(obj_state *s)
{
    return op_error_set(s->err, OP_ERR_NOMEM, "%s: out of memory", s->path);
}

/* Reads n floats (at least min, the rest default 0; extra ones are ignored) into vector v. */
static op_status read_floats(obj_state *s, const char *p, const char *end, vec *v, int n, int min,
                             long line)
{
    if (!vec_reserve(v, (size_t)n))
        return nomem(s);
    float *dst = (float *)v->p + v->n;
    for (int i = 0; i < n; i++) {
        p = skip_space(p, end);
        dst[i] = 0.0f;
        if (p == end || *p == '#') {
            if (i < min)
                return fail(s, line, "too few numbers");
            continue;
        }
        if (!parse_float(&p, end, &dst[i]))
            return fail(s, line, "bad number");
    }
    if (v->n / (size_t)n >= OP_MESH_MAX_COUNT)
        return fail(s, line, "too many vertices");
    v->n += (size_t)n;
    return OP_OK;
}

/* Turns a 1-based (or negative, relative) index into a 0-based one for a stream with count
 * entries read so far. */
static op_status resolve_index(obj_state *s, int stream, int64_t idx, size_t count, long line,
                               int32_t *out)
{
    static const char *names[3] = {"vertex", "texture coordinate", "normal"};
    char msg[160];
    if (idx == 0) {
        snprintf(msg, sizeof msg, "%s index 0 (OBJ indices start at 1)", names[stream]);
        return fail(s, line, msg);
    }
    if (idx < 0) {
        int64_t r = (int64_t)count + idx;
        if (r < 0) {
            snprintf(msg, sizeof msg, "relative %s index %lld reaches before the first one",
                     names[stream], (long long)idx);
            return fail(s, line, msg);
        }
        *out = (int32_t)r;
        return OP_OK;
    }
    /* Positive indices may refer forward; they are checked once the whole file is read. */
    *out = (int32_t)(idx - 1);
    if (idx - 1 > s->max_ref[stream]) {
        s->max_ref[stream] = idx - 1;
        s->max_line[stream] = line;
    }
    return OP_OK;
}

static op_status read_face(obj_state *s, const char *p, const char *end, long line)
{
    s->face.n = 0;
    for (;;) {
        p = skip_space(p, end);
        if (p == end || *p == '#')
            break;
        corner c = {-1, -1, -1};
        int64_t idx;
        op_status st;
        if (!parse_int(&p, end, &idx))
            return fail(s, line, "bad face corner (expected v, v/vt, v//vn or v/vt/vn)");
        if ((st = resolve_index(s, 0, idx, s->pos.n / 3, line, &c.v)) != OP_OK)
            return st;
        if (p < end && *p == '/') {
            p++;
            if (p < end && *p != '/') {
                if (!parse_int(&p, end, &idx))
                    return fail(s, line, "bad texture coordinate index");
                if ((st = resolve_index(s, 1, idx, s->tex.n / 2, line, &c.vt)) != OP_OK)
                    return st;
            }
            if (p < end && *p == '/') {
                p++;
                if (!parse_int(&p, end, &idx))
                    return fail(s, line, "bad normal index");
                if ((st = resolve_index(s, 2, idx, s->nor.n / 3, line, &c.vn)) != OP_OK)
                    return st;
            }
        }
        if (p < end && !is_space(*p) && *p != '#')
            return fail(s, line, "bad face corner (expected v, v/vt, v//vn or v/vt/vn)");
        if (!vec_reserve(&s->face, 1))
            return nomem(s);
        ((corner *)s->face.p)[s->face.n++] = c;
    }
    if (s->face.n < 3)
        return fail(s, line, "a face needs at least three corners");
    size_t ntri = s->face.n - 2;
    if (s->tris.n / 3 + ntri >= OP_MESH_MAX_COUNT)
        return fail(s, line, "too many triangles");
    if (!vec_reserve(&s->tris, 3 * ntri))
        return nomem(s);
    const corner *f = s->face.p;
    corner *t = (corner *)s->tris.p + s->tris.n;
    for (size_t i = 0; i < ntri; i++) { /* fan around the first corner */
        t[3 * i] = f[0];
        t[3 * i + 1] = f[i + 1];
        t[3 * i + 2] = f[i + 2];
    }
    s->tris.n += 3 * ntri;
    return OP_OK;
}

static op_status parse_lines(obj_state *s, const char *data, size_t size)
{
    if (size == 0)
        return OP_OK;
    const char *p = data, *end = data + size;
    long line = 0;
    while (p < end) {
        line++;
        const char *eol = memchr(p, '\n', (size_t)(end - p));
        if (!eol)
            eol = end;
        const char *q = skip_space(p, eol);
        op_status st = OP_OK;
        if (eol - q >= 2 && q[0] == 'v' && is_space(q[1]))
            st = read_floats(s, q + 2, eol, &s->pos, 3, 3, line);
        else if (eol - q >= 3 && q[0] == 'v' && q[1] == 't' && is_space(q[2]))
            st = read_floats(s, q + 3, eol, &s->tex, 2, 1, line);
        else if (eol - q >= 3 && q[0] == 'v' && q[1] == 'n' && is_space(q[2]))
            st = read_floats(s, q + 3, eol, &s->nor, 3, 3, line);
        else if (eol - q >= 2 && q[0] == 'f' && is_space(q[1]))
            st = read_face(s, q + 2, eol, line);
        else if (q < eol && *q == '\0')
            st = fail(s, line, "not a text file (NUL byte)");
        /* Everything else (comments, o, g, s, usemtl, mtllib, l, p, ...) is ignored. */
        if (st != OP_OK)
            return st;
        p = eol + 1;
    }
    return OP_OK;
}

/* Unifies corners into mesh vertices and fills out. */
static op_status build(obj_state *s, op_mesh *out)
{
    static const char *names[3] = {"vertex", "texture coordinate", "normal"};
    size_t counts[3] = {s->pos.n / 3, s->tex.n / 2, s->nor.n / 3};
    for (int k = 0; k < 3; k++)
        if (s->max_ref[k] >= 0 && (size_t)s->max_ref[k] >= counts[k]) {
            char msg[200];
            snprintf(msg, sizeof msg, "%s index %lld is out of range (the file has %zu)", names[k],
                     (long long)s->max_ref[k] + 1, counts[k]);
            return fail(s, s->max_line[k], msg);
        }
    size_t ncorners = s->tris.n;
    if (ncorners == 0)
        return op_error_set(s->err, OP_ERR_FORMAT, "%s: the file has no faces", s->path);
    const corner *cs = s->tris.p;
    int has_uv = 0, has_n = 1;
    for (size_t i = 0; i < ncorners; i++) {
        has_uv |= cs[i].vt >= 0;
        has_n &= cs[i].vn >= 0;
    }
    uint32_t *first = malloc(counts[0] * sizeof *first + 1);
    uint32_t *index = malloc(ncorners * sizeof *index);
    vec next = {NULL, 0, 0, sizeof(uint32_t)}, keys = {NULL, 0, 0, sizeof(corner)};
    if (!first || !index) {
        free(first);
        free(index);
        return nomem(s);
    }
    memset(first, 0xff, counts[0] * sizeof *first);
    op_status st = OP_OK;
    for (size_t i = 0; i < ncorners && st == OP_OK; i++) {
        corner key = {cs[i].v, has_uv ? cs[i].vt : -1, has_n ? cs[i].vn : -1};
        uint32_t o = first[key.v];
        const corner *kp = keys.p;
        while (o != UINT32_MAX && (kp[o].vt != key.vt || kp[o].vn != key.vn))
            o = ((uint32_t *)next.p)[o];
        if (o == UINT32_MAX) {
            if (!vec_reserve(&next, 1) || !vec_reserve(&keys, 1)) {
                st = nomem(s);
                break;
            }
            o = (uint32_t)keys.n;
            ((corner *)keys.p)[keys.n++] = key;
            ((uint32_t *)next.p)[next.n++] = first[key.v];
            first[key.v] = o;
        }
        index[i] = o;
    }
    free(first);
    free(next.p);
    if (st != OP_OK) {
        free(index);
        free(keys.p);
        return st;
    }
    size_t nv = keys.n;
    out->positions = malloc(nv * 3 * sizeof(float));
    out->uvs = has_uv ? malloc(nv * 2 * sizeof(float)) : NULL;
    out->normals = has_n ? malloc(nv * 3 * sizeof(float)) : NULL;
    if (!out->positions || (has_uv && !out->uvs) || (has_n && !out->normals)) {
        free(index);
        free(keys.p);
        op_mesh_free(out);
        return nomem(s);
    }
    const corner *kp = keys.p;
    const float *pos = s->pos.p, *tex = s->tex.p, *nor = s->nor.p;
    for (size_t o = 0; o < nv; o++) {
        memcpy(&out->positions[3 * o], &pos[3 * (size_t)kp[o].v], 3 * sizeof(float));
        if (has_uv) {
            if (kp[o].vt >= 0)
                memcpy(&out->uvs[2 * o], &tex[2 * (size_t)kp[o].vt], 2 * sizeof(float));
            else
                out->uvs[2 * o] = out->uvs[2 * o + 1] = 0.0f;
        }
        if (has_n)
            memcpy(&out->normals[3 * o], &nor[3 * (size_t)kp[o].vn], 3 * sizeof(float));
    }
    free(keys.p);
    out->indices = index;
    out->nverts = (uint32_t)nv;
    out->ntris = (uint32_t)(ncorners / 3);
    return OP_OK;
}

op_status op_mesh_load_obj(const char *path, op_mesh *out, op_error *err)
{
    memset(out, 0, sizeof *out);
    op_file_view f;
    op_status st = op_file_map(path, &f, err);
    if (st != OP_OK)
        return st;
    obj_state s;
    memset(&s, 0, sizeof s);
    s.path = path;
    s.err = err;
    s.pos.item = s.nor.item = s.tex.item = sizeof(float);
    s.tris.item = s.face.item = sizeof(corner);
    for (int k = 0; k < 3; k++)
        s.max_ref[k] = -1;
    st = parse_lines(&s, f.data, f.size);
    op_file_unmap(&f);
    if (st == OP_OK)
        st = build(&s, out);
    free(s.pos.p);
    free(s.tex.p);
    free(s.nor.p);
    free(s.tris.p);
    free(s.face.p);
    if (st != OP_OK)
        op_mesh_free(out);
    return st;
}
