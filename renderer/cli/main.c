/* opaline-render - renders a scene to image files or to the tile stream on stdout, or answers
 * questions about a scene (--check, --estimate, --list-inputs) and about where materials are
 * found (--find-material, --preset-folders). The command line and the tile stream are
 * documented in docs/rendering.md. */
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#ifdef __linux__
#include <sys/prctl.h>
#endif

#include "estimate.h"
#include "inputs.h"
#include "options.h"
#include "outputs.h"
#include "presets.h"
#include "stream.h"
#include "tile_merge.h"

static atomic_int g_cancel;   /* the renderer's cancel flag: a signal or a dead stream */
static atomic_int g_signal;   /* the cancelling signal received, 0 while none */

/* The first SIGINT, SIGTERM or SIGHUP (op_interrupt_install: from a thread of its own) cancels:
 * the render stops cleanly and main exits 130; a second one ends the process at once, removing
 * any temporary output. */
static void on_interrupt(void *user, int sig)
{
    (void)user;
    atomic_store(&g_signal, sig);
    atomic_store(&g_cancel, 1);
}

static const char *signal_name(int sig)
{
    return sig == SIGINT ? "SIGINT" : sig == SIGTERM ? "SIGTERM" : sig == SIGHUP ? "SIGHUP" : "?";
}

/* In --stream mode the renderer works for the process that reads the stream (Blender): when that
 * process dies, the kernel sends SIGTERM (Linux), which cancels like any interrupt. A parent that
 * died before the request took effect (the program was reparented: its parent is no longer the
 * OPALINE_PARENT_PID the starter set) counts the same. */
static void stop_with_parent(void)
{
#ifdef __linux__
    if (prctl(PR_SET_PDEATHSIG, SIGTERM) != 0)
        op_log(OP_LOG_WARN, "cannot ask to stop with the parent process: %s", strerror(errno));
    const char *want = getenv("OPALINE_PARENT_PID");
    char *end;
    errno = 0;
    long pid = want && *want ? strtol(want, &end, 10) : 0;
    if (want && *want && (errno || *end || pid <= 0))
        op_log(OP_LOG_WARN, "OPALINE_PARENT_PID=%s is not a process id: ignored", want);
    else if (pid > 0 && pid != (long)getppid())
        kill(getpid(), SIGTERM);
#endif
}

/* What a run over a scene holds, released by run_free whatever the mode did. */
typedef struct run {
    const op_cli_options *o;
    op_stream *stream;   /* with --stream */
    op_scene_description *described; /* the modes that need no build (--list-inputs,
                                        --estimate, --merge-tiles) */
    op_scene *scene;                 /* the others: the built scene (with its description) */
    op_scene_info info;
    uint64_t key;        /* with --estimate, --merge-tiles, --raw-exr: inputs.h's key */
    char scene_tag[96];  /* "key=... film=WxH": what every tile carries, --merge-tiles expects */
    char tile_tag[160];  /* with --raw-exr: the .exr outputs' tag, scene_tag and the crop */
    char default_out[2048];
    const char *outputs[OP_CLI_MAX_OUTPUTS + 1];
    int noutputs;
} run;

static void run_free(run *r)
{
    op_log_set_hook(NULL, NULL);
    op_stream_free(r->stream);
    op_scene_description_free(r->described);
    op_scene_free(r->scene);
}

/* The scene's description, whichever way it was loaded. */
static const op_scene_description *description(const run *r)
{
    return r->described ? r->described : op_scene_description_of(r->scene);
}

/* The exit code of a failed step, its message logged. */
static int failed(const op_error *err)
{
    op_log(OP_LOG_ERROR, "%s", err->message);
    return op_exit_code(err->status);
}

/* Every output (and the cache) writable, none of them another or the scene, before loading. */
static int check_outputs_before(const op_cli_options *o, op_error *err)
{
    const char *written[OP_CLI_MAX_OUTPUTS + 1], *read[2] = {o->scene_path, o->merge_list};
    int nwritten = 0;
    for (int i = 0; i < o->noutputs; i++)
        written[nwritten++] = o->outputs[i];
    struct stat cache_st; /* a cache that is not a regular file is the cache's to refuse (exit 2) */
    if (o->sss_cache && (stat(o->sss_cache, &cache_st) != 0 || S_ISREG(cache_st.st_mode)))
        written[nwritten++] = o->sss_cache;
    return op_output_check(written, nwritten, read, 2, err);
}

/* Describes the scene, and builds it unless the mode needs only its description; lists or
 * keys its inputs as the mode asks; applies the crop. Returns -1 to go on, else the exit code. */
static int load(run *r, op_error *err)
{
    const op_cli_options *o = r->o;
    int list = o->mode == OP_MODE_LIST_INPUTS;
    int keyed = o->mode == OP_MODE_ESTIMATE || o->mode == OP_MODE_MERGE_TILES || o->raw_exr;
    op_status st = list || o->mode == OP_MODE_ESTIMATE || o->mode == OP_MODE_MERGE_TILES
                       ? op_scene_describe_in(o->scene_path, o->folders, o->nfolders,
                                              o->defines, o->ndefines, &o->limits,
                                              &r->described, err)
                       : op_scene_load_in(o->scene_path, o->folders, o->nfolders, o->defines,
                                          o->ndefines, &o->limits, &r->scene, err);
    if (st == OP_OK && o->has_crop)
        st = r->described ? op_scene_description_set_crop(r->described, o->crop[0], o->crop[1],
                                                          o->crop[2], o->crop[3], err)
                          : op_scene_set_crop(r->scene, o->crop[0], o->crop[1], o->crop[2],
                                              o->crop[3], err);
    if (st == OP_OK && r->described)
        op_scene_description_get_info(r->described, &r->info);
    else if (st == OP_OK)
        op_scene_get_info(r->scene, &r->info);
    op_inputs inputs = {0}; /* the files the scene reads: listed, or hashed into its key */
    if (st == OP_OK && (list || keyed))
        st = op_inputs_collect(&inputs, err);
    if (st == OP_OK && list)
        st = op_inputs_print(&inputs, stdout, err);
    else if (st == OP_OK && keyed)
        st = op_inputs_key(&inputs, &r->info, o->defines, o->ndefines, &o->limits, o->spp,
                           &r->key, err);
    op_inputs_free(&inputs);
    if (st)
        return failed(err);
    if (atomic_load(&g_signal)) { /* loading is not cancellable, but quick: stop before rendering */
        op_log(OP_LOG_WARN, "interrupted (%s) while loading %s",
               signal_name(atomic_load(&g_signal)), o->scene_path);
        return op_exit_code(OP_ERR_CANCELLED);
    }
    return -1;
}

static int print_estimate(const run *r)
{
    op_estimate e;
    op_estimate_render(&r->info, &r->o->limits, &e);
    const double mb = 1024.0 * 1024.0;
    const op_scene_info *in = &r->info;
    printf("width=%d height=%d full_width=%d full_height=%d spp=%d translucent=%d "
           "memory_mb=%.0f loaded_mb=%.0f image_mb=%.0f sss_mb=%.0f key=%016llx\n",
           in->width, in->height, in->full_width, in->full_height, in->spp,
           in->subsurface_shapes, e.total_bytes / mb + 0.5, e.loaded_bytes / mb,
           e.image_bytes / mb, e.sss_bytes / mb, (unsigned long long)r->key);
    if (fflush(stdout) != 0 || ferror(stdout)) {
        op_log(OP_LOG_ERROR, "stdout: cannot write the estimate");
        return 1;
    }
    return 0;
}

/* The tiles' floats, written exactly as a render's image. */
static int merge_tiles(const run *r)
{
    op_image merged;
    op_error err = {0};
    op_status st = op_tiles_merge(r->o->merge_list, r->info.width, r->info.height, r->scene_tag,
                                  &merged, &err);
    int code = st ? failed(&err)
                  : op_write_images(description(r), &merged, r->outputs, r->noutputs,
                                    r->o->raw_exr ? r->tile_tag : NULL, 0);
    op_image_free(&merged);
    return code;
}

/* Writes what the render made (its stats rs): the image when complete, else what an
 * interrupted render leaves. Returns code as op_write_images does. */
static int write_result(const run *r, op_renderer *rend, const op_render_stats *rs, op_status st,
                        int code)
{
    const op_cli_options *o = r->o;
    const char *raw_tag = o->raw_exr ? r->tile_tag : NULL;
    if (o->sss_cache_only) {
        if (st == OP_OK)
            op_log(OP_LOG_INFO, "pre-pass cache %s: done (--sss-cache-only: no image)",
                   o->sss_cache);
        return code;
    }
    if (st != OP_OK && st != OP_ERR_CANCELLED)
        return code;
    const op_image *img = op_renderer_image(rend);
    if (rs->tiles_done == rs->tiles)
        return op_write_images(description(r), img, r->outputs, r->noutputs, raw_tag, code);
    char what[64];
    int sig = atomic_load(&g_signal);
    if (sig)
        snprintf(what, sizeof what, "interrupted (%s)", signal_name(sig));
    else
        snprintf(what, sizeof what, "stopped");
    return op_write_partial(description(r), img, rs, r->outputs, r->noutputs, o->partial_beside,
                            what, raw_tag, code);
}

static int render(run *r)
{
    const op_cli_options *o = r->o;
    op_render_options opt;
    op_render_options_init(&opt);
    opt.threads = o->threads;
    opt.spp = o->spp;
    opt.tile_size = o->tile_size > 0 ? o->tile_size : OP_RENDER_TILE_SIZE;
    opt.cancel = &g_cancel;
    opt.sss_cache = o->sss_cache;
    opt.sss_cache_only = o->sss_cache_only;
    if (r->stream) {
        opt.tile = op_stream_tile;
        opt.tile_user = r->stream;
        opt.progress = op_stream_progress;
        opt.progress_user = r->stream;
        op_stream_begin(r->stream, r->info.width, r->info.height, opt.tile_size);
    }
    op_renderer *rend = op_renderer_new(&opt);
    if (!rend) {
        op_log(OP_LOG_ERROR, "out of memory");
        return 1;
    }
    op_error err = {0};
    op_status st = op_renderer_render(rend, r->scene, &err); /* a failed stream cancels it */
    int code = 0;
    if (r->stream && op_stream_error(r->stream)) {
        op_log(OP_LOG_ERROR, "stdout: cannot write the tile stream (%s): rendering stopped",
               strerror(op_stream_error(r->stream)));
        code = op_exit_code(OP_ERR_IO);
    } else if (st && st != OP_ERR_CANCELLED) {
        code = failed(&err);
    }
    op_render_stats rs;
    op_renderer_get_stats(rend, &rs);
    code = write_result(r, rend, &rs, st, code);
    int sig = atomic_load(&g_signal); /* read once: the message and the exit code agree */
    int complete = rs.tiles_done == rs.tiles && (st == OP_OK || st == OP_ERR_CANCELLED);
    if (sig && complete && !o->sss_cache_only)
        op_log(OP_LOG_WARN, "interrupted (%s) after the image was complete", signal_name(sig));
    if (code == 0 && (sig || st == OP_ERR_CANCELLED))
        code = op_exit_code(OP_ERR_CANCELLED);
    if (r->stream) {
        int failed_before = op_stream_error(r->stream) != 0;
        if (o->stream_log)
            op_stream_stats(r->stream, &rs);
        op_stream_end(r->stream, code);
        if (op_stream_error(r->stream) && !failed_before) {
            op_log(OP_LOG_ERROR, "stdout: cannot write the tile stream's end (%s)",
                   strerror(op_stream_error(r->stream)));
            code = op_exit_code(OP_ERR_IO);
        }
    }
    op_renderer_free(rend);
    return code;
}

/* The run of a mode over a scene, from the checks before loading to its exit code. */
static int run_scene(run *r)
{
    const op_cli_options *o = r->o;
    op_error err = {0};
    if (o->stream) {
        r->stream = op_stream_new(stdout, &g_cancel);
        if (!r->stream) {
            op_log(OP_LOG_ERROR, "out of memory");
            return 1;
        }
        if (o->stream_log)
            op_log_set_hook(op_stream_log, r->stream); /* before any thread starts */
    }
    if (op_interrupt_install(on_interrupt, NULL, &err) != OP_OK)
        return failed(&err);
    if (o->stream || getenv("OPALINE_PARENT_PID")) /* a stream's reader, or opaline-cluster */
        stop_with_parent();
    if (check_outputs_before(o, &err) != OP_OK)
        return failed(&err);
    int code = load(r, &err);
    if (code >= 0 || o->mode == OP_MODE_LIST_INPUTS)
        return code >= 0 ? code : 0;
    const op_scene_info *in = &r->info;
    snprintf(r->scene_tag, sizeof r->scene_tag, "key=%016llx film=%dx%d",
             (unsigned long long)r->key, in->full_width, in->full_height);
    snprintf(r->tile_tag, sizeof r->tile_tag, "%s crop=%d,%d,%d,%d", r->scene_tag, o->crop[0],
             o->crop[1], o->has_crop ? o->crop[2] : in->width,
             o->has_crop ? o->crop[3] : in->height);
    r->noutputs = o->noutputs;
    memcpy(r->outputs, o->outputs, sizeof o->outputs);
    if (r->noutputs == 0 && !o->stream && !o->sss_cache_only && o->mode != OP_MODE_ESTIMATE) {
        op_default_output(o->scene_path, in, r->default_out, sizeof r->default_out);
        r->outputs[r->noutputs++] = r->default_out;
    }
    /* after loading: none of the outputs a file the scene reads */
    if (op_output_check(r->outputs, r->noutputs, NULL, 0, &err) != OP_OK)
        return failed(&err);
    switch (o->mode) {
    case OP_MODE_CHECK:
        op_log(OP_LOG_INFO, "%s: valid (%dx%d, %d shapes, %d triangles, %d emitters, %d "
               "translucent)", o->scene_path, in->width, in->height, in->shapes,
               in->triangles, in->emitters, in->subsurface_shapes);
        return 0;
    case OP_MODE_ESTIMATE:
        return print_estimate(r);
    case OP_MODE_MERGE_TILES:
        return merge_tiles(r);
    default:
        return render(r);
    }
}

int main(int argc, char **argv)
{
    op_file_guard_faults(); /* an input file truncated while mapped: a message, exit 2 */
    op_file_protect_inputs(); /* no output replaces a file this run reads */
    op_cli_options o;
    int code = op_cli_parse(argc, argv, &o);
    if (code < 0) {
        op_log_set_level(o.verbosity <= -2 ? OP_LOG_ERROR
                         : o.verbosity == -1 ? OP_LOG_WARN
                         : o.verbosity == 0  ? OP_LOG_INFO
                                             : OP_LOG_DEBUG);
        if (o.mode == OP_MODE_FIND_MATERIAL) {
            code = op_print_material(stdout, o.material, o.scene_dir);
        } else if (o.mode == OP_MODE_PRESET_FOLDERS) {
            code = op_print_preset_folders(stdout, o.scene_dir);
        } else {
            run r = {.o = &o};
            code = run_scene(&r);
            run_free(&r);
        }
    }
    op_cli_options_free(&o);
    return code;
}
