/* options.c - opaline-render's command line (options.h). */
#include "options.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

static void usage(FILE *f)
{
    fprintf(f,
            "usage: opaline-render [options] SCENE.xml\n"
            "       opaline-render --find-material NAME [--scene-dir DIR]\n"
            "       opaline-render --preset-folders [--scene-dir DIR]\n"
            "  -o FILE        output image (.exr .png .pfm .hdr by extension; the film's\n"
            "                 format without one, as /dev/stdout); repeatable\n"
            "  -t N           worker threads (default: all cores)\n"
            "  -s N           samples per pixel (overrides the scene's sampler)\n"
            "  -D name=value  overrides <default name=...>; repeatable\n"
            "  -a FOLDER[:FOLDER...]  also look for the files the scene names in these\n"
            "                 folders, after its own folder and <path> folders, before\n"
            "                 the current folder; repeatable. A missing folder: exit 2\n"
            "  --tile-size N  render in NxN tiles (default 32; the image does not change)\n"
            "  --check        load the scene (meshes, materials, images) and validate only\n"
            "  --estimate     describe the scene (no mesh, material or image loaded), then\n"
            "                 print the render's size and memory estimate on stdout\n"
            "                 (key=value; for schedulers, docs/cluster.md), and key=, the\n"
            "                 hash of everything the image depends on\n"
            "  --list-inputs  describe the scene, then print every file it reads (absolute\n"
            "                 paths, one a line: the scene, includes, meshes, images,\n"
            "                 materials)\n"
            "  --find-material NAME  print where a scene in DIR (--scene-dir, default the\n"
            "                 current folder) finds the material NAME: a line 'searched\n"
            "                 FOLDER' per folder searched, then 'found FILE'; exit 0 found,\n"
            "                 3 not found\n"
            "  --preset-folders  print the folders preset names are looked up in after the\n"
            "                 scene's own (--scene-dir DIR: that one first), one a line\n"
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
            "  --stream-log   with --stream, every log line also goes into the stream, and\n"
            "                 the render's counts before its end\n"
            "  --partial MODE on an interrupt, OUT is kept and with MODE beside (default) the\n"
            "                 finished tiles go to OUT.partial.EXT; none writes nothing\n"
            "  -q / -v        quieter / more verbose\n");
}

/* Reads option opt's value v, a whole number in [lo, hi], into *out; 0 when it is not one
 * (said). */
static int take_whole(const char *opt, const char *v, int lo, int hi, int *out)
{
    double x;
    op_error err = {0};
    if (op_parse_number(opt, v, lo, hi, OP_NUMBER_WHOLE, &x, &err) != OP_OK) {
        op_log(OP_LOG_ERROR, "%s", err.message);
        return 0;
    }
    *out = (int)x;
    return 1;
}

static int takes_value(const char *a)
{
    static const char *const with_value[] = {"-o", "-t", "-s", "-D", "-a", "--limit", "--partial",
                                             "--crop", "--merge-tiles", "--sss-cache",
                                             "--tile-size", "--find-material", "--scene-dir"};
    for (size_t i = 0; i < sizeof with_value / sizeof *with_value; i++)
        if (strcmp(a, with_value[i]) == 0)
            return 1;
    return 0;
}

/* Takes -a's value v (folders separated by ':') into o. Returns 0 when it is bad (said). */
static int take_folders(op_cli_options *o, const char *v)
{
    if (o->nfolder_args == OP_CLI_MAX_FOLDERS) {
        op_log(OP_LOG_ERROR, "-a %s: at most %d search folders", v, OP_CLI_MAX_FOLDERS);
        return 0;
    }
    char *copy = strdup(v);
    if (!copy) {
        op_log(OP_LOG_ERROR, "out of memory");
        return 0;
    }
    o->folder_args[o->nfolder_args++] = copy;
    for (char *f = copy, *end;; f = end + 1) {
        end = strchr(f, ':');
        if (end)
            *end = '\0';
        if (!*f) {
            op_log(OP_LOG_ERROR, "-a %s: an empty folder name", v);
            return 0;
        }
        if (o->nfolders == OP_CLI_MAX_FOLDERS) {
            op_log(OP_LOG_ERROR, "-a %s: at most %d search folders", v, OP_CLI_MAX_FOLDERS);
            return 0;
        }
        o->folders[o->nfolders++] = f;
        if (!end)
            return 1;
    }
}

/* Takes the option a (its value v when it has one) into o. Returns 0 when it is bad (said). */
static int take(op_cli_options *o, const char *a, const char *v, int *check, int *estimate,
                int *list_inputs, int *folders)
{
    if (strcmp(a, "-o") == 0) {
        if (o->noutputs == OP_CLI_MAX_OUTPUTS) {
            op_log(OP_LOG_ERROR, "at most %d -o outputs", OP_CLI_MAX_OUTPUTS);
            return 0;
        }
        o->outputs[o->noutputs++] = v;
    } else if (strcmp(a, "-t") == 0) {
        if (!take_whole(a, v, 1, 1024, &o->threads))
            return 0;
    } else if (strcmp(a, "-s") == 0) {
        if (!take_whole(a, v, 1, 1 << 24, &o->spp))
            return 0;
    } else if (strcmp(a, "--tile-size") == 0) {
        if (!take_whole(a, v, 1, 4096, &o->tile_size))
            return 0;
    } else if (strcmp(a, "-D") == 0) {
        const char *eq = strchr(v, '=');
        if (!eq || eq == v || o->ndefines == OP_CLI_MAX_DEFINES) {
            op_log(OP_LOG_ERROR, "-D %s: need name=value", v);
            return 0;
        }
        char *copy = strdup(v);
        if (!copy) {
            op_log(OP_LOG_ERROR, "out of memory");
            return 0;
        }
        copy[eq - v] = '\0';
        o->defines[o->ndefines].name = copy;
        o->defines[o->ndefines].value = copy + (eq - v) + 1;
        o->ndefines++;
    } else if (strcmp(a, "-a") == 0) {
        return take_folders(o, v);
    } else if (strcmp(a, "--limit") == 0) {
        op_error lerr = {0};
        if (op_scene_limits_set(&o->limits, v, &lerr) != OP_OK) {
            op_log(OP_LOG_ERROR, "--%s", lerr.message); /* "--limit ...: ..." */
            return 0;
        }
    } else if (strcmp(a, "--crop") == 0) {
        /* X,Y,W,H: the film checks they fit */
        double xywh[4];
        op_error err = {0};
        if (op_parse_numbers(a, v, 4, 0, 65536, OP_NUMBER_WHOLE, xywh, &err) != OP_OK) {
            op_log(OP_LOG_ERROR, "%s", err.message);
            return 0;
        }
        o->has_crop = 1;
        for (int i = 0; i < 4; i++)
            o->crop[i] = (int)xywh[i];
    } else if (strcmp(a, "--sss-cache") == 0) {
        o->sss_cache = v;
        if (!*v) {
            op_log(OP_LOG_ERROR, "--sss-cache needs a file name");
            return 0;
        }
    } else if (strcmp(a, "--partial") == 0) {
        o->partial_beside = strcmp(v, "beside") == 0;
        if (!o->partial_beside && strcmp(v, "none") != 0) {
            op_log(OP_LOG_ERROR, "--partial %s: need beside or none", v);
            return 0;
        }
    } else if (strcmp(a, "--merge-tiles") == 0) {
        o->merge_list = v;
    } else if (strcmp(a, "--find-material") == 0) {
        o->material = v;
        if (!*v) {
            op_log(OP_LOG_ERROR, "--find-material needs a material name");
            return 0;
        }
    } else if (strcmp(a, "--scene-dir") == 0) {
        o->scene_dir = v;
    } else if (strcmp(a, "--sss-cache-only") == 0) {
        o->sss_cache_only = 1;
    } else if (strcmp(a, "--check") == 0) {
        *check = 1;
    } else if (strcmp(a, "--estimate") == 0) {
        *estimate = 1;
    } else if (strcmp(a, "--list-inputs") == 0) {
        *list_inputs = 1;
    } else if (strcmp(a, "--preset-folders") == 0) {
        *folders = 1;
    } else if (strcmp(a, "--raw-exr") == 0) {
        o->raw_exr = 1;
    } else if (strcmp(a, "--stream") == 0) {
        o->stream = 1;
    } else if (strcmp(a, "--stream-log") == 0) {
        o->stream_log = 1;
    } else if (strcmp(a, "-q") == 0) {
        o->verbosity--;
    } else if (strcmp(a, "-v") == 0) {
        o->verbosity++;
    } else if (a[0] == '-' && a[1]) {
        op_log(OP_LOG_ERROR, "unknown option %s", a);
        return 0;
    } else if (o->scene_path) {
        op_log(OP_LOG_ERROR, "more than one scene given (%s, %s)", o->scene_path, a);
        return 0;
    } else {
        o->scene_path = a;
    }
    return 1;
}

/* The mode the options ask for, or a message saying why they do not go together. */
static const char *choose_mode(op_cli_options *o, int check, int estimate, int list_inputs,
                               int folders)
{
    if (o->material || folders) {
        o->mode = o->material ? OP_MODE_FIND_MATERIAL : OP_MODE_PRESET_FOLDERS;
        if (o->material && folders)
            return "--find-material and --preset-folders: one at a time";
        if (o->nfolders > 0)
            return "-a goes with a scene, not with --find-material or --preset-folders";
        return o->scene_path ? "--find-material and --preset-folders take no scene "
                               "(--scene-dir DIR names its folder)"
                             : NULL;
    }
    if (o->scene_dir)
        return "--scene-dir goes with --find-material or --preset-folders";
    if (!o->scene_path)
        return "no scene given";
    o->mode = list_inputs ? OP_MODE_LIST_INPUTS
              : check     ? OP_MODE_CHECK
              : estimate  ? OP_MODE_ESTIMATE
              : o->merge_list ? OP_MODE_MERGE_TILES
                              : OP_MODE_RENDER;
    if (o->merge_list && (o->has_crop || o->stream))
        return "--merge-tiles assembles the whole film: not with --crop or --stream";
    if (o->sss_cache_only && !o->sss_cache)
        return "--sss-cache-only needs --sss-cache FILE";
    if (o->sss_cache_only && (o->noutputs > 0 || o->stream))
        return "--sss-cache-only renders no image: it takes no -o or --stream";
    return NULL;
}

int op_cli_parse(int argc, char **argv, op_cli_options *o)
{
    memset(o, 0, sizeof *o);
    op_scene_limits_init(&o->limits);
    o->partial_beside = 1;
    int check = 0, estimate = 0, list_inputs = 0, folders = 0, ok = 1;
    for (int i = 1; i < argc && ok; i++) {
        const char *a = argv[i];
        if (strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0) {
            usage(stdout);
            if (fflush(stdout) != 0 || ferror(stdout)) {
                op_log(OP_LOG_ERROR, "stdout: cannot write the usage: %s",
                       errno ? strerror(errno) : "write error");
                return 1;
            }
            return 0;
        }
        if (takes_value(a) && i + 1 >= argc) {
            op_log(OP_LOG_ERROR, "%s needs a value", a);
            ok = 0;
        } else {
            ok = take(o, a, takes_value(a) ? argv[++i] : NULL, &check, &estimate, &list_inputs,
                      &folders);
        }
    }
    const char *conflict = ok ? choose_mode(o, check, estimate, list_inputs, folders) : NULL;
    if (conflict)
        op_log(OP_LOG_ERROR, "%s", conflict);
    if (ok && !conflict)
        return -1;
    usage(stderr);
    return 2;
}

void op_cli_options_free(op_cli_options *o)
{
    for (int k = 0; k < o->ndefines; k++)
        free((char *)o->defines[k].name);
    o->ndefines = 0;
    for (int k = 0; k < o->nfolder_args; k++)
        free(o->folder_args[k]);
    o->nfolder_args = o->nfolders = 0;
}
