/* phong.h - Mitsuba 0.6's `phong`: the modified Phong BRDF (Phong 1975, Lafortune and Willems
 * 1994), energy-normalised: f = diffuse / pi + specular (n + 2) / (2 pi) cos^n alpha, alpha
 * the angle between wo and wi mirrored about the normal (no glossy reflection past 90
 * degrees), n the exponent (default 30; a texture's value is the mean of its channels). The
 * glossy lobe is sampled by cos^n alpha about the mirror direction (density (n + 1) / (2 pi)
 * cos^n alpha, the part of it below the surface absorbed), the diffuse one by the cosine,
 * chosen by the lobe weights of diffuse_glossy.h. One-sided, reciprocal; its albedo is at most
 * diffuse + specular (equal at normal incidence), so at most 1.
 * Directions and values as bsdf.h (local frame, f |cos wo|); wi.z, wo.z > 0. */
#ifndef OP_PHONG_H
#define OP_PHONG_H

#include "math/vec.h"
#include "scene/scene_desc.h"
#include "bsdf/texture.h"
#include "bsdf/diffuse_glossy.h"

typedef struct op_phong {
    op_diffuse_glossy dg;
    float exponent;           /* at a point (after op_phong_at) */
    op_texture exponent_tex;  /* type OP_TEX_NONE: constant */
} op_phong;

/* Builds p from a <bsdf type="phong"> node, reading textures' images through cache. */
op_status op_phong_build(op_node *node, op_tex_cache *cache, op_phong *p, op_error *err);
/* Whether some parameter of p is a texture. */
int op_phong_textured(const op_phong *p);
/* p's textures looked up at (u, v) into *out (a copy of p). */
void op_phong_at(const op_phong *p, float u, float v, op_phong *out);
/* f |cos wo| and the density of wo under op_phong_sample. */
op_v3 op_phong_eval(const op_phong *p, op_v3 wi, op_v3 wo, float *pdf);
/* A direction for wi from u1, u2 (in the lobe) and u3 (which lobe); it may lie below the
 * surface (absorbed). */
op_v3 op_phong_sample(const op_phong *p, op_v3 wi, float u1, float u2, float u3);

#endif
