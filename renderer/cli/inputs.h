/* inputs.h - the files a scene reads, as the renderer resolves them (opaline-render
 * --list-inputs), and the content key over them (--estimate's key=, the tiles' opalineTile
 * attribute that --merge-tiles checks; docs/cluster.md). */
#ifndef OP_INPUTS_H
#define OP_INPUTS_H

#include <stdio.h>

#include "opaline_render.h"

typedef struct op_inputs {
    char **paths; /* absolute (links resolved where possible), in the order first opened */
    int n, cap;
    int nomem;    /* a path could not be recorded */
} op_inputs;

/* Fills in (zeroed first) with the inputs this run has opened so far (op_file_inputs_each; the
 * record starts with op_file_protect_inputs, first thing in main): right after describing
 * or loading a scene, the files it reads. */
op_status op_inputs_collect(op_inputs *in, op_error *err);
/* Frees the list. Accepts a zeroed in. */
void op_inputs_free(op_inputs *in);
/* Prints the paths, one a line. OP_ERR_INPUT for a name holding a line break, OP_ERR_IO when
 * f cannot be written. */
op_status op_inputs_print(const op_inputs *in, FILE *f, op_error *err);
/* Hashes (XXH3-64) what the image of a scene depends on: the renderer's version, the bytes of
 * every file recorded, the -D values, the limits (sss-max-points sets the default maxPoints),
 * the samples per pixel (spp, else info's) and the whole film's size (not a --crop). info may
 * be a description's or a built scene's: describing opens every file a build reads, in the
 * same order, so that both give the same key. */
op_status op_inputs_key(const op_inputs *in, const op_scene_info *info,
                        const op_scene_define *defines, int ndefines, const op_scene_limits *limits,
                        int spp, uint64_t *key, op_error *err);

#endif
