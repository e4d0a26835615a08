/* opaline-render - renders a scene to image files or to the tile stream on stdout.
 * Command line and tile stream: /work/notes/interfaces.md, documented in docs/rendering.md. */
#include <errno.h>
#include <libgen.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "opaline_render.h"

enum { MAX_OUTPUTS = 16, MAX_DEFINES = 256 };

static atomic_int g_cancel; /* set by SIGINT; lock-free, so safe from the handler */

static void on_sigint(int sig)
{
    (void)sig;
    atomic_store(&g_cancel, 1);
}

static void usage(FILE *f)
{
    fprintf(f,
            "usage: opaline-render [options] SCENE.xml\n"
            "  -o FILE        output image (.exr .png .pfm .hdr by extension); repeatable\n"
            "  -t N           worker threads (default: all cores)\n"
            "  -s N           samples per pixel (overrides the scene's sampler)\n"
            "  -D name=value  overrides <default name=...>; repeatable\n"
            "  --check        parse and validate only\n"
            "  --stream       write the tile stream to stdout\n"
            "  -q / -v        quieter / more verbose\n");
}

/* ------------------------------------------------------------ the tile stream (little-endian) */

typedef struct stream {
    pthread_mutex_t lock;
    FILE *f;
} stream;

static void put_u32(unsigned char *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (unsigned char)(v >> (8 * i));
}

static void put_u64(unsigned char *p, uint64_t v)
{
    for (int i = 0; i < 8; i++)
        p[i] = (unsigned char)(v >> (8 * i));
}

/* Writes one record's header and payload; the caller holds the lock. */
static void record(stream *s, uint32_t type, const void *payload, uint64_t n)
{
    unsigned char h[16];
    memcpy(h, "OPTS", 4);
    put_u32(h + 4, type);
    put_u64(h + 8, n);
    fwrite(h, 1, sizeof h, s->f);
    if (n)
        fwrite(payload, 1, (size_t)n, s->f);
    fflush(s->f);
}

static int host_le(void)
{
    uint16_t one = 1;
    unsigned char b;
    memcpy(&b, &one, 1);
    return b == 1;
}

static void on_tile(void *user, const op_render_tile *t)
{
    stream *s = user; /* the renderer serializes tile callbacks; the lock orders them with progress */
    size_t nf = (size_t)t->w * t->h * 4;
    size_t n = 16 + nf * 4;
    unsigned char *p = malloc(n);
    if (!p)
        return;
    put_u32(p, (uint32_t)t->x);
    put_u32(p + 4, (uint32_t)t->y);
    put_u32(p + 8, (uint32_t)t->w);
    put_u32(p + 12, (uint32_t)t->h);
    if (host_le()) {
        memcpy(p + 16, t->rgba, nf * 4);
    } else {
        for (size_t i = 0; i < nf; i++) {
            uint32_t v;
            memcpy(&v, &t->rgba[i], 4);
            put_u32(p + 16 + 4 * i, v);
        }
    }
    pthread_mutex_lock(&s->lock);
    record(s, 2, p, n);
    pthread_mutex_unlock(&s->lock);
    free(p);
}

static void on_progress(void *user, const char *label, double fraction, double eta)
{
    (void)eta;
    stream *s = user;
    if (strcmp(label, "render") != 0)
        return; /* the subsurface pre-passes are not part of the image's progress */
    unsigned char p[8];
    uint64_t bits;
    memcpy(&bits, &fraction, 8);
    put_u64(p, bits);
    pthread_mutex_lock(&s->lock);
    record(s, 3, p, 8);
    pthread_mutex_unlock(&s->lock);
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
    const char *outputs[MAX_OUTPUTS];
    int noutputs = 0, threads = 0, spp = 0, check = 0, stream_mode = 0, verbosity = 0;
    op_scene_define defines[MAX_DEFINES];
    char *define_buf[MAX_DEFINES];
    int ndefines = 0;
    const char *scene_path = NULL;
    int bad = 0;
    for (int i = 1; i < argc && !bad; i++) {
        const char *a = argv[i];
        int need = strcmp(a, "-o") == 0 || strcmp(a, "-t") == 0 || strcmp(a, "-s") == 0 ||
                   strcmp(a, "-D") == 0;
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
        } else if (strcmp(a, "--check") == 0) {
            check = 1;
        } else if (strcmp(a, "--stream") == 0) {
            stream_mode = 1;
        } else if (strcmp(a, "-q") == 0) {
            verbosity--;
        } else if (strcmp(a, "-v") == 0) {
            verbosity++;
        } else if (strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0) {
            usage(stdout);
            for (int k = 0; k < ndefines; k++)
                free(define_buf[k]);
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

    op_error err = {0};
    op_scene *scene = NULL;
    op_status st = op_scene_load(scene_path, defines, ndefines, &scene, &err);
    for (int k = 0; k < ndefines; k++)
        free(define_buf[k]);
    if (st) {
        op_log(OP_LOG_ERROR, "%s", err.message);
        return op_exit_code(st);
    }
    op_scene_info info;
    op_scene_get_info(scene, &info);
    if (check) {
        op_log(OP_LOG_INFO, "%s: valid (%dx%d, %d shapes, %d triangles, %d emitters, %d "
               "translucent)", scene_path, info.width, info.height, info.shapes, info.triangles,
               info.emitters, info.subsurface_shapes);
        op_scene_free(scene);
        return 0;
    }
    char default_out[2048];
    if (noutputs == 0 && !stream_mode) {
        default_output(scene_path, &info, default_out, sizeof default_out);
        outputs[noutputs++] = default_out;
    }

    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_sigint;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);

    stream s;
    pthread_mutex_init(&s.lock, NULL);
    s.f = stdout;
    op_render_options opt;
    op_render_options_init(&opt);
    opt.threads = threads;
    opt.spp = spp;
    opt.cancel = &g_cancel;
    if (stream_mode) {
        opt.tile = on_tile;
        opt.tile_user = &s;
        opt.progress = on_progress;
        opt.progress_user = &s;
        unsigned char p[12];
        put_u32(p, (uint32_t)info.width);
        put_u32(p + 4, (uint32_t)info.height);
        put_u32(p + 8, 4);
        record(&s, 1, p, sizeof p);
    }
    op_renderer *r = op_renderer_new(&opt);
    if (!r) {
        op_log(OP_LOG_ERROR, "out of memory");
        op_scene_free(scene);
        return 1;
    }
    st = op_renderer_render(r, scene, &err);
    int code = op_exit_code(st);
    const op_image *img = op_renderer_image(r);
    if (st && st != OP_ERR_CANCELLED)
        op_log(OP_LOG_ERROR, "%s", err.message);
    if (st == OP_ERR_CANCELLED)
        op_log(OP_LOG_WARN, "interrupted: writing the partial image");
    if (img && (st == OP_OK || st == OP_ERR_CANCELLED)) {
        for (int i = 0; i < noutputs; i++) {
            op_error werr = {0};
            op_status ws = op_scene_write_image(scene, img, outputs[i], &werr);
            if (ws) {
                op_log(OP_LOG_ERROR, "%s", werr.message);
                if (code == 0)
                    code = op_exit_code(ws);
            } else {
                op_log(OP_LOG_INFO, "wrote %s", outputs[i]);
            }
        }
    }
    if (stream_mode) {
        unsigned char p[4];
        put_u32(p, (uint32_t)code);
        record(&s, 4, p, sizeof p);
    }
    pthread_mutex_destroy(&s.lock);
    op_renderer_free(r);
    op_scene_free(scene);
    return code;
}
