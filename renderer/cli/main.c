/* opaline-render - renders a scene to image files or to the tile stream on stdout.
 * The command line and the tile stream are documented in docs/rendering.md. */
#include <errno.h>
#include <libgen.h>
#include <pthread.h>
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
#include "opaline_render.h"
#include "tile_merge.h"

enum { MAX_OUTPUTS = 16, MAX_DEFINES = 256 };

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

static void usage(FILE *f)
{
    fprintf(f,
            "usage: opaline-render [options] SCENE.xml\n"
            "  -o FILE        output image (.exr .png .pfm .hdr by extension; the film's\n"
            "                 format without one, as /dev/stdout); repeatable\n"
            "  -t N           worker threads (default: all cores)\n"
            "  -s N           samples per pixel (overrides the scene's sampler)\n"
            "  -D name=value  overrides <default name=...>; repeatable\n"
            "  --check        parse and validate only\n"
            "  --estimate     parse, then print the render's size and memory estimate on\n"
            "                 stdout (key=value; for schedulers, docs/cluster.md), and key=,\n"
            "                 the hash of everything the image depends on\n"
            "  --list-inputs  parse, then print every file the scene reads (absolute paths,\n"
            "                 one a line: the scene, includes, meshes, images, materials)\n"
            "  --raw-exr      .exr outputs hold the rendered floats exactly (32-bit RGBA,\n"
            "                 whatever the film says) and the key, film and crop: tiles for\n"
            "                 --merge-tiles\n"
            "  --merge-tiles LIST  render nothing: assemble the film from the tiles LIST\n"
            "                 names (lines X Y W H FILE), each of this scene's key, film and\n"
            "                 listed crop, and write the outputs as a render\n"
            "  --limit NAME=VALUE  raise or lower a scene limit (coordinate, image-pixels,\n"
            "                 kernel, sss-points, sss-max-points, include-bytes,\n"
            "                 include-count, attribute-bytes, triangles, load-memory;\n"
            "                 see docs/limits.md); repeatable\n"
            "  --crop X,Y,W,H render only the WxH pixels at X,Y (top-left origin) of the film\n"
            "  --sss-cache FILE  reuse the subsurface pre-pass's results saved in FILE where\n"
            "                 its key (everything they depend on; not the camera, film or\n"
            "                 crop) matches; FILE is (re)written when anything new was\n"
            "                 computed. A FILE that is not such a cache is refused (exit 2)\n"
            "  --sss-cache-only  with --sss-cache: the pre-pass for the whole film only (no\n"
            "                 image, no -o), to be reused by later --crop tile renders\n"
            "  --stream       write the tile stream to stdout; the render stops (exit 130)\n"
            "                 when the parent process goes away\n"
            "  --stream-log   with --stream, every log line also goes into the stream\n"
            "  --partial MODE on an interrupt, OUT is kept and with MODE beside (default) the\n"
            "                 finished tiles go to OUT.partial.EXT; none writes nothing\n"
            "  -q / -v        quieter / more verbose\n");
}

/* ------------------------------------------------------------ the tile stream (little-endian) */

typedef struct stream {
    pthread_mutex_t lock;
    FILE *f;
    int error; /* errno of the first failed write; nothing is written after it */
} stream;

static int host_le(void)
{
    uint16_t one = 1;
    unsigned char b;
    memcpy(&b, &one, 1);
    return b == 1;
}

/* Writes n bytes. The first failure is kept in s->error and sets the cancel flag: with its
 * reader gone (a closed pipe, a full disk) the render has no one to render for. */
static void put(stream *s, const void *p, size_t n)
{
    if (s->error || n == 0)
        return;
    errno = 0;
    if (fwrite(p, 1, n, s->f) != n) {
        s->error = errno ? errno : EIO;
        atomic_store(&g_cancel, 1);
    }
}

/* Starts a record: its header; the caller then puts exactly n payload bytes and ends it. The
 * caller holds the lock from start to end. */
static void record_start(stream *s, uint32_t type, uint64_t n)
{
    unsigned char h[16];
    memcpy(h, "OPTS", 4);
    op_put_le32(h + 4, type);
    op_put_le64(h + 8, n);
    put(s, h, sizeof h);
}

/* Ends a record: flushed, so the reader gets it now (and a write error shows now). */
static void record_end(stream *s)
{
    errno = 0;
    if (!s->error && fflush(s->f) != 0) {
        s->error = errno ? errno : EIO;
        atomic_store(&g_cancel, 1);
    }
}

static void record(stream *s, uint32_t type, const void *payload, uint64_t n)
{
    record_start(s, type, n);
    put(s, payload, (size_t)n);
    record_end(s);
}

static void on_tile(void *user, const op_render_tile *t)
{
    stream *s = user; /* the renderer serializes tile callbacks; the lock orders them with progress */
    size_t nf = (size_t)t->w * t->h * 4;
    unsigned char head[16];
    op_put_le32(head, (uint32_t)t->x);
    op_put_le32(head + 4, (uint32_t)t->y);
    op_put_le32(head + 8, (uint32_t)t->w);
    op_put_le32(head + 12, (uint32_t)t->h);
    pthread_mutex_lock(&s->lock);
    record_start(s, 2, sizeof head + 4 * (uint64_t)nf);
    put(s, head, sizeof head);
    if (host_le()) {
        put(s, t->rgba, nf * 4);
    } else {
        unsigned char b[4 * 256];
        for (size_t i = 0; i < nf; i += 256) {
            size_t m = nf - i < 256 ? nf - i : 256;
            for (size_t k = 0; k < m; k++) {
                uint32_t v;
                memcpy(&v, &t->rgba[i + k], 4);
                op_put_le32(b + 4 * k, v);
            }
            put(s, b, 4 * m);
        }
    }
    record_end(s);
    pthread_mutex_unlock(&s->lock);
}

/* PROGRESS: f64 fraction of the stage, then (since the stage label was added; readers of the
 * first version read the fraction only) u32 label length and the label. */
static void on_progress(void *user, const char *label, double fraction, double eta)
{
    (void)eta;
    stream *s = user;
    size_t n = strlen(label);
    if (n > 255)
        n = 255;
    unsigned char p[12 + 255];
    uint64_t bits;
    memcpy(&bits, &fraction, 8);
    op_put_le64(p, bits);
    op_put_le32(p + 8, (uint32_t)n);
    memcpy(p + 12, label, n);
    pthread_mutex_lock(&s->lock);
    record(s, 3, p, 12 + n);
    pthread_mutex_unlock(&s->lock);
}

/* LOG: u32 level (0 error, 1 warning, 2 info, 3 debug), then the message (UTF-8, escaped as
 * op_log prints it). Every line op_log writes with --stream-log (readers of the first version
 * of the stream refuse record types they do not know), while it also goes to stderr. */
static void on_log(void *user, op_log_level level, const char *message)
{
    stream *s = user;
    size_t n = strlen(message);
    unsigned char p[4];
    op_put_le32(p, (uint32_t)level);
    pthread_mutex_lock(&s->lock);
    record_start(s, 5, 4 + (uint64_t)n);
    put(s, p, 4);
    put(s, message, n);
    record_end(s);
    pthread_mutex_unlock(&s->lock);
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

/* Parses "X,Y,W,H" (non-negative integers; the film checks they fit). */
static int parse_crop(const char *s, int v[4])
{
    for (int i = 0; i < 4; i++) {
        char *end;
        errno = 0;
        long x = strtol(s, &end, 10);
        if (errno || end == s || x < 0 || x > 65536 || *end != (i < 3 ? ',' : '\0'))
            return 0;
        v[i] = (int)x;
        s = end + 1;
    }
    return 1;
}

/* ------------------------------------------------------------ output images */

static int g_raw_exr; /* --raw-exr: .exr outputs are the image's floats, 32-bit RGBA */
static char g_tile_tag[160]; /* with --raw-exr: their "opalineTile" attribute (tile_merge.h) */

/* Writes img to each path, all of them put in place together or none (op_output_group).
 * Returns code, or when code is 0 the exit code of a failed write. */
static int write_images(const op_scene_description *desc, const op_image *img,
                        const char *const *paths, int n, int code)
{
    op_error werr = {0};
    op_status ws = OP_OK;
    op_output_group_begin();
    for (int i = 0; i < n && !ws; i++) {
        const char *format = op_scene_description_image_format(desc, paths[i]);
        ws = g_raw_exr && format && !strcmp(format, ".exr")
                 ? op_image_write_exr_attr(paths[i], img, 0, OP_TILE_ATTR, g_tile_tag, &werr)
                 : op_scene_description_write_image(desc, img, paths[i], &werr);
    }
    if (ws)
        op_output_group_abort();
    else
        ws = op_output_group_commit(&werr);
    if (ws) {
        op_log(OP_LOG_ERROR, "%s%s", werr.message, n > 1 ? " (no output was replaced)" : "");
        return code ? code : op_exit_code(ws);
    }
    for (int i = 0; i < n; i++)
        op_log(OP_LOG_INFO, "wrote %s", paths[i]);
    return code;
}

/* path with ".partial" before its extension (out.exr -> out.partial.exr), so the format stays.
 * Returns 0 when it does not fit in n bytes. */
static int partial_name(const char *path, char *out, size_t n)
{
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    const char *dot = strrchr(base, '.');
    int len = dot && dot != base
                  ? snprintf(out, n, "%.*s.partial%s", (int)(dot - path), path, dot)
                  : snprintf(out, n, "%s.partial", path);
    return len >= 0 && (size_t)len < n;
}

/* An incomplete render (interrupted, or its tile stream gone): the outputs are left as they
 * are, never replaced by less; with beside, the finished tiles go to each output's partial name
 * (nothing when no tile finished). Returns code as write_images does. */
static int write_partial(const op_scene *scene, const op_image *img, const op_render_stats *rs,
                         const char *const *outputs, int n, int beside, int code)
{
    char what[64], when[64];
    if (atomic_load(&g_signal))
        snprintf(what, sizeof what, "interrupted (%s)", signal_name(atomic_load(&g_signal)));
    else
        snprintf(what, sizeof what, "stopped");
    if (rs->tiles_done == 0)
        snprintf(when, sizeof when, "before any tile was finished");
    else
        snprintf(when, sizeof when, "after %d of %d tiles", rs->tiles_done, rs->tiles);
    if (n == 0)
        op_log(OP_LOG_WARN, "%s %s", what, when);
    for (int i = 0; i < n; i++) {
        char part[4096];
        if (!beside || rs->tiles_done == 0) {
            op_log(OP_LOG_WARN, "%s %s: %s not written", what, when, outputs[i]);
        } else if (!partial_name(outputs[i], part, sizeof part)) {
            op_log(OP_LOG_ERROR, "%s: the name is too long for its partial image", outputs[i]);
            if (code == 0)
                code = op_exit_code(OP_ERR_IO);
        } else {
            op_log(OP_LOG_WARN, "%s %s: %s not written, the finished tiles go to %s", what, when,
                   outputs[i], part);
            const char *p = part;
            code = write_images(op_scene_description_of(scene), img, &p, 1, code);
        }
    }
    return code;
}

/* ------------------------------------------------------------ main */

static int parse_int(const char *s, int lo, int hi, int *out)
{
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi)
        return 0;
    *out = (int)v;
    return 1;
}

/* The default output: the film's filename, else the scene's basename, with the film's
 * fileFormat's extension when it has none. */
static void default_output(const char *scene_path, const op_scene_info *info, char *out, size_t n)
{
    if (info->film_filename) {
        const char *f = info->film_filename;
        const char *dot = strrchr(f, '.');
        const char *slash = strrchr(f, '/');
        if (!dot || (slash && dot < slash))
            snprintf(out, n, "%s%s", f, info->film_extension);
        else
            snprintf(out, n, "%s", f);
        return;
    }
    char *tmp = strdup(scene_path);
    const char *base = tmp ? basename(tmp) : "render";
    char stem[1024];
    snprintf(stem, sizeof stem, "%s", base);
    char *dot = strrchr(stem, '.');
    if (dot && dot != stem)
        *dot = '\0';
    snprintf(out, n, "%s%s", stem, info->film_extension);
    free(tmp);
}

int main(int argc, char **argv)
{
    op_file_guard_faults(); /* an input file truncated while mapped: a message, exit 2 */
    op_file_protect_inputs(); /* no output replaces a file this run reads */
    const char *outputs[MAX_OUTPUTS];
    int noutputs = 0, threads = 0, spp = 0, check = 0, stream_mode = 0, verbosity = 0;
    int partial_beside = 1, has_crop = 0, crop[4] = {0, 0, 0, 0}, stream_log = 0;
    int estimate = 0, list_inputs = 0;
    const char *merge_list = NULL;
    op_scene_define defines[MAX_DEFINES];
    char *define_buf[MAX_DEFINES];
    int ndefines = 0;
    const char *scene_path = NULL, *sss_cache = NULL;
    int sss_cache_only = 0;
    op_scene_limits limits;
    op_scene_limits_init(&limits);
    int bad = 0;
    for (int i = 1; i < argc && !bad; i++) {
        const char *a = argv[i];
        int need = strcmp(a, "-o") == 0 || strcmp(a, "-t") == 0 || strcmp(a, "-s") == 0 ||
                   strcmp(a, "-D") == 0 || strcmp(a, "--limit") == 0 ||
                   strcmp(a, "--partial") == 0 || strcmp(a, "--crop") == 0 ||
                   strcmp(a, "--merge-tiles") == 0 || strcmp(a, "--sss-cache") == 0;
        if (need && i + 1 >= argc) {
            op_log(OP_LOG_ERROR, "%s needs a value", a);
            bad = 1;
            break;
        }
        if (strcmp(a, "-o") == 0) {
            if (noutputs == MAX_OUTPUTS) {
                op_log(OP_LOG_ERROR, "at most %d -o outputs", MAX_OUTPUTS);
                bad = 1;
            } else {
                outputs[noutputs++] = argv[++i];
            }
        } else if (strcmp(a, "-t") == 0) {
            if (!parse_int(argv[++i], 1, 1024, &threads)) {
                op_log(OP_LOG_ERROR, "-t %s: need a thread count in 1..1024", argv[i]);
                bad = 1;
            }
        } else if (strcmp(a, "-s") == 0) {
            if (!parse_int(argv[++i], 1, 1 << 24, &spp)) {
                op_log(OP_LOG_ERROR, "-s %s: need a sample count in 1..16777216", argv[i]);
                bad = 1;
            }
        } else if (strcmp(a, "-D") == 0) {
            const char *d = argv[++i];
            const char *eq = strchr(d, '=');
            if (!eq || eq == d || ndefines == MAX_DEFINES) {
                op_log(OP_LOG_ERROR, "-D %s: need name=value", d);
                bad = 1;
            } else {
                char *copy = strdup(d);
                if (!copy) {
                    bad = 1;
                    break;
                }
                copy[eq - d] = '\0';
                define_buf[ndefines] = copy;
                defines[ndefines].name = copy;
                defines[ndefines].value = copy + (eq - d) + 1;
                ndefines++;
            }
        } else if (strcmp(a, "--limit") == 0) {
            op_error lerr = {0};
            if (op_scene_limits_set(&limits, argv[++i], &lerr) != OP_OK) {
                op_log(OP_LOG_ERROR, "--%s", lerr.message); /* "--limit ...: ..." */
                bad = 1;
            }
        } else if (strcmp(a, "--crop") == 0) {
            if (!parse_crop(argv[++i], crop)) {
                op_log(OP_LOG_ERROR, "--crop %s: need X,Y,W,H (whole numbers, pixels of the "
                       "film from its top-left corner)", argv[i]);
                bad = 1;
            }
            has_crop = 1;
        } else if (strcmp(a, "--sss-cache") == 0) {
            sss_cache = argv[++i];
            if (!*sss_cache) {
                op_log(OP_LOG_ERROR, "--sss-cache needs a file name");
                bad = 1;
            }
        } else if (strcmp(a, "--sss-cache-only") == 0) {
            sss_cache_only = 1;
        } else if (strcmp(a, "--check") == 0) {
            check = 1;
        } else if (strcmp(a, "--estimate") == 0) {
            estimate = 1;
        } else if (strcmp(a, "--list-inputs") == 0) {
            list_inputs = 1;
        } else if (strcmp(a, "--raw-exr") == 0) {
            g_raw_exr = 1;
        } else if (strcmp(a, "--merge-tiles") == 0) {
            merge_list = argv[++i];
        } else if (strcmp(a, "--stream") == 0) {
            stream_mode = 1;
        } else if (strcmp(a, "--stream-log") == 0) {
            stream_log = 1;
        } else if (strcmp(a, "--partial") == 0) {
            const char *w = argv[++i];
            partial_beside = strcmp(w, "beside") == 0;
            if (!partial_beside && strcmp(w, "none") != 0) {
                op_log(OP_LOG_ERROR, "--partial %s: need beside or none", w);
                bad = 1;
            }
        } else if (strcmp(a, "-q") == 0) {
            verbosity--;
        } else if (strcmp(a, "-v") == 0) {
            verbosity++;
        } else if (strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0) {
            usage(stdout);
            for (int k = 0; k < ndefines; k++)
                free(define_buf[k]);
            if (fflush(stdout) != 0 || ferror(stdout)) {
                op_log(OP_LOG_ERROR, "stdout: cannot write the usage: %s",
                       errno ? strerror(errno) : "write error");
                return 1;
            }
            return 0;
        } else if (a[0] == '-' && a[1]) {
            op_log(OP_LOG_ERROR, "unknown option %s", a);
            bad = 1;
        } else if (scene_path) {
            op_log(OP_LOG_ERROR, "more than one scene given (%s, %s)", scene_path, a);
            bad = 1;
        } else {
            scene_path = a;
        }
    }
    if (!bad && !scene_path) {
        op_log(OP_LOG_ERROR, "no scene given");
        bad = 1;
    }
    if (!bad && merge_list && (has_crop || stream_mode)) {
        op_log(OP_LOG_ERROR, "--merge-tiles assembles the whole film: not with --crop or --stream");
        bad = 1;
    }
    if (!bad && sss_cache_only && !sss_cache) {
        op_log(OP_LOG_ERROR, "--sss-cache-only needs --sss-cache FILE");
        bad = 1;
    }
    if (!bad && sss_cache_only && (noutputs > 0 || stream_mode)) {
        op_log(OP_LOG_ERROR, "--sss-cache-only renders no image: it takes no -o or --stream");
        bad = 1;
    }
    if (bad) {
        usage(stderr);
        for (int k = 0; k < ndefines; k++)
            free(define_buf[k]);
        return 2;
    }
    op_log_set_level(verbosity <= -2 ? OP_LOG_ERROR
                     : verbosity == -1 ? OP_LOG_WARN
                     : verbosity == 0  ? OP_LOG_INFO
                                       : OP_LOG_DEBUG);

    stream s;
    pthread_mutex_init(&s.lock, NULL);
    s.f = stdout;
    s.error = 0;
    if (stream_mode && stream_log)
        op_log_set_hook(on_log, &s); /* before any thread starts; removed before s goes */
    op_error err = {0};
    if (op_interrupt_install(on_interrupt, NULL, &err) != OP_OK) {
        op_log(OP_LOG_ERROR, "%s", err.message);
        op_log_set_hook(NULL, NULL);
        return op_exit_code(err.status);
    }
    if (stream_mode || getenv("OPALINE_PARENT_PID")) /* a stream's reader, or opaline-cluster */
        stop_with_parent();
    /* Every output (and the cache) writable, none of them another or the scene, before loading;
     * after it, none of them a file the scene reads. */
    const char *written[MAX_OUTPUTS + 1], *read[2] = {scene_path, merge_list};
    int nwritten = 0;
    for (int i = 0; i < noutputs; i++)
        written[nwritten++] = outputs[i];
    struct stat cache_st; /* a cache that is not a regular file is the cache's to refuse (exit 2) */
    if (sss_cache && (stat(sss_cache, &cache_st) != 0 || S_ISREG(cache_st.st_mode)))
        written[nwritten++] = sss_cache;
    if (op_output_check(written, nwritten, read, 2, &err) != OP_OK) {
        for (int k = 0; k < ndefines; k++)
            free(define_buf[k]);
        op_log(OP_LOG_ERROR, "%s", err.message);
        op_log_set_hook(NULL, NULL);
        return op_exit_code(err.status);
    }
    /* --list-inputs, --estimate and --merge-tiles need the scene's description only */
    op_scene_description *desc = NULL;
    op_scene *scene = NULL;
    op_status st = list_inputs || estimate || merge_list
                       ? op_scene_describe(scene_path, defines, ndefines, &limits, &desc, &err)
                       : op_scene_load_limited(scene_path, defines, ndefines, &limits, &scene, &err);
    if (st == OP_OK && has_crop)
        st = desc ? op_scene_description_set_crop(desc, crop[0], crop[1], crop[2], crop[3], &err)
                  : op_scene_set_crop(scene, crop[0], crop[1], crop[2], crop[3], &err);
    op_scene_info info = {0};
    if (desc)
        op_scene_description_get_info(desc, &info);
    else if (scene)
        op_scene_get_info(scene, &info);
    op_inputs inputs = {0}; /* the files the scene reads: listed, or hashed into its key */
    uint64_t key = 0;
    if (st == OP_OK && (list_inputs || estimate || merge_list || g_raw_exr))
        st = op_inputs_collect(&inputs, &err);
    if (st == OP_OK && list_inputs)
        st = op_inputs_print(&inputs, stdout, &err);
    else if (st == OP_OK && (estimate || merge_list || g_raw_exr))
        st = op_inputs_key(&inputs, &info, defines, ndefines, &limits, spp, &key, &err);
    op_inputs_free(&inputs);
    for (int k = 0; k < ndefines; k++)
        free(define_buf[k]);
    if (st) {
        op_log(OP_LOG_ERROR, "%s", err.message);
        op_log_set_hook(NULL, NULL);
        op_scene_free(scene);
        op_scene_description_free(desc);
        return op_exit_code(st);
    }
    if (atomic_load(&g_signal)) { /* loading is not cancellable, but quick: stop before rendering */
        op_log(OP_LOG_WARN, "interrupted (%s) while loading %s",
               signal_name(atomic_load(&g_signal)), scene_path);
        op_log_set_hook(NULL, NULL);
        op_scene_free(scene);
        op_scene_description_free(desc);
        return op_exit_code(OP_ERR_CANCELLED);
    }
    if (list_inputs) {
        op_log_set_hook(NULL, NULL);
        op_scene_free(scene);
        op_scene_description_free(desc);
        return 0;
    }
    char scene_tag[96]; /* what every tile of this render carries and --merge-tiles expects */
    snprintf(scene_tag, sizeof scene_tag, "key=%016llx film=%dx%d", (unsigned long long)key,
             info.full_width, info.full_height);
    snprintf(g_tile_tag, sizeof g_tile_tag, "%s crop=%d,%d,%d,%d", scene_tag, crop[0], crop[1],
             has_crop ? crop[2] : info.width, has_crop ? crop[3] : info.height);
    char default_out[2048];
    if (noutputs == 0 && !stream_mode && !sss_cache_only && !estimate) {
        default_output(scene_path, &info, default_out, sizeof default_out);
        outputs[noutputs++] = default_out;
    }
    if (op_output_check(outputs, noutputs, NULL, 0, &err) != OP_OK) {
        op_log(OP_LOG_ERROR, "%s", err.message);
        op_log_set_hook(NULL, NULL);
        op_scene_free(scene);
        op_scene_description_free(desc);
        return op_exit_code(err.status);
    }
    if (check) {
        op_log(OP_LOG_INFO, "%s: valid (%dx%d, %d shapes, %d triangles, %d emitters, %d "
               "translucent)", scene_path, info.width, info.height, info.shapes, info.triangles,
               info.emitters, info.subsurface_shapes);
        op_log_set_hook(NULL, NULL);
        op_scene_free(scene);
        op_scene_description_free(desc);
        return 0;
    }
    if (estimate) {
        op_estimate e;
        op_estimate_render(&info, &limits, &e);
        const double mb = 1024.0 * 1024.0;
        printf("width=%d height=%d full_width=%d full_height=%d spp=%d translucent=%d "
               "memory_mb=%.0f loaded_mb=%.0f image_mb=%.0f sss_mb=%.0f key=%016llx\n",
               info.width, info.height, info.full_width, info.full_height, info.spp,
               info.subsurface_shapes, e.total_bytes / mb + 0.5, e.loaded_bytes / mb,
               e.image_bytes / mb, e.sss_bytes / mb, (unsigned long long)key);
        op_log_set_hook(NULL, NULL);
        op_scene_free(scene);
        op_scene_description_free(desc);
        if (fflush(stdout) != 0 || ferror(stdout)) {
            op_log(OP_LOG_ERROR, "stdout: cannot write the estimate");
            return 1;
        }
        return 0;
    }
    if (merge_list) { /* the tiles' floats, written exactly as a render's image */
        op_image merged;
        st = op_tiles_merge(merge_list, info.width, info.height, scene_tag, &merged, &err);
        int mcode = st ? op_exit_code(st) : write_images(desc, &merged, outputs, noutputs, 0);
        if (st)
            op_log(OP_LOG_ERROR, "%s", err.message);
        op_image_free(&merged);
        op_log_set_hook(NULL, NULL);
        op_scene_free(scene);
        op_scene_description_free(desc);
        return mcode;
    }

    op_render_options opt;
    op_render_options_init(&opt);
    opt.threads = threads;
    opt.spp = spp;
    opt.cancel = &g_cancel;
    opt.sss_cache = sss_cache;
    opt.sss_cache_only = sss_cache_only;
    if (stream_mode) {
        opt.tile = on_tile;
        opt.tile_user = &s;
        opt.progress = on_progress;
        opt.progress_user = &s;
        unsigned char p[12];
        op_put_le32(p, (uint32_t)info.width);
        op_put_le32(p + 4, (uint32_t)info.height);
        op_put_le32(p + 8, 4);
        record(&s, 1, p, sizeof p);
    }
    op_renderer *r = op_renderer_new(&opt);
    if (!r) {
        op_log(OP_LOG_ERROR, "out of memory");
        op_log_set_hook(NULL, NULL);
        pthread_mutex_destroy(&s.lock);
        op_scene_free(scene);
        return 1;
    }
    st = op_renderer_render(r, scene, &err); /* a stream already failed cancels it at once */
    op_render_stats rs;
    op_renderer_get_stats(r, &rs);
    int code = 0;
    if (s.error) {
        op_log(OP_LOG_ERROR, "stdout: cannot write the tile stream (%s): rendering stopped",
               strerror(s.error));
        code = op_exit_code(OP_ERR_IO);
    } else if (st && st != OP_ERR_CANCELLED) {
        op_log(OP_LOG_ERROR, "%s", err.message);
        code = op_exit_code(st);
    }
    if (sss_cache_only) {
        if (st == OP_OK)
            op_log(OP_LOG_INFO, "pre-pass cache %s: done (--sss-cache-only: no image)", sss_cache);
    } else if (st == OP_OK || st == OP_ERR_CANCELLED) {
        const op_image *img = op_renderer_image(r);
        if (rs.tiles_done == rs.tiles) {
            code = write_images(op_scene_description_of(scene), img, outputs, noutputs, code);
            if (atomic_load(&g_signal))
                op_log(OP_LOG_WARN, "interrupted (%s) after the image was complete",
                       signal_name(atomic_load(&g_signal)));
        } else {
            code = write_partial(scene, img, &rs, outputs, noutputs, partial_beside, code);
        }
    }
    if (code == 0 && (atomic_load(&g_signal) || st == OP_ERR_CANCELLED))
        code = op_exit_code(OP_ERR_CANCELLED);
    if (stream_mode) {
        unsigned char p[4];
        op_put_le32(p, (uint32_t)code);
        int failed_before = s.error != 0;
        pthread_mutex_lock(&s.lock);
        record(&s, 4, p, sizeof p);
        pthread_mutex_unlock(&s.lock);
        if (s.error && !failed_before) {
            op_log(OP_LOG_ERROR, "stdout: cannot write the tile stream's end (%s)",
                   strerror(s.error));
            code = op_exit_code(OP_ERR_IO);
        }
    }
    op_log_set_hook(NULL, NULL);
    pthread_mutex_destroy(&s.lock);
    op_renderer_free(r);
    op_scene_free(scene);
    return code;
}
