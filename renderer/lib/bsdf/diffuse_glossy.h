/* diffuse_glossy.h - what Mitsuba 0.6's phong and ward share: a Lambertian lobe of
 * diffuseReflectance (default 0.5) beside a glossy lobe weighted by specularReflectance
 * (default 0.2), each a colour or a texture; when the two add up to more than 1 in some channel
 * both are scaled by 0.99 / that maximum (unless ensureEnergyConservation is false, as in
 * Mitsuba); and directions
 * drawn from the glossy lobe with probability lum(mean specular) / (lum(mean diffuse) +
 * lum(mean specular)), the means over the textures' images. */
#ifndef OP_DIFFUSE_GLOSSY_H
#define OP_DIFFUSE_GLOSSY_H

#include "math/vec.h"
#include "scene/scene_desc.h"
#include "bsdf/texture.h"

typedef struct op_diffuse_glossy {
    op_v3 diffuse, specular;     /* the weights at a point (after op_diffuse_glossy_at) */
    op_texture diffuse_tex, specular_tex; /* type OP_TEX_NONE: constant */
    float scale;                 /* the energy scale, which the constants above already carry */
    float glossy_prob;           /* the probability of drawing from the glossy lobe */
} op_diffuse_glossy;

/* Reads diffuseReflectance and specularReflectance of a phong or ward node (images through
 * cache) into *dg. */
op_status op_diffuse_glossy_build(op_node *node, op_tex_cache *cache, op_diffuse_glossy *dg,
                                  op_error *err);
/* Whether a weight of dg is a texture. */
int op_diffuse_glossy_textured(const op_diffuse_glossy *dg);
/* dg's textures looked up at (u, v) into *out (a copy of dg). */
void op_diffuse_glossy_at(const op_diffuse_glossy *dg, float u, float v, op_diffuse_glossy *out);
/* The two lobes together (wo.z > 0): f |cos wo| = diffuse wo.z / pi + specular glossy_f, where
 * glossy_f is the glossy lobe's f |cos wo| per unit weight; *pdf mixes glossy_pdf (the glossy
 * sampling's density of wo) with the cosine density by glossy_prob. */
op_v3 op_diffuse_glossy_mix(const op_diffuse_glossy *dg, op_v3 wo, float glossy_f,
                            float glossy_pdf, float *pdf);

#endif
