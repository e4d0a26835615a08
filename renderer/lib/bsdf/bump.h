/* bump.h - Mitsuba's `bumpmap` (0.6 and 3) and `normalmap` wrappers: they tilt the shading frame
 * of the BSDF they wrap, whatever its model. A bump map is a height field: the gradient of its
 * texture's luminance along the texture coordinates (times `scale`) lifts the surface's
 * derivatives dp/du, dp/dv along the shading normal, whose cross product is the new normal. A
 * normal map holds tangent-space normals, each channel c meaning 2 c - 1 along (s, t, n) of the
 * shading frame whose s follows dp/du. The wrapped BSDF then sees directions in the tilted frame
 * (geometry/isect.c makes it where the hit's shading frame is made). */
#ifndef OP_BUMP_H
#define OP_BUMP_H

#include "math/vec.h"
#include "scene/scene_desc.h"
#include "bsdf/texture.h"

typedef enum op_bump_type { OP_BUMP_NONE = 0, OP_BUMP_HEIGHT, OP_BUMP_NORMAL } op_bump_type;

typedef struct op_bump {
    op_bump_type type;  /* OP_BUMP_NONE: the frame is left alone (zero-initialized) */
    op_texture tex;     /* the height field, or the tangent-space normals */
    float scale;        /* height: the gradient's multiplier */
    int flip_invalid;   /* Mitsuba 3: a tilted normal the viewer sees from behind while it sees
                           the surface from the front (or the reverse) is mirrored about the
                           untilted normal */
    int needs_uv;       /* Mitsuba 0.6: only on shapes with texture coordinates */
    int shadowing;      /* Mitsuba 3's use_shadowing_function (op_isect_shadowing) */
} op_bump;

/* Reads a <bsdf type="bumpmap"> or "normalmap" node's own parameters into *bump (its texture,
 * nested or referenced under any name, read through cache) and gives its one nested <bsdf> in
 * *inner (which the caller builds). Mitsuba 0.6 files: a bitmap must state its gamma, as
 * Mitsuba 0.6 demands. */
op_status op_bump_build(op_node *node, op_tex_cache *cache, op_bump *bump, op_node **inner,
                        op_error *err);

/* The tilted shading frame at a surface point whose untilted one is sh (normal sh.n), with
 * geometric normal ng (unit, on sh.n's side), derivatives dpdu, dpdv along the texture
 * coordinates (u, v), seen from direction wi (unit, away from the surface). Where the tilt is
 * undefined (a zero normal, a degenerate parameterization), sh itself. */
op_frame op_bump_frame(const op_bump *b, const op_frame *sh, op_v3 ng, op_v3 dpdu, op_v3 dpdv,
                       float u, float v, op_v3 wi);

/* The untilted shading frame around the unit normal ns whose s follows dpdu (as Mitsuba's
 * shading frames do); op_frame_from_normal(ns) where dpdu is parallel to ns or zero. */
op_frame op_frame_from_tangent(op_v3 ns, op_v3 dpdu);

#endif
