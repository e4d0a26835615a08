/* options.h - opaline-render's command line (docs/rendering.md): what a run is asked to do. */
#ifndef OP_OPTIONS_H
#define OP_OPTIONS_H

#include <stdio.h>

#include "opaline_render.h"

enum { OP_CLI_MAX_OUTPUTS = 16, OP_CLI_MAX_DEFINES = 256, OP_CLI_MAX_FOLDERS = 64 };

typedef enum op_cli_mode {
    OP_MODE_RENDER,         /* render into the outputs and/or the tile stream */
    OP_MODE_CHECK,          /* --check: load and validate only */
    OP_MODE_ESTIMATE,       /* --estimate: load, print the size, memory and key */
    OP_MODE_LIST_INPUTS,    /* --list-inputs: load, print every file read */
    OP_MODE_MERGE_TILES,    /* --merge-tiles LIST: assemble the film from --raw-exr tiles */
    OP_MODE_FIND_MATERIAL,  /* --find-material NAME: where a scene finds the material */
    OP_MODE_PRESET_FOLDERS  /* --preset-folders: where preset names are looked up */
} op_cli_mode;

typedef struct op_cli_options {
    op_cli_mode mode;
    const char *scene_path;
    const char *outputs[OP_CLI_MAX_OUTPUTS + 1]; /* room for the default output */
    int noutputs;
    int threads, spp, tile_size; /* 0: all cores, the scene's sampler, OP_RENDER_TILE_SIZE */
    int verbosity;               /* -q counts down, -v up */
    op_scene_define defines[OP_CLI_MAX_DEFINES]; /* names and values owned (one copy each) */
    int ndefines;
    const char *folders[OP_CLI_MAX_FOLDERS]; /* -a: search folders, in order */
    int nfolders;
    char *folder_args[OP_CLI_MAX_FOLDERS];   /* the -a values they point into (owned) */
    int nfolder_args;
    op_scene_limits limits;
    int has_crop, crop[4];       /* --crop X,Y,W,H */
    const char *sss_cache;
    int sss_cache_only;
    int stream, stream_log, raw_exr;
    int partial_beside;          /* --partial beside (1, the default) or none (0) */
    const char *merge_list;      /* --merge-tiles LIST */
    const char *material;        /* --find-material NAME */
    const char *scene_dir;       /* --scene-dir DIR, or NULL */
} op_cli_options;

/* Fills o from argv. Returns -1 when the run goes on, else its exit code now: 0 after --help
 * (the usage on stdout; 1 when it cannot be written), 2 for bad arguments (said, then the
 * usage on stderr). Call op_cli_options_free either way. */
int op_cli_parse(int argc, char **argv, op_cli_options *o);
void op_cli_options_free(op_cli_options *o);

#endif
