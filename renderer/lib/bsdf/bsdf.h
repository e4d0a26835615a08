/* bsdf.h - surface scattering models as Mitsuba 0.6 defines them: diffuse, roughdiffuse
 * (Oren-Nayar), dielectric, roughdielectric (Walter et al. 2007), conductor, roughconductor
 * (named conductors: conductor_table.h), plastic, roughplastic (GGX); the rough ones over the
 * microfacet distributions of microfacet.h; Mitsuba 3's principled and principledthin
 * (principled.h); Mitsuba 0.6's phong (phong.h) and ward (ward.h). Reflecting models may be two-sided, and Mitsuba's
 * `mask` (cut-out opacity) goes around any of them. The boundary of a translucent shape
 * (op_bsdf_boundary) is the reflection of a dielectric, roughdielectric, plastic, roughplastic
 * or coating whose transmitted part is the subsurface transport (docs/subsurface-rendering.md).
 * All work in the local shading frame (z = normal); wi points away from the surface toward where
 * the light goes (the viewer), wo toward where it comes from (either side of the surface for
 * dielectrics). Values returned are f * |cos(wo)|; light refracted into a medium of relative
 * index eta is radiance, scaled by 1 / eta^2.
 *
 * Passable surfaces: a ray meeting a mask (cut-out opacity, `mask`) or a thin dielectric
 * (`thindielectric`, a two-sided perfect mirror that light also crosses straight) either stops
 * there, and the model applies, or goes straight on without a bounce (op_bsdf_passage); shadow
 * rays cross it attenuated. The eval/sample functions below describe the model a ray that
 * stopped meets. */
#ifndef OP_BSDF_H
#define OP_BSDF_H

#include "math/vec.h"
#include "scene/scene_desc.h"
#include "bsdf/texture.h"
#include "bsdf/microfacet.h"
#include "bsdf/principled.h"
#include "bsdf/phong.h"
#include "bsdf/ward.h"
#include "bsdf/bump.h"

typedef enum op_bsdf_type {
    OP_BSDF_DIFFUSE,
    OP_BSDF_DIELECTRIC,
    OP_BSDF_CONDUCTOR,
    OP_BSDF_PLASTIC,
    OP_BSDF_ROUGHPLASTIC,
    OP_BSDF_ROUGHDIELECTRIC, /* frosted glass (Walter et al. 2007), or a translucent shape's
                                boundary */
    OP_BSDF_COATING,         /* parsed; rendered only as a translucent shape's boundary */
    OP_BSDF_SHEEN,   /* a boundary's reflection lobe alone: Fresnel reflection of a smooth
                        (alpha 0) or GGX-rough dielectric interface, tinted by specular */
    OP_BSDF_THROUGH, /* a white Lambertian behind a boundary: f = t(cos wo) / pi (the irradiance
                        that crosses it, op_bsdf_through) */
    OP_BSDF_ROUGHCONDUCTOR,
    OP_BSDF_ROUGHDIFFUSE, /* Oren-Nayar */
    OP_BSDF_PRINCIPLED,   /* Mitsuba 3's principled and principledthin (principled.h) */
    OP_BSDF_PHONG,        /* Mitsuba 0.6's modified Phong (phong.h) */
    OP_BSDF_WARD          /* Mitsuba 0.6's Ward and its variants (ward.h) */
} op_bsdf_type;

/* What a translucent shape's boundary lets through, per direction: t[k] is the fraction of
 * light arriving at cos theta = k / (OP_THROUGH_N - 1) that enters (1 - the reflection lobe's
 * directional albedo, times a coating's absorption), and exit_norm is 1 / (2 int (1 - R(mu))
 * mu dmu): leaving with weight t(cos) exit_norm keeps the exitance that crosses the boundary
 * equal to M (internal reflection is part of the subsurface transport). */
enum { OP_THROUGH_N = 64 };
typedef struct op_bsdf_through {
    op_v3 t[OP_THROUGH_N];
    float exit_norm;
} op_bsdf_through;

typedef struct op_bsdf {
    op_bsdf_type type;
    int twosided;
    op_v3 reflectance;     /* diffuse; the diffuse base of plastics */
    op_texture refl_tex;   /* when set (type != OP_TEX_NONE), reflectance varies over the
                              surface: op_bsdf_at() looks it up */
    op_v3 specular;        /* specularReflectance */
    op_texture spec_tex;   /* conductors: specularReflectance as a texture, like refl_tex */
    op_v3 transmittance;   /* dielectrics: specularTransmittance */
    float eta;             /* interior / exterior index of refraction */
    op_v3 cond_eta, cond_k;/* conductor: complex index relative to the exterior */
    int mirror;            /* conductor "none": a perfect mirror */
    float alpha;           /* roughplastic, sheen: GGX roughness (sheen: 0 smooth); roughdielectric:
                              the isotropic GGX roughness it has as a boundary; roughdiffuse:
                              Oren-Nayar's roughness (sigma sqrt 2) */
    int rough_beckmann;    /* roughplastic: Beckmann normals (Mitsuba's default distribution),
                              not GGX */
    op_microfacet mf;      /* roughconductor, roughdielectric */
    op_texture alpha_tex[2]; /* roughconductor, roughdielectric: alphaU and alphaV (alpha: both)
                              as textures of one value, looked up by op_bsdf_at */
    int fast_approx;       /* roughdiffuse: Oren-Nayar's qualitative model */
    op_v3 sigma_a;         /* coating: absorption per unit thickness */
    float thickness;       /* coating: layer thickness */
    const op_bsdf_through *through; /* OP_BSDF_THROUGH: the boundary it sits behind */
    int nonlinear;
    /* roughplastic (as Mitsuba 0.6 and 3 define it): its rough interface's transmittance
     * 1 - R(mu) at mu = k / (OP_THROUGH_N - 1) and its internal diffuse reflectance, both by
     * integrating the specular lobe; rough_tables 0 (a translucent shape's stand-in): the
     * smooth interface's Fresnel terms instead */
    int rough_tables;
    float rough_t[OP_THROUGH_N];
    float rough_fdr;
    int masked;            /* wrapped in a mask: opacity below applies */
    op_v3 opacity;         /* mask: per-channel opacity in [0, 1] (1 = opaque) */
    op_texture opacity_tex;/* mask: when set, the opacity (times the one above) varies over
                              the surface */
    int thin;              /* thindielectric: a conductor mirror of reflectance specular that is
                              crossed straight with the thin slab's transmittance (eta, and
                              transmittance = specularTransmittance) */
    op_bump bump;          /* wrapped in a bumpmap or normalmap: the tilt of its shading frame,
                              which the hit's frame gets (geometry/isect.c) */
    op_phong phong;        /* OP_BSDF_PHONG: its weights, exponent and their textures */
    op_ward ward;          /* OP_BSDF_WARD: its weights, roughnesses and their textures */
    op_principled pr;      /* OP_BSDF_PRINCIPLED: its weights and their textures (last:
                              op_bsdf_at copies it only for this type) */
} op_bsdf;

typedef struct op_bsdf_sample {
    op_v3 wo;
    op_v3 weight; /* f * |cos| / pdf */
    float pdf;    /* solid angle; meaningless when delta */
    int delta;    /* sampled a specular component */
} op_bsdf_sample;

/* Builds b from a <bsdf> node (twosided, mask, bumpmap and normalmap unwrap their child; a mask
 * without a child wraps the default diffuse; nested masks multiply their opacities). Out-of-range reflectances
 * and opacities are clamped to [0, 1] with a warning. The diffuse reflectance (diffuse, plastic,
 * roughplastic) may be a nested or referenced <texture>, whose image is read through tex. */
op_status op_bsdf_build(op_node *node, op_tex_cache *tex, op_bsdf *b, op_error *err);
/* 1 when op_bsdf_build renders <bsdf type="type">, else 0. */
int op_bsdf_type_known(const char *type);
/* The boundary of a translucent shape from a dielectric, roughdielectric, plastic,
 * roughplastic or coating b (any other type: OP_ERR_INPUT, the message naming the type): its
 * reflection lobe *sheen (a plastic's diffuse base is replaced by the subsurface transport) and
 * what it lets through, *tr (tabulated by integrating the lobe). */
op_status op_bsdf_boundary(const op_bsdf *b, op_bsdf *sheen, op_bsdf_through *tr, op_error *err);
/* t(cos) of a boundary, interpolated (cos clamped to [0, 1]). */
op_v3 op_bsdf_through_at(const op_bsdf_through *tr, float cos);
/* The stand-in of a translucent shape where no exitance is known: plastic (smooth sheen) or
 * roughplastic (rough sheen) of diffuse reflectance albedo with sheen's interface. */
void op_bsdf_sheen_standin(const op_bsdf *sheen, op_v3 albedo, op_bsdf *out);
/* The default material of shapes without a BSDF: diffuse 0.5. */
void op_bsdf_default(op_bsdf *b);
/* The BSDF at surface coordinates (u, v): b itself when nothing in it is textured, else
 * *scratch, a copy of b with its textures looked up there. Every function below takes the
 * result (a textured b evaluates as its constant reflectances). */
const op_bsdf *op_bsdf_at(const op_bsdf *b, float u, float v, op_bsdf *scratch);
/* Whether the BSDF has a non-delta component that next-event estimation can evaluate. */
int op_bsdf_is_smooth_only(const op_bsdf *b);
/* Whether b's model depends on the orientation of its shading frame about the normal (an
 * anisotropic microfacet model or principled): its frame's tangent then follows dp/du, as in
 * Mitsuba, where the other models keep an arbitrary tangent (so their images do not change). */
int op_bsdf_is_anisotropic(const op_bsdf *b);

/* f * |cos(wo)| and the sampling density of wo (solid angle), non-delta parts only. */
op_v3 op_bsdf_eval(const op_bsdf *b, op_v3 wi, op_v3 wo, float *pdf);
/* Samples wo; returns 0 when the sample is absorbed. */
int op_bsdf_sample_dir(const op_bsdf *b, op_v3 wi, float u1, float u2, float u3,
                       op_bsdf_sample *s);
/* What a ray meeting a passable surface does before any scattering: it stops with
 * probability stop (the model applies, the throughput times hit) or passes straight on (times
 * pass; not a bounce). A shadow ray carries the fraction through across it (exact, no
 * sampling). A surface that is not passable always stops: stop 1, hit 1, through 0. */
typedef struct op_bsdf_passage {
    float stop;
    op_v3 hit, pass, through;
} op_bsdf_passage;

/* Whether rays can pass b (a mask or a thin dielectric). */
int op_bsdf_passable(const op_bsdf *b);
/* Whether b's passage depends on where and how the surface is met (a textured opacity, a
 * thin dielectric); when not, any arguments of op_bsdf_passage_at give it. */
int op_bsdf_passage_varies(const op_bsdf *b);
/* The passage of b at surface coordinates (u, v) (a textured opacity) for a ray whose
 * direction makes cosine cos_i with the shading normal (a thin dielectric's reflectance;
 * either sign). */
op_bsdf_passage op_bsdf_passage_at(const op_bsdf *b, float u, float v, float cos_i);

/* A colour for the albedo debug view. */
op_v3 op_bsdf_albedo(const op_bsdf *b);

#endif
