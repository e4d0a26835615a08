/* layout.c - where a translucent shape's irradiance points go (see layout.h). */
#include "sss/layout.h"

#include "sss/measured_points.h"

#include <float.h>
#include <limits.h>

/* What the warnings of a shape given fewer irradiance points than it needs tell the user. */
#define OP_SSS_RAISE_CAP "raise maxPoints (Blender: Render Properties > opaline > Irradiance " \
                         "Point Cap)"

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

/* The points a measured material lays on mesh m (sss/measured_points.h): one per sample of the
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

op_status op_sss_plan(const op_scene *scene, long long max_total, op_sss_plan_entry *plan,
                      op_error *err)
{
    op_v3 ext = v3_sub(scene->bmax, scene->bmin);
    double extent = fmax(ext.x, fmax(ext.y, ext.z)), total = 0.0;
    for (int i = 0; i < scene->nshapes; i++) {
        const op_shape_rec *sh = &scene->shapes[i];
        if (sh->sss < 0)
            continue;
        const op_sss_desc *d = &scene->sss[sh->sss];
        op_sss_plan_entry *p = &plan[sh->sss];
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
        p->windowed = 0;
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
            /* more than a layout can index: its finest layout is the first area-uniform level
             * (4^l times fewer points) that can */
            for (p->coarse = 0; want > INT32_MAX; p->coarse++) {
                want = ceil(want / 4.0);
                step = 0.0;
            }
            p->points = p->finest = want < 1.0 ? 1 : step > 0.0 ? (int)want : (int)ceil(want);
            p->windowed = p->points > d->max_points;
        } else if (want > d->max_points && want <= INT32_MAX &&
                   level_first((long long)ceil(want), DIPOLE_LEVELS) <= INT32_MAX) {
            /* the dipole's layout in levels, windowed in the same way */
            p->finest = (int)ceil(want);
            p->points = (int)level_first(p->finest, DIPOLE_LEVELS);
            p->windowed = 1;
        } else {
            p->capped = want > d->max_points;
            if (p->capped)
                op_log(OP_LOG_WARN, "%s: subsurface needs %.3g irradiance points at the "
                       "profile's spacing; capped at %d (coarser than the profile): %s",
                       sh->label, want, d->max_points, OP_SSS_RAISE_CAP);
            p->points = p->finest =
                want < 1.0 ? 1 : want > d->max_points ? d->max_points : (int)ceil(want);
        }
        total += p->windowed ? d->max_points : p->points;
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

/* A windowed layout's room: maxPoints points and their indices in the whole layout; 0 when out
 * of memory. */
static int window_alloc(sss_shape *ss)
{
    ss->pts = calloc((size_t)ss->desc->max_points, sizeof *ss->pts);
    ss->gid = malloc((size_t)ss->desc->max_points * sizeof *ss->gid);
    return ss->pts && ss->gid;
}

/* Keeps the first laid (> 0) points of a windowed layout, its room shrunk to them; returns 1. */
static int window_keep(sss_shape *ss, int laid)
{
    ss->n = laid;
    sss_point *p = realloc(ss->pts, (size_t)laid * sizeof *p);
    int *g = realloc(ss->gid, (size_t)laid * sizeof *g);
    if (p)
        ss->pts = p;
    if (g)
        ss->gid = g;
    return 1;
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

/* Lays a measured material's points at its pixel (sub-)centres (sss/measured_points.h), at most ss->n
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
static float hits_span(const cam_row *rows, int gh, int sss, float pix)
{
    float span = 0.0f;
    for (int r = 0; r < gh; r++)
        for (int k = 0; k < rows[r].n; k++)
            if (rows[r].h[k].sss == sss)
                span = fmaxf(span, pix * rows[r].h[k].span);
    return span;
}

/* The window of every point within d of a camera hit on shape sss: the cells of side d / 4
 * within 4 of a cell that holds a hit (such a point lies in one), with their bounds. Returns 1,
 * -1 when out of memory, and 0 when cap > 0 and the hits' cells are more than cap / 4. */
static int hit_window(const cam_row *rows, int gh, int sss, float d, int cap, cell_set *win)
{
    cell_set hits;
    memset(&hits, 0, sizeof hits);
    memset(win, 0, sizeof *win);
    hits.cells.cell = win->cells.cell = d / 4.0f;
    int ok = 1, over = 0;
    for (int r = 0; r < gh && ok && !over; r++)
        for (int k = 0; k < rows[r].n && ok && !over; k++)
            if (rows[r].h[k].sss == sss) {
                int32_t c[3];
                cell_of(&hits.cells, rows[r].h[k].p, c);
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
static float window_reach(const sss_shape *ss, int sss, const cam_row *rows, int gh, float pix)
{
    return hits_span(rows, gh, sss, pix) + ss->h + 2.0f * sqrtf(3.0f) * ss->radius + ss->spacing;
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
    if (!window_alloc(ss))
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
    return window_keep(ss, j.laid);
}

/* The barycentrics of point k of an area-uniform layout within its triangle: the R2 sequence. */
static void uniform_bary(long long k, float *b1, float *b2)
{
    double r1 = 0.5 + (double)k * 0.7548776662466927, r2 = 0.5 + (double)k * 0.5698402909980532;
    op_sample_triangle((float)(r1 - floor(r1)), (float)(r2 - floor(r2)), b1, b2);
}

/* Point k of the area-uniform layout of n points on mesh m (in triangle t): systematic
 * sampling of the area, an R2 sequence inside each triangle; a material tiled every sx x sy. */
static void uniform_point(const op_trimesh *m, const sss_shape *ss, long long k, int t, double sx,
                          double sy, sss_point *q)
{
    float b1, b2;
    uniform_bary(k, &b1, &b2);
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
 * tree aggregates clusters of up to theta x that distance (and, within a channel's fade
 * radius, of up to 0.75 of its diffusion length): its points are at most half of theta x that
 * distance apart and, within a channel's fade radius, half its diffusion length. The
 * regions end past the profile's reach. Returns -1 when out of memory, 0 when the hits' cells
 * of region 0 are too many for maxPoints (each hit's disk of radius D_0, at least 12 spacings,
 * is in it, and overlaps those of at most 81 others in distinct cells: over 5.6 points per
 * cell), 1 when planned. */
static int level_plan_build(const sss_shape *ss, int sss, const cam_row *rows, int gh, float pix,
                            const op_sss_dipole_kernel *dk, level_plan *lp)
{
    memset(lp, 0, sizeof *lp);
    float span = hits_span(rows, gh, sss, pix);
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
        int got = hit_window(rows, gh, sss, d, j == 0 ? ss->desc->max_points : 0, &lp->win[j]);
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
    if (!window_alloc(ss))
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
                float b1, b2;
                uniform_bary(k, &b1, &b2);
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
    return window_keep(ss, laid);
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

/* Reports a measured shape laid coarser than its material (ss->spacing apart): a warning, and
 * ss->capped, where that is coarser than the smallest pixel footprint of the camera's hits on it
 * (rows: gh rows; NULL: every point is needed), so that the image shows it; else a note. */
static void coarse_note(const op_shape_rec *sh, sss_shape *ss, const cam_row *rows, int gh,
                        float pix)
{
    float foot = FLT_MAX;
    for (int r = 0; rows && r < gh; r++)
        for (int k = 0; k < rows[r].n; k++)
            if (rows[r].h[k].sss == sh->sss)
                foot = fminf(foot, pix * rows[r].h[k].span);
    ss->capped = !rows || ss->spacing > foot;
    double need = ldexp((double)ss->plan->finest, 2 * ss->plan->coarse);
    if (ss->capped)
        op_log(OP_LOG_WARN, "%s: subsurface: the view needs more of its %.3g irradiance points "
               "(one per material pixel) than maxPoints; capped at %d (%.3g scene units apart, "
               "coarser than the image's finest pixel on it, %.3g: the material's detail is "
               "blurred): %s", sh->label, need, ss->n, ss->spacing, foot < FLT_MAX ? foot : 0.0f,
               OP_SSS_RAISE_CAP);
    else
        op_log(OP_LOG_INFO, "%s: subsurface: the view needs more of its %.3g irradiance points "
               "(one per material pixel) than maxPoints; laid %d, %.3g scene units apart, "
               "within the image's finest pixel on it (%.3g)", sh->label, need, ss->n,
               ss->spacing, foot);
}

/* At most the surface area of shape sss that the camera's hits see: per hit the solid angle
 * between neighbouring corner rays, bounded below over the image plane (0 for a camera
 * without an image plane), times dist^2 / |cos|. */
static double seen_area(const op_scene *scene, const cam_row *rows, int gh, int sss)
{
    const op_camera *cm = &scene->camera;
    if (!(cm->tan_x > 0.0f && cm->tan_y > 0.0f))
        return 0.0;
    double t2 = (double)cm->tan_x * cm->tan_x + (double)cm->tan_y * cm->tan_y;
    double a = 2.0 * fmin(cm->tan_x / (double)cm->full_width,
                          cm->tan_y / (double)cm->full_height) / (1.0 + t2);
    double sum = 0.0;
    for (int r = 0; r < gh; r++)
        for (int k = 0; k < rows[r].n; k++)
            if (rows[r].h[k].sss == sss) {
                double span = rows[r].h[k].span;
                sum += a * a * span * span * rows[r].h[k].cosine;
            }
    return sum;
}

/* Lays a windowed shape's points near the view (the camera's hits in rows: gh rows; pix the
 * angle between neighbouring rays): the dipole in levels around it (level_plan_build,
 * lay_levels), a measured material at its physical size at its pixel centres within reach
 * (lay_window), one on a stretched map as the points of its area-uniform layout within reach
 * (lay_levels with one region). Sets *laid to 1 when they are laid, 0 when the view needs more
 * than maxPoints (nothing usable is laid). */
static op_status lay_near_view(const op_scene *scene, const op_shape_rec *sh, sss_shape *ss,
                               const cam_row *rows, int gh, float pix, double sx, double sy,
                               int *laid, op_error *err)
{
    const op_trimesh *m = &sh->mesh;
    level_plan lp;
    memset(&lp, 0, sizeof lp);
    int got;
    if (ss->hier) {
        /* the finest level's points: the profile's spacing */
        ss->a_i = m->area / (float)ss->plan->finest;
        ss->spacing = sqrtf(ss->a_i);
        ss->h = 2.0f * fmaxf(ss->spacing, fmaxf(ss->px, ss->py)); /* prepare_shape's */
        op_sss_dipole_kernel dk;
        op_status st = op_sss_dipole_kernel_init(&dk, &ss->desc->dipole, ss->a_i, ss->spacing,
                                                 err);
        if (st)
            return st;
        got = level_plan_build(ss, sh->sss, rows, gh, pix, &dk, &lp);
        op_sss_dipole_kernel_free(&dk);
        if (got > 0)
            got = lay_levels(m, ss, sx, sy, ss->plan->finest, &lp);
        ss->levels = got > 0;
        if (got > 0) {
            int fine = 0;
            for (int i = 0; i < ss->n; i++)
                fine += ss->gid[i] < ss->plan->finest;
            op_log(OP_LOG_DEBUG, "%s: subsurface: %d regions around the view, %d points at the "
                   "profile's spacing and %d coarser", sh->label, lp.nregions, fine,
                   ss->n - fine);
        }
    } else {
        /* a measured material: its finest layout (the pixel centres, else area-uniform) near
         * the view, else the first coarser area-uniform level (4^l times fewer points) whose
         * points near the view fit; a level as coarse as maxPoints over the whole shape is
         * left to the caller */
        double step = ss->plan->coarse ? 0.0 : centred_step(m, ss->width, ss->height, sx, sy,
                                                            ss->a_pix, ss->desc->density);
        int half = ss->kernel / 2;
        /* a level whose points on the surface seen are over twice maxPoints is not tried (the
         * window holds that surface; twice: for a surface seen twice, in a sheen) */
        double seen = seen_area(scene, rows, gh, sh->sss) / (double)m->area;
        got = 0;
        for (int l = 0; got == 0; l++) {
            long long n = level_points(ss->plan->finest, l);
            if (l > 0 && n <= ss->desc->max_points)
                break;
            if ((double)n * seen > 2.0 * ss->desc->max_points)
                continue;
            int centred = l == 0 && step > 0.0;
            /* the radii prepare_shape sets */
            ss->a_i = m->area / (float)n;
            ss->spacing = sqrtf(ss->a_i);
            if (centred) {
                ss->h = 2.0f * ss->spacing;
                ss->radius = ((float)half + 1.0f) * (float)M_SQRT2 * fmaxf(ss->px, ss->py);
            } else {
                ss->h = 2.0f * fmaxf(ss->spacing, fmaxf(ss->px, ss->py));
                ss->radius = ((float)half + 1.5f) * fmaxf(ss->px, ss->py);
            }
            level_plan_free(&lp);
            lp.nregions = 1;
            got = hit_window(rows, gh, sh->sss, window_reach(ss, sh->sss, rows, gh, pix), 0,
                             &lp.win[0]);
            lp.lo = lp.win[0].lo;
            lp.hi = lp.win[0].hi;
            if (got > 0) {
                free(ss->pts);
                free(ss->gid);
                ss->pts = NULL;
                ss->gid = NULL;
                got = centred ? lay_window(m, ss, sx, sy, step, &lp.win[0])
                              : lay_levels(m, ss, sx, sy, n, &lp);
            }
            ss->centred = got > 0 && centred;
            if (got > 0 && l > 0) {
                ss->nfull = (int)n;
                ss->coarse = l;
                coarse_note(sh, ss, rows, gh, pix);
            }
        }
    }
    level_plan_free(&lp);
    if (got < 0)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for %d irradiance points",
                            ss->desc->max_points);
    *laid = got;
    return OP_OK;
}

op_status op_sss_lay_points(const op_scene *scene, const op_shape_rec *sh, sss_shape *ss,
                             const cam_row *rows, int gh, float pix, op_error *err)
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
    int n = ss->plan->points; /* op_sss_plan */
    ss->n = ss->nfull = n;
    ss->a_i = m->area / (float)n;
    ss->spacing = sqrtf(ss->a_i);
    if (ss->plan->windowed) {
        int laid = 0;
        if (rows) {
            op_status st = lay_near_view(scene, sh, ss, rows, gh, pix, sx, sy, &laid, err);
            if (st)
                return st;
        }
        if (laid)
            return ss->hier ? spatial_order(ss, scene->bmin, scene->bmax, err) : OP_OK;
        free(ss->pts);
        free(ss->gid);
        ss->pts = NULL;
        ss->gid = NULL;
        n = ss->n = ss->nfull = ss->desc->max_points;
        ss->a_i = m->area / (float)n;
        ss->spacing = sqrtf(ss->a_i);
        if (ss->hier) {
            op_log(OP_LOG_WARN, "%s: subsurface: the view needs more of its %d irradiance "
                   "points (at the profile's spacing) than maxPoints; capped at %d (coarser "
                   "than the profile): %s", sh->label, ss->plan->finest, ss->desc->max_points,
                   OP_SSS_RAISE_CAP);
            ss->capped = 1;
        } else {
            coarse_note(sh, ss, rows, gh, pix);
        }
    }
    ss->pts = calloc((size_t)n, sizeof *ss->pts);
    if (!ss->pts)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for %d irradiance points", n);
    if (!ss->desc->is_dipole && !ss->plan->windowed) {
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
