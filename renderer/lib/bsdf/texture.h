/* texture.h - Mitsuba's 2-D textures: `bitmap` (an image file, bilinear or nearest lookups,
 * wrap modes, gamma) and `checkerboard`, both with uoffset/voffset/uscale/vscale, and Mitsuba
 * 3's `rawconstant` (one value, used as given).
 *
 * Convention (Mitsuba's): texture coordinate (u, v) = (uv.u * uscale + uoffset,
 * uv.v * vscale + voffset); u runs left to right over the image, v from its TOP row (v = 0) to
 * its bottom row (v = 1); texel centres are at ((i + 0.5) / width, (j + 0.5) / height). Mesh
 * files meet it through the OBJ reader's default flipTexCoords and the add-on's (u, 1 - v).
 *
 * Images live in an op_tex_cache that the scene owns: each (file, gamma) is read once, however
 * many textures use it, and only when a texture that something renders is built. Textures
 * point into the cache, so it must outlive them. Evaluation is read-only and thread-safe. */
#ifndef OP_TEXTURE_H
#define OP_TEXTURE_H

#include "math/vec.h"
#include "scene/scene_desc.h"
#include "opaline_image.h"

typedef enum op_tex_type {
    OP_TEX_NONE = 0,
    OP_TEX_BITMAP,
    OP_TEX_CHECKERBOARD,
    OP_TEX_CONSTANT /* rawconstant: color0 everywhere */
} op_tex_type;

typedef enum op_tex_wrap {
    OP_WRAP_REPEAT = 0,
    OP_WRAP_MIRROR,
    OP_WRAP_CLAMP,
    OP_WRAP_ZERO, /* 0 outside [0, 1] */
    OP_WRAP_ONE   /* 1 outside [0, 1] */
} op_tex_wrap;

typedef struct op_texture {
    op_tex_type type;        /* OP_TEX_NONE: no texture (zero-initialized) */
    const op_image *img;     /* bitmap: 3 channels, linear, in [0, 1]; owned by the cache */
    int nearest;             /* bitmap: nearest-texel lookups instead of bilinear */
    op_tex_wrap wrap_u, wrap_v;
    float uoffset, voffset, uscale, vscale;
    op_v3 color0, color1;    /* checkerboard */
    int value_lum;           /* op_texture_eval_value of a colour: its luminance (Mitsuba 3),
                                not its mean (0.6) */
} op_texture;

typedef struct op_tex_cache op_tex_cache;

/* NULL when out of memory. */
op_tex_cache *op_tex_cache_new(long long max_pixels); /* images over max_pixels are refused */
/* Frees the cache and its images. Accepts NULL. */
void op_tex_cache_free(op_tex_cache *c);
/* How many images the cache holds (how many files were read). */
int op_tex_cache_count(const op_tex_cache *c);
/* Image i (0 <= i < count), in the order the files were first read. */
const op_image *op_tex_cache_image(const op_tex_cache *c, int i);

/* Builds t from a <texture> node (marking it and its parameters used), reading the image of a
 * bitmap through cache. Errors name the scene file, line and the image file. */
op_status op_texture_build(op_node *node, op_tex_cache *cache, op_texture *t, op_error *err);
/* 1 when the texture builders render <texture type="type">, else 0. */
int op_texture_type_known(const char *type);
/* op_texture_build for values that are not reflectances (a principled BSDF's index of
 * refraction or diffuse transmission): checkerboard colours may exceed 1. */
/* op_texture_build for a texture read as one value (a roughness, a principled weight), its
 * checkerboard colours in [0, vmax]: as Mitsuba 3 reads one value, a checkerboard gives color1
 * where its colour lookup gives color0 and the reverse. */
op_status op_texture_build_value(op_node *node, op_tex_cache *cache, double vmax, op_texture *t,
                                 op_error *err);
/* The one value of a texture built by op_texture_build_value at (u, v): a grey colour's value,
 * else its luminance (Mitsuba 3 files) or the mean of its channels (Mitsuba 0.6), as each
 * reads one value from a colour texture. */
float op_texture_eval_value(const op_texture *t, float u, float v);
op_status op_texture_build_unbounded(op_node *node, op_tex_cache *cache, op_texture *t,
                                     op_error *err);
/* The value at surface coordinates (u, v) (before uscale/uoffset). */
op_v3 op_texture_eval(const op_texture *t, float u, float v);
/* The per-channel maximum and mean of t's values over its image or cells (what Mitsuba 0.6's
 * getMaximum and getAverage report: a bitmap's texels, a checkerboard's two colours). */
void op_texture_stats(const op_texture *t, op_v3 *max, op_v3 *mean);
/* The <texture> child of n that its parent names name (a name attribute or a <ref>'s), or
 * NULL. */
op_node *op_texture_child(const op_node *n, const char *name);
/* The gradient (*du, *dv) of the luminance of t along the surface coordinates (u, v): analytic
 * for bilinear lookups (the derivative of the interpolation between the four texels), 0 for
 * nearest lookups and the piecewise-constant textures. */
void op_texture_lum_grad(const op_texture *t, float u, float v, float *du, float *dv);

#endif
