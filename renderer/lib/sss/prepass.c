/* prepass.c - the subsurface pre-pass: camera marking, irradiance and exitance at the points
 * sss/layout.c lays (see prepass.h); the lookups over its result are sss/lookup.c's. */
#include "sss/prepass.h"

#include "sss/dipole_kernel.h"
#include "sss/layout.h"
#include "sss/lookup.h"
#include "sss/scatter.h"
#include "sss/shape_points.h"
#include "sss/tree.h"

#include <float.h>
#include <stddef.h>
#include <limits.h>
#include <stdlib.h>
#include <string.h>


/* The grid of the points i < ss->n with only[i] set (every point when only is NULL). */
static op_status point_grid(sss_grid *g, const sss_shape *ss, const unsigned char *only,
                            op_v3 origin, float cell, op_error *err)
{
    const char *p = ss->pts ? (const char *)ss->pts + offsetof(sss_point, p) : NULL;
    return op_sss_grid_build(g, p, sizeof *ss->pts, ss->pts ? ss->n : 0, only, origin, cell, err);
}

struct op_sss_prepass {
    sss_shape *shapes;
    int n;
    double seconds; /* the build's wall time */
};

/* The camera pass's job: the ray grid and its rows of translucent hits. */
typedef struct cam_job {
    const op_scene *scene;
    const op_sss_transport *transport;
    uint64_t seed;
    int ext, gw;      /* the ray grid: gw columns, film corners widened by ext pixels */
    cam_row *rows;
    atomic_int nomem;
} cam_job;

typedef struct build_job {
    const op_scene *scene;
    const op_sss_transport *transport;
    op_sss_prepass *prepass;
    uint64_t seed;
    atomic_int *cancel;
    op_progress *prog; /* the running stage's report, owned by its *_pass call; else NULL */
    /* task -> (shape, first point) */
    int *task_shape, *task_first;
    int scatter_shape; /* the shape the scattering stage is at */
} build_job;

enum { POINTS_PER_TASK = 256, UNSAVED_FACTOR = 16 };

static void irradiance_task(void *user, int task, int thread)
{
    (void)thread;
    build_job *job = user;
    sss_shape *ss = &job->prepass->shapes[job->task_shape[task]];
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
    h->cosine = fmaxf(cosine, 0.05f);
    h->span = dist / h->cosine;
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

/* Sets mark[i] for the points that may be receivers (rep) within r of p (exactly: a hashed
 * cell mark would also catch the far cells that share its bucket). */
static void mark_near(const sss_shape *ss, unsigned char *mark, op_v3 p, float r)
{
    float r2 = r * r;
    GRID_FOR_EACH(ss->rep ? &ss->look : &ss->interp, p, r, i, {
        op_v3 d = v3_sub(ss->pts[i].p, p);
        if (v3_dot(d, d) <= r2)
            mark[i] = 1;
    });
}

/* The receivers' marking of one shape: per thread its marks (thread 0's: ss->recv), per task
 * NEAR_ROWS rows of camera hits. */
enum { NEAR_ROWS = 8 };
typedef struct near_job {
    const sss_shape *ss;
    const cam_row *rows;
    int gh, sss;
    float pix;
    unsigned char **marks;
} near_job;

static void near_task(void *user, int task, int thread)
{
    near_job *job = user;
    int last = (task + 1) * NEAR_ROWS < job->gh ? (task + 1) * NEAR_ROWS : job->gh;
    for (int r = task * NEAR_ROWS; r < last; r++)
        for (int k = 0; k < job->rows[r].n; k++) {
            const cam_hit *hh = &job->rows[r].h[k];
            /* a sample lies within one grid spacing (pix * span) of a traced hit; the points
             * its interpolation uses lie within hr of the sample */
            if (hh->sss == job->sss)
                mark_near(job->ss, job->marks[thread], hh->p, job->ss->hr + job->pix * hh->span);
        }
}

/* Sets ss->recv (allocated, zero) for the points near the camera's hits on shape sss. */
static op_status mark_receivers(sss_shape *ss, int sss, const cam_job *cam, int gh, float pix,
                                const op_sss_prepass_options *opt, op_error *err)
{
    int threads = op_parallel_threads(opt->threads);
    near_job job = {ss, cam->rows, gh, sss, pix, calloc((size_t)threads, sizeof(unsigned char *))};
    op_status st = OP_OK;
    if (!job.marks)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for %d irradiance points", ss->n);
    job.marks[0] = ss->recv;
    for (int t = 1; st == OP_OK && t < threads; t++)
        if (!(job.marks[t] = calloc((size_t)ss->n, 1)))
            st = op_error_set(err, OP_ERR_NOMEM, "out of memory for %d irradiance points", ss->n);
    if (st == OP_OK)
        st = op_parallel_for(opt->threads, (gh + NEAR_ROWS - 1) / NEAR_ROWS, near_task, &job,
                             opt->cancel, err);
    for (int t = 1; t < threads; t++) {
        for (int i = 0; st == OP_OK && i < ss->n; i++)
            ss->recv[i] |= job.marks[t][i];
        free(job.marks[t]);
    }
    free(job.marks);
    return st;
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
    sss_cells cells = {sr, origin};
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
    return point_grid(&ss->look, ss, ss->rep, origin, ss->hr, err);
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

/* Sets need[i] for the points i of one task whose gather cells hold a marked cell. */
typedef struct need_job {
    const sss_shape *ss;
    cell_set marked; /* the gather cells that hold a computed receiver */
    unsigned char *need;
} need_job;

static void need_task(void *user, int task, int thread)
{
    (void)thread;
    need_job *job = user;
    int last = (task + 1) * POINTS_PER_TASK < job->ss->n ? (task + 1) * POINTS_PER_TASK : job->ss->n;
    for (int i = task * POINTS_PER_TASK; i < last; i++) {
        int32_t cells[OP_SSS_GATHER_CELLS][3];
        int ncells = op_sss_gather_cells(job->ss, &job->ss->pts[i], cells);
        for (int ci = 0; ci < ncells && !job->need[i]; ci++)
            job->need[i] = (unsigned char)cell_set_has(&job->marked, cells[ci]);
    }
}

/* The scatter's selection (select_receivers, then): the sources, the points whose gather cells
 * (op_sss_gather_cells, those the scatter visits) hold a computed receiver. */
static op_status select_points(sss_shape *ss, const op_sss_saved *sv,
                               const op_sss_prepass_options *opt, op_error *err)
{
    const sss_grid *g = &ss->gather;
    op_status st = select_receivers(ss, sv, err);
    if (st)
        return st;
    need_job job = {.ss = ss, .need = calloc((size_t)ss->n + 1, 1)};
    int ok = job.need != NULL;
    for (int j = 0; j < ss->n && ok; j++)
        if (ss->rmap[j] >= 0)
            ok = cell_set_add(&job.marked, g->coord + 3 * j);
    if (!ok)
        st = op_error_set(err, OP_ERR_NOMEM, "out of memory for %d irradiance points", ss->n);
    if (st == OP_OK && job.marked.count > 0)
        st = op_parallel_for(opt->threads, (ss->n + POINTS_PER_TASK - 1) / POINTS_PER_TASK,
                             need_task, &job, opt->cancel, err);
    for (int i = 0; st == OP_OK && i < ss->n; i++)
        if (job.need[i])
            add_source(ss, sv, i);
    free(job.marked.tab);
    free(job.need);
    return st ? st : op_sss_gather_build(ss, err);
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
        st = point_grid(&ss->ballg, ss, NULL, origin, ss->dk.radial.ball, err);
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
static op_status select_tree(sss_shape *ss, const op_sss_saved *sv,
                             const op_sss_prepass_options *opt, op_error *err)
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
static op_status camera_pass(const op_scene *scene, op_sss_prepass *c,
                             const op_sss_prepass_options *opt, cam_job *job, int *gh,
                             op_error *err)
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
static op_status irradiance_pass(build_job *job, const op_sss_prepass_options *opt, int ntasks,
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
    sss_shape *ss = &job->prepass->shapes[job->scatter_shape];
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
static op_status tree_pass(build_job *job, const op_sss_prepass_options *opt, op_error *err)
{
    sss_shape *ss = &job->prepass->shapes[job->scatter_shape];
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

/* The scattering stage: M at the receivers of every shape. Its progress report (job->prog)
 * lives for exactly the duration of this call, whatever it returns; on an error or cancellation
 * the receivers' M is incomplete and the caller drops the result. */
static op_status scatter_pass(build_job *job, const op_sss_prepass_options *opt, op_error *err)
{
    op_sss_prepass *c = job->prepass;
    op_status st = OP_OK;
    uint64_t npts = 0; /* the scatter runs over all the points of the shapes it scatters */
    for (int s = 0; s < c->n; s++)
        if (c->shapes[s].nrecv > 0)
            npts += (uint64_t)c->shapes[s].n;
    job->prog = op_progress_begin("subsurface", npts, opt->progress, opt->progress_user);
    for (int s = 0; st == OP_OK && s < c->n; s++) {
        sss_shape *ss = &c->shapes[s];
        if (ss->nrecv == 0)
            continue;
        job->scatter_shape = s;
        st = ss->hier ? tree_pass(job, opt, err)
                      : op_sss_scatter(ss, opt->threads, opt->cancel, job->prog, err);
    }
    op_progress_end(job->prog);
    job->prog = NULL;
    return st;
}

/* Makes the store's entry for subsurface index sss ready for a layout of n points: allocated
 * (empty) when it has none or holds the other layout of a windowed shape (d). Entries of the
 * same key always have the layout's point count; one that does not is refused (a damaged file
 * that kept its checksum, or a key collision). */
static op_status saved_prepare(op_sss_store *store, int sss, int n, const op_sss_desc *d,
                               const op_sss_plan_entry *p, const char *label, op_error *err)
{
    if (sss >= store->nshapes)
        return op_error_set(err, OP_ERR_FORMAT, "%s: the pre-pass cache holds %d translucent "
                            "shapes, the scene has more", label, store->nshapes);
    op_sss_saved *sv = &store->shapes[sss];
    if (sv->n == n)
        return OP_OK;
    if (p->windowed && (sv->n == p->points || sv->n == d->max_points)) {
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
static void store_update(op_sss_store *store, const op_sss_prepass *c)
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
static op_status mark_reached(const op_scene *scene, op_sss_prepass *c,
                              const op_sss_prepass_options *opt, cam_job *cam, int *gh,
                              op_error *err)
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
                               const op_sss_prepass_options *opt, const cam_job *cam, int gh,
                               float pix, op_error *err)
{
    op_status st = op_sss_lay_points(scene, sh, ss, opt->everywhere ? NULL : cam->rows, gh,
                                     pix, err);
    if (st)
        return st;
    int half = ss->kernel / 2;
    ss->h = ss->centred ? 2.0f * ss->spacing : 2.0f * fmaxf(ss->spacing, fmaxf(ss->px, ss->py));
    if (!ss->hier) {
        /* centred: a receiver lies less than half + 1 pixels from the source along each of
         * its frame's axes */
        ss->radius = ss->centred ? ((float)half + 1.0f) * (float)M_SQRT2 * fmaxf(ss->px, ss->py)
                                 : ((float)half + 1.5f) * fmaxf(ss->px, ss->py);
        st = point_grid(&ss->gather, ss, NULL, scene->bmin, 0.5f * ss->radius, err);
    } else {
        st = tree_prepare(ss, scene->bmin, err);
    }
    if (st == OP_OK)
        st = point_grid(&ss->interp, ss, NULL, scene->bmin, ss->h, err);
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
        st = mark_receivers(ss, sh->sss, cam, gh, pix, opt, err);
        if (st)
            return st;
    }
    op_sss_saved *sv = NULL;
    /* the store holds 25 bytes per point of the whole layout: a windowed shape of more than
     * UNSAVED_FACTOR x maxPoints is computed without it, as is one laid at a level the view
     * chose (its points' indices are that level's) */
    ss->unsaved = opt->store && ss->gid &&
                  ((long long)ss->nfull > UNSAVED_FACTOR * (long long)ss->desc->max_points ||
                   ss->coarse);
    if (ss->unsaved && ss->coarse)
        op_log(OP_LOG_INFO, "%s: not kept in the pre-pass cache (laid coarser than its "
               "material near the view)", sh->label);
    else if (ss->unsaved)
        op_log(OP_LOG_INFO, "%s: not kept in the pre-pass cache (%d irradiance points in its "
               "whole layout, over %d x maxPoints)", sh->label, ss->nfull, UNSAVED_FACTOR);
    if (opt->store && !ss->unsaved) {
        st = saved_prepare(opt->store, sh->sss, ss->nfull, ss->desc, ss->plan, sh->label,
                               err);
        if (st)
            return st;
        sv = &opt->store->shapes[sh->sss];
    }
    st = ss->hier ? select_tree(ss, sv, opt, err) : select_points(ss, sv, opt, err);
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
static op_status prepare_shapes(const op_scene *scene, op_sss_prepass *c,
                                const op_sss_prepass_options *opt, const cam_job *cam, int gh,
                                op_error *err)
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
        ss->plan = &scene->sss_plan[sh->sss];
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
static op_status irradiance_phase(build_job *job, const op_sss_prepass_options *opt,
                                  op_error *err)
{
    const op_sss_prepass *c = job->prepass;
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

op_status op_sss_prepass_run(const op_scene *scene, const op_sss_prepass_options *opt,
                             op_sss_prepass **out, op_error *err)
{
    double t0 = op_monotonic_seconds();
    op_sss_prepass *c = calloc(1, sizeof *c);
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
    job.prepass = c;
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
    for (int s = 0; st == OP_OK && s < c->n; s++) {
        op_sss_gather_free(&c->shapes[s]); /* the scatter's only */
        st = op_sss_lookup_prepare(&c->shapes[s], err);
    }
    double te = op_monotonic_seconds();
    c->seconds = te - t0;
    if (st == OP_OK && c->n > 0)
        op_log(OP_LOG_INFO, "subsurface pre-pass: %.3f s (camera pass %.3f s, points %.3f s, "
               "irradiance %.3f s, scattering %.3f s)", te - t0, tc - t0, tp - tc, t1 - tp,
               te - t1);
    if (st) {
        op_sss_prepass_free(c);
        return st;
    }
    if (opt->store)
        store_update(opt->store, c);
    *out = c;
    return OP_OK;
}

void op_sss_prepass_free(op_sss_prepass *c)
{
    if (!c)
        return;
    for (int i = 0; i < c->n; i++) {
        sss_shape *ss = &c->shapes[i];
        free(ss->pts);
        op_sss_lookup_free(&ss->lk);
        free(ss->gid);
        op_sss_tree_free(&ss->tree);
        free(ss->near_recv);
        free(ss->rep);
        op_sss_grid_free(&ss->look);
        op_sss_grid_free(&ss->ballg);
        op_sss_dipole_kernel_free(&ss->dk);
        free(ss->recv);
        free(ss->rmap);
        free(ss->src);
        op_sss_gather_free(ss);
        op_sss_grid_free(&ss->gather);
        op_sss_grid_free(&ss->interp);
    }
    free(c->shapes);
    free(c);
}

int op_sss_prepass_points(const op_sss_prepass *c, int sss)
{
    return sss >= 0 && sss < c->n ? c->shapes[sss].n : 0;
}

void op_sss_prepass_stats(const op_sss_prepass *c, op_sss_stats *st)
{
    memset(st, 0, sizeof *st);
    for (int i = 0; i < c->n; i++) {
        st->points += c->shapes[i].n;
        st->sources += c->shapes[i].nsrc;
        st->receivers += c->shapes[i].nrecv;
        st->sources_reused += c->shapes[i].reused_src;
        st->receivers_reused += c->shapes[i].reused_recv;
        st->shapes_reached += c->shapes[i].reached;
        const sss_shape *ss = &c->shapes[i];
        st->shapes_capped += ss->reached && (ss->capped || (ss->plan && ss->plan->capped));
    }
    st->seconds = c->seconds;
}

int op_sss_lookup(const op_sss_prepass *c, int sss, op_v3 p, op_v3 n, op_v3 *out)
{
    return op_sss_shape_lookup(&c->shapes[sss], p, n, out);
}

op_v3 op_sss_exitance(const op_sss_prepass *c, int sss, op_v3 p, op_v3 n)
{
    op_v3 m;
    op_sss_lookup(c, sss, p, n, &m);
    return m;
}
