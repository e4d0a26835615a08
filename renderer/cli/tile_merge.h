/* tile_merge.h - assembles an image from tiles rendered separately (opaline-render --crop ...
 * --raw-exr), for opaline-render --merge-tiles (docs/cluster.md). */
#ifndef OP_TILE_MERGE_H
#define OP_TILE_MERGE_H

#include "opaline.h"

/* Reads the tile list at list_path: one tile a line, "X Y W H FILE" (pixels of the film from
 * its top-left corner; FILE relative to the list's folder unless absolute; '#' starts a
 * comment), and assembles the width x height RGBA image (allocated into *img) from the tiles'
 * files, which must be W x H RGBA images (32-bit EXR as --raw-exr writes them keep the render's
 * floats exactly). Refuses, with OP_ERR_INPUT naming every missing or invalid tile and its
 * file, a list whose tiles leave a pixel uncovered, overlap, leave the image, or whose files
 * are missing, unreadable or of the wrong size; *img is then left empty. */
op_status op_tiles_merge(const char *list_path, int width, int height, op_image *img,
                         op_error *err);

#endif
