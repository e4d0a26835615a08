/* principled.h - Mitsuba 3's `principled` and `principledthin` BSDFs (Burley's Disney BSDF as
 * Mitsuba 3 defines it), every weight a constant or a texture.
 *
 * principled: a diffuse lobe (Burley's retro-reflection, Hanrahan-Krueger flattening), a sheen
 * lobe, a main GGX lobe (anisotropic) that reflects with a Fresnel term blending the dielectric's
 * exact one with Schlick's tinted and metallic ones and refracts (spec_trans, tinted by the
 * square root of base_color), and a GTR1 clearcoat lobe. Seen from below (wi.z < 0), only the
 * main lobe's dielectric part, weighted by (1 - metallic) spec_trans. principledthin: a
 * two-sided sheet (no bending, no index change) with diffuse reflection and sheen, Lambertian
 * diffuse transmission (diff_trans in [0, 2]) and the main lobe's reflection and transmission
 * (transmission through a roughness scaled by the index, as Burley 2015 scales it).
 *
 * Directions and values follow bsdf.h (local frame, wi toward the viewer, f |cos wo|, refraction
 * radiance-scaled). The densities are those of the lobe choice Mitsuba makes, with its sampling
 * rates, over visible-normal GGX, GTR1 and cosine sampling. */
#ifndef OP_PRINCIPLED_H
#define OP_PRINCIPLED_H

#include "math/vec.h"
#include "scene/scene_desc.h"
#include "bsdf/texture.h"

/* The scalar weights (base_color is the one colour). */
typedef enum op_pr_param {
    OP_PR_ROUGHNESS,
    OP_PR_ANISOTROPIC,
    OP_PR_METALLIC,
    OP_PR_SPEC_TRANS,
    OP_PR_SPEC_TINT,
    OP_PR_SHEEN,
    OP_PR_SHEEN_TINT,
    OP_PR_FLATNESS,
    OP_PR_CLEARCOAT,
    OP_PR_CLEARCOAT_GLOSS,
    OP_PR_DIFF_TRANS, /* principledthin, in [0, 2] */
    OP_PR_ETA,        /* principledthin (a texture there); principled: the constant index */
    OP_PR_N
} op_pr_param;

typedef struct op_principled {
    int thin;                 /* principledthin */
    op_v3 base_color;
    float v[OP_PR_N];         /* the weights (at a point, after op_principled_at) */
    op_texture base_tex;      /* base_color as a texture (type OP_TEX_NONE: constant) */
    op_texture tex[OP_PR_N];  /* each weight as a texture (luminance of its colour), or none */
    int textured;             /* some texture is set */
    /* sampling rates: principled's main specular, clearcoat and diffuse; principledthin's
     * specular reflection, specular transmission, diffuse reflection, diffuse transmission */
    float rate[4];
} op_principled;

/* Builds p from a <bsdf type="principled"> or "principledthin" node with Mitsuba 3's parameter
 * names (as camelCase, dialect.h) and defaults; any weight may be a nested <texture>, whose
 * image is read through tex. */
op_status op_principled_build(op_node *node, op_tex_cache *tex, op_principled *p, op_error *err);
/* p's textures looked up at (u, v) into *out (a copy of p). */
void op_principled_at(const op_principled *p, float u, float v, op_principled *out);
/* f |cos wo| and the density of wo (solid angle) under op_principled_sample. */
op_v3 op_principled_eval(const op_principled *p, op_v3 wi, op_v3 wo, float *pdf);
/* Draws wo from u1, u2 (the direction) and u3 (the lobe); fills *wo, *weight (f |cos| / pdf)
 * and *pdf. Returns 0 when nothing is drawn. */
int op_principled_sample(const op_principled *p, op_v3 wi, float u1, float u2, float u3,
                         op_v3 *wo, op_v3 *weight, float *pdf);

#endif
