/* volume_grid.c - grid and constant volumes (see volume_grid.h). */
#include "medium/volume_grid.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define VOL_HEADER 48 /* bytes before the values */

struct op_volume {
    float *data; /* nx * ny * nz * channels values; NULL for a constant */
    int nx, ny, nz, channels;
    float *brick; /* nb[0] * nb[1] * nb[2] brick bounds (volume_grid.h), x fastest */
    int nb[3];
    op_v3 value; /* a constant's value */
    op_v3 lo, hi;
    double bbox_min[3], bbox_max[3];
    float m[3][4]; /* world -> unit cube, affine rows */
    op_volume_layout layout;
    op_volume_filter filter;
    op_volume_wrap wrap;
    int bounded;
};

static uint32_t le32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static float lef(const unsigned char *p)
{
    uint32_t u = le32(p);
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

static op_volume *volume_new(void)
{
    op_volume *v = calloc(1, sizeof *v);
    if (!v)
        return NULL;
    op_matrix4 id = op_matrix4_identity();
    op_volume_place(v, &id, OP_VOLUME_CELLS, 0);
    for (int i = 0; i < 3; i++)
        v->bbox_max[i] = 1.0;
    return v;
}

op_volume *op_volume_constant(op_v3 value)
{
    op_volume *v = volume_new();
    if (!v)
        return NULL;
    v->channels = 3;
    v->value = v->lo = v->hi = value;
    return v;
}

/* The values after the header, converted to float; fills lo and hi. */
static op_status read_values(op_volume *v, const unsigned char *p, int encoding, size_t n,
                             const char *name, op_error *err)
{
    v->data = malloc(n * sizeof *v->data);
    if (!v->data)
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory for %zu grid values", name, n);
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < n; i++) {
        float x = encoding == 1 ? lef(p + 4 * i) : (float)p[i] / 255.0f;
        if (!(fabsf(x) <= OP_VOLUME_MAX_VALUE)) {
            size_t cell = i / (size_t)v->channels;
            size_t row = (size_t)v->nx * (size_t)v->ny;
            return op_error_set(err, OP_ERR_INPUT,
                                "%s: the value of channel %zu at voxel "
                                "(%zu, %zu, %zu) is not finite or beyond %g",
                                name, i % (size_t)v->channels, cell % (size_t)v->nx,
                                cell % row / (size_t)v->nx, cell / row, OP_VOLUME_MAX_VALUE);
        }
        int c = (int)(i % (size_t)v->channels);
        lo[c] = fminf(lo[c], x);
        hi[c] = fmaxf(hi[c], x);
        v->data[i] = x;
    }
    if (v->channels == 1) {
        v->lo = v3s(lo[0]);
        v->hi = v3s(hi[0]);
    } else {
        v->lo = v3(lo[0], lo[1], lo[2]);
        v->hi = v3(hi[0], hi[1], hi[2]);
    }
    return OP_OK;
}

/* The largest value of any channel over voxels lo..hi (inclusive, in range) of v. */
static float block_max(const op_volume *v, const int lo[3], const int hi[3])
{
    float m = -INFINITY;
    for (int z = lo[2]; z <= hi[2]; z++)
        for (int y = lo[1]; y <= hi[1]; y++) {
            size_t row = ((size_t)z * (size_t)v->ny + (size_t)y) * (size_t)v->nx;
            const float *p = v->data + (row + (size_t)lo[0]) * (size_t)v->channels;
            const float *e = v->data + (row + (size_t)hi[0] + 1) * (size_t)v->channels;
            for (; p < e; p++)
                m = fmaxf(m, *p);
        }
    return m;
}

/* Fills v->brick from the values. */
static op_status build_bricks(op_volume *v, const char *name, op_error *err)
{
    int n[3] = {v->nx, v->ny, v->nz};
    size_t count = 1;
    for (int a = 0; a < 3; a++) {
        v->nb[a] = (n[a] + OP_VOLUME_BRICK - 1) / OP_VOLUME_BRICK;
        count *= (size_t)v->nb[a];
    }
    v->brick = malloc(count * sizeof *v->brick);
    if (!v->brick)
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory for %zu grid bricks", name,
                            count);
    float *out = v->brick;
    int b[3], lo[3], hi[3];
    for (b[2] = 0; b[2] < v->nb[2]; b[2]++)
        for (b[1] = 0; b[1] < v->nb[1]; b[1]++)
            for (b[0] = 0; b[0] < v->nb[0]; b[0]++) {
                for (int a = 0; a < 3; a++) {
                    lo[a] = b[a] * OP_VOLUME_BRICK - 2;
                    hi[a] = (b[a] + 1) * OP_VOLUME_BRICK + 1;
                    lo[a] = lo[a] < 0 ? 0 : lo[a];
                    hi[a] = hi[a] >= n[a] ? n[a] - 1 : hi[a];
                }
                *out++ = block_max(v, lo, hi);
            }
    return OP_OK;
}

static op_status parse(op_volume *v, const unsigned char *p, size_t size, const char *name,
                       op_error *err)
{
    if (size < 4 || memcmp(p, "VOL", 3) != 0)
        return op_error_set(err, OP_ERR_INPUT,
                            "%s: not a Mitsuba volume file (it does not "
                            "start with \"VOL\")",
                            name);
    if (p[3] != 3)
        return op_error_set(err, OP_ERR_INPUT,
                            "%s: volume file version %d (opaline reads "
                            "version 3)",
                            name, p[3]);
    if (size < VOL_HEADER)
        return op_error_set(err, OP_ERR_INPUT, "%s: truncated volume header (%zu of %d bytes)",
                            name, size, VOL_HEADER);
    int32_t encoding = (int32_t)le32(p + 4), res[3], channels = (int32_t)le32(p + 20);
    if (encoding != 1 && encoding != 3)
        return op_error_set(err, OP_ERR_INPUT,
                            "%s: volume encoding %d is not supported (1: "
                            "float32 and 3: uint8 are, as in Mitsuba)",
                            name, (int)encoding);
    for (int i = 0; i < 3; i++) {
        res[i] = (int32_t)le32(p + 8 + 4 * i);
        if (res[i] <= 0)
            return op_error_set(err, OP_ERR_INPUT,
                                "%s: volume resolution %d x %d x %d must be "
                                "positive",
                                name, (int)(int32_t)le32(p + 8), (int)(int32_t)le32(p + 12),
                                (int)(int32_t)le32(p + 16));
    }
    if (channels != 1 && channels != 3)
        return op_error_set(err, OP_ERR_INPUT,
                            "%s: %d channels (opaline reads volumes of 1 or "
                            "3)",
                            name, (int)channels);
    for (int i = 0; i < 3; i++) {
        v->bbox_min[i] = lef(p + 24 + 4 * i);
        v->bbox_max[i] = lef(p + 36 + 4 * i);
    }
    size_t bytes = encoding == 1 ? 4 : 1, avail = (size - VOL_HEADER) / bytes, n = 1;
    for (int i = 0; i < 3; i++) {
        if ((size_t)res[i] > avail / n)
            return op_error_set(err, OP_ERR_INPUT,
                                "%s: truncated: a %d x %d x %d volume of %d "
                                "channels needs more than the file's %zu bytes of values",
                                name, (int)res[0], (int)res[1], (int)res[2], (int)channels,
                                size - VOL_HEADER);
        n *= (size_t)res[i];
    }
    if (n > avail / (size_t)channels)
        return op_error_set(err, OP_ERR_INPUT,
                            "%s: truncated: a %d x %d x %d volume of %d "
                            "channels needs %zu bytes of values, the file has %zu",
                            name, (int)res[0], (int)res[1], (int)res[2], (int)channels,
                            n * (size_t)channels * bytes, size - VOL_HEADER);
    v->nx = res[0];
    v->ny = res[1];
    v->nz = res[2];
    v->channels = channels;
    op_status st = read_values(v, p + VOL_HEADER, encoding, n * (size_t)channels, name, err);
    return st == OP_OK ? build_bricks(v, name, err) : st;
}

op_status op_volume_parse(const void *data, size_t size, const char *name, op_volume **out,
                          op_error *err)
{
    *out = NULL;
    op_volume *v = volume_new();
    if (!v)
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", name);
    op_status st = parse(v, data, size, name, err);
    if (st != OP_OK) {
        op_volume_free(v);
        return st;
    }
    *out = v;
    return OP_OK;
}

op_status op_volume_read(const char *path, op_volume **out, op_error *err)
{
    op_file_view f;
    *out = NULL;
    op_status st = op_file_map(path, &f, err);
    if (st != OP_OK)
        return st;
    st = op_volume_parse(f.data ? f.data : "", f.size, path, out, err);
    op_file_unmap(&f);
    return st;
}

void op_volume_free(op_volume *v)
{
    if (!v)
        return;
    free(v->data);
    free(v->brick);
    free(v);
}

int op_volume_channels(const op_volume *v)
{
    return v->channels;
}

void op_volume_file_bbox(const op_volume *v, double min[3], double max[3])
{
    memcpy(min, v->bbox_min, sizeof v->bbox_min);
    memcpy(max, v->bbox_max, sizeof v->bbox_max);
}

op_v3 op_volume_min(const op_volume *v)
{
    return v->lo;
}

op_v3 op_volume_max(const op_volume *v)
{
    return v->hi;
}

int op_volume_place(op_volume *v, const op_matrix4 *world_to_unit, op_volume_layout layout,
                    int bounded)
{
    if (!op_matrix4_is_finite(world_to_unit))
        return 0;
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 4; c++)
            v->m[r][c] = (float)world_to_unit->m[r][c];
    v->layout = layout;
    v->bounded = bounded;
    return 1;
}

void op_volume_set_lookup(op_volume *v, op_volume_filter filter, op_volume_wrap wrap)
{
    v->filter = filter;
    v->wrap = wrap;
    if (!v->brick || filter != OP_VOLUME_TRILINEAR || wrap != OP_VOLUME_REPEAT)
        return;
    /* Trilinear lookups at a face blend in the opposite face's cells: bricks at a face are
     * bounded by those too. */
    int n[3] = {v->nx, v->ny, v->nz};
    for (int a = 0; a < 3; a++)
        for (int side = 0; side < 2; side++) {
            int lo[3] = {0, 0, 0}, hi[3] = {n[0] - 1, n[1] - 1, n[2] - 1};
            lo[a] = hi[a] = side ? 0 : n[a] - 1; /* the face opposite to `side` */
            float face = block_max(v, lo, hi);
            int b[3];
            for (b[2] = 0; b[2] < v->nb[2]; b[2]++)
                for (b[1] = 0; b[1] < v->nb[1]; b[1]++)
                    for (b[0] = 0; b[0] < v->nb[0]; b[0]++) {
                        if (b[a] != (side ? v->nb[a] - 1 : 0))
                            continue;
                        float *bound = &v->brick[((size_t)b[2] * (size_t)v->nb[1] + (size_t)b[1]) *
                                                     (size_t)v->nb[0] + (size_t)b[0]];
                        *bound = fmaxf(*bound, face);
                    }
        }
}

static op_v3 to_unit(const op_volume *v, op_v3 p)
{
    float q[3];
    for (int r = 0; r < 3; r++)
        q[r] = v->m[r][0] * p.x + v->m[r][1] * p.y + v->m[r][2] * p.z + v->m[r][3];
    return v3(q[0], q[1], q[2]);
}

/* The part [*t0, *t1] of the ray org + t dir, t >= 0, inside v's unit cube (empty: *t0 > *t1). */
static void cube_span(const op_volume *v, op_v3 org, op_v3 dir, float *t0, float *t1)
{
    op_v3 o = to_unit(v, org);
    float d[3];
    for (int r = 0; r < 3; r++)
        d[r] = v->m[r][0] * dir.x + v->m[r][1] * dir.y + v->m[r][2] * dir.z;
    float lo = 0.0f, hi = INFINITY, oo[3] = {o.x, o.y, o.z};
    for (int a = 0; a < 3; a++) {
        if (d[a] == 0.0f) {
            if (oo[a] < 0.0f || oo[a] > 1.0f)
                lo = INFINITY;
            continue;
        }
        float ta = -oo[a] / d[a], tb = (1.0f - oo[a]) / d[a];
        lo = fmaxf(lo, fminf(ta, tb));
        hi = fminf(hi, fmaxf(ta, tb));
    }
    *t0 = lo;
    *t1 = hi;
}

int op_volume_ray_span(const op_volume *v, op_v3 org, op_v3 dir, float *t0, float *t1)
{
    if (!v->bounded)
        return 0;
    cube_span(v, org, dir, t0, t1);
    return 1;
}

/* Grid value of channel c at integer voxel (x, y, z), already in range. */
static float at(const op_volume *v, int x, int y, int z, int c)
{
    size_t i = ((size_t)z * (size_t)v->ny + (size_t)y) * (size_t)v->nx + (size_t)x;
    return v->data[i * (size_t)v->channels + (size_t)c];
}

static int clampi(int i, int n)
{
    return i < 0 ? 0 : (i >= n ? n - 1 : i);
}

/* Cell index i (any integer) of an axis of n cells under v's wrap mode. */
static int wrap_index(const op_volume *v, int i, int n)
{
    if (v->wrap == OP_VOLUME_CLAMP)
        return clampi(i, n);
    int m = v->wrap == OP_VOLUME_REPEAT ? n : 2 * n, r = i % m;
    r += r < 0 ? m : 0;
    return r < n ? r : m - 1 - r;
}

/* The cell coordinate of unit coordinate u on an axis of n cells, kept within a range whose
 * floor is a representable int (a NaN goes to its low end). */
static float cell_coordinate(float u, int n)
{
    const float far = 0x1p24f;
    return fminf(fmaxf(u * (float)n, -far), far);
}

op_v3 op_volume_eval(const op_volume *v, op_v3 p)
{
    op_v3 u = to_unit(v, p);
    int inside =
        u.x >= 0.0f && u.x <= 1.0f && u.y >= 0.0f && u.y <= 1.0f && u.z >= 0.0f && u.z <= 1.0f;
    if (v->bounded && !inside)
        return v3s(0.0f);
    if (!v->data)
        return v->value;
    int n[3] = {v->nx, v->ny, v->nz}, i0[3], i1[3];
    float f[3], uu[3] = {u.x, u.y, u.z};
    if (v->layout == OP_VOLUME_CELLS && v->filter == OP_VOLUME_NEAREST) {
        for (int a = 0; a < 3; a++)
            i0[a] = wrap_index(v, (int)floorf(cell_coordinate(uu[a], n[a])), n[a]);
        op_v3 r = v3s(at(v, i0[0], i0[1], i0[2], 0));
        if (v->channels == 3)
            r = v3(r.x, at(v, i0[0], i0[1], i0[2], 1), at(v, i0[0], i0[1], i0[2], 2));
        return r;
    }
    for (int a = 0; a < 3; a++) {
        if (v->layout == OP_VOLUME_VERTICES) {
            float g = uu[a] * (float)(n[a] - 1);
            if (!(g >= 0.0f) || g >= (float)(n[a] - 1))
                return v3s(0.0f);
            i0[a] = (int)g;
            i1[a] = i0[a] + 1;
            f[a] = g - (float)i0[a];
        } else {
            float g = cell_coordinate(uu[a], n[a]) - 0.5f;
            if (v->wrap == OP_VOLUME_CLAMP)
                g = fminf(fmaxf(g, -1.0f), (float)n[a]);
            float fl = floorf(g);
            f[a] = g - fl;
            i0[a] = wrap_index(v, (int)fl, n[a]);
            i1[a] = wrap_index(v, (int)fl + 1, n[a]);
        }
    }
    float out[3];
    for (int c = 0; c < v->channels; c++) {
        float c00 =
            at(v, i0[0], i0[1], i0[2], c) * (1 - f[0]) + at(v, i1[0], i0[1], i0[2], c) * f[0];
        float c10 =
            at(v, i0[0], i1[1], i0[2], c) * (1 - f[0]) + at(v, i1[0], i1[1], i0[2], c) * f[0];
        float c01 =
            at(v, i0[0], i0[1], i1[2], c) * (1 - f[0]) + at(v, i1[0], i0[1], i1[2], c) * f[0];
        float c11 =
            at(v, i0[0], i1[1], i1[2], c) * (1 - f[0]) + at(v, i1[0], i1[1], i1[2], c) * f[0];
        out[c] =
            (c00 * (1 - f[1]) + c10 * f[1]) * (1 - f[2]) + (c01 * (1 - f[1]) + c11 * f[1]) * f[2];
    }
    return v->channels == 1 ? v3s(out[0]) : v3(out[0], out[1], out[2]);
}

void op_volume_walk_start(op_volume_walk *w, const op_volume *v, op_v3 org, op_v3 dir, float t0,
                          float t1)
{
    w->v = v;
    w->t = t0;
    w->span_end = t1;
    w->stage = 2;
    w->grid_start = w->grid_end = t0;
    if (!v->brick)
        return;
    float c0, c1;
    cube_span(v, org, dir, &c0, &c1);
    c0 = fmaxf(c0, t0);
    c1 = fminf(c1, t1);
    if (!(c0 < c1))
        return;
    w->stage = 0;
    w->grid_start = c0;
    w->grid_end = c1;
    op_v3 o = to_unit(v, org);
    float oo[3] = {o.x, o.y, o.z};
    int n[3] = {v->nx, v->ny, v->nz};
    for (int a = 0; a < 3; a++) {
        float d = v->m[a][0] * dir.x + v->m[a][1] * dir.y + v->m[a][2] * dir.z;
        float s = (float)(v->layout == OP_VOLUME_VERTICES ? n[a] - 1 : n[a]) / OP_VOLUME_BRICK;
        w->so[a] = oo[a] * s;
        w->sd[a] = d * s;
        w->step[a] = w->sd[a] > 0.0f ? 1 : (w->sd[a] < 0.0f ? -1 : 0);
        float g = floorf(w->so[a] + c0 * w->sd[a]);
        g = fminf(fmaxf(g, 0.0f), (float)(v->nb[a] - 1)); /* (fmaxf drops a NaN) */
        w->idx[a] = (int)g;
    }
}

/* Where the ray leaves the current brick. */
static float brick_exit(const op_volume_walk *w, int *axis)
{
    float best = INFINITY;
    *axis = 0;
    for (int a = 0; a < 3; a++) {
        if (!w->step[a])
            continue;
        float face = (float)(w->idx[a] + (w->step[a] > 0));
        float t = (face - w->so[a]) / w->sd[a];
        if (t < best) {
            best = t;
            *axis = a;
        }
    }
    return best;
}

int op_volume_walk_next(op_volume_walk *w, float *a, float *b, float *bound)
{
    const op_volume *v = w->v;
    float whole = fmaxf(v3_max(v->hi), 0.0f);
    while (w->stage < 3) {
        if (w->stage == 0) { /* before the cube */
            w->stage = 1;
            if (w->t < w->grid_start) {
                *a = w->t;
                *b = w->t = w->grid_start;
                *bound = whole;
                return 1;
            }
            continue;
        }
        if (w->stage == 1) { /* one brick */
            int axis;
            float exit = brick_exit(w, &axis), start = w->t;
            float stop = fminf(fmaxf(exit, start), w->grid_end);
            size_t i =
                ((size_t)w->idx[2] * (size_t)v->nb[1] + (size_t)w->idx[1]) * (size_t)v->nb[0] +
                (size_t)w->idx[0];
            float here = v->brick[i];
            w->idx[axis] += w->step[axis];
            if (!(stop < w->grid_end) || w->idx[axis] < 0 || w->idx[axis] >= v->nb[axis]) {
                stop = w->grid_end;
                w->stage = 2;
            }
            w->t = stop;
            if (start < stop) {
                *a = start;
                *b = stop;
                *bound = here;
                return 1;
            }
            continue;
        }
        w->stage = 3; /* after the cube */
        if (w->t < w->span_end) {
            *a = w->t;
            *b = w->span_end;
            *bound = whole;
            return 1;
        }
    }
    return 0;
}
