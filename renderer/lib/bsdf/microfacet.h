/* microfacet.h - microfacet normal distributions for the rough BSDFs: Beckmann, GGX
 * (Trowbridge-Reitz) and Phong (anisotropic: Ashikhmin-Shirley, exponent 2 / alpha^2 - 2 as
 * Walter et al. 2007 convert it), isotropic or anisotropic (alpha_u along the local x axis,
 * alpha_v along y), with Smith's shadowing-masking G1 of each (Phong uses Beckmann's, with the
 * distribution's alpha) and sampling of microfacet normals either by D(m) cos(m) or, for
 * Beckmann and GGX, by the distribution of normals visible from a direction (Heitz and d'Eon
 * 2014; GGX by Heitz 2018). Local frame: z is the macro-surface normal. */
#ifndef OP_MICROFACET_H
#define OP_MICROFACET_H

#include "math/vec.h"

typedef enum op_mf_type { OP_MF_BECKMANN, OP_MF_GGX, OP_MF_PHONG } op_mf_type;

typedef struct op_microfacet {
    op_mf_type type;
    float alpha_u, alpha_v;
    float exp_u, exp_v; /* Phong exponents */
    int visible;        /* sample visible normals (never for Phong) */
} op_microfacet;

/* A distribution; alphas below 1e-4 are raised to it, visible is ignored for Phong. */
op_microfacet op_mf_make(op_mf_type type, float alpha_u, float alpha_v, int visible);
/* The distribution of normals D(m) (0 for m.z <= 0). */
float op_mf_d(const op_microfacet *d, op_v3 m);
/* Smith's masking of microfacet normal m seen from v (either side of the surface; 0 where v
 * sees m's back). */
float op_mf_g1(const op_microfacet *d, op_v3 v, op_v3 m);
/* A microfacet normal (m.z > 0) for a direction wi with wi.z > 0, drawn from u1, u2 in [0, 1). */
op_v3 op_mf_sample(const op_microfacet *d, op_v3 wi, float u1, float u2);
/* The solid-angle density of op_mf_sample's m for wi (wi.z > 0): D(m) m.z, or with visible
 * normals G1(wi, m) max(0, wi.m) D(m) / wi.z. */
float op_mf_pdf(const op_microfacet *d, op_v3 wi, op_v3 m);

#endif
