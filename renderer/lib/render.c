/* render.c - the public renderer API of opaline_render.h: scene loading, the subsurface
 * pre-pass through its cache file, tiled multithreaded rendering; writing the image is the
 * film's (camera/film.h). */
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "integrator/integrator.h"
#include "opaline_render.h"
#include "scene/scene_build.h"
#include "sss/cache_file.h"
#include "sss/prepass.h"

op_status op_scene_describe(const char *path, const op_scene_define *defines, int ndefines,
                            const op_scene_limits *limits, op_scene_description **out,
                            op_error *err)
{
    return op_scene_describe_in(path, NULL, 0, defines, ndefines, limits, out, err);
}

op_status op_scene_describe_in(const char *path, const char *const *folders, int nfolders,
                               const op_scene_define *defines, int ndefines,
                               const op_scene_limits *limits, op_scene_description **out,
                               op_error *err)
{
    /* the describer passes nested statuses through err, so it always gets one */
    op_error scratch = {0};
    if (!err)
        err = &scratch;
    op_scene_limits defaults;
    op_scene_limits_init(&defaults);
    if (!limits)
        limits = &defaults;
    *out = NULL;
    if (ndefines < 0 || (ndefines > 0 && !defines))
        return op_error_set(err, OP_ERR_INPUT, "bad define list");
    op_define *defs = calloc((size_t)(ndefines ? ndefines : 1), sizeof *defs);
    if (!defs)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    for (int i = 0; i < ndefines; i++) {
        defs[i].name = defines[i].name;
        defs[i].value = defines[i].value;
    }
    op_node *root = NULL;
    op_status st = op_desc_parse_in(path, folders, nfolders, defs, ndefines, limits, &root, err);
    free(defs);
    if (st)
        return st;
    op_scene_description *d = calloc(1, sizeof *d);
    if (!d) {
        op_desc_free(root);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    }
    st = op_describe(root, path, limits, d, err);
    if (st) {
        op_scene_description_free(d);
        return st;
    }
    *out = d;
    return OP_OK;
}

void op_scene_description_free(op_scene_description *d)
{
    if (!d)
        return;
    op_describe_release(d);
    free(d);
}

void op_scene_description_get_info(const op_scene_description *d, op_scene_info *info)
{
    op_describe_info(d, info);
}

op_status op_scene_load_limited(const char *path, const op_scene_define *defines, int ndefines,
                                const op_scene_limits *limits, op_scene **out, op_error *err)
{
    return op_scene_load_in(path, NULL, 0, defines, ndefines, limits, out, err);
}

op_status op_scene_load_in(const char *path, const char *const *folders, int nfolders,
                           const op_scene_define *defines, int ndefines,
                           const op_scene_limits *limits, op_scene **out, op_error *err)
{
    op_error scratch = {0};
    if (!err)
        err = &scratch;
    *out = NULL;
    op_scene_description *d;
    op_status st =
        op_scene_describe_in(path, folders, nfolders, defines, ndefines, limits, &d, err);
    if (st)
        return st;
    op_scene *s = calloc(1, sizeof *s);
    if (!s) {
        op_scene_description_free(d);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    }
    s->desc = d;
    st = op_scene_build(d, s, err);
    if (st == OP_OK && s->nsss > 0)
        op_sss_desc_hash(d->root, s->desc_hash);
    op_desc_free(d->root); /* built: the tree is no longer read */
    d->root = NULL;
    if (st) {
        op_scene_free(s);
        return st;
    }
    *out = s;
    return OP_OK;
}

op_status op_scene_load(const char *path, const op_scene_define *defines, int ndefines,
                        op_scene **out, op_error *err)
{
    return op_scene_load_limited(path, defines, ndefines, NULL, out, err);
}

void op_scene_free(op_scene *scene)
{
    if (!scene)
        return;
    op_scene_release(scene);
    op_scene_description_free(scene->desc);
    free(scene);
}

op_status op_scene_set_crop(op_scene *s, int x, int y, int w, int h, op_error *err)
{
    op_status st = op_film_set_crop(&s->film, x, y, w, h, "--crop", err);
    s->desc->film = s->film; /* the description stays the scene's */
    return st;
}

op_status op_scene_description_set_crop(op_scene_description *d, int x, int y, int w, int h,
                                        op_error *err)
{
    return op_film_set_crop(&d->film, x, y, w, h, "--crop", err);
}

const op_scene_description *op_scene_description_of(const op_scene *s)
{
    return s->desc;
}

void op_scene_get_info(const op_scene *s, op_scene_info *info)
{
    op_describe_info(s->desc, info); /* the film, sampler and integrator are the description's */
    info->shapes = s->nshapes;
    info->triangles = info->instances = info->geometry_bytes = 0;
    for (int i = 0; i < s->nshapes; i++) {
        const op_trimesh *m = &s->shapes[i].mesh;
        info->triangles += m->ntris;
        info->instances += s->shapes[i].instanced;
        if (!s->shapes[i].instanced)
            info->geometry_bytes += op_trimesh_bytes(m);
    }
    for (int i = 0; i < s->nprotos; i++)
        info->geometry_bytes += op_trimesh_bytes(&s->protos[i]);
    if (s->accel)
        info->geometry_bytes += op_accel_bytes(s->accel);
    info->emitters = s->nemitters;
    info->subsurface_shapes = s->nsss;
}

const char *op_scene_description_image_format(const op_scene_description *d, const char *path)
{
    return op_film_image_format(&d->film, path);
}

op_status op_scene_description_write_image(const op_scene_description *d, const op_image *img,
                                           const char *path, op_error *err)
{
    return op_film_write_image(&d->film, img, path, err);
}

struct op_renderer {
    op_render_options opt;
    op_image img;
    int has_image;
    op_render_stats stats;
};

void op_renderer_get_stats(const op_renderer *r, op_render_stats *st)
{
    *st = r->stats;
}

void op_render_options_init(op_render_options *opt)
{
    memset(opt, 0, sizeof *opt);
}

op_renderer *op_renderer_new(const op_render_options *opt)
{
    op_renderer *r = calloc(1, sizeof *r);
    if (!r)
        return NULL;
    if (opt)
        r->opt = *opt;
    return r;
}

void op_renderer_free(op_renderer *r)
{
    if (!r)
        return;
    op_image_free(&r->img);
    free(r);
}

const op_image *op_renderer_image(const op_renderer *r)
{
    return r->has_image ? &r->img : NULL;
}

typedef struct render_job {
    const op_scene *scene;
    const op_render_options *opt;
    op_trace_ctx ctx;
    op_image *img;
    int tile, tiles_x, spp;
    float **scratch;   /* per thread, tile * tile * 4 floats */
    pthread_mutex_t tile_lock;
    op_progress *prog;
    atomic_int *cancel;
    atomic_int tiles_done; /* tiles whose pixels are in img */
} render_job;

static void render_tile(void *user, int task, int thread)
{
    render_job *job = user;
    const op_scene *s = job->scene;
    const op_film *film = &s->film;
    int tx = task % job->tiles_x, ty = task / job->tiles_x;
    int x0 = tx * job->tile, y0 = ty * job->tile;
    int w = film->width - x0 < job->tile ? film->width - x0 : job->tile;
    int h = film->height - y0 < job->tile ? film->height - y0 : job->tile;
    float *buf = job->scratch[thread];
    float inv = 1.0f / (float)job->spp;
    int unfiltered = op_camera_unfiltered(&s->camera);
    float measure = op_camera_weight(&s->camera);
    for (int y = 0; y < h; y++) {
        if (job->cancel && atomic_load(job->cancel))
            return;
        for (int x = 0; x < w; x++) {
            int fx = film->crop_x + x0 + x, fy = film->crop_y + y0 + y;
            uint64_t pixel = (uint64_t)fy * (uint64_t)film->full_width + (uint64_t)fx;
            double acc[4] = {0, 0, 0, 0};
            for (int k = 0; k < job->spp; k++) {
                op_path_sampler ps = op_path_sampler_begin(s->sampler.type == OP_SAMPLER_LD,
                                                           job->opt->seed, pixel, (uint32_t)k);
                float u[2], dx, dy;
                op_path_sample(&ps, OP_DIM_PIXEL, 2, u);
                float weight = 1.0f;
                if (unfiltered) {
                    dx = u[0] - 0.5f;
                    dy = u[1] - 0.5f;
                } else {
                    weight = op_film_sample_offset(film, u[0], u[1], &dx, &dy);
                }
                float lens[2] = {0.5f, 0.5f};
                if (op_camera_lens_dims(&s->camera))
                    op_path_sample(&ps, OP_DIM_LENS, 2, lens);
                op_v3 org, dir;
                float tmin, tmax, alpha;
                op_camera_ray_lens(&s->camera, (float)fx + 0.5f + dx, (float)fy + 0.5f + dy,
                                   lens[0], lens[1], &org, &dir, &tmin, &tmax);
                op_v3 L = v3_scale(op_li(&job->ctx, org, dir, tmin, tmax, &ps, &alpha), measure);
                if (!isfinite(L.x) || !isfinite(L.y) || !isfinite(L.z))
                    continue; /* a numerically broken path: dropped (counts as black) */
                acc[0] += weight * L.x;
                acc[1] += weight * L.y;
                acc[2] += weight * L.z;
                acc[3] += weight * alpha;
            }
            float *o = buf + 4 * ((size_t)y * w + x);
            for (int c = 0; c < 4; c++)
                o[c] = (float)acc[c] * inv;
        }
    }
    for (int y = 0; y < h; y++)
        memcpy(job->img->pixels + 4 * ((size_t)(y0 + y) * film->width + x0),
               buf + 4 * (size_t)y * w, 4 * (size_t)w * sizeof(float));
    atomic_fetch_add(&job->tiles_done, 1);
    if (job->opt->tile) {
        op_render_tile t = {x0, y0, w, h, buf};
        pthread_mutex_lock(&job->tile_lock);
        job->opt->tile(job->opt->tile_user, &t);
        pthread_mutex_unlock(&job->tile_lock);
    }
    op_progress_advance(job->prog, (uint64_t)w * (uint64_t)h);
}

/* The subsurface pre-pass, through the cache file when opt names one: its results are reused
 * where the key matches, and the file is (re)written, before the camera pass, when the pre-pass
 * computed anything or the file was missing or stale. */
static op_status prepass(const op_scene *s, const op_render_options *opt,
                         op_sss_prepass_options *so, op_sss_prepass **sss, op_error *err)
{
    if (!opt->sss_cache)
        return op_sss_prepass_run(s, so, sss, err);
    unsigned char key[OP_SSS_KEY_BYTES];
    op_sss_store store;
    op_sss_file_state state;
    double t0 = op_monotonic_seconds();
    op_status st = op_sss_key(s, opt->seed, key, err);
    if (st)
        return st;
    double t1 = op_monotonic_seconds();
    if ((st = op_sss_store_load(opt->sss_cache, key, s->nsss, &store, &state, err)))
        return st;
    double t2 = op_monotonic_seconds();
    so->store = &store;
    st = op_sss_prepass_run(s, so, sss, err);
    if (st == OP_ERR_FORMAT) /* the store does not fit the scene (saved_prepare) */
        op_error_prefix(err, "--sss-cache %s: ", opt->sss_cache);
    if (st == OP_OK) {
        long long fresh = store.new_e + store.new_m;
        if (state == OP_SSS_FILE_VALID)
            op_log(OP_LOG_INFO, "pre-pass cache %s: reused %lld sources / %lld receivers, "
                   "computed %lld new (%lld sources, %lld receivers); key %.3f s, read %.3f s",
                   opt->sss_cache, store.reused_e, store.reused_m, fresh, store.new_e,
                   store.new_m, t1 - t0, t2 - t1);
        if (fresh > 0 || state != OP_SSS_FILE_VALID) {
            double t3 = op_monotonic_seconds();
            st = op_sss_store_save(opt->sss_cache, key, &store, err);
            if (st == OP_OK)
                op_log(OP_LOG_INFO, "pre-pass cache %s: written (%lld new sources, %lld new "
                       "receivers; %.3f s)", opt->sss_cache, store.new_e, store.new_m,
                       op_monotonic_seconds() - t3);
        }
        if (st) {
            op_sss_prepass_free(*sss);
            *sss = NULL;
        }
    }
    op_sss_store_free(&store);
    return st;
}

op_status op_renderer_render(op_renderer *r, const op_scene *s, op_error *err)
{
    const op_render_options *opt = &r->opt;
    op_image_free(&r->img);
    r->has_image = 0;
    memset(&r->stats, 0, sizeof r->stats);
    op_status st = op_image_alloc(&r->img, s->film.width, s->film.height, 4, err);
    if (st)
        return st;
    memset(r->img.pixels, 0, (size_t)s->film.width * s->film.height * 4 * sizeof(float));
    r->has_image = 1;
    render_job job;
    memset(&job, 0, sizeof job);
    job.scene = s;
    job.opt = opt;
    job.img = &r->img;
    job.cancel = opt->cancel;
    job.ctx.scene = s;
    job.spp = opt->spp > 0 ? opt->spp : s->sampler.spp;
    job.tile = opt->tile_size > 0 ? opt->tile_size : OP_RENDER_TILE_SIZE;
    atomic_init(&job.tiles_done, 0);
    job.tiles_x = (s->film.width + job.tile - 1) / job.tile;
    int tiles_y = (s->film.height + job.tile - 1) / job.tile;
    r->stats.tiles = job.tiles_x * tiles_y;
    op_sss_prepass *sss = NULL;
    int it = s->integrator.type;
    if (s->nsss > 0 && (it == OP_INT_PATH || it == OP_INT_DIRECT)) {
        op_sss_prepass_options so = {opt->threads, opt->seed, opt->cancel, opt->progress,
                                   opt->progress_user, 0, NULL, &op_path_transport};
        st = prepass(s, opt, &so, &sss, err);
        if (st)
            return st;
        op_sss_stats ss;
        op_sss_prepass_stats(sss, &ss);
        r->stats.sss_points = ss.points;
        r->stats.sss_sources = ss.sources;
        r->stats.sss_receivers = ss.receivers;
        r->stats.sss_sources_reused = ss.sources_reused;
        r->stats.sss_receivers_reused = ss.receivers_reused;
        r->stats.sss_shapes_reached = ss.shapes_reached;
        r->stats.sss_shapes_capped = ss.shapes_capped;
        r->stats.sss_seconds = ss.seconds;
        job.ctx.sss = sss;
    } else if (opt->sss_cache) {
        op_log(OP_LOG_INFO, "pre-pass cache %s: not used (%s)", opt->sss_cache,
               s->nsss > 0 ? "this integrator has no subsurface pre-pass"
                           : "the scene has no translucent shapes");
    }
    if (opt->sss_cache_only) {
        op_sss_prepass_free(sss);
        return OP_OK;
    }
    int threads = op_parallel_threads(opt->threads);
    job.scratch = calloc((size_t)threads, sizeof *job.scratch);
    if (!job.scratch) {
        op_sss_prepass_free(sss);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    }
    for (int i = 0; i < threads; i++)
        if (!(job.scratch[i] = malloc((size_t)job.tile * job.tile * 4 * sizeof(float))))
            st = op_error_set(err, OP_ERR_NOMEM, "out of memory");
    pthread_mutex_init(&job.tile_lock, NULL);
    if (st == OP_OK) {
        op_log(OP_LOG_DEBUG, "rendering %dx%d, %d spp, %d threads", s->film.width, s->film.height,
               job.spp, threads);
        job.prog = op_progress_begin("render", (uint64_t)s->film.width * s->film.height,
                                     opt->progress, opt->progress_user);
        double t0 = op_monotonic_seconds();
        st = op_parallel_for(threads, job.tiles_x * tiles_y, render_tile, &job, opt->cancel, err);
        op_progress_end(job.prog);
        r->stats.tiles_done = atomic_load(&job.tiles_done);
        r->stats.render_seconds = op_monotonic_seconds() - t0;
        op_log(OP_LOG_INFO, "camera pass: %.3f s (%dx%d, %d spp, %d threads)",
               r->stats.render_seconds, s->film.width, s->film.height, job.spp, threads);
    }
    pthread_mutex_destroy(&job.tile_lock);
    for (int i = 0; i < threads; i++)
        free(job.scratch[i]);
    free(job.scratch);
    op_sss_prepass_free(sss);
    return st;
}

const char *op_scene_image_format(const op_scene *s, const char *path)
{
    return op_film_image_format(&s->film, path);
}

op_status op_scene_write_image(const op_scene *s, const op_image *img, const char *path,
                               op_error *err)
{
    return op_film_write_image(&s->film, img, path, err);
}
