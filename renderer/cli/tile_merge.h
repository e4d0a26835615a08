/* tile_merge.h - assembles an image from tiles rendered separately (opaline-render --crop ...
 * --raw-exr), for opaline-render --merge-tiles (docs/cluster.md). */
#ifndef OP_TILE_MERGE_H
#define OP_TILE_MERGE_H

#include "opaline.h"
#include "opaline_image.h"

/* The OpenEXR string attribute of a tile (--raw-exr): "key=K film=WxH crop=X,Y,W,H", the
 * scene's content key (inputs.h), its whole film and the tile's crop. */
#define OP_TILE_ATTR "opalineTile"

/* Reads the tile list at list_path: one tile a line, "X Y W H FILE" (pixels of the film from
 * its top-left corner, each in 0..2^31-1; FILE relative to the list's folder unless absolute;
 * '#' starts a comment), and assembles the width x height RGBA image (allocated into *img) from
 * the tiles' files, which must be W x H RGBA images (32-bit EXR as --raw-exr writes them keep
 * the render's floats exactly) whose OP_TILE_ATTR is scene_tag ("key=K film=WxH") followed by
 * " crop=X,Y,W,H" as listed. Refuses, with OP_ERR_INPUT naming the line, a number that does not
 * fit, a file listed twice, tiles that leave a pixel uncovered, overlap or leave the image, and
 * naming every such tile and its file, files missing, unreadable, of the wrong size or of
 * another render (key, film or crop); *img is then left empty. */
op_status op_tiles_merge(const char *list_path, int width, int height, const char *scene_tag,
                         op_image *img, op_error *err);

#endif
