/* subsurface.c - irradiance points, exitance gathering and interpolation (see subsurface.h). */
#include "subsurface.h"

#include "sss_dipole.h"
#include "sss_measured.h"
#include "sss_tree.h"

#include <float.h>
#include <limits.h>
#include <stdlib.h>
#include <string.h>


typedef struct sss_point {
    op_v3 p, ng, n;   /* position, geometric and shading normal */
    op_v3 tu, tv;     /* unit tangents along the material's x (columns) and y (rows) */
    float fx, fy;     /* continuous material pixel coordinates, in [0, W) x [0, H) */
    op_v3 e;          /* irradiance */
    op_v3 m;          /* exitance */
    float a;          /* centred: the surface area it stands for */
    op_v3 gu, gv;     /* centred: tu and tv over the pixel size (a world offset d is dot(d,
                         gu), dot(d, gv) material pixels at the material's physical size) */
} sss_point;

/* A uniform grid hashed into buckets, stored compressed (bucket starts + point indices). */
typedef struct sss_grid {
    float cell;
    op_v3 origin;
    uint32_t mask;
    uint32_t *start; /* mask + 2 entries */
    uint32_t *items;
    int32_t *coord;  /* 3 per point: its cell */
} sss_grid;

/* A receiver as the centred scatter reads it, stored in the gather grid's bucket order so that
 * a cell's points are contiguous. */
typedef struct gather_pt {
    float x, y, z, nx, ny, nz;
    float a;        /* centred: its area over the pixel's */
    int32_t rj;     /* its index among the computed receivers, or -1 */
    int32_t c[3];   /* its gather cell */
} gather_pt;

typedef struct sss_shape {
    const op_sss_desc *desc;
    int width, height, kernel, channels;
    float px, py, a_pix, a_i, spacing;
    float radius; /* gather radius: the kernel footprint */
    float h;      /* the interp grid's cell: 2 point spacings */
    float hr;     /* the lookup's interpolation radius: h, or 2 sqrt(3) x the receiver
                     spacing where the receivers are thinned */
    unsigned char *rep; /* hier, NULL or per point: it may be a receiver (one per cell of the
                           receiver spacing and normal class); NULL: every point may */
    sss_grid look;      /* hier with rep: the grid of the rep points, of cell hr */
    sss_grid ballg;     /* hier: the grid of the points, of the profile's ball as cell */
    int n;
    sss_point *pts;
    int nfull;    /* the points of the whole layout (n unless windowed) */
    int *gid;     /* windowed (n points of a layout of nfull, those near the view): per
                     point its index in the whole layout (ascending for a measured layout, in
                     Morton order for the dipole's); NULL: the identity */
    sss_grid gather, interp;
    struct gather_pt *gpts; /* the scatter's: the points in the gather grid's bucket order */
    float *acc; /* scatter pass: one 3 * n accumulator per chunk of sources */
    int nchunks;
    int hier;     /* 1: exitance from the hierarchical sum (the dipole), 0: the scatter */
    int centred;  /* measured: points at material pixel (sub-)centres (sss_measured.h), pair
                     values at whole-pixel offsets, each point's own area */
    op_sss_tree tree;        /* hier: the tree over the points */
    op_sss_dipole_kernel dk; /* hier: the profile it sums */
    unsigned char *near_recv; /* hier: per point: a computed receiver lies within the
                                 profile's ball (its normalization is needed) */
    int reached;           /* some camera segment reaches the shape: points are laid */
    unsigned char *recv;   /* per point: the view needs its exitance (a receiver) */
    int32_t *rmap;         /* per point: its index among the receivers whose exitance is
                              computed (those the store lacks), or -1 */
    int *src;              /* the sources whose irradiance is computed (those the store
                              lacks), ascending */
    int nsrc, nrecv;       /* how many are computed */
    int reused_src, reused_recv; /* the sources and receivers of this view taken from the store */
    int unsaved;           /* a windowed shape too large for the store's entry: computed only */
    int levels;            /* a windowed dipole laid in levels around the view (lay_levels): its
                              exitance depends on the view's regions, so the store lends it
                              irradiance only */
} sss_shape;

struct op_sss_cache {
    sss_shape *shapes;
    int n;
    double seconds; /* the build's wall time */
};

/* Point i's index in the shape's whole layout (what the irradiance's random stream, the
 * scatter's chunks and the pre-pass cache go by). */
static int point_index(const sss_shape *ss, int i)
{
    return ss->gid ? ss->gid[i] : i;
}

static uint32_t cell_hash(int32_t x, int32_t y, int32_t z, uint32_t mask)
{
    return ((uint32_t)x * 73856093u ^ (uint32_t)y * 19349663u ^ (uint32_t)z * 83492791u) & mask;
}

static void cell_of(const sss_grid *g, op_v3 p, int32_t c[3])
{
    c[0] = (int32_t)floorf((p.x - g->origin.x) / g->cell);
    c[1] = (int32_t)floorf((p.y - g->origin.y) / g->cell);
    c[2] = (int32_t)floorf((p.z - g->origin.z) / g->cell);
}

/* The grid of the points i < n with only[i] set (every point when only is NULL). */
static op_status grid_build(sss_grid *g, const sss_point *pts, int n, const unsigned char *only,
                            op_v3 origin, float cell, op_error *err)
{
    memset(g, 0, sizeof *g);
    g->cell = cell;
    g->origin = origin;
    uint32_t buckets = 1, count = 0;
    for (int i = 0; i < n; i++)
        count += !only || only[i];
    while (buckets < 2u * count && buckets < (1u << 30))
        buckets <<= 1;
    g->mask = buckets - 1;
    g->start = calloc((size_t)buckets + 1, sizeof *g->start);
    g->items = malloc((size_t)(count ? count : 1) * sizeof *g->items);
    g->coord = malloc(3 * (size_t)n * sizeof *g->coord);
    uint32_t *fill = calloc((size_t)buckets, sizeof *fill);
    if (!g->start || !g->items || !g->coord || !fill) {
        free(fill);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for the subsurface grid");
    }
    for (int i = 0; i < n; i++) {
        cell_of(g, pts[i].p, g->coord + 3 * i);
        if (only && !only[i])
            continue;
        g->start[cell_hash(g->coord[3 * i], g->coord[3 * i + 1], g->coord[3 * i + 2], g->mask) + 1]++;
    }
    for (uint32_t b = 0; b < buckets; b++)
        g->start[b + 1] += g->start[b];
    for (int i = 0; i < n; i++) {
        if (only && !only[i])
            continue;
        uint32_t b = cell_hash(g->coord[3 * i], g->coord[3 * i + 1], g->coord[3 * i + 2], g->mask);
        g->items[g->start[b] + fill[b]++] = (uint32_t)i;
    }
    free(fill);
    return OP_OK;
}

static void grid_free(sss_grid *g)
{
    free(g->start);
    free(g->items);
    free(g->coord);
}

/* Runs the statements after i for every point i whose cell lies within radius r of p (a
 * superset of the points within r), in a fixed order; `continue` skips to the next point. */
#define GRID_FOR_EACH(g, p, r, i, ...)                                                            \
    do {                                                                                           \
        int32_t lo_[3], hi_[3];                                                                    \
        cell_of((g), v3_sub((p), v3s(r)), lo_);                                                    \
        cell_of((g), v3_add((p), v3s(r)), hi_);                                                    \
        for (int32_t cz_ = lo_[2]; cz_ <= hi_[2]; cz_++)                                           \
            for (int32_t cy_ = lo_[1]; cy_ <= hi_[1]; cy_++)                                       \
                for (int32_t cx_ = lo_[0]; cx_ <= hi_[0]; cx_++) {                                 \
                    uint32_t b_ = cell_hash(cx_, cy_, cz_, (g)->mask);                             \
                    for (uint32_t k_ = (g)->start[b_]; k_ < (g)->start[b_ + 1]; k_++) {            \
                        int i = (int)(g)->items[k_];                                               \
                        const int32_t *c_ = (g)->coord + 3 * i;                                    \
                        if (c_[0] != cx_ || c_[1] != cy_ || c_[2] != cz_)                          \
                            continue;                                                              \
                        __VA_ARGS__                                                                \
                    }                                                                              \
                }                                                                                  \
    } while (0)

/* The material frame of triangle t: tangents from its texture coordinates when it has usable
 * ones, else from the box projection (see docs/subsurface-rendering.md). */
static int triangle_uv_frame(const op_trimesh *m, int t, op_v3 n, op_v3 *tu, op_v3 *tv)
{
    if (!m->uv)
        return 0;
    const uint32_t *i = m->idx + 3 * (size_t)t;
    op_v3 a, b, c;
    op_trimesh_tri(m, t, &a, &b, &c);
    float du1 = m->uv[2 * i[1]] - m->uv[2 * i[0]], dv1 = m->uv[2 * i[1] + 1] - m->uv[2 * i[0] + 1];
    float du2 = m->uv[2 * i[2]] - m->uv[2 * i[0]], dv2 = m->uv[2 * i[2] + 1] - m->uv[2 * i[0] + 1];
    float det = du1 * dv2 - dv1 * du2;
    if (!(fabsf(det) > 1e-12f))
        return 0;
    op_v3 e1 = v3_sub(b, a), e2 = v3_sub(c, a);
    op_v3 dpdu = v3_scale(v3_sub(v3_scale(e1, dv2), v3_scale(e2, dv1)), 1.0f / det);
    op_v3 dpdv = v3_scale(v3_sub(v3_scale(e2, du1), v3_scale(e1, du2)), 1.0f / det);
    op_v3 u = v3_norm(v3_sub(dpdu, v3_scale(n, v3_dot(n, dpdu))));
    op_v3 v = v3_sub(dpdv, v3_scale(n, v3_dot(n, dpdv)));
    v = v3_norm(v3_sub(v, v3_scale(u, v3_dot(u, v))));
    if (v3_len(u) < 0.5f || v3_len(v) < 0.5f)
        return 0;
    *tu = u;
    *tv = v;
    return 1;
}

/* Box projection: the two world axes other than n's dominant one. */
static void box_axes(op_v3 n, int *ua, int *va)
{
    float ax = fabsf(n.x), ay = fabsf(n.y), az = fabsf(n.z);
    if (ax >= ay && ax >= az) {
        *ua = 1;
        *va = 2;
    } else if (ay >= az) {
        *ua = 0;
        *va = 2;
    } else {
        *ua = 0;
        *va = 1;
    }
}

static float wrap(float x, int n)
{
    float f = x - floorf(x / (float)n) * (float)n;
    return f >= (float)n || f < 0.0f ? 0.0f : f;
}

/* The material pixel coordinates of triangle t's vertices, for a material of W x H pixels tiled
 * every sx x sy scene units: from its texture coordinates when it has a usable uv frame (*ua =
 * -1), else the box projection along its geometric normal's dominant axis (*ua, *va). */
static void triangle_pixels(const op_trimesh *m, int t, int W, int H, double sx, double sy,
                            double xy[3][2], int *ua, int *va)
{
    op_v3 a, b, c, tu, tv;
    op_trimesh_tri(m, t, &a, &b, &c);
    op_v3 ng = v3_norm(v3_cross(v3_sub(b, a), v3_sub(c, a)));
    const uint32_t *ix = m->idx + 3 * (size_t)t;
    if (triangle_uv_frame(m, t, ng, &tu, &tv)) {
        for (int k = 0; k < 3; k++) {
            xy[k][0] = (double)m->uv[2 * ix[k]] * W;
            xy[k][1] = (double)m->uv[2 * ix[k] + 1] * H;
        }
        *ua = *va = -1;
        return;
    }
    box_axes(ng, ua, va);
    op_v3 p[3] = {a, b, c};
    for (int k = 0; k < 3; k++) {
        xy[k][0] = (double)v3_get(p[k], *ua) / sx * W;
        xy[k][1] = (double)v3_get(p[k], *va) / sy * H;
    }
}

/* The area of triangle t in scene units, and of the triangle xy (its material pixel
 * coordinates) in pixels. */
static double world_area(const op_trimesh *m, int t)
{
    op_v3 a, b, c;
    op_trimesh_tri(m, t, &a, &b, &c);
    return 0.5 * v3_len(v3_cross(v3_sub(b, a), v3_sub(c, a)));
}

static double mapped_area(double xy[3][2])
{
    return 0.5 * fabs((xy[1][0] - xy[0][0]) * (xy[2][1] - xy[0][1]) -
                      (xy[1][1] - xy[0][1]) * (xy[2][0] - xy[0][0]));
}

/* The sample step, in material pixels of the map, that lays `density` points per material
 * pixel area (a_pix, scene units) on mesh m when the map shows the material at its physical
 * size (the map's mean linear stretch, the square root of the mesh's area over its mapped
 * pixels' area, within 1 % of 1): op_sss_measured_step. Otherwise 0: whole-pixel offsets at
 * the physical size would alias against the map's pixels (a beat pattern), and the shape keeps
 * the area-uniform layout and the bilinear pairs. */
static double centred_step(const op_trimesh *m, int W, int H, double sx, double sy, double a_pix,
                           double density)
{
    double world = 0.0, mapped = 0.0;
    for (int t = 0; t < m->ntris; t++) {
        double xy[3][2];
        int ua, va;
        triangle_pixels(m, t, W, H, sx, sy, xy, &ua, &va);
        mapped += mapped_area(xy);
        world += world_area(m, t);
    }
    if (!(mapped > 0.0 && world > 0.0))
        return 0.0;
    double stretch = sqrt(world / (mapped * a_pix));
    return fabs(stretch - 1.0) < 0.01 ? op_sss_measured_step(density) : 0.0;
}

/* The points a measured material lays on mesh m (sss_measured.h): one per sample of the
 * material's pixel grid at the step. */
static long long centred_count(const op_trimesh *m, int W, int H, double sx, double sy,
                               double step)
{
    long long n = 0;
    for (int t = 0; t < m->ntris; t++) {
        double xy[3][2];
        int ua, va;
        triangle_pixels(m, t, W, H, sx, sy, xy, &ua, &va);
        n += op_sss_measured_count(xy, step);
    }
    return n;
}

/* The dipole's windowed layout in levels (docs/subsurface-rendering.md, *Large objects*):
 * level l is an area-uniform layout of level_points(n0, l) points, 2^l times the profile's
 * spacing apart; its points have indices level_first(n0, l) + k in the whole layout. */
enum { DIPOLE_LEVELS = 16, MAX_REGIONS = 24 };

static long long level_points(long long n0, int l)
{
    long long d = 1LL << (2 * l);
    return (n0 + d - 1) / d;
}

static long long level_first(long long n0, int l)
{
    long long f = 0;
    for (int i = 0; i < l; i++)
        f += level_points(n0, i);
    return f;
}

op_status op_sss_plan(op_scene *scene, long long max_total, op_error *err)
{
    op_v3 ext = v3_sub(scene->bmax, scene->bmin);
    double extent = fmax(ext.x, fmax(ext.y, ext.z)), total = 0.0;
    for (int i = 0; i < scene->nshapes; i++) {
        const op_shape_rec *sh = &scene->shapes[i];
        if (sh->sss < 0)
            continue;
        op_sss_desc *d = &scene->sss[sh->sss];
        double px, py, size_x = 0.0, size_y = 0.0;
        if (d->is_dipole) {
            px = py = op_sss_dipole_spacing(&d->dipole);
        } else {
            const op_material_info *info = op_material_get_info(d->material);
            size_x = info->size_x_cm;
            size_y = info->size_y_cm;
            px = (info->size_x_cm * 0.01 * d->scale) / info->width;
            py = (info->size_y_cm * 0.01 * d->scale) / info->height;
        }
        /* the pre-pass grids cells of at least 2 pixels (the kernel footprint, the
         * interpolation radius) over the scene, counted in int32: at most 2^30 across; a
         * pixel's area must be a normal float */
        if (!(px > 0.0 && py > 0.0 && px <= FLT_MAX && py <= FLT_MAX) ||
            !((float)px * (float)py >= FLT_MIN) || !((float)px * (float)py <= FLT_MAX) ||
            !(2.0 * fmax(px, py) * 0x1p30 >= extent))
            return op_error_set(err, OP_ERR_INPUT, "%s: <subsurface>: a material pixel of %g x %g "
                                "scene units (size %g x %g cm, scale %g) is out of range for a "
                                "scene %g units across in single precision: it must be > 0, finite, "
                                "and at least 2^-31 of the scene's extent",
                                sh->label, px, py, size_x, size_y, d->scale, extent);
        float a_pix = (float)px * (float)py; /* as make_points computes it */
        double want = (double)sh->mesh.area / a_pix * d->density;
        if (!isfinite(want))
            return op_error_set(err, OP_ERR_INPUT, "%s: <subsurface>: the shape's area over the "
                                "material pixel's area is not finite", sh->label);
        d->windowed = 0;
        if (!d->is_dipole) {
            /* a measured material: one point per material pixel (at its centre where the map
             * shows the material at its physical size); a shape needing more than maxPoints
             * lays only the points near the view (make_points) */
            const op_material_info *info = op_material_get_info(d->material);
            double sx = size_x * 0.01 * d->scale, sy = size_y * 0.01 * d->scale;
            double step = centred_step(&sh->mesh, info->width, info->height, sx, sy, a_pix,
                                       d->density);
            if (step > 0.0)
                want = (double)centred_count(&sh->mesh, info->width, info->height, sx, sy, step);
            if (want > INT32_MAX)
                return op_error_set(err, OP_ERR_INPUT, "%s: <subsurface>: %.0f irradiance "
                                    "points (one per material pixel at density %g) are more "
                                    "than a shape can hold (%d)", sh->label, want, d->density,
                                    INT32_MAX);
            d->points = d->finest = want < 1.0 ? 1 : step > 0.0 ? (int)want : (int)ceil(want);
            d->windowed = d->points > d->max_points;
        } else if (want > d->max_points && want <= INT32_MAX &&
                   level_first((long long)ceil(want), DIPOLE_LEVELS) <= INT32_MAX) {
            /* the dipole's layout in levels, windowed in the same way */
            d->finest = (int)ceil(want);
            d->points = (int)level_first(d->finest, DIPOLE_LEVELS);
            d->windowed = 1;
        } else {
            if (want > d->max_points)
                op_log(OP_LOG_WARN, "%s: subsurface needs %.3g irradiance points at the "
                       "profile's spacing; capped at %d (coarser than the material: raise "
                       "maxPoints or lower scale)", sh->label, want, d->max_points);
            d->points = d->finest =
                want < 1.0 ? 1 : want > d->max_points ? d->max_points : (int)ceil(want);
        }
        total += d->windowed ? d->max_points : d->points;
        if (total > (double)max_total)
            return op_error_set(err, OP_ERR_INPUT, "%s: <subsurface>: the translucent shapes "
                                "need %.0f irradiance points so far, over the limit of %lld "
                                "(sss-points; lower maxPoints or raise it with --limit "
                                "sss-points=VALUE)", sh->label, total, max_total);
    }
    return OP_OK;
}

/* Point q's position and normals at barycentrics (b0, b1, b2) of triangle t (vertices a, b, c). */
static void point_geometry(const op_trimesh *m, int t, float b0, float b1, float b2, sss_point *q)
{
    op_v3 a, b, c;
    op_trimesh_tri(m, t, &a, &b, &c);
    const uint32_t *ix = m->idx + 3 * (size_t)t;
    q->p = v3_add(v3_add(v3_scale(a, b0), v3_scale(b, b1)), v3_scale(c, b2));
    q->ng = v3_norm(v3_cross(v3_sub(b, a), v3_sub(c, a)));
    q->n = q->ng;
    if (m->nrm) {
        const float *nn = m->nrm;
        op_v3 s = v3_add(v3_add(v3_scale(v3(nn[3 * ix[0]], nn[3 * ix[0] + 1], nn[3 * ix[0] + 2]), b0),
                                v3_scale(v3(nn[3 * ix[1]], nn[3 * ix[1] + 1], nn[3 * ix[1] + 2]), b1)),
                         v3_scale(v3(nn[3 * ix[2]], nn[3 * ix[2] + 1], nn[3 * ix[2] + 2]), b2));
        if (v3_len(s) > 0.0f)
            q->n = v3_norm(s);
        if (v3_dot(q->n, q->ng) < 0.0f)
            q->ng = v3_neg(q->ng);
    }
}

/* The box projection's frame at q: world axes ua, va projected into q's tangent plane. */
static void box_frame(sss_point *q, int ua, int va)
{
    op_v3 eu = v3(ua == 0, ua == 1, ua == 2), ev = v3(va == 0, va == 1, va == 2);
    q->tu = v3_norm(v3_sub(eu, v3_scale(q->n, v3_dot(q->n, eu))));
    q->tv = v3_sub(ev, v3_scale(q->n, v3_dot(q->n, ev)));
    q->tv = v3_norm(v3_sub(q->tv, v3_scale(q->tu, v3_dot(q->tu, q->tv))));
}

/* One translucent hit of a camera segment: the shape, the point, and the length one radian of
 * ray angle spans there (path length / |cos|). */
typedef struct cam_hit {
    op_v3 p;
    float span;
    int sss;
} cam_hit;

typedef struct cam_row {
    cam_hit *h;
    int n, cap;
} cam_row;

typedef struct cam_job {
    const op_scene *scene;
    const op_sss_transport *transport;
    uint64_t seed;
    int ext, gw;      /* the ray grid: gw columns, film corners widened by ext pixels */
    cam_row *rows;
    atomic_int nomem;
} cam_job;

/* A set of grid cells, by exact coordinates (open addressing): a windowed shape's window. */
typedef struct cell_set {
    sss_grid cells; /* only cell and origin */
    uint32_t size, count; /* size a power of 2, or 0 */
    int32_t *tab;   /* 3 per slot; INT32_MIN in x: empty */
    op_v3 lo, hi;   /* window_build: the bounds of its cells */
} cell_set;

static uint32_t cell_slot(const cell_set *cs, const int32_t c[3])
{
    uint32_t b = cell_hash(c[0], c[1], c[2], cs->size - 1);
    while (cs->tab[3 * (size_t)b] != INT32_MIN &&
           (cs->tab[3 * (size_t)b] != c[0] || cs->tab[3 * (size_t)b + 1] != c[1] ||
            cs->tab[3 * (size_t)b + 2] != c[2]))
        b = (b + 1) & (cs->size - 1);
    return b;
}

static int cell_set_has(const cell_set *cs, const int32_t c[3])
{
    return cs->size && cs->tab[3 * (size_t)cell_slot(cs, c)] != INT32_MIN;
}

/* Adds cell c; 0 when out of memory. */
static int cell_set_add(cell_set *cs, const int32_t c[3])
{
    if (2 * (cs->count + 1) > cs->size) {
        uint32_t size = cs->size ? 2 * cs->size : 1024;
        cell_set old = *cs;
        if (size > (1u << 30) || !(cs->tab = malloc(3 * (size_t)size * sizeof *cs->tab))) {
            cs->tab = old.tab;
            return 0;
        }
        cs->size = size;
        for (uint32_t b = 0; b < size; b++)
            cs->tab[3 * (size_t)b] = INT32_MIN;
        for (uint32_t b = 0; b < old.size; b++)
            if (old.tab[3 * (size_t)b] != INT32_MIN)
                memcpy(cs->tab + 3 * (size_t)cell_slot(cs, old.tab + 3 * (size_t)b),
                       old.tab + 3 * (size_t)b, 3 * sizeof *cs->tab);
        free(old.tab);
    }
    uint32_t b = cell_slot(cs, c);
    if (cs->tab[3 * (size_t)b] == INT32_MIN) {
        memcpy(cs->tab + 3 * (size_t)b, c, 3 * sizeof *c);
        cs->count++;
    }
    return 1;
}

/* Whether a cell of the box [lo, hi] is in the set. */
static int cell_set_box(const cell_set *cs, op_v3 lo, op_v3 hi)
{
    int32_t a[3], b[3], c[3];
    cell_of(&cs->cells, lo, a);
    cell_of(&cs->cells, hi, b);
    for (c[2] = a[2]; c[2] <= b[2]; c[2]++)
        for (c[1] = a[1]; c[1] <= b[1]; c[1]++)
            for (c[0] = a[0]; c[0] <= b[0]; c[0]++)
                if (cell_set_has(cs, c))
                    return 1;
    return 0;
}

typedef struct lay_job {
    const op_trimesh *m;
    sss_shape *ss;
    int t, ua, va;
    long long k;   /* the samples visited so far: the next one's index in the whole layout */
    float area;    /* what one sample of triangle t stands for */
    const cell_set *win; /* windowed: lay only the samples in these cells, at most cap */
    op_v3 a, b, c;       /* windowed: triangle t */
    int laid, cap, over;
} lay_job;

static void lay_site(void *user, const op_sss_site *s)
{
    lay_job *j = user;
    sss_point *q;
    if (j->win) {
        long long k = j->k + s->index;
        float b1 = (float)s->b1, b2 = (float)s->b2;
        op_v3 p = v3_add(v3_add(v3_scale(j->a, 1.0f - b1 - b2), v3_scale(j->b, b1)),
                         v3_scale(j->c, b2));
        int32_t c[3];
        cell_of(&j->win->cells, p, c);
        if (j->over || !cell_set_has(j->win, c))
            return;
        if (j->laid == j->cap) {
            j->over = 1;
            return;
        }
        j->ss->gid[j->laid] = (int)k;
        q = &j->ss->pts[j->laid++];
    } else {
        if (j->k++ >= j->ss->n)
            return; /* counted only */
        q = &j->ss->pts[j->k - 1];
    }
    point_geometry(j->m, j->t, (float)(1.0 - s->b1 - s->b2), (float)s->b1, (float)s->b2, q);
    if (j->ua >= 0 || !triangle_uv_frame(j->m, j->t, q->n, &q->tu, &q->tv)) {
        int ua = j->ua, va = j->va;
        if (ua < 0)
            box_axes(q->n, &ua, &va);
        box_frame(q, ua, va);
    }
    q->fx = wrap((float)s->x, j->ss->width);
    q->fy = wrap((float)s->y, j->ss->height);
    q->a = j->area;
    q->gu = v3_scale(q->tu, 1.0f / j->ss->px);
    q->gv = v3_scale(q->tv, 1.0f / j->ss->py);
}

/* Lays a measured material's points at its pixel (sub-)centres (sss_measured.h), at most ss->n
 * of them; returns how many samples there are (the layout is complete when that is ss->n). */
static long long lay_centred(const op_trimesh *m, sss_shape *ss, double sx, double sy,
                             double step)
{
    lay_job j = {.m = m, .ss = ss};
    for (j.t = 0; j.t < m->ntris && j.k <= ss->n; j.t++) {
        double xy[3][2];
        triangle_pixels(m, j.t, ss->width, ss->height, sx, sy, xy, &j.ua, &j.va);
        double samples = mapped_area(xy) / (step * step);
        j.area = samples > 0.0 ? (float)(world_area(m, j.t) / samples) : 0.0f;
        op_sss_measured_raster(xy, step, lay_site, &j);
    }
    return j.k;
}

/* The largest footprint (pix x span) of the camera's hits on shape sss. */
static float hits_span(const cam_job *cam, int gh, int sss, float pix)
{
    float span = 0.0f;
    for (int r = 0; r < gh; r++)
        for (int k = 0; k < cam->rows[r].n; k++)
            if (cam->rows[r].h[k].sss == sss)
                span = fmaxf(span, pix * cam->rows[r].h[k].span);
    return span;
}

/* The window of every point within d of a camera hit on shape sss: the cells of side d / 4
 * within 4 of a cell that holds a hit (such a point lies in one), with their bounds. Returns 1,
 * -1 when out of memory, and 0 when cap > 0 and the hits' cells are more than cap / 4. */
static int hit_window(const cam_job *cam, int gh, int sss, float d, int cap, cell_set *win)
{
    cell_set hits;
    memset(&hits, 0, sizeof hits);
    memset(win, 0, sizeof *win);
    hits.cells.cell = win->cells.cell = d / 4.0f;
    int ok = 1, over = 0;
    for (int r = 0; r < gh && ok && !over; r++)
        for (int k = 0; k < cam->rows[r].n && ok && !over; k++)
            if (cam->rows[r].h[k].sss == sss) {
                int32_t c[3];
                cell_of(&hits.cells, cam->rows[r].h[k].p, c);
                ok = cell_set_add(&hits, c);
                over = cap > 0 && (long long)hits.count * 4 > cap;
            }
    for (uint32_t b = 0; b < hits.size && ok && !over; b++) {
        const int32_t *h = hits.tab + 3 * (size_t)b;
        if (h[0] == INT32_MIN)
            continue;
        int32_t c[3];
        for (c[2] = h[2] - 4; c[2] <= h[2] + 4 && ok; c[2]++)
            for (c[1] = h[1] - 4; c[1] <= h[1] + 4 && ok; c[1]++)
                for (c[0] = h[0] - 4; c[0] <= h[0] + 4 && ok; c[0]++)
                    ok = cell_set_add(win, c);
    }
    free(hits.tab);
    int32_t lo[3] = {INT32_MAX, INT32_MAX, INT32_MAX}, hi[3] = {INT32_MIN, INT32_MIN, INT32_MIN};
    for (uint32_t b = 0; b < win->size; b++) {
        const int32_t *c = win->tab + 3 * (size_t)b;
        for (int a = 0; a < 3 && c[0] != INT32_MIN; a++) {
            lo[a] = c[a] < lo[a] ? c[a] : lo[a];
            hi[a] = c[a] > hi[a] ? c[a] : hi[a];
        }
    }
    float w = win->cells.cell;
    win->lo = v3((float)lo[0] * w, (float)lo[1] * w, (float)lo[2] * w);
    win->hi = v3((float)(hi[0] + 1) * w, (float)(hi[1] + 1) * w, (float)(hi[2] + 1) * w);
    return !ok ? -1 : !over;
}

/* The reach of a windowed measured shape's window around the camera's hits on it: what a
 * receiver there may need: the lookup's radius h and the hit's footprint (the receivers), a
 * source's reach from a receiver and a neighbour's from a source (the normalization), each at
 * most sqrt(3) x the gather radius, and a spacing. */
static float window_reach(const sss_shape *ss, int sss, const cam_job *cam, int gh, float pix)
{
    return hits_span(cam, gh, sss, pix) + ss->h + 2.0f * sqrtf(3.0f) * ss->radius + ss->spacing;
}

/* The samples of triangle j->t (material coordinates xy) that may lie in the window's bounds:
 * the bounds' corners projected onto the triangle's plane and mapped to its material
 * coordinates (an affine map, so their hull holds every point of the plane in the bounds). */
static void window_clip(const lay_job *j, double xy[3][2], double step, long long clip[4])
{
    op_v3 e1 = v3_sub(j->b, j->a), e2 = v3_sub(j->c, j->a);
    double g11 = v3_dot(e1, e1), g12 = v3_dot(e1, e2), g22 = v3_dot(e2, e2);
    double det = g11 * g22 - g12 * g12;
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (int k = 0; k < 8; k++) {
        op_v3 q = v3(k & 1 ? j->win->hi.x : j->win->lo.x, k & 2 ? j->win->hi.y : j->win->lo.y,
                     k & 4 ? j->win->hi.z : j->win->lo.z);
        op_v3 d = v3_sub(q, j->a);
        double r1 = v3_dot(d, e1), r2 = v3_dot(d, e2);
        double s = (g22 * r1 - g12 * r2) / det, t = (g11 * r2 - g12 * r1) / det;
        for (int a = 0; a < 2; a++) {
            double x = xy[0][a] + s * (xy[1][a] - xy[0][a]) + t * (xy[2][a] - xy[0][a]);
            lo[a] = fmin(lo[a], x);
            hi[a] = fmax(hi[a], x);
        }
    }
    for (int a = 0; a < 2; a++) {
        double l = lo[a] / step - 0.5, h = hi[a] / step - 0.5;
        int finite = det > 0.0 && fabs(l) < 0x1p50 && fabs(h) < 0x1p50;
        clip[2 * a] = finite ? (long long)floor(l) - 1 : LLONG_MIN;
        clip[2 * a + 1] = finite ? (long long)ceil(h) + 1 : LLONG_MAX;
    }
}

/* Lays the centred samples of a windowed shape that lie in win (every one has its index in the
 * whole layout in gid), at most ss->desc->max_points of them; returns 0 when there are more
 * (nothing usable is laid) and -1 when out of memory. */
static int lay_window(const op_trimesh *m, sss_shape *ss, double sx, double sy, double step,
                      const cell_set *win)
{
    int cap = ss->desc->max_points;
    ss->pts = calloc((size_t)cap, sizeof *ss->pts);
    ss->gid = malloc((size_t)cap * sizeof *ss->gid);
    if (!ss->pts || !ss->gid)
        return -1;
    lay_job j = {.m = m, .ss = ss, .win = win, .cap = cap};
    for (j.t = 0; j.t < m->ntris && !j.over; j.t++) {
        double xy[3][2];
        triangle_pixels(m, j.t, ss->width, ss->height, sx, sy, xy, &j.ua, &j.va);
        op_trimesh_tri(m, j.t, &j.a, &j.b, &j.c);
        op_v3 lo = v3(fminf(j.a.x, fminf(j.b.x, j.c.x)), fminf(j.a.y, fminf(j.b.y, j.c.y)),
                      fminf(j.a.z, fminf(j.b.z, j.c.z)));
        op_v3 hi = v3(fmaxf(j.a.x, fmaxf(j.b.x, j.c.x)), fmaxf(j.a.y, fmaxf(j.b.y, j.c.y)),
                      fmaxf(j.a.z, fmaxf(j.b.z, j.c.z)));
        op_v3 e = v3_sub(hi, lo);
        double cells = 1.0;
        for (int a = 0; a < 3; a++)
            cells *= floor(v3_get(e, a) / win->cells.cell) + 2.0;
        long long here = op_sss_measured_count(xy, step);
        if (cells <= 4096.0 && !cell_set_box(win, lo, hi)) {
            j.k += here; /* counted only */
            continue;
        }
        double samples = mapped_area(xy) / (step * step);
        j.area = samples > 0.0 ? (float)(world_area(m, j.t) / samples) : 0.0f;
        long long clip[4];
        window_clip(&j, xy, step, clip);
        op_sss_measured_raster_clip(xy, step, clip, lay_site, &j);
        j.k += here;
    }
    if (j.over || j.laid == 0)
        return 0;
    ss->n = j.laid;
    sss_point *p = realloc(ss->pts, (size_t)j.laid * sizeof *p);
    int *g = realloc(ss->gid, (size_t)j.laid * sizeof *g);
    if (p)
        ss->pts = p;
    if (g)
        ss->gid = g;
    return 1;
}

/* Point k of the area-uniform layout of n points on mesh m (in triangle t): systematic
 * sampling of the area, an R2 sequence inside each triangle; a material tiled every sx x sy. */
static void uniform_point(const op_trimesh *m, const sss_shape *ss, long long k, int t, double sx,
                          double sy, sss_point *q)
{
    double r1 = 0.5 + (double)k * 0.7548776662466927, r2 = 0.5 + (double)k * 0.5698402909980532;
    float b1, b2;
    op_sample_triangle((float)(r1 - floor(r1)), (float)(r2 - floor(r2)), &b1, &b2);
    float b0 = 1.0f - b1 - b2;
    const uint32_t *ix = m->idx + 3 * (size_t)t;
    point_geometry(m, t, b0, b1, b2, q);
    float u, v;
    if (triangle_uv_frame(m, t, q->n, &q->tu, &q->tv)) {
        const float *uv = m->uv;
        u = uv[2 * ix[0]] * b0 + uv[2 * ix[1]] * b1 + uv[2 * ix[2]] * b2;
        v = uv[2 * ix[0] + 1] * b0 + uv[2 * ix[1] + 1] * b1 + uv[2 * ix[2] + 1] * b2;
    } else {
        int ua, va;
        box_axes(q->n, &ua, &va);
        box_frame(q, ua, va);
        u = v3_get(q->p, ua) / (float)sx;
        v = v3_get(q->p, va) / (float)sy;
    }
    q->fx = wrap(u * (float)ss->width, ss->width);
    q->fy = wrap(v * (float)ss->height, ss->height);
}

/* The first index of triangle t's points in a windowed area-uniform layout of n points: those k
 * whose (k + 1/2) / n of the area falls in t's part of the cumulative area (in double, so the
 * triangles partition 0 .. n - 1 exactly for any n). */
static long long uniform_first(const op_trimesh *m, int t, int n)
{
    if (t <= 0)
        return 0;
    if (t >= m->ntris)
        return n;
    double f = ceil((double)m->area_cdf[t - 1] / (double)m->area * n - 0.5);
    return f < 0.0 ? 0 : f > n ? n : (long long)f;
}

/* The regions around the camera's hits on a windowed dipole shape: region j holds the surface
 * within D_j = D_0 2^j of some hit (window j: the cells of D_j / 4 within 4 of a hit's, which
 * cover every point that close) and not in an earlier region; its points are of level
 * level[j]. */
typedef struct level_plan {
    int nregions;
    int level[MAX_REGIONS];
    cell_set win[MAX_REGIONS];
    op_v3 lo, hi; /* the bounds of every window */
} level_plan;

static void level_plan_free(level_plan *lp)
{
    for (int j = 0; j < lp->nregions; j++)
        free(lp->win[j].tab);
    lp->nregions = 0;
}

/* Plans the regions of a windowed dipole shape. Receivers lie within `recv` of a hit (the
 * lookup's radius and the hits' footprints); region 0 reaches what their exact pairs and the
 * normalization of those pairs' sources read (the profile's exact radius and ball) at the
 * finest level; a region farther out is at least D_{j-1} - recv from every receiver, where the
 * tree aggregates clusters of up to theta x that distance and, within a channel's fade radius,
 * of up to 0.75 of its diffusion length: its points are at most half of each bound apart. The
 * regions end past the profile's reach. Returns -1 when out of memory, 0 when the hits' cells
 * of region 0 are too many for maxPoints (each hit's disk of radius D_0, at least 12 spacings,
 * is in it, and overlaps those of at most 81 others in distinct cells: over 5.6 points per
 * cell), 1 when planned. */
static int level_plan_build(const sss_shape *ss, int sss, const cam_job *cam, int gh, float pix,
                            const op_sss_dipole_kernel *dk, level_plan *lp)
{
    memset(lp, 0, sizeof *lp);
    float span = hits_span(cam, gh, sss, pix);
    const op_sss_radial *q = &dk->radial;
    /* thin_receivers may put the receivers 2 sqrt(3) / 12 of a footprint apart */
    float recv = span * (1.0f + 2.0f * sqrtf(3.0f) / 12.0f) + ss->h;
    float d0 = recv + q->exact + q->ball + ss->spacing;
    float outer = recv + q->reach + ss->spacing;
    for (int j = 0; j < MAX_REGIONS; j++) {
        float d = d0 * (float)(1 << j);
        int l = 0;
        if (j > 0) {
            float from = 0.5f * d - recv, most = 0.5f * q->theta * from;
            for (int c = 0; c < 3; c++)
                if (from < q->fade[c])
                    most = fminf(most, 0.5f * (float)op_sss_dipole_length(&dk->d, c));
            l = most > ss->spacing ? (int)floorf(log2f(most / ss->spacing)) : 0;
            if (l < lp->level[j - 1])
                l = lp->level[j - 1];
            if (l > DIPOLE_LEVELS - 1)
                l = DIPOLE_LEVELS - 1;
        }
        lp->level[j] = l;
        lp->nregions = j + 1;
        int got = hit_window(cam, gh, sss, d, j == 0 ? ss->desc->max_points : 0, &lp->win[j]);
        if (got <= 0)
            return got;
        if (d >= outer)
            break;
    }
    lp->lo = lp->win[0].lo;
    lp->hi = lp->win[0].hi;
    for (int j = 1; j < lp->nregions; j++) {
        lp->lo = v3_lo(lp->lo, lp->win[j].lo);
        lp->hi = v3_hi(lp->hi, lp->win[j].hi);
    }
    return 1;
}

/* Whether the boxes [alo, ahi] and [blo, bhi] meet. */
static int box_overlap(op_v3 alo, op_v3 ahi, op_v3 blo, op_v3 bhi)
{
    return ahi.x >= blo.x && ahi.y >= blo.y && ahi.z >= blo.z && alo.x <= bhi.x &&
           alo.y <= bhi.y && alo.z <= bhi.z;
}

/* The region of point p: the first whose window holds it, or -1 (beyond every window). */
static int level_region(const level_plan *lp, op_v3 p)
{
    if (!box_overlap(p, p, lp->lo, lp->hi))
        return -1;
    for (int j = 0; j < lp->nregions; j++) {
        int32_t c[3];
        cell_of(&lp->win[j].cells, p, c);
        if (cell_set_has(&lp->win[j], c))
            return j;
    }
    return -1;
}

/* Lays a windowed dipole shape's points by the plan: of each level's layout, the points whose
 * region is of that level, each with its index in the whole layout in gid and the area it
 * stands for, at most ss->desc->max_points of them; returns 0 when there are more (nothing
 * usable is laid) and -1 when out of memory. */
static int lay_levels(const op_trimesh *m, sss_shape *ss, double sx, double sy, long long n0,
                      const level_plan *lp)
{
    int cap = ss->desc->max_points, laid = 0;
    ss->pts = calloc((size_t)cap, sizeof *ss->pts);
    ss->gid = malloc((size_t)cap * sizeof *ss->gid);
    if (!ss->pts || !ss->gid)
        return -1;
    for (int l = 0; l < DIPOLE_LEVELS; l++) {
        /* the bounds of the windows of this level's regions */
        op_v3 wlo = v3s(FLT_MAX), whi = v3s(-FLT_MAX);
        for (int j = 0; j < lp->nregions; j++)
            if (lp->level[j] == l) {
                wlo = v3_lo(wlo, lp->win[j].lo);
                whi = v3_hi(whi, lp->win[j].hi);
            }
        if (wlo.x > whi.x)
            continue;
        long long n = level_points(n0, l), first = level_first(n0, l);
        float area = (float)((double)m->area / (double)n);
        for (int t = 0; t < m->ntris; t++) {
            long long k0 = uniform_first(m, t, n), k1 = uniform_first(m, t + 1, n);
            if (k0 == k1)
                continue;
            op_v3 a, b, c;
            op_trimesh_tri(m, t, &a, &b, &c);
            op_v3 lo = v3_lo(a, v3_lo(b, c)), hi = v3_hi(a, v3_hi(b, c));
            if (!box_overlap(lo, hi, wlo, whi))
                continue;
            for (long long k = k0; k < k1; k++) {
                double r1 = 0.5 + (double)k * 0.7548776662466927;
                double r2 = 0.5 + (double)k * 0.5698402909980532;
                float b1, b2;
                op_sample_triangle((float)(r1 - floor(r1)), (float)(r2 - floor(r2)), &b1, &b2);
                op_v3 p = v3_add(v3_add(v3_scale(a, 1.0f - b1 - b2), v3_scale(b, b1)),
                                 v3_scale(c, b2));
                if (!box_overlap(p, p, wlo, whi))
                    continue;
                int j = level_region(lp, p);
                if (j < 0 || lp->level[j] != l)
                    continue;
                if (laid == cap)
                    return 0;
                ss->gid[laid] = (int)(first + k);
                uniform_point(m, ss, k, t, sx, sy, &ss->pts[laid]);
                ss->pts[laid++].a = area;
            }
        }
    }
    if (laid == 0)
        return 0;
    ss->n = laid;
    sss_point *p = realloc(ss->pts, (size_t)laid * sizeof *p);
    int *g = realloc(ss->gid, (size_t)laid * sizeof *g);
    if (p)
        ss->pts = p;
    if (g)
        ss->gid = g;
    return 1;
}

typedef struct morton_key {
    uint64_t key;
    int index;
} morton_key;

static int morton_cmp(const void *a, const void *b)
{
    const morton_key *x = a, *y = b;
    if (x->key != y->key)
        return x->key < y->key ? -1 : 1;
    return (x->index > y->index) - (x->index < y->index);
}

/* 21 bits of v spread to every third bit. */
static uint64_t spread3(uint32_t v)
{
    uint64_t x = v & 0x1fffff;
    x = (x | x << 32) & 0x1f00000000ffffull;
    x = (x | x << 16) & 0x1f0000ff0000ffull;
    x = (x | x << 8) & 0x100f00f00f00f00full;
    x = (x | x << 4) & 0x10c30c30c30c30c3ull;
    x = (x | x << 2) & 0x1249249249249249ull;
    return x;
}

/* Puts the laid points in Morton order of their positions in the scene's bounds (ties by the
 * order laid): neighbours in space are neighbours in memory for the hierarchical sum's grids.
 * Depends on the positions only. */
static op_status spatial_order(sss_shape *ss, op_v3 lo, op_v3 hi, op_error *err)
{
    morton_key *k = malloc((size_t)ss->n * sizeof *k);
    sss_point *p = malloc((size_t)ss->n * sizeof *p);
    if (!k || !p) {
        free(k);
        free(p);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for %d irradiance points", ss->n);
    }
    op_v3 e = v3_sub(hi, lo);
    float ext = fmaxf(e.x, fmaxf(e.y, e.z)), scale = ext > 0.0f ? 2097151.0f / ext : 0.0f;
    for (int i = 0; i < ss->n; i++) {
        op_v3 d = v3_scale(v3_sub(ss->pts[i].p, lo), scale);
        uint32_t q[3];
        for (int a = 0; a < 3; a++) {
            float x = v3_get(d, a);
            q[a] = x > 0.0f ? (x < 2097151.0f ? (uint32_t)x : 2097151u) : 0u;
        }
        k[i].key = spread3(q[0]) | spread3(q[1]) << 1 | spread3(q[2]) << 2;
        k[i].index = i;
    }
    qsort(k, (size_t)ss->n, sizeof *k, morton_cmp);
    for (int i = 0; i < ss->n; i++)
        p[i] = ss->pts[k[i].index];
    free(ss->pts);
    ss->pts = p;
    if (ss->gid) {
        /* gid's room (n entries) takes the permutation */
        for (int i = 0; i < ss->n; i++)
            k[i].key = (uint64_t)ss->gid[k[i].index];
        for (int i = 0; i < ss->n; i++)
            ss->gid[i] = (int)k[i].key;
    }
    free(k);
    return OP_OK;
}

/* Lays a windowed shape's points near the view (the camera's hits in cam: gh rows; pix the
 * angle between neighbouring rays): the dipole in levels around it (level_plan_build,
 * lay_levels), a measured material at its physical size at its pixel centres within reach
 * (lay_window), one on a stretched map as the points of its area-uniform layout within reach
 * (lay_levels with one region). Sets *laid to 1 when they are laid, 0 when the view needs more
 * than maxPoints (nothing usable is laid). */
static op_status lay_near_view(const op_shape_rec *sh, sss_shape *ss, const cam_job *cam, int gh,
                               float pix, double sx, double sy, int *laid, op_error *err)
{
    const op_trimesh *m = &sh->mesh;
    level_plan lp;
    memset(&lp, 0, sizeof lp);
    int got;
    if (ss->hier) {
        /* the finest level's points: the profile's spacing */
        ss->a_i = m->area / (float)ss->desc->finest;
        ss->spacing = sqrtf(ss->a_i);
        ss->h = 2.0f * fmaxf(ss->spacing, fmaxf(ss->px, ss->py)); /* prepare_shape's */
        op_sss_dipole_kernel dk;
        op_status st = op_sss_dipole_kernel_init(&dk, &ss->desc->dipole, ss->a_i, ss->spacing,
                                                 err);
        if (st)
            return st;
        got = level_plan_build(ss, sh->sss, cam, gh, pix, &dk, &lp);
        op_sss_dipole_kernel_free(&dk);
        if (got > 0)
            got = lay_levels(m, ss, sx, sy, ss->desc->finest, &lp);
        ss->levels = got > 0;
        if (got > 0) {
            int fine = 0;
            for (int i = 0; i < ss->n; i++)
                fine += ss->gid[i] < ss->desc->finest;
            op_log(OP_LOG_DEBUG, "%s: subsurface: %d regions around the view, %d points at the "
                   "profile's spacing and %d coarser", sh->label, lp.nregions, fine,
                   ss->n - fine);
        }
    } else {
        /* the radii prepare_shape sets */
        double step = centred_step(m, ss->width, ss->height, sx, sy, ss->a_pix,
                                   ss->desc->density);
        int half = ss->kernel / 2;
        if (step > 0.0) {
            ss->h = 2.0f * ss->spacing;
            ss->radius = ((float)half + 1.0f) * (float)M_SQRT2 * fmaxf(ss->px, ss->py);
        } else {
            ss->h = 2.0f * fmaxf(ss->spacing, fmaxf(ss->px, ss->py));
            ss->radius = ((float)half + 1.5f) * fmaxf(ss->px, ss->py);
        }
        lp.nregions = 1;
        got = hit_window(cam, gh, sh->sss, window_reach(ss, sh->sss, cam, gh, pix), 0, &lp.win[0]);
        lp.lo = lp.win[0].lo;
        lp.hi = lp.win[0].hi;
        if (got > 0)
            got = step > 0.0 ? lay_window(m, ss, sx, sy, step, &lp.win[0])
                             : lay_levels(m, ss, sx, sy, ss->desc->finest, &lp);
        ss->centred = got > 0 && step > 0.0;
    }
    level_plan_free(&lp);
    if (got < 0)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for %d irradiance points",
                            ss->desc->max_points);
    *laid = got;
    return OP_OK;
}

/* Lays shape sh's points. A windowed shape (op_sss_desc.windowed) lays those near the camera's
 * hits (cam: gh rows; NULL: the whole shape is in view; lay_near_view) when they are at most
 * maxPoints, and is coarsened to maxPoints points otherwise. */
static op_status make_points(const op_scene *scene, const op_shape_rec *sh, sss_shape *ss,
                             const cam_job *cam, int gh, float pix, op_error *err)
{
    const op_trimesh *m = &sh->mesh;
    double sx, sy; /* one tile of the material in scene units */
    if (ss->desc->is_dipole) {
        /* a one-pixel homogeneous material of the profile's spacing (op_sss_dipole_spacing) */
        ss->hier = 1;
        ss->width = ss->height = ss->kernel = 1;
        ss->channels = 3;
        ss->px = ss->py = (float)op_sss_dipole_spacing(&ss->desc->dipole);
        sx = ss->px;
        sy = ss->py;
    } else {
        const op_material_info *info = op_material_get_info(ss->desc->material);
        ss->width = info->width;
        ss->height = info->height;
        ss->kernel = info->kernel;
        ss->channels = info->channels;
        sx = info->size_x_cm * 0.01 * ss->desc->scale;
        sy = info->size_y_cm * 0.01 * ss->desc->scale;
        ss->px = (float)(sx / info->width);
        ss->py = (float)(sy / info->height);
    }
    ss->a_pix = ss->px * ss->py;
    int n = ss->desc->points; /* op_sss_plan */
    ss->n = ss->nfull = n;
    ss->a_i = m->area / (float)n;
    ss->spacing = sqrtf(ss->a_i);
    if (ss->desc->windowed) {
        int laid = 0;
        if (cam) {
            op_status st = lay_near_view(sh, ss, cam, gh, pix, sx, sy, &laid, err);
            if (st)
                return st;
        }
        if (laid)
            return ss->hier ? spatial_order(ss, scene->bmin, scene->bmax, err) : OP_OK;
        op_log(OP_LOG_WARN, "%s: subsurface: the view needs more of its %d irradiance points "
               "(%s) than maxPoints; capped at %d (coarser than the material: raise maxPoints "
               "or lower scale)", sh->label, ss->hier ? ss->desc->finest : n,
               ss->hier ? "at the profile's spacing" :
               "one per material pixel", ss->desc->max_points);
        free(ss->pts);
        free(ss->gid);
        ss->pts = NULL;
        ss->gid = NULL;
        n = ss->n = ss->nfull = ss->desc->max_points;
        ss->a_i = m->area / (float)n;
        ss->spacing = sqrtf(ss->a_i);
    }
    ss->pts = calloc((size_t)n, sizeof *ss->pts);
    if (!ss->pts)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for %d irradiance points", n);
    if (!ss->desc->is_dipole && !ss->desc->windowed) {
        double step = centred_step(m, ss->width, ss->height, sx, sy, ss->a_pix,
                                   ss->desc->density);
        if (step > 0.0 && lay_centred(m, ss, sx, sy, step) == n) {
            ss->centred = 1; /* a_i and spacing: the mean area and spacing, as above */
            return OP_OK;
        }
        /* a map not at the physical size (or a shape smaller than one sample): as below */
        memset(ss->pts, 0, (size_t)n * sizeof *ss->pts);
    }
    for (int k = 0; k < n; k++) {
        uniform_point(m, ss, k, op_trimesh_pick(m, ((float)k + 0.5f) / (float)n), sx, sy,
                      &ss->pts[k]);
        ss->pts[k].a = ss->a_i;
    }
    return ss->hier ? spatial_order(ss, scene->bmin, scene->bmax, err) : OP_OK;
}

typedef struct build_job {
    const op_scene *scene;
    const op_sss_transport *transport;
    op_sss_cache *cache;
    uint64_t seed;
    atomic_int *cancel;
    op_progress *prog; /* the running stage's report, owned by its *_pass call; else NULL */
    int chunk;  /* sources per scatter chunk */
    /* task -> (shape, first point) */
    int *task_shape, *task_first;
    float **rows; /* per thread: one kernel row per channel */
    int scatter_shape;
    atomic_int nomem; /* a scatter task ran out of memory */
} build_job;

/* The scatter's accumulators (one per chunk of sources) take at most about MAX_ACC_BYTES
 * beyond one chunk: fewer chunks for shapes of many points (fixed by the point count, so the
 * summation order does not depend on which points are receivers). */
enum { POINTS_PER_TASK = 256, MAX_CHUNKS = 16, UNSAVED_FACTOR = 16 };
#define MAX_ACC_BYTES (256.0 * 1024 * 1024)

static void irradiance_task(void *user, int task, int thread)
{
    (void)thread;
    build_job *job = user;
    sss_shape *ss = &job->cache->shapes[job->task_shape[task]];
    int first = job->task_first[task], last = first + POINTS_PER_TASK;
    if (last > ss->nsrc)
        last = ss->nsrc;
    int spp = ss->desc->irr_samples;
    for (int l = first; l < last; l++) {
        int k = ss->src[l];
        sss_point *q = &ss->pts[k];
        op_v3 sum = v3s(0.0f);
        for (int s = 0; s < spp; s++) {
            op_rng rng = op_rng_seed(job->seed ^ 0x5355425355524641ull,
                                     ((uint64_t)job->task_shape[task] << 40) |
                                         (uint64_t)point_index(ss, k),
                                     (uint64_t)s);
            op_v3 e = job->transport->irradiance(job->scene, job->task_shape[task], q->p, q->ng,
                                                 q->n, &rng);
            if (isfinite(e.x) && isfinite(e.y) && isfinite(e.z))
                sum = v3_add(sum, e);
        }
        q->e = v3_scale(sum, 1.0f / (float)spp);
    }
    op_progress_advance(job->prog, (uint64_t)(last - first));
}

/* The gather grid's cells are half the gather radius r across. The scatter's receivers of a
 * source s are the points of the cells of side r (aligned with the grid's) that overlap the box
 * of half-extents E around s (centred: per world axis the smaller of r and the extent of the box
 * of half + 1 kernel pixels along s's tangents plus r along its normal; else r) that lie in the
 * kernel's window (kernel_at, centred_task): the set of the scatter before its cells were
 * halved. gather_cells lists the grid cells of those side-r cells that may meet the window (a
 * cell whose extent along s's tangents misses [-(half + 1), half + 1] pixels has no receiver),
 * at most GATHER_CELLS; they are visited in this order. */
enum { GATHER_CELLS = 512 }; /* 8 per axis: E <= r spans 3 side-r cells (4 with rounding) */

static int gather_cells(const sss_shape *ss, const sss_point *s, op_v3 gu, op_v3 gv,
                        int32_t cells[GATHER_CELLS][3])
{
    const sss_grid *g = &ss->gather;
    float r = ss->radius, w = (float)(ss->kernel / 2) + 1.0f + 0.01f;
    int32_t lo[3], hi[3];
    for (int a = 0; a < 3; a++) {
        float e = ss->radius;
        if (ss->centred)
            e = fminf(((float)(ss->kernel / 2) + 1.0f) * (fabsf(v3_get(s->tu, a)) * ss->px +
                                                         fabsf(v3_get(s->tv, a)) * ss->py) +
                          fabsf(v3_get(s->n, a)) * ss->radius,
                      ss->radius);
        float o = v3_get(g->origin, a), x = v3_get(s->p, a);
        lo[a] = 2 * (int32_t)floorf((x - e - o) / r);
        hi[a] = 2 * (int32_t)floorf((x + e - o) / r) + 1;
    }
    /* a cell's extent along gu and gv: its centre's offset -/+ half its side times the
     * L1 norm */
    float su = 0.5f * g->cell * (fabsf(gu.x) + fabsf(gu.y) + fabsf(gu.z));
    float sv = 0.5f * g->cell * (fabsf(gv.x) + fabsf(gv.y) + fabsf(gv.z));
    int n = 0;
    for (int32_t cz = lo[2]; cz <= hi[2]; cz++)
        for (int32_t cy = lo[1]; cy <= hi[1]; cy++)
            for (int32_t cx = lo[0]; cx <= hi[0]; cx++) {
                op_v3 m = v3(g->origin.x + ((float)cx + 0.5f) * g->cell - s->p.x,
                             g->origin.y + ((float)cy + 0.5f) * g->cell - s->p.y,
                             g->origin.z + ((float)cz + 0.5f) * g->cell - s->p.z);
                float u = v3_dot(m, gu), v = v3_dot(m, gv);
                if (u - su > w || u + su < -w || v - sv > w || v + sv < -w || n == GATHER_CELLS)
                    continue;
                cells[n][0] = cx;
                cells[n][1] = cy;
                cells[n++][2] = cz;
            }
    return n;
}

/* The points [*first, *last) of scatter chunk `chunk`: those whose index in the whole layout
 * lies in [chunk size, (chunk + 1) size), so that a receiver's sum runs in the same order
 * whichever points are laid or are sources. */
static void chunk_range(const sss_shape *ss, int chunk, int size, int *first, int *last)
{
    long long lo = (long long)chunk * size, hi = lo + size;
    if (hi > ss->nfull)
        hi = ss->nfull;
    int b[2];
    for (int e = 0; e < 2; e++) {
        long long want = e ? hi : lo;
        int l = 0, h = ss->n; /* the first point whose index is at least want */
        while (l < h) {
            int mid = l + (h - l) / 2;
            if (point_index(ss, mid) < want)
                l = mid + 1;
            else
                h = mid;
        }
        b[e] = l;
    }
    *first = b[0];
    *last = b[1];
}

/* The kernel value at the receiver r of the source s (its rows rr, rg, rb), interpolated
 * bilinearly between the four kernel offsets around the offset s -> r in material pixels, in s's
 * frame (gu, gv: its tangents over the pixel size). Returns 0 when r is not a receiver of s
 * (other side, or outside the kernel). */
static int kernel_at(const sss_shape *ss, const sss_point *s, op_v3 gu, op_v3 gv,
                     const gather_pt *r, const float *rr, const float *rg, const float *rb,
                     float v[3])
{
    if (s->n.x * r->nx + s->n.y * r->ny + s->n.z * r->nz <= 0.0f)
        return 0;
    int K = ss->kernel, half = K / 2;
    op_v3 d = v3(r->x - s->p.x, r->y - s->p.y, r->z - s->p.z);
    /* the offsets floor(dx), floor(dy) in [-half - 1, half] */
    float lim = (float)half + 1.0f, dx = v3_dot(d, gu);
    if (!(dx >= -lim && dx < lim))
        return 0;
    float dy = v3_dot(d, gv);
    if (!(dy >= -lim && dy < lim))
        return 0;
    float flx = floorf(dx), fly = floorf(dy);
    int ox = (int)flx, oy = (int)fly;
    float tx = dx - flx, ty = dy - fly;
    float wx[2] = {1.0f - tx, tx}, wy[2] = {1.0f - ty, ty};
    v[0] = v[1] = v[2] = 0.0f;
    for (int b = 0; b < 2; b++) {
        int oyb = oy + b;
        if (oyb < -half || oyb > half)
            continue;
        for (int a = 0; a < 2; a++) {
            int oxa = ox + a;
            if (oxa < -half || oxa > half)
                continue;
            int col = (oyb + half) * K + (oxa + half);
            float w = wx[a] * wy[b];
            v[0] += w * rr[col];
            v[1] += w * rg[col];
            v[2] += w * rb[col];
        }
    }
    return 1;
}

/* The centred layout's scatter of one chunk of sources (scatter_task's contract): the pair
 * value is the kernel at the whole-pixel offset from the source's pixel to the receiver's
 * (sss_measured.h), each receiver weighted by its area in the normalization, each source's
 * energy E_i A_i g_i / A_pixel. Receivers lie within sqrt(3) gather radii of their source (in
 * the kernel's window they are within one radius in its tangent plane; the bound holds the
 * pairs a curved surface may add, and is what a windowed shape's window assumes). */
static void centred_task(void *user, int task, int thread)
{
    build_job *job = user;
    sss_shape *ss = &job->cache->shapes[job->scatter_shape];
    const op_material *mat = ss->desc->material;
    const sss_grid *g = &ss->gather;
    int first, last;
    chunk_range(ss, task, job->chunk, &first, &last);
    float *acc = ss->acc + (size_t)task * 3 * (size_t)ss->nrecv;
    int K = ss->kernel, half = K / 2;
    float *rows = job->rows[thread];
    float reach2 = 3.0f * ss->radius * ss->radius; /* a pair lies within sqrt(3) radii */
    int cap = 0, nrec = 0;
    int32_t *rec = NULL; /* pairs: receiver index, kernel column */
    int i;
    for (i = first; i < last; i++) {
        if ((i & 63) == 0 && job->cancel && atomic_load(job->cancel))
            break;
        const sss_point *s = &ss->pts[i];
        if (v3_is_black(s->e))
            continue;
        int x = (int)s->fx, y = (int)s->fy;
        for (int c = 0; c < ss->channels; c++)
            op_material_eval_row(mat, c, x, y, rows + (size_t)c * K * K);
        const float *rr = rows, *rg = ss->channels == 3 ? rows + K * K : rows,
                    *rb = ss->channels == 3 ? rows + 2 * K * K : rows;
        double total[3] = {0, 0, 0};
        float got[3] = {0, 0, 0};
        for (int k = 0; k < K * K; k++) {
            total[0] += rr[k];
            total[1] += rg[k];
            total[2] += rb[k];
        }
        /* offsets from the source's position inside its pixel (fractions in [0, 1)); a
         * pixel index is (int)(v + BIAS) - BIAS for |v| < BIAS, without floorf's cost */
        const float BIAS = 1024.0f;
        float frx = s->fx - floorf(s->fx) + BIAS, fry = s->fy - floorf(s->fy) + BIAS;
        int32_t cells[GATHER_CELLS][3];
        int ncells = gather_cells(ss, s, s->gu, s->gv, cells);
        nrec = 0;
        for (int ci = 0; ci < ncells; ci++) {
            int32_t cx = cells[ci][0], cy = cells[ci][1], cz = cells[ci][2];
            uint32_t b = cell_hash(cx, cy, cz, g->mask);
            for (uint32_t k = g->start[b]; k < g->start[b + 1]; k++) {
                const gather_pt *r = &ss->gpts[k];
                if (r->c[0] != cx || r->c[1] != cy || r->c[2] != cz)
                    continue;
                if (r->nx * s->n.x + r->ny * s->n.y + r->nz * s->n.z <= 0.0f)
                    continue;
                op_v3 d = v3(r->x - s->p.x, r->y - s->p.y, r->z - s->p.z);
                if (v3_dot(d, d) > reach2)
                    continue; /* beyond a windowed shape's reach (window_build) */
                float ux = v3_dot(d, s->gu), uy = v3_dot(d, s->gv);
                if (!(fabsf(ux) < 512.0f && fabsf(uy) < 512.0f))
                    continue;
                int ox = (int)(frx + ux) - 1024, oy = (int)(fry + uy) - 1024;
                if (ox < -half || ox > half || oy < -half || oy > half)
                    continue;
                int col = (oy + half) * K + (ox + half);
                got[0] += rr[col] * r->a;
                got[1] += rg[col] * r->a;
                got[2] += rb[col] * r->a;
                if (r->rj < 0)
                    continue; /* counts for the normalization only */
                if (nrec == cap) {
                    int nc = cap ? 2 * cap : 2048;
                    int32_t *r2 = realloc(rec, 2 * (size_t)nc * sizeof *rec);
                    if (!r2) { /* this source's light is lost, reported by the pass */
                        atomic_store(&job->nomem, 1);
                        goto next;
                    }
                    rec = r2;
                    cap = nc;
                }
                rec[2 * nrec] = r->rj;
                rec[2 * nrec++ + 1] = col;
            }
        }
        float gn[3];
        for (int c = 0; c < 3; c++) {
            double q = got[c] > 0.0f ? total[c] / got[c] : 1.0;
            gn[c] = (float)(q < 0.5 ? 0.5 : q > 2.0 ? 2.0 : q) * (s->a / ss->a_pix);
        }
        {
            float ex = s->e.x * gn[0], ey = s->e.y * gn[1], ez = s->e.z * gn[2];
            for (int k = 0; k < nrec; k++) {
                float *o = acc + 3 * (size_t)rec[2 * k];
                int col = rec[2 * k + 1];
                o[0] += ex * rr[col];
                o[1] += ey * rg[col];
                o[2] += ez * rb[col];
            }
        }
    next:;
    }
    free(rec);
    op_progress_advance(job->prog, (uint64_t)(i - first));
}

/* Scatters the irradiance of one chunk of source points into that chunk's own accumulator:
 * acc[3 j + c] += E_i,c g_i,c Rd_c(pixel(i), offset(i -> j)) over the receivers j in i's
 * footprint, where g_i,c (clamped to [1/2, 2]) makes the receivers of i get exactly the row's
 * sum (the albedo of i's pixel) times A_pixel / A_i: each source hands on exactly its energy
 * whatever the local arrangement of the points (see docs/subsurface-rendering.md). Chunks are
 * fixed ranges of points, summed in order afterwards, so the result does not depend on the
 * thread count. */
static void scatter_task(void *user, int task, int thread)
{
    build_job *job = user;
    sss_shape *ss = &job->cache->shapes[job->scatter_shape];
    const op_material *mat = ss->desc->material;
    int chunk = task;
    int first, last;
    chunk_range(ss, chunk, job->chunk, &first, &last);
    float *acc = ss->acc + (size_t)chunk * 3 * (size_t)ss->nrecv;
    int K = ss->kernel;
    float *rows = job->rows[thread];
    float expect = ss->a_pix / ss->a_i; /* receivers per kernel pixel */
    /* the receivers of one source and their kernel values, kept between the two steps */
    int cap = 0, nrec = 0;
    int *rec = NULL;
    float *val = NULL;
    int i;
    for (i = first; i < last; i++) {
        if ((i & 63) == 0 && job->cancel && atomic_load(job->cancel))
            break; /* the pass returns OP_ERR_CANCELLED; this chunk's sum is dropped */
        const sss_point *s = &ss->pts[i];
        if (v3_is_black(s->e)) /* also every point that is not a source */
            continue;
        int x = (int)s->fx, y = (int)s->fy;
        for (int c = 0; c < ss->channels; c++)
            op_material_eval_row(mat, c, x, y, rows + (size_t)c * K * K);
        const float *rr = rows, *rg = ss->channels == 3 ? rows + K * K : rows,
                    *rb = ss->channels == 3 ? rows + 2 * K * K : rows;
        double total[3] = {0, 0, 0}, got[3] = {0, 0, 0};
        for (int k = 0; k < K * K; k++) {
            total[0] += rr[k];
            total[1] += rg[k];
            total[2] += rb[k];
        }
        float v[3];
        nrec = 0;
        const sss_grid *gr = &ss->gather;
        op_v3 gu = v3_scale(s->tu, 1.0f / ss->px), gv = v3_scale(s->tv, 1.0f / ss->py);
        int32_t cells[GATHER_CELLS][3];
        int ncells = gather_cells(ss, s, gu, gv, cells);
        for (int ci = 0; ci < ncells; ci++) {
            int32_t cx = cells[ci][0], cy = cells[ci][1], cz = cells[ci][2];
            uint32_t b = cell_hash(cx, cy, cz, gr->mask);
            for (uint32_t k = gr->start[b]; k < gr->start[b + 1]; k++) {
                const gather_pt *r = &ss->gpts[k];
                if (r->c[0] != cx || r->c[1] != cy || r->c[2] != cz)
                    continue;
                if (!kernel_at(ss, s, gu, gv, r, rr, rg, rb, v))
                    continue;
                got[0] += v[0];
                got[1] += v[1];
                got[2] += v[2];
                if (r->rj < 0)
                    continue; /* counts for the normalization only */
                if (nrec == cap) {
                    int nc = cap ? 2 * cap : 1024;
                    int *r2 = realloc(rec, (size_t)nc * sizeof *rec);
                    float *v2 = r2 ? realloc(val, 3 * (size_t)nc * sizeof *val) : NULL;
                    if (r2)
                        rec = r2;
                    if (!v2) { /* out of memory: this source's light is lost, reported below */
                        atomic_store(&job->nomem, 1);
                        goto scatter;
                    }
                    val = v2;
                    cap = nc;
                }
                rec[nrec] = r->rj;
                memcpy(val + 3 * (size_t)nrec++, v, sizeof v);
            }
        }
    scatter:;
        float g[3];
        for (int c = 0; c < 3; c++) {
            double q = got[c] > 0.0 ? total[c] * expect / got[c] : 1.0;
            g[c] = (float)(q < 0.5 ? 0.5 : q > 2.0 ? 2.0 : q);
        }
        op_v3 e = v3(s->e.x * g[0], s->e.y * g[1], s->e.z * g[2]);
        for (int k = 0; k < nrec; k++) {
            size_t j = (size_t)rec[k];
            acc[3 * j] += e.x * val[3 * (size_t)k];
            acc[3 * j + 1] += e.y * val[3 * (size_t)k + 1];
            acc[3 * j + 2] += e.z * val[3 * (size_t)k + 2];
        }
    }
    free(rec);
    free(val);
    op_progress_advance(job->prog, (uint64_t)(i - first));
}

enum { CAM_MAX_BOUNCES = 8 };

/* Appends one translucent hit of a camera segment to its row (cam_hit_fn's user). */
typedef struct cam_add {
    const op_scene *scene;
    cam_row *row;
    atomic_int *nomem;
} cam_add;

static int cam_hit_fn(void *user, const op_isect *it, float dist, float cosine)
{
    cam_add *a = user;
    cam_row *row = a->row;
    if (row->n == row->cap) {
        int nc = row->cap ? 2 * row->cap : 64;
        cam_hit *h = realloc(row->h, (size_t)nc * sizeof *h);
        if (!h) {
            atomic_store(a->nomem, 1);
            return 0;
        }
        row->h = h;
        row->cap = nc;
    }
    cam_hit *h = &row->h[row->n++];
    h->p = it->p;
    h->span = dist / fmaxf(cosine, 0.05f);
    h->sss = a->scene->shapes[it->shape].sss;
    return 1;
}

/* Traces the camera segments through the pixel corners of one row of the ray grid. */
static void camera_task(void *user, int task, int thread)
{
    (void)thread;
    cam_job *job = user;
    const op_scene *s = job->scene;
    cam_add add = {s, &job->rows[task], &job->nomem};
    float fy = (float)(task - job->ext);
    for (int ix = 0; ix < job->gw && !atomic_load(&job->nomem); ix++) {
        float fx = (float)(ix - job->ext);
        op_v3 org, dir;
        float tmin, tmax;
        op_camera_ray(&s->camera, fx, fy, &org, &dir, &tmin, &tmax);
        op_rng rng = op_rng_seed(job->seed ^ 0x43414d4552414d4bull,
                                 (uint64_t)task * (uint64_t)job->gw + (uint64_t)ix, 0);
        job->transport->camera_hits(s, org, dir, tmin, tmax, CAM_MAX_BOUNCES, &rng, cam_hit_fn,
                                    &add);
    }
}

/* Marks as receivers the points that may be (rep) within r of p (exactly: a hashed cell mark
 * would also catch the far cells that share its bucket). */
static void mark_near(sss_shape *ss, op_v3 p, float r)
{
    float r2 = r * r;
    GRID_FOR_EACH(ss->rep ? &ss->look : &ss->interp, p, r, i, {
        op_v3 d = v3_sub(ss->pts[i].p, p);
        if (v3_dot(d, d) <= r2)
            ss->recv[i] = 1;
    });
}

/* The receivers' thinning of a hierarchical shape whose camera needs its exitance no finer
 * than sr apart (sr at least 2 point spacings): one point may be a receiver per cell of side sr
 * and normal class (the signed dominant axis of its normal), the lowest point index in it. A
 * surface point lies within a point spacing plus a cell's diagonal, so within
 * hr = 2 sqrt(3) sr, of one that may. Sets rep, hr and look; depends on the points and sr only,
 * so a receiver's exitance is what the full computation gives it. */
static op_status thin_receivers(sss_shape *ss, op_v3 origin, float sr, op_error *err)
{
    uint32_t size = 1;
    while (size < 2u * (uint32_t)ss->n && size < (1u << 30))
        size <<= 1;
    int32_t *tab = malloc((size_t)size * 4 * sizeof *tab); /* cell x, y, z, class; class -1: empty */
    ss->rep = calloc((size_t)ss->n, 1);
    if (!tab || !ss->rep) {
        free(tab);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for %d irradiance points", ss->n);
    }
    for (uint32_t b = 0; b < size; b++)
        tab[4 * (size_t)b + 3] = -1;
    sss_grid cells = {.cell = sr, .origin = origin};
    for (int i = 0; i < ss->n; i++) {
        int32_t c[4];
        cell_of(&cells, ss->pts[i].p, c);
        op_v3 n = ss->pts[i].n;
        float ax = fabsf(n.x), ay = fabsf(n.y), az = fabsf(n.z);
        int a = ax >= ay && ax >= az ? 0 : ay >= az ? 1 : 2;
        c[3] = 2 * a + (v3_get(n, a) < 0.0f);
        uint32_t b = cell_hash(c[0], c[1], c[2] * 8 + c[3], size - 1);
        for (;; b = (b + 1) & (size - 1)) {
            int32_t *e = tab + 4 * (size_t)b;
            if (e[3] < 0) { /* the first of its cell and class */
                memcpy(e, c, sizeof c);
                ss->rep[i] = 1;
                break;
            }
            if (e[0] == c[0] && e[1] == c[1] && e[2] == c[2] && e[3] == c[3])
                break;
        }
    }
    free(tab);
    ss->hr = 2.0f * sqrtf(3.0f) * sr;
    return grid_build(&ss->look, ss->pts, ss->n, ss->rep, origin, ss->hr, err);
}

/* From the receivers marked in recv and what sv (NULL: nothing) already holds: the receivers
 * whose exitance is computed (those sv lacks: rmap, nrecv); receivers sv has the exitance of
 * get it now. Allocates rmap and src. */
static op_status select_receivers(sss_shape *ss, const op_sss_saved *sv, op_error *err)
{
    ss->rmap = malloc((size_t)ss->n * sizeof *ss->rmap);
    ss->src = malloc((size_t)ss->n * sizeof *ss->src);
    if (!ss->rmap || !ss->src)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for %d irradiance points", ss->n);
    ss->nrecv = ss->nsrc = 0;
    for (int j = 0; j < ss->n; j++) {
        size_t g = (size_t)point_index(ss, j);
        int known = ss->recv[j] && sv && !ss->levels && (sv->has[g] & OP_SSS_HAS_M);
        if (known) {
            ss->pts[j].m = v3(sv->m[3 * g], sv->m[3 * g + 1], sv->m[3 * g + 2]);
            ss->reused_recv++;
        }
        ss->rmap[j] = ss->recv[j] && !known ? ss->nrecv++ : -1;
    }
    return OP_OK;
}

/* Point i is a source: it takes its irradiance from sv when sv holds it, else it is listed in
 * src to be computed (in ascending order when called in ascending i). */
static void add_source(sss_shape *ss, const op_sss_saved *sv, int i)
{
    size_t g = (size_t)point_index(ss, i);
    if (sv && (sv->has[g] & OP_SSS_HAS_E)) {
        ss->pts[i].e = v3(sv->e[3 * g], sv->e[3 * g + 1], sv->e[3 * g + 2]);
        ss->reused_src++;
    } else {
        ss->src[ss->nsrc++] = i;
    }
}

/* The scatter's selection (select_receivers, then): the sources, the points whose gather cells
 * (gather_cells, those the scatter visits) hold a computed receiver. */
static op_status select_points(sss_shape *ss, const op_sss_saved *sv, op_error *err)
{
    const sss_grid *g = &ss->gather;
    op_status st = select_receivers(ss, sv, err);
    if (st)
        return st;
    cell_set marked; /* the gather cells that hold a computed receiver */
    memset(&marked, 0, sizeof marked);
    int ok = 1;
    for (int j = 0; j < ss->n && ok; j++)
        if (ss->rmap[j] >= 0)
            ok = cell_set_add(&marked, g->coord + 3 * j);
    for (int i = 0; i < ss->n && ok; i++) {
        const sss_point *q = &ss->pts[i];
        op_v3 gu = ss->centred ? q->gu : v3_scale(q->tu, 1.0f / ss->px);
        op_v3 gv = ss->centred ? q->gv : v3_scale(q->tv, 1.0f / ss->py);
        int32_t cells[GATHER_CELLS][3];
        int ncells = gather_cells(ss, q, gu, gv, cells), need = 0;
        for (int ci = 0; ci < ncells && !need; ci++)
            need = cell_set_has(&marked, cells[ci]);
        if (need)
            add_source(ss, sv, i);
    }
    free(marked.tab);
    if (!ok)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for %d irradiance points", ss->n);
    {
        if (!(ss->gpts = malloc((size_t)ss->n * sizeof *ss->gpts)))
            return op_error_set(err, OP_ERR_NOMEM, "out of memory for %d irradiance points", ss->n);
        for (int k = 0; k < ss->n; k++) {
            int q = (int)g->items[k];
            const sss_point *pt = &ss->pts[q];
            gather_pt *o = &ss->gpts[k];
            *o = (gather_pt){pt->p.x, pt->p.y, pt->p.z, pt->n.x, pt->n.y, pt->n.z,
                             pt->a / ss->a_pix, ss->rmap[q], {g->coord[3 * q], g->coord[3 * q + 1],
                                                             g->coord[3 * q + 2]}};
        }
    }
    return OP_OK;
}

/* The hierarchical sum's structures of a laid shape: the tree over its points and the
 * dipole's profile for points of its area and spacing. */
static op_status tree_prepare(sss_shape *ss, op_v3 origin, op_error *err)
{
    op_v3 *p = malloc((size_t)ss->n * sizeof *p), *n = malloc((size_t)ss->n * sizeof *n);
    op_status st = OP_OK;
    if (!p || !n)
        st = op_error_set(err, OP_ERR_NOMEM, "out of memory for %d irradiance points", ss->n);
    for (int i = 0; st == OP_OK && i < ss->n; i++) {
        p[i] = ss->pts[i].p;
        n[i] = ss->pts[i].n;
    }
    if (st == OP_OK)
        st = op_sss_tree_build(&ss->tree, p, n, ss->n, err);
    free(p);
    free(n);
    if (st == OP_OK)
        st = op_sss_dipole_kernel_init(&ss->dk, &ss->desc->dipole, ss->a_i, ss->spacing, err);
    /* the normalization's neighbourhoods (within the ball) in a few cells each */
    if (st == OP_OK)
        st = grid_build(&ss->ballg, ss->pts, ss->n, NULL, origin, ss->dk.radial.ball, err);
    return st;
}

typedef struct touch_job {
    const sss_shape *ss;
    unsigned char **marks; /* per thread: one byte per tree node */
    int chunk;
} touch_job;

static void touch_task(void *user, int task, int thread)
{
    touch_job *job = user;
    const sss_shape *ss = job->ss;
    int first = task * job->chunk, last = first + job->chunk < ss->n ? first + job->chunk : ss->n;
    for (int j = first; j < last; j++)
        if (ss->rmap[j] >= 0)
            op_sss_tree_touch(&ss->tree, &ss->dk.radial, ss->pts[j].p, ss->pts[j].n,
                              job->marks[thread]);
}

/* The hierarchical sum's selection (select_receivers, then): the sources are the points under
 * the tree nodes the computed receivers' sums use (op_sss_tree_touch), which depend on geometry
 * only: every node a receiver uses has all its points' irradiance, whatever else is marked. */
static op_status select_tree(sss_shape *ss, const op_sss_saved *sv, const op_sss_build_options *opt,
                             op_error *err)
{
    op_status st = select_receivers(ss, sv, err);
    if (st)
        return st;
    int threads = op_parallel_threads(opt->threads);
    touch_job job = {ss, calloc((size_t)threads, sizeof(unsigned char *)), POINTS_PER_TASK};
    unsigned char *need = calloc((size_t)ss->n, 1);
    if (!job.marks || !need)
        st = op_error_set(err, OP_ERR_NOMEM, "out of memory for %d irradiance points", ss->n);
    for (int t = 0; st == OP_OK && t < threads; t++)
        if (!(job.marks[t] = calloc((size_t)ss->tree.nnodes, 1)))
            st = op_error_set(err, OP_ERR_NOMEM, "out of memory for %d irradiance points", ss->n);
    if (st == OP_OK && ss->nrecv > 0)
        st = op_parallel_for(opt->threads, (ss->n + job.chunk - 1) / job.chunk, touch_task, &job,
                             opt->cancel, err);
    for (int t = 0; st == OP_OK && t < threads; t++) {
        if (t > 0)
            for (int i = 0; i < ss->tree.nnodes; i++)
                job.marks[0][i] |= job.marks[t][i];
        if (t == threads - 1)
            op_sss_tree_points(&ss->tree, job.marks[0], need);
    }
    for (int i = 0; st == OP_OK && i < ss->n; i++)
        if (need[i])
            add_source(ss, sv, i);
    /* the sources whose normalized weight a computed receiver's exact pairs use */
    if (st == OP_OK && !(ss->near_recv = calloc((size_t)ss->n, 1)))
        st = op_error_set(err, OP_ERR_NOMEM, "out of memory for %d irradiance points", ss->n);
    float ball = ss->dk.radial.ball;
    for (int j = 0; st == OP_OK && j < ss->n; j++) {
        if (ss->rmap[j] < 0)
            continue;
        op_v3 p = ss->pts[j].p;
        GRID_FOR_EACH(&ss->ballg, p, ball, i, {
            if (v3_len(v3_sub(ss->pts[i].p, p)) <= ball) /* as op_sss_tree_sum tests it */
                ss->near_recv[i] = 1;
        });
    }
    for (int t = 0; job.marks && t < threads; t++)
        free(job.marks[t]);
    free(job.marks);
    free(need);
    return st;
}

/* The camera pass: one segment per pixel corner of the whole film (widened by the filter's
 * reach; a crop window does not narrow it, so that a cropped render's pixels are exactly the
 * full render's), so that every sample position lies within one grid spacing of a traced ray.
 * Fills *rows (gh rows of hits) and marks the translucent shapes reached. */
static op_status camera_pass(const op_scene *scene, op_sss_cache *c, const op_sss_build_options *opt,
                             cam_job *job, int *gh, op_error *err)
{
    const op_film *film = &scene->film;
    memset(job, 0, sizeof *job);
    job->scene = scene;
    job->transport = opt->transport;
    job->seed = opt->seed;
    job->ext = (int)ceilf(fmaxf(film->filter_radius - 0.5f, 0.0f));
    job->gw = film->full_width + 2 * job->ext + 1;
    *gh = film->full_height + 2 * job->ext + 1;
    job->rows = calloc((size_t)*gh, sizeof *job->rows);
    if (!job->rows)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    op_status st = op_parallel_for(opt->threads, *gh, camera_task, job, opt->cancel, err);
    if (st == OP_OK && atomic_load(&job->nomem))
        st = op_error_set(err, OP_ERR_NOMEM, "out of memory in the subsurface camera pass");
    for (int r = 0; st == OP_OK && r < *gh; r++)
        for (int k = 0; k < job->rows[r].n; k++)
            c->shapes[job->rows[r].h[k].sss].reached = 1;
    return st;
}

/* The irradiance stage: E at the sources, ntasks tasks of POINTS_PER_TASK points. Its progress
 * report is job->prog for exactly the duration of this call. */
static op_status irradiance_pass(build_job *job, const op_sss_build_options *opt, int ntasks,
                                 uint64_t nsrc, op_error *err)
{
    job->prog = op_progress_begin("irradiance", nsrc, opt->progress, opt->progress_user);
    op_status st = op_parallel_for(opt->threads, ntasks, irradiance_task, job, opt->cancel, err);
    op_progress_end(job->prog);
    job->prog = NULL;
    return st;
}

static void tree_task(void *user, int task, int thread)
{
    (void)thread;
    build_job *job = user;
    sss_shape *ss = &job->cache->shapes[job->scatter_shape];
    int first = task * POINTS_PER_TASK, last = first + POINTS_PER_TASK;
    if (last > ss->n)
        last = ss->n;
    for (int j = first; j < last; j++)
        if (ss->rmap[j] >= 0)
            ss->pts[j].m = op_sss_tree_sum(&ss->tree, &ss->dk.radial, ss->pts[j].p, ss->pts[j].n);
    op_progress_advance(job->prog, (uint64_t)(last - first));
}

typedef struct weigh_job {
    const sss_shape *ss;
    op_v3 *w, *wn, *ga;
} weigh_job;

/* The weights of one task's points (op_sss_radial's normalization): E_i A_i; and where a
 * computed receiver lies within the ball, g_i (per channel, clamped to [1/2, 2]) making the
 * point's near profile summed over the points within the ball what it is over the plane, the
 * weight E_i A_i g_i and the area A_i g_i its exact pairs use: each source hands on exactly its
 * energy whatever the local arrangement of the points (see docs/subsurface-rendering.md). */
static void weigh_task(void *user, int task, int thread)
{
    (void)thread;
    weigh_job *job = user;
    const sss_shape *ss = job->ss;
    const op_sss_radial *k = &ss->dk.radial;
    int first = task * POINTS_PER_TASK, last = first + POINTS_PER_TASK;
    if (last > ss->n)
        last = ss->n;
    for (int i = first; i < last; i++) {
        const sss_point *q = &ss->pts[i];
        job->w[i] = v3_scale(q->e, q->a);
        job->wn[i] = job->w[i];
        job->ga[i] = v3s(q->a);
        if (!ss->near_recv[i])
            continue; /* not used */
        float r2 = k->ball * k->ball;
        op_v3 got = v3s(0.0f);
        GRID_FOR_EACH(&ss->ballg, q->p, k->ball, j, {
            op_v3 d = v3_sub(ss->pts[j].p, q->p);
            float v[3];
            if (v3_dot(d, d) > r2 || v3_dot(ss->pts[j].n, q->n) <= 0.0f)
                continue;
            k->near(k->user, v3_len(d), v);
            got = v3_add(got, v3(v[0], v[1], v[2]));
        });
        got = v3_scale(got, q->a); /* its neighbours within the ball: of its level */
        float g[3], have[3] = {got.x, got.y, got.z};
        for (int c = 0; c < 3; c++) {
            float r = have[c] > 0.0f ? k->ball_total[c] / have[c] : 1.0f;
            g[c] = (r < 0.5f ? 0.5f : r > 2.0f ? 2.0f : r) * q->a;
        }
        job->ga[i] = v3(g[0], g[1], g[2]);
        job->wn[i] = v3_mul(q->e, job->ga[i]);
    }
}

/* The hierarchical stage of shape job->scatter_shape: the tree weighed with E_i A_i g_i (zero
 * at the points that are not sources), then M at each computed receiver from its own walk of
 * the tree: the same bits for any thread count. */
static op_status tree_pass(build_job *job, const op_sss_build_options *opt, op_error *err)
{
    sss_shape *ss = &job->cache->shapes[job->scatter_shape];
    size_t bytes = (size_t)ss->n * sizeof(op_v3);
    weigh_job wj = {ss, malloc(bytes), malloc(bytes), malloc(bytes)};
    int ntasks = (ss->n + POINTS_PER_TASK - 1) / POINTS_PER_TASK;
    op_status st = OP_OK;
    if (!wj.w || !wj.wn || !wj.ga)
        st = op_error_set(err, OP_ERR_NOMEM, "out of memory for %d irradiance points", ss->n);
    if (st == OP_OK)
        st = op_parallel_for(opt->threads, ntasks, weigh_task, &wj, opt->cancel, err);
    if (st == OP_OK)
        st = op_sss_tree_weigh(&ss->tree, wj.w, wj.wn, wj.ga, err);
    free(wj.w);
    free(wj.wn);
    free(wj.ga);
    if (st == OP_OK)
        st = op_parallel_for(opt->threads, ntasks, tree_task, job, opt->cancel, err);
    return st;
}

/* The scattering stage: M at the receivers of every shape. Its progress report (job->prog) and
 * per-thread kernel rows (job->rows) live for exactly the duration of this call, whatever it
 * returns; on an error or cancellation the receivers' M is incomplete and the caller drops the
 * cache. */
static op_status scatter_pass(build_job *job, const op_sss_build_options *opt, op_error *err)
{
    op_sss_cache *c = job->cache;
    int threads = op_parallel_threads(opt->threads);
    if (!(job->rows = calloc((size_t)threads, sizeof *job->rows)))
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    op_status st = OP_OK;
    uint64_t npts = 0; /* scatter_task runs over all the points of the shapes it scatters */
    for (int s = 0; s < c->n; s++)
        if (c->shapes[s].nrecv > 0)
            npts += (uint64_t)c->shapes[s].n;
    job->prog = op_progress_begin("subsurface", npts, opt->progress, opt->progress_user);
    for (int s = 0; st == OP_OK && s < c->n; s++) {
        sss_shape *ss = &c->shapes[s];
        if (ss->nrecv == 0)
            continue;
        if (ss->hier) {
            job->scatter_shape = s;
            st = tree_pass(job, opt, err);
            continue;
        }
        int K = ss->kernel;
        for (int i = 0; i < threads && st == OP_OK; i++) {
            free(job->rows[i]);
            if (!(job->rows[i] = malloc((size_t)ss->channels * K * K * sizeof(float))))
                st = op_error_set(err, OP_ERR_NOMEM, "out of memory");
        }
        /* the chunks are fixed ranges of the whole layout, whatever the camera needs, so a
         * receiver's sum runs in the same order as in the full computation (chunk_range) */
        int nf = ss->nfull;
        ss->nchunks = (nf + POINTS_PER_TASK - 1) / POINTS_PER_TASK;
        int most = (int)fmin(MAX_CHUNKS, fmax(1.0, MAX_ACC_BYTES / (12.0 * nf)));
        if (ss->nchunks > most)
            ss->nchunks = most;
        job->chunk = (nf + ss->nchunks - 1) / ss->nchunks;
        ss->nchunks = (nf + job->chunk - 1) / job->chunk;
        if (st == OP_OK &&
            !(ss->acc = calloc((size_t)ss->nchunks * 3 * (size_t)ss->nrecv, sizeof(float))))
            st = op_error_set(err, OP_ERR_NOMEM, "out of memory for the subsurface pass");
        job->scatter_shape = s;
        if (st == OP_OK)
            st = op_parallel_for(opt->threads, ss->nchunks, ss->centred ? centred_task : scatter_task,
                                 job, opt->cancel, err);
        if (st == OP_OK && atomic_load(&job->nomem))
            st = op_error_set(err, OP_ERR_NOMEM, "out of memory in the subsurface pass");
        if (st == OP_OK) {
            float k = ss->centred ? 1.0f : ss->a_i / ss->a_pix;
            for (int j = 0; j < ss->n; j++) {
                int rj = ss->rmap[j];
                if (rj < 0)
                    continue;
                double m[3] = {0, 0, 0};
                for (int ch = 0; ch < ss->nchunks; ch++)
                    for (int q = 0; q < 3; q++)
                        m[q] += ss->acc[((size_t)ch * ss->nrecv + (size_t)rj) * 3 + q];
                ss->pts[j].m = v3((float)m[0] * k, (float)m[1] * k, (float)m[2] * k);
            }
        }
        free(ss->acc);
        ss->acc = NULL;
    }
    op_progress_end(job->prog);
    job->prog = NULL;
    for (int i = 0; i < threads; i++)
        free(job->rows[i]);
    free(job->rows);
    job->rows = NULL;
    return st;
}

/* Makes the store's entry for subsurface index sss ready for a layout of n points: allocated
 * (empty) when it has none or holds the other layout of a windowed shape (d). Entries of the
 * same key always have the layout's point count; one that does not is refused (a damaged file
 * that kept its checksum, or a key collision). */
static op_status saved_prepare(op_sss_store *store, int sss, int n, const op_sss_desc *d,
                               const char *label, op_error *err)
{
    if (sss >= store->nshapes)
        return op_error_set(err, OP_ERR_FORMAT, "%s: the pre-pass cache holds %d translucent "
                            "shapes, the scene has more", label, store->nshapes);
    op_sss_saved *sv = &store->shapes[sss];
    if (sv->n == n)
        return OP_OK;
    if (d->windowed && (sv->n == d->points || sv->n == d->max_points)) {
        /* the other of a windowed shape's two layouts (another view): recomputed */
        free(sv->has);
        free(sv->e);
        free(sv->m);
        sv->n = 0;
    }
    if (sv->n != 0)
        return op_error_set(err, OP_ERR_FORMAT, "%s: the pre-pass cache holds %d irradiance "
                            "points for this shape, the scene lays %d", label, sv->n, n);
    sv->has = calloc((size_t)n, 1);
    sv->e = calloc(3 * (size_t)n, sizeof *sv->e);
    sv->m = calloc(3 * (size_t)n, sizeof *sv->m);
    if (!sv->has || !sv->e || !sv->m) {
        free(sv->has);
        free(sv->e);
        free(sv->m);
        sv->has = NULL;
        sv->e = sv->m = NULL;
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for the pre-pass cache");
    }
    sv->n = n;
    return OP_OK;
}

/* Adds what a finished build computed to the store (every shape whose points were laid has its
 * entry, from saved_prepare) and counts it. */
static void store_update(op_sss_store *store, const op_sss_cache *c)
{
    for (int s = 0; s < c->n; s++) {
        const sss_shape *ss = &c->shapes[s];
        if (!ss->pts || ss->unsaved)
            continue;
        op_sss_saved *sv = &store->shapes[s];
        for (int k = 0; k < ss->nsrc; k++) {
            int i = ss->src[k];
            size_t g = (size_t)point_index(ss, i);
            float *e = sv->e + 3 * g;
            e[0] = ss->pts[i].e.x;
            e[1] = ss->pts[i].e.y;
            e[2] = ss->pts[i].e.z;
            sv->has[g] |= OP_SSS_HAS_E;
        }
        for (int j = 0; j < ss->n && !ss->levels; j++)
            if (ss->rmap[j] >= 0) {
                size_t g = (size_t)point_index(ss, j);
                float *m = sv->m + 3 * g;
                m[0] = ss->pts[j].m.x;
                m[1] = ss->pts[j].m.y;
                m[2] = ss->pts[j].m.z;
                sv->has[g] |= OP_SSS_HAS_M;
            }
        store->reused_e += ss->reused_src;
        store->reused_m += ss->reused_recv;
        store->new_e += ss->nsrc;
        store->new_m += ss->levels ? 0 : ss->nrecv;
    }
}

/* The camera-marking phase: which translucent shapes some camera segment reaches (all of them
 * when opt->everywhere), and the segments' hits (*gh rows in cam->rows, owned by the caller
 * and freed with cam_free). */
static op_status mark_reached(const op_scene *scene, op_sss_cache *c, const op_sss_build_options *opt,
                              cam_job *cam, int *gh, op_error *err)
{
    memset(cam, 0, sizeof *cam);
    *gh = 0;
    if (!opt->everywhere)
        return camera_pass(scene, c, opt, cam, gh, err);
    for (int i = 0; i < c->n; i++)
        c->shapes[i].reached = 1;
    return OP_OK;
}

static void cam_free(cam_job *cam, int gh)
{
    for (int r = 0; r < gh; r++)
        free(cam->rows[r].h);
    free(cam->rows);
    cam->rows = NULL;
}

/* The point phase of one reached translucent shape sh (its sss_shape ss, desc set): lays its
 * points, builds its lookup structures (grids; the tree and profile for the hierarchical sum),
 * marks its receivers (every point, or those near the camera's hits in cam: pix is the angle
 * between neighbouring corner rays), and selects what must be computed against the store:
 * receivers (rmap) and sources (src), taking what the store holds. */
static op_status prepare_shape(const op_scene *scene, const op_shape_rec *sh, sss_shape *ss,
                               const op_sss_build_options *opt, const cam_job *cam, int gh,
                               float pix, op_error *err)
{
    op_status st = make_points(scene, sh, ss, opt->everywhere ? NULL : cam, gh, pix, err);
    if (st)
        return st;
    int half = ss->kernel / 2;
    ss->h = ss->centred ? 2.0f * ss->spacing : 2.0f * fmaxf(ss->spacing, fmaxf(ss->px, ss->py));
    if (!ss->hier) {
        /* centred: a receiver lies less than half + 1 pixels from the source along each of
         * its frame's axes */
        ss->radius = ss->centred ? ((float)half + 1.0f) * (float)M_SQRT2 * fmaxf(ss->px, ss->py)
                                 : ((float)half + 1.5f) * fmaxf(ss->px, ss->py);
        st = grid_build(&ss->gather, ss->pts, ss->n, NULL, scene->bmin, 0.5f * ss->radius, err);
    } else {
        st = tree_prepare(ss, scene->bmin, err);
    }
    if (st == OP_OK)
        st = grid_build(&ss->interp, ss->pts, ss->n, NULL, scene->bmin, ss->h, err);
    if (st == OP_OK && !(ss->recv = calloc((size_t)ss->n, 1)))
        st = op_error_set(err, OP_ERR_NOMEM, "out of memory");
    ss->hr = ss->h;
    if (st == OP_OK && ss->hier && !opt->everywhere) {
        /* exitance at the image's resolution: receivers a twelfth of the smallest pixel
         * footprint on the shape apart where that is at least 2 point spacings */
        float foot = FLT_MAX;
        for (int r = 0; r < gh; r++)
            for (int k = 0; k < cam->rows[r].n; k++)
                if (cam->rows[r].h[k].sss == sh->sss)
                    foot = fminf(foot, pix * cam->rows[r].h[k].span);
        if (foot < FLT_MAX && foot / 12.0f >= 2.0f * ss->spacing)
            st = thin_receivers(ss, scene->bmin, foot / 12.0f, err);
    }
    if (st)
        return st;
    if (opt->everywhere) {
        memset(ss->recv, 1, (size_t)ss->n);
    } else {
        /* a sample lies within one grid spacing (pix * span) of a traced hit; the points its
         * interpolation uses lie within h of the sample */
        for (int r = 0; r < gh; r++)
            for (int k = 0; k < cam->rows[r].n; k++) {
                const cam_hit *hh = &cam->rows[r].h[k];
                if (hh->sss == sh->sss)
                    mark_near(ss, hh->p, ss->hr + pix * hh->span);
            }
    }
    op_sss_saved *sv = NULL;
    /* the store holds 25 bytes per point of the whole layout: a windowed shape of more than
     * UNSAVED_FACTOR x maxPoints is computed without it */
    ss->unsaved = opt->store && ss->gid &&
                  (long long)ss->nfull > UNSAVED_FACTOR * (long long)ss->desc->max_points;
    if (ss->unsaved)
        op_log(OP_LOG_INFO, "%s: not kept in the pre-pass cache (%d irradiance points in its "
               "whole layout, over %d x maxPoints)", sh->label, ss->nfull, UNSAVED_FACTOR);
    if (opt->store && !ss->unsaved) {
        st = saved_prepare(opt->store, sh->sss, ss->nfull, ss->desc, sh->label, err);
        if (st)
            return st;
        sv = &opt->store->shapes[sh->sss];
    }
    st = ss->hier ? select_tree(ss, sv, opt, err) : select_points(ss, sv, err);
    if (st)
        return st;
    op_log(OP_LOG_INFO, "%s: %d irradiance points laid of %d (%.3g per material pixel), %d x %d "
           "pixels of %.3g x %.3g scene units; the camera needs exitance at %d, irradiance at %d",
           sh->label, ss->n, ss->nfull, ss->a_pix / ss->a_i, ss->width, ss->height, ss->px, ss->py,
           ss->nrecv + ss->reused_recv, ss->nsrc + ss->reused_src);
    if (opt->store)
        op_log(OP_LOG_DEBUG, "%s: from the pre-pass cache: irradiance at %d, exitance at %d; "
               "computed: irradiance at %d, exitance at %d", sh->label, ss->reused_src,
               ss->reused_recv, ss->nsrc, ss->nrecv);
    return OP_OK;
}

/* The point phase of every translucent shape (prepare_shape for those reached). */
static op_status prepare_shapes(const op_scene *scene, op_sss_cache *c, const op_sss_build_options *opt,
                                const cam_job *cam, int gh, op_error *err)
{
    /* the angle between neighbouring grid rays, bounded over the image plane */
    const op_camera *cm = &scene->camera;
    float pix = 2.0f * fmaxf(cm->tan_x / (float)cm->full_width, cm->tan_y / (float)cm->full_height) *
                (1.0f + cm->tan_x * cm->tan_x + cm->tan_y * cm->tan_y);
    for (int s = 0; s < scene->nshapes; s++) {
        if (opt->cancel && atomic_load(opt->cancel))
            return op_error_set(err, OP_ERR_CANCELLED, "interrupted");
        const op_shape_rec *sh = &scene->shapes[s];
        if (sh->sss < 0)
            continue;
        sss_shape *ss = &c->shapes[sh->sss];
        ss->desc = &scene->sss[sh->sss];
        if (!ss->reached) {
            op_log(OP_LOG_INFO, "%s: no camera segment reaches this translucent shape: no "
                   "irradiance points", sh->label);
            continue;
        }
        op_status st = prepare_shape(scene, sh, ss, opt, cam, gh, pix, err);
        if (st)
            return st;
    }
    return OP_OK;
}

/* The irradiance phase: E at every shape's listed sources (src), in tasks of POINTS_PER_TASK
 * points of one shape (job->task_shape/task_first, freed by the caller). */
static op_status irradiance_phase(build_job *job, const op_sss_build_options *opt, op_error *err)
{
    const op_sss_cache *c = job->cache;
    long long ntasks = 0;
    uint64_t nsrc = 0;
    for (int s = 0; s < c->n; s++) {
        ntasks += (c->shapes[s].nsrc + POINTS_PER_TASK - 1) / POINTS_PER_TASK;
        nsrc += (uint64_t)c->shapes[s].nsrc;
    }
    if (ntasks == 0)
        return OP_OK;
    if (ntasks > INT32_MAX)
        return op_error_set(err, OP_ERR_NOMEM, "too many irradiance points");
    job->task_shape = malloc((size_t)ntasks * sizeof(int));
    job->task_first = malloc((size_t)ntasks * sizeof(int));
    if (!job->task_shape || !job->task_first)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    int t = 0;
    for (int s = 0; s < c->n; s++)
        for (int k = 0; k < c->shapes[s].nsrc; k += POINTS_PER_TASK) {
            job->task_shape[t] = s;
            job->task_first[t++] = k;
        }
    return irradiance_pass(job, opt, (int)ntasks, nsrc, err);
}

op_status op_sss_cache_build(const op_scene *scene, const op_sss_build_options *opt,
                             op_sss_cache **out, op_error *err)
{
    double t0 = op_monotonic_seconds();
    op_sss_cache *c = calloc(1, sizeof *c);
    if (!c)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    c->n = scene->nsss;
    c->shapes = calloc((size_t)(c->n ? c->n : 1), sizeof *c->shapes);
    if (!c->shapes) {
        free(c);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    }
    cam_job cam;
    int gh = 0;
    op_status st = mark_reached(scene, c, opt, &cam, &gh, err);
    double tc = op_monotonic_seconds();
    if (st == OP_OK)
        st = prepare_shapes(scene, c, opt, &cam, gh, err);
    cam_free(&cam, gh);
    double tp = op_monotonic_seconds();
    build_job job;
    memset(&job, 0, sizeof job);
    job.scene = scene;
    job.transport = opt->transport;
    job.cache = c;
    job.seed = opt->seed;
    job.cancel = opt->cancel;
    if (st == OP_OK)
        st = irradiance_phase(&job, opt, err);
    double t1 = op_monotonic_seconds();
    /* with a store, every irradiance a scatter needs may be known already */
    int scatter = 0;
    for (int s = 0; s < c->n; s++)
        scatter |= c->shapes[s].nrecv > 0;
    if (st == OP_OK && scatter)
        st = scatter_pass(&job, opt, err);
    free(job.task_shape);
    free(job.task_first);
    double te = op_monotonic_seconds();
    c->seconds = te - t0;
    if (st == OP_OK && c->n > 0)
        op_log(OP_LOG_INFO, "subsurface pre-pass: %.3f s (camera pass %.3f s, points %.3f s, "
               "irradiance %.3f s, scattering %.3f s)", te - t0, tc - t0, tp - tc, t1 - tp,
               te - t1);
    if (st) {
        op_sss_cache_free(c);
        return st;
    }
    if (opt->store)
        store_update(opt->store, c);
    *out = c;
    return OP_OK;
}

void op_sss_cache_free(op_sss_cache *c)
{
    if (!c)
        return;
    for (int i = 0; i < c->n; i++) {
        sss_shape *ss = &c->shapes[i];
        free(ss->pts);
        free(ss->gid);
        op_sss_tree_free(&ss->tree);
        free(ss->near_recv);
        free(ss->rep);
        grid_free(&ss->look);
        grid_free(&ss->ballg);
        op_sss_dipole_kernel_free(&ss->dk);
        free(ss->recv);
        free(ss->rmap);
        free(ss->src);
        free(ss->acc);
        free(ss->gpts);
        grid_free(&ss->gather);
        grid_free(&ss->interp);
    }
    free(c->shapes);
    free(c);
}

int op_sss_cache_points(const op_sss_cache *c, int sss)
{
    return sss >= 0 && sss < c->n ? c->shapes[sss].n : 0;
}

void op_sss_cache_stats(const op_sss_cache *c, op_sss_stats *st)
{
    memset(st, 0, sizeof *st);
    for (int i = 0; i < c->n; i++) {
        st->points += c->shapes[i].n;
        st->sources += c->shapes[i].nsrc;
        st->receivers += c->shapes[i].nrecv;
        st->sources_reused += c->shapes[i].reused_src;
        st->receivers_reused += c->shapes[i].reused_recv;
        st->shapes_reached += c->shapes[i].reached;
    }
    st->seconds = c->seconds;
}

/* The weighted mean of the exitance of the points within h of p (same-side normals) into *out
 * (0 where none); returns 0 when one of them is not a receiver (*out is then meaningless). Weights 1 - r^2/h^2, or for the
 * centred layout Franke and Little's ((h - r) / r)^2: each point's own value at its position
 * (the material pixel's exitance at its centre), smooth between. */
static int lookup_within(const sss_shape *ss, op_v3 p, op_v3 n, float h, op_v3 *out, float *wsum)
{
    float h2 = h * h;
    op_v3 m = v3s(0.0f);
    int ok = 1;
    *wsum = 0.0f;
    GRID_FOR_EACH(ss->rep ? &ss->look : &ss->interp, p, h, i, {
        const sss_point *q = &ss->pts[i];
        op_v3 d = v3_sub(q->p, p);
        float w = 1.0f - v3_dot(d, d) / h2;
        if (w <= 0.0f || v3_dot(q->n, n) <= 0.0f)
            continue;
        if (ss->centred) {
            float r = sqrtf(1.0f - w);
            w = (1.0f - r) / (r + 1e-4f);
            w *= w;
        } else if (ss->rep) { /* thinned receivers: the nearest count most (a narrower blur) */
            w *= w * w * w;
        }
        if (!ss->recv[i])
            ok = 0;
        *wsum += w;
        m = v3_add(m, v3_scale(q->m, w));
    });
    *out = *wsum > 0.0f ? v3_scale(m, 1.0f / *wsum) : v3s(0.0f);
    return ok;
}

int op_sss_lookup(const op_sss_cache *c, int sss, op_v3 p, op_v3 n, op_v3 *out)
{
    const sss_shape *ss = &c->shapes[sss];
    *out = v3s(0.0f);
    if (!ss->pts)
        return 0;
    float wsum;
    /* centred: the points of p's own material pixel (1.5 spacings: a pixel's (sub-)centres
     * and not its neighbours'), all within h where none is that close (a stretched map) */
    if (ss->centred && lookup_within(ss, p, n, 0.75f * ss->h, out, &wsum) && wsum > 0.0f)
        return 1;
    /* no point at all near p (outside a windowed shape's laid part): no exitance either */
    if (lookup_within(ss, p, n, ss->hr, out, &wsum) && wsum > 0.0f)
        return 1;
    *out = v3s(0.0f);
    return 0;
}

op_v3 op_sss_exitance(const op_sss_cache *c, int sss, op_v3 p, op_v3 n)
{
    op_v3 m;
    op_sss_lookup(c, sss, p, n, &m);
    return m;
}
