/* stream.h - the tile stream opaline-render --stream writes on stdout (docs/rendering.md, "Tile
 * stream"): little-endian records, each "OPTS", u32 type, u64 payload bytes, payload. Every
 * record is flushed as it is written; the first failed write stops all later ones and sets the
 * render's cancel flag (its reader is gone). */
#ifndef OP_STREAM_H
#define OP_STREAM_H

#include <stdio.h>

#include "opaline_render.h"

typedef enum op_stream_record {
    OP_RECORD_BEGIN = 1,    /* u32 width, height, channels (4), tile side */
    OP_RECORD_TILE = 2,     /* u32 x, y, w, h, then w*h*4 f32 RGBA, rows top to bottom */
    OP_RECORD_PROGRESS = 3, /* f64 fraction of the stage, u32 label bytes, the label */
    OP_RECORD_END = 4,      /* u32 exit status */
    OP_RECORD_LOG = 5,      /* u32 level (op_log_level), then the message */
    OP_RECORD_STATS = 6     /* what the render computed: op_stream_stats */
} op_stream_record;

typedef struct op_stream op_stream;

/* A stream writing to f; cancel (may be NULL) is set when a write fails. NULL when out of
 * memory. */
op_stream *op_stream_new(FILE *f, atomic_int *cancel);
/* Frees s (not its FILE). Remove op_stream_log from the log hook first. */
void op_stream_free(op_stream *s);
/* The errno of the first failed write, 0 while none failed. */
int op_stream_error(const op_stream *s);

/* BEGIN: the image's size (the crop window's when there is one) and the side of its tiles. */
void op_stream_begin(op_stream *s, int width, int height, int tile_size);
/* TILE, as op_render_options.tile (user: the stream). */
void op_stream_tile(void *user, const op_render_tile *t);
/* PROGRESS, as op_render_options.progress (user: the stream; the label cut at 255 bytes). */
void op_stream_progress(void *user, const char *label, double fraction, double eta);
/* LOG, as an op_log_set_hook hook (user: the stream). */
void op_stream_log(void *user, op_log_level level, const char *message);
/* STATS: i64 sss_points, sss_sources, sss_receivers, sss_sources_reused,
 * sss_receivers_reused; u32 sss_shapes_reached, sss_shapes_capped, tiles, tiles_done; f64
 * sss_seconds, render_seconds (op_render_stats' fields). */
void op_stream_stats(op_stream *s, const op_render_stats *rs);
/* END: the exit status. */
void op_stream_end(op_stream *s, int status);

#endif
