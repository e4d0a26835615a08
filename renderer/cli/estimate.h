/* estimate.h - what a render of a scene is expected to need, for a scheduler's request
 * (opaline-render --estimate; docs/cluster.md). */
#ifndef OP_ESTIMATE_H
#define OP_ESTIMATE_H

#include "opaline_render.h"

typedef struct op_estimate {
    long long loaded_bytes; /* the peak memory of loading the scene, as its description
                               estimates it (op_scene_info.load_bytes: geometry, Embree,
                               materials mapped, textures) */
    long long image_bytes;  /* the film: the render's float RGBA image and one output's copy */
    long long sss_bytes;    /* a bound on the subsurface pre-pass: every translucent shape at
                               its point cap (sss-max-points, all shapes within sss-points) */
    long long total_bytes;  /* their sum */
} op_estimate;

/* Fills e for a scene (described or built) with limits lim. */
void op_estimate_render(const op_scene_info *info, const op_scene_limits *lim, op_estimate *e);

#endif
