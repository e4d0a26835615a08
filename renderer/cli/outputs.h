/* outputs.h - the images a run writes: all of them or none, and what an incomplete render
 * leaves (docs/rendering.md, "Interrupting a render"). */
#ifndef OP_OUTPUTS_H
#define OP_OUTPUTS_H

#include <stddef.h>

#include "opaline_render.h"

/* Writes img to each of the n paths as desc's film asks, all of them put in place together or
 * none (op_output_group); with raw_tag (--raw-exr), .exr outputs hold the floats exactly, tagged
 * with it (tile_merge.h). Returns code, or when code is 0 the exit code of a failed write. */
int op_write_images(const op_scene_description *desc, const op_image *img, const char *const *paths, int n,
                    const char *raw_tag, int code);
/* An incomplete render, `what` happened to it ("interrupted (SIGINT)"): the outputs are left
 * as they are, never replaced by less; with beside, the finished tiles go to each output's
 * partial name (out.partial.exr; nothing when no tile finished). Returns code as
 * op_write_images does. */
int op_write_partial(const op_scene_description *desc, const op_image *img, const op_render_stats *rs,
                     const char *const *outputs, int n, int beside, const char *what,
                     const char *raw_tag, int code);
/* The default output: the film's filename, else the scene's basename, with the film's
 * fileFormat's extension when it has none. */
void op_default_output(const char *scene_path, const op_scene_info *info, char *out, size_t n);

#endif
