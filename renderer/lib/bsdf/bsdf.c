/* bsdf.c - the surface scattering models (see bsdf.h). */
#include "bsdf/bsdf.h"

#include <stddef.h>
#include <string.h>
#include <strings.h>

#include "bsdf/conductor_table.h"
#include "bsdf/fresnel.h"

/* Named indices of refraction: Mitsuba 0.6's table (src/bsdfs/ior.h there, Hecht's Optics at
 * ~589 nm), where "air" (1.000277) and "silicone oil" (1.52045) keep the values opaline has
 * always rendered them with, and opaline's own additions ("ice", "glass", "sapphire",
 * "polycarbonate", "skin"). */
static const struct {
    const char *name;
    double ior;
} iors[] = {{"vacuum", 1.0},          {"helium", 1.000036},    {"hydrogen", 1.000132},
            {"air", 1.00028},         {"carbon dioxide", 1.00045}, {"water", 1.3330},
            {"acetone", 1.36},        {"ethanol", 1.361},      {"carbon tetrachloride", 1.461},
            {"glycerol", 1.4729},     {"benzene", 1.501},      {"silicone oil", 1.52008},
            {"bromine", 1.661},       {"water ice", 1.31},     {"ice", 1.31},
            {"fused quartz", 1.458},  {"pyrex", 1.470},        {"acrylic glass", 1.49},
            {"polypropylene", 1.49},  {"bk7", 1.5046},         {"sodium chloride", 1.544},
            {"amber", 1.55},          {"pet", 1.575},          {"diamond", 2.419},
            {"glass", 1.5},           {"sapphire", 1.77},      {"polycarbonate", 1.58},
            {"skin", 1.4}};

static op_status read_ior(op_node *n, const char *name, const char *def, double *out, op_error *err)
{
    for (int i = 0; i < n->nprops; i++) {
        op_prop *p = &n->props[i];
        if (strcmp(p->name, name) != 0)
            continue;
        if (p->kind == OP_PROP_STRING) {
            p->used = 1;
            for (size_t k = 0; k < sizeof iors / sizeof iors[0]; k++)
                if (strcasecmp(iors[k].name, p->value.s) == 0) {
                    *out = iors[k].ior;
                    return OP_OK;
                }
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"%s\">: unknown %s \"%s\"",
                                p->file, p->line, n->type, name, p->value.s);
        }
        GET_OR_FAIL(op_node_float(n, name, 1.0, out, err));
        if (!(*out > 0.0 && *out < 10.0))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"%s\">: %s %g is not in "
                                "(0, 10)", p->file, p->line, n->type, name, *out);
        return OP_OK;
    }
    for (size_t k = 0; k < sizeof iors / sizeof iors[0]; k++)
        if (strcmp(iors[k].name, def) == 0)
            *out = iors[k].ior;
    return OP_OK;
}

/* A reflectance in [0, 1]^3; larger or negative values are clamped with a warning. */
static op_status read_reflectance(op_node *n, const char *name, const char *alias, double def,
                                  op_v3 *out, op_error *err)
{
    double d[3] = {def, def, def}, c[3];
    const char *used = name;
    if (alias && !op_node_has(n, name) && op_node_has(n, alias))
        used = alias;
    GET_OR_FAIL(op_node_color(n, used, d, c, err));
    int clamped = 0;
    for (int i = 0; i < 3; i++) {
        if (!(c[i] >= 0.0)) {
            c[i] = 0.0;
            clamped = 1;
        } else if (c[i] > 1.0) {
            c[i] = 1.0;
            clamped = 1;
        }
    }
    if (clamped)
        op_log(OP_LOG_WARN, "%s:%d: <bsdf type=\"%s\">: %s is outside [0, 1]; clamped", n->file,
               n->line, n->type, used);
    *out = v3_from_d(c);
    return OP_OK;
}

/* The texture child of n given under name (or alias when name has none), or NULL; *given: the
 * name it was found under. */
static op_node *texture_child(const op_node *n, const char *name, const char *alias,
                              const char **given)
{
    op_node *t = op_texture_child(n, name);
    *given = name;
    if (!t && alias) {
        t = op_texture_child(n, alias);
        *given = alias;
    }
    return t;
}

/* A reflectance that may be a texture: a <texture> child named name (or alias) fills tex, else
 * read_reflectance fills out. */
static op_status read_textured(op_node *n, const char *name, const char *alias, double def,
                               op_tex_cache *cache, op_v3 *out, op_texture *tex, op_error *err)
{
    const char *given = NULL;
    op_node *t = texture_child(n, name, alias, &given);
    if (!t)
        return read_reflectance(n, name, alias, def, out, err);
    if (op_node_has(n, name) || (alias && op_node_has(n, alias)))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"%s\">: %s is given both as a "
                            "colour and as a texture", n->file, n->line, n->type, given);
    if (!cache)
        return op_error_set(err, OP_ERR_INTERNAL, "%s:%d: <bsdf type=\"%s\">: no texture cache",
                            n->file, n->line, n->type);
    GET_OR_FAIL(op_texture_build(t, cache, tex, err));
    *out = v3s((float)def);
    return OP_OK;
}

/* A rough plastic's distribution (beckmann, the default, sets *beckmann; ggx; phong, rendered
 * as GGX) and alpha (default 0.1, clamped to [0.001, 1] with a warning). */
static op_status read_alpha(op_node *node, float *out, int *beckmann, op_error *err)
{
    const char *dist;
    double alpha;
    GET_OR_FAIL(op_node_string(node, "distribution", "beckmann", &dist, err));
    GET_OR_FAIL(op_node_float(node, "alpha", 0.1, &alpha, err));
    if (strcmp(dist, "beckmann") != 0 && strcmp(dist, "ggx") != 0 && strcmp(dist, "phong") != 0)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"%s\">: unknown distribution "
                            "\"%s\"", node->file, node->line, node->type, dist);
    *beckmann = strcmp(dist, "beckmann") == 0;
    if (strcmp(dist, "phong") == 0)
        op_log(OP_LOG_DEBUG, "%s:%d: %s: distribution phong rendered as ggx", node->file,
               node->line, node->type);
    if (!(alpha > 0.0 && alpha <= 1.0)) {
        op_log(OP_LOG_WARN, "%s:%d: <bsdf type=\"%s\">: alpha %g clamped to [0.001, 1]",
               node->file, node->line, node->type, alpha);
        alpha = alpha > 1.0 ? 1.0 : 0.001;
    }
    *out = (float)alpha;
    return OP_OK;
}

/* A microfacet model's distribution as Mitsuba 0.6 reads it: distribution (beckmann, ggx,
 * phong, or as: Phong read through alphaU/alphaV), alpha (default 0.1) or both alphaU and
 * alphaV, sampleVisible (default true). Alphas below 1e-4 are raised to it with a warning.
 * Each alpha may be a texture (tex[0] for alphaU or alpha, tex[1] for alphaV or alpha; cache
 * reads their images), its constant then being the default. */
static op_status read_microfacet(op_node *node, op_tex_cache *cache, op_texture tex[2],
                                 op_microfacet *out, op_error *err)
{
    static const char *const names[3] = {"alpha", "alphaU", "alphaV"};
    int textured[3] = {0, 0, 0};
    for (int k = 0; k < 3; k++) {
        const char *given = NULL;
        op_node *t = texture_child(node, names[k], NULL, &given);
        if (!t)
            continue;
        if (op_node_has(node, names[k]))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"%s\">: %s is given both "
                                "as a number and as a texture", node->file, node->line,
                                node->type, names[k]);
        if (!cache)
            return op_error_set(err, OP_ERR_INTERNAL, "%s:%d: <bsdf type=\"%s\">: no texture "
                                "cache", node->file, node->line, node->type);
        GET_OR_FAIL(op_texture_build_value(t, cache, 1e30, &tex[k == 2 ? 1 : 0], err));
        if (k == 0)
            tex[1] = tex[0];
        textured[k] = 1;
    }
    const char *dist;
    double au = 0.1, av = 0.1;
    int visible;
    GET_OR_FAIL(op_node_string(node, "distribution", "beckmann", &dist, err));
    op_mf_type t;
    if (strcasecmp(dist, "beckmann") == 0)
        t = OP_MF_BECKMANN;
    else if (strcasecmp(dist, "ggx") == 0)
        t = OP_MF_GGX;
    else if (strcasecmp(dist, "phong") == 0 || strcasecmp(dist, "as") == 0)
        t = OP_MF_PHONG;
    else
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"%s\">: unknown distribution "
                            "\"%s\" (beckmann, ggx, phong, as)", node->file, node->line,
                            node->type, dist);
    int has_u = op_node_has(node, "alphaU") || textured[1];
    int has_v = op_node_has(node, "alphaV") || textured[2];
    if ((op_node_has(node, "alpha") || textured[0]) && (has_u || has_v))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"%s\">: give alpha or "
                            "alphaU/alphaV, not both", node->file, node->line, node->type);
    if (has_u != has_v)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"%s\">: alphaU and alphaV go "
                            "together", node->file, node->line, node->type);
    if (has_u) {
        GET_OR_FAIL(op_node_float(node, "alphaU", 0.1, &au, err));
        GET_OR_FAIL(op_node_float(node, "alphaV", 0.1, &av, err));
    } else {
        GET_OR_FAIL(op_node_float(node, "alpha", 0.1, &au, err));
        av = au;
    }
    GET_OR_FAIL(op_node_bool(node, "sampleVisible", 1, &visible, err));
    if (!(au >= 1e-4 && av >= 1e-4)) {
        op_log(OP_LOG_WARN, "%s:%d: <bsdf type=\"%s\">: roughness below 1e-4 raised to 1e-4",
               node->file, node->line, node->type);
        au = au >= 1e-4 ? au : 1e-4;
        av = av >= 1e-4 ? av : 1e-4;
    }
    *out = op_mf_make(t, (float)au, (float)av, visible);
    return OP_OK;
}

/* A conductor's complex index relative to the exterior: material (a name of conductor_table.h,
 * default Cu; "none": a perfect mirror) with eta and k overriding either part of it, divided by
 * extEta (default air). */
static op_status read_conductor(op_node *node, op_bsdf *b, op_error *err)
{
    const char *mat;
    double ext_ior = 1.0;
    /* Mitsuba 3's conductors default to a perfect mirror, 0.6's to copper */
    GET_OR_FAIL(op_node_string(node, "material",
                               node->dialect == OP_DIALECT_MITSUBA_3 ? "none" : "Cu", &mat, err));
    GET_OR_FAIL(read_ior(node, "extEta", "air", &ext_ior, err));
    double me[3] = {0, 0, 0}, mk[3] = {1, 1, 1}, e[3], k[3];
    int none = strcasecmp(mat, "none") == 0;
    if (!none) {
        const op_conductor *c = op_conductor_find(mat);
        if (!c)
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"%s\">: unknown material "
                                "\"%s\" (Mitsuba's conductor names, docs/scene-format.md; none; "
                                "or eta and k)", node->file, node->line, node->type, mat);
        for (int i = 0; i < 3; i++) {
            me[i] = c->eta[i];
            mk[i] = c->k[i];
        }
    }
    int given = op_node_has(node, "eta") || op_node_has(node, "k");
    GET_OR_FAIL(op_node_color(node, "eta", me, e, err));
    GET_OR_FAIL(op_node_color(node, "k", mk, k, err));
    b->mirror = none && !given;
    b->cond_eta = v3_scale(v3_from_d(e), (float)(1.0 / ext_ior));
    b->cond_k = v3_scale(v3_from_d(k), (float)(1.0 / ext_ior));
    return OP_OK;
}

void op_bsdf_default(op_bsdf *b)
{
    memset(b, 0, sizeof *b);
    b->type = OP_BSDF_DIFFUSE;
    b->reflectance = v3s(0.5f);
}

static void roughplastic_tables(op_bsdf *b);

/* A mask around its nested <bsdf> (default diffuse): opacity a colour or a texture (read as one
 * value in Mitsuba 3 files, as Mitsuba 3 does; per channel in Mitsuba 0.6 files). Nested masks
 * multiply their opacities; one of them at most may be textured. */
static op_status build_mask(op_node *node, op_tex_cache *tex, op_bsdf *b, op_error *err)
{
    op_v3 opacity = v3s(1.0f);
    op_texture t;
    memset(&t, 0, sizeof t);
    const char *given = NULL;
    op_node *tn = texture_child(node, "opacity", NULL, &given);
    if (tn && op_node_has(node, "opacity"))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"mask\">: opacity is given both "
                            "as a colour and as a texture", node->file, node->line);
    if (tn && !tex)
        return op_error_set(err, OP_ERR_INTERNAL, "%s:%d: <bsdf type=\"mask\">: no texture cache",
                            node->file, node->line);
    if (tn && node->dialect == OP_DIALECT_MITSUBA_3)
        GET_OR_FAIL(op_texture_build_value(tn, tex, 1.0, &t, err));
    else if (tn)
        GET_OR_FAIL(op_texture_build(tn, tex, &t, err));
    else
        GET_OR_FAIL(read_reflectance(node, "opacity", NULL, 0.5, &opacity, err));
    op_node *inner = op_node_child(node, "bsdf", 0);
    if (inner)
        GET_OR_FAIL(op_bsdf_build(inner, tex, b, err));
    if (tn && b->opacity_tex.type != OP_TEX_NONE)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"mask\">: nested masks with "
                            "textured opacities are not supported (one of them may be textured)",
                            node->file, node->line);
    if (tn)
        b->opacity_tex = t;
    b->opacity = b->masked ? v3_mul(b->opacity, opacity) : opacity;
    b->masked = 1;
    return OP_OK;
}

/* The types op_bsdf_build renders. */
static const char *const bsdf_types[] = {
    "diffuse",      "roughdiffuse", "dielectric", "roughdielectric", "thindielectric",
    "conductor",    "roughconductor", "plastic",  "roughplastic",    "coating",
    "principled",   "principledthin", "phong",    "ward",            "twosided",
    "mask",         "bumpmap",      "normalmap",  NULL};

int op_bsdf_type_known(const char *type) { return op_name_listed(bsdf_types, type); }

op_status op_bsdf_build(op_node *node, op_tex_cache *tex, op_bsdf *b, op_error *err)
{
    op_bsdf_default(b);
    node->used = 1;
    if (strcmp(node->type, "twosided") == 0) {
        op_node *inner = NULL;
        for (int i = 0; i < node->nchildren; i++)
            if (strcmp(node->children[i]->tag, "bsdf") == 0 && !inner)
                inner = node->children[i];
        if (!inner)
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"twosided\"> needs a nested "
                                "<bsdf>", node->file, node->line);
        GET_OR_FAIL(op_bsdf_build(inner, tex, b, err));
        b->twosided = 1;
        return OP_OK;
    }
    if (strcmp(node->type, "mask") == 0)
        return build_mask(node, tex, b, err);
    if (strcmp(node->type, "bumpmap") == 0 || strcmp(node->type, "normalmap") == 0) {
        op_bump bump;
        op_node *inner;
        GET_OR_FAIL(op_bump_build(node, tex, &bump, &inner, err));
        GET_OR_FAIL(op_bsdf_build(inner, tex, b, err));
        if (b->bump.type != OP_BUMP_NONE)
            return op_node_error(node, err, OP_ERR_INPUT, "wraps another bumpmap or normalmap "
                                 "(not yet supported)");
        b->bump = bump;
        return OP_OK;
    }
    double int_ior = 1.5046, ext_ior = 1.00028;
    if (strcmp(node->type, "principled") == 0 || strcmp(node->type, "principledthin") == 0) {
        b->type = OP_BSDF_PRINCIPLED;
        return op_principled_build(node, tex, &b->pr, err);
    }
    if (strcmp(node->type, "phong") == 0) {
        b->type = OP_BSDF_PHONG;
        return op_phong_build(node, tex, &b->phong, err);
    }
    if (strcmp(node->type, "ward") == 0) {
        b->type = OP_BSDF_WARD;
        return op_ward_build(node, tex, &b->ward, err);
    }
    if (strcmp(node->type, "diffuse") == 0) {
        b->type = OP_BSDF_DIFFUSE;
        return read_textured(node, "reflectance", "diffuseReflectance", 0.5, tex, &b->reflectance,
                             &b->refl_tex, err);
    }
    if (strcmp(node->type, "roughdiffuse") == 0) {
        double alpha;
        b->type = OP_BSDF_ROUGHDIFFUSE;
        GET_OR_FAIL(op_node_float(node, "alpha", 0.2, &alpha, err));
        GET_OR_FAIL(op_node_bool(node, "useFastApprox", 0, &b->fast_approx, err));
        if (!(alpha >= 0.0))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"roughdiffuse\">: alpha "
                                "must be >= 0", node->file, node->line);
        b->alpha = (float)alpha;
        return read_textured(node, "reflectance", "diffuseReflectance", 0.5, tex, &b->reflectance,
                             &b->refl_tex, err);
    }
    int rough_dielectric = strcmp(node->type, "roughdielectric") == 0;
    int thin = strcmp(node->type, "thindielectric") == 0;
    if (strcmp(node->type, "dielectric") == 0 || thin || rough_dielectric) {
        b->type = rough_dielectric ? OP_BSDF_ROUGHDIELECTRIC : OP_BSDF_DIELECTRIC;
        GET_OR_FAIL(read_ior(node, "intIOR", "bk7", &int_ior, err));
        GET_OR_FAIL(read_ior(node, "extIOR", "air", &ext_ior, err));
        GET_OR_FAIL(read_reflectance(node, "specularReflectance", NULL, 1.0, &b->specular, err));
        GET_OR_FAIL(read_reflectance(node, "specularTransmittance", NULL, 1.0, &b->transmittance,
                                     err));
        if (rough_dielectric) {
            GET_OR_FAIL(read_microfacet(node, tex, b->alpha_tex, &b->mf, err));
            b->alpha = fminf(fmaxf(b->mf.alpha_u, 0.001f), 1.0f);
        }
        b->eta = (float)(int_ior / ext_ior);
        if (thin) {
            b->type = OP_BSDF_CONDUCTOR;
            b->mirror = 1;
            b->twosided = 1;
            b->thin = 1;
        }
        return OP_OK;
    }
    int rough_conductor = strcmp(node->type, "roughconductor") == 0;
    if (strcmp(node->type, "conductor") == 0 || rough_conductor) {
        b->type = rough_conductor ? OP_BSDF_ROUGHCONDUCTOR : OP_BSDF_CONDUCTOR;
        if (rough_conductor)
            GET_OR_FAIL(read_microfacet(node, tex, b->alpha_tex, &b->mf, err));
        GET_OR_FAIL(read_textured(node, "specularReflectance", NULL, 1.0, tex, &b->specular,
                                  &b->spec_tex, err));
        return read_conductor(node, b, err);
    }
    if (strcmp(node->type, "plastic") == 0 || strcmp(node->type, "roughplastic") == 0) {
        int rough = strcmp(node->type, "roughplastic") == 0;
        b->type = rough ? OP_BSDF_ROUGHPLASTIC : OP_BSDF_PLASTIC;
        GET_OR_FAIL(read_ior(node, "intIOR", "polypropylene", &int_ior, err));
        GET_OR_FAIL(read_ior(node, "extIOR", "air", &ext_ior, err));
        GET_OR_FAIL(read_textured(node, "diffuseReflectance", "reflectance", 0.5, tex,
                                  &b->reflectance, &b->refl_tex, err));
        GET_OR_FAIL(read_reflectance(node, "specularReflectance", NULL, 1.0, &b->specular, err));
        GET_OR_FAIL(op_node_bool(node, "nonlinear", 0, &b->nonlinear, err));
        b->eta = (float)(int_ior / ext_ior);
        if (rough) {
            GET_OR_FAIL(read_alpha(node, &b->alpha, &b->rough_beckmann, err));
            roughplastic_tables(b);
        }
        return OP_OK;
    }
    if (strcmp(node->type, "coating") == 0) {
        b->type = OP_BSDF_COATING;
        double thick, zero[3] = {0, 0, 0}, sa[3];
        GET_OR_FAIL(read_ior(node, "intIOR", "bk7", &int_ior, err));
        GET_OR_FAIL(read_ior(node, "extIOR", "air", &ext_ior, err));
        GET_OR_FAIL(read_reflectance(node, "specularReflectance", NULL, 1.0, &b->specular, err));
        GET_OR_FAIL(op_node_float(node, "thickness", 1.0, &thick, err));
        GET_OR_FAIL(op_node_color(node, "sigmaA", zero, sa, err));
        if (!(thick >= 0.0) || !(sa[0] >= 0.0 && sa[1] >= 0.0 && sa[2] >= 0.0))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"coating\">: thickness and "
                                "sigmaA must be >= 0", node->file, node->line);
        b->thickness = (float)thick;
        b->sigma_a = v3_from_d(sa);
        b->eta = (float)(int_ior / ext_ior);
        return OP_OK;
    }
    char names[512];
    return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"%s\">: unknown BSDF type (%s)",
                        node->file, node->line, node->type,
                        op_names_join(bsdf_types, names, sizeof names));
}

_Static_assert(offsetof(op_bsdf, pr) + sizeof(op_principled) == sizeof(op_bsdf),
               "op_bsdf_at copies what precedes pr: it must stay op_bsdf's last member");

const op_bsdf *op_bsdf_at(const op_bsdf *b, float u, float v, op_bsdf *scratch)
{
    /* what precedes pr (the last member), so that other models copy no principled weights */
    size_t head = offsetof(op_bsdf, pr);
    if (b->type == OP_BSDF_PRINCIPLED && b->pr.textured) {
        memcpy(scratch, b, head);
        op_principled_at(&b->pr, u, v, &scratch->pr);
        return scratch;
    }
    if (b->type == OP_BSDF_PHONG && op_phong_textured(&b->phong)) {
        memcpy(scratch, b, head);
        op_phong_at(&b->phong, u, v, &scratch->phong);
        return scratch;
    }
    if (b->type == OP_BSDF_WARD && op_ward_textured(&b->ward)) {
        memcpy(scratch, b, head);
        op_ward_at(&b->ward, u, v, &scratch->ward);
        return scratch;
    }
    if (b->refl_tex.type == OP_TEX_NONE && b->spec_tex.type == OP_TEX_NONE &&
        b->alpha_tex[0].type == OP_TEX_NONE && b->alpha_tex[1].type == OP_TEX_NONE)
        return b;
    memcpy(scratch, b, head);
    if (b->refl_tex.type != OP_TEX_NONE)
        scratch->reflectance = op_texture_eval(&b->refl_tex, u, v);
    if (b->spec_tex.type != OP_TEX_NONE)
        scratch->specular = op_texture_eval(&b->spec_tex, u, v);
    if (b->alpha_tex[0].type != OP_TEX_NONE || b->alpha_tex[1].type != OP_TEX_NONE) {
        float au = b->alpha_tex[0].type != OP_TEX_NONE
                       ? op_texture_eval_value(&b->alpha_tex[0], u, v)
                       : b->mf.alpha_u;
        float av = b->alpha_tex[1].type != OP_TEX_NONE
                       ? op_texture_eval_value(&b->alpha_tex[1], u, v)
                       : b->mf.alpha_v;
        scratch->mf = op_mf_make(b->mf.type, au, av, b->mf.visible);
        scratch->alpha = fminf(fmaxf(scratch->mf.alpha_u, 0.001f), 1.0f);
    }
    return scratch;
}

/* Whether textures a and b give the same values everywhere (field by field: the same image,
 * lookup, placement and colours). */
static int same_texture(const op_texture *a, const op_texture *b)
{
    return a->type == b->type && a->img == b->img && a->nearest == b->nearest &&
           a->wrap_u == b->wrap_u && a->wrap_v == b->wrap_v && a->uoffset == b->uoffset &&
           a->voffset == b->voffset && a->uscale == b->uscale && a->vscale == b->vscale &&
           a->color0.x == b->color0.x && a->color0.y == b->color0.y &&
           a->color0.z == b->color0.z && a->color1.x == b->color1.x &&
           a->color1.y == b->color1.y && a->color1.z == b->color1.z &&
           a->value_lum == b->value_lum;
}

int op_bsdf_is_anisotropic(const op_bsdf *b)
{
    switch (b->type) {
    case OP_BSDF_ROUGHCONDUCTOR:
    case OP_BSDF_ROUGHDIELECTRIC:
        return b->mf.alpha_u != b->mf.alpha_v || !same_texture(&b->alpha_tex[0], &b->alpha_tex[1]);
    case OP_BSDF_PRINCIPLED:
        return b->pr.v[OP_PR_ANISOTROPIC] != 0.0f || b->pr.tex[OP_PR_ANISOTROPIC].type != OP_TEX_NONE;
    case OP_BSDF_WARD:
        return op_ward_is_anisotropic(&b->ward);
    default:
        return 0;
    }
}

int op_bsdf_is_smooth_only(const op_bsdf *b)
{
    return b->type == OP_BSDF_DIELECTRIC || b->type == OP_BSDF_CONDUCTOR ||
           (b->type == OP_BSDF_SHEEN && b->alpha <= 0.0f);
}

/* Fresnel reflectance of a conductor for one channel (the common approximation of pbrt). */
static float fresnel_conductor1(float ci, float eta, float k)
{
    float c2 = ci * ci, s2 = 1.0f - c2;
    float e2 = eta * eta, k2 = k * k;
    float t0 = e2 - k2 - s2;
    float a2b2 = sqrtf(fmaxf(t0 * t0 + 4.0f * e2 * k2, 0.0f));
    float a = sqrtf(fmaxf(0.5f * (a2b2 + t0), 0.0f));
    float t1 = a2b2 + c2, t2 = 2.0f * ci * a;
    float rs = (t1 - t2) / (t1 + t2);
    float t3 = c2 * a2b2 + s2 * s2, t4 = t2 * s2;
    float rp = rs * (t3 - t4) / (t3 + t4);
    return 0.5f * (rp + rs);
}

/* The isotropic distribution of a rough plastic's or a sheen's interface: Beckmann or GGX of
 * roughness alpha, its normals drawn by D(m) m.z (visible: drawn from those visible). */
static op_microfacet interface_mf(const op_bsdf *b, int visible)
{
    return op_mf_make(b->rough_beckmann ? OP_MF_BECKMANN : OP_MF_GGX, b->alpha, b->alpha,
                      visible);
}

/* The reflection of b's rough dielectric interface (f |cos wo|, without the specular tint) and
 * the density of wo under interface_normal's reflection. */
static float interface_reflect(const op_bsdf *b, op_v3 wi, op_v3 wo, float *pdf)
{
    op_microfacet mf = interface_mf(b, 0);
    op_v3 h = v3_norm(v3_add(wi, wo));
    float ct, d = op_mf_d(&mf, h);
    float fh = op_fresnel_dielectric(v3_dot(wi, h), b->eta, &ct);
    float g = op_mf_g1(&mf, wi, h) * op_mf_g1(&mf, wo, h);
    *pdf = op_mf_pdf(&mf, wi, h) / (4.0f * v3_dot(wo, h));
    return fh * d * g / (4.0f * wi.z);
}

/* A normal of b's interface, with density D(m) m.z. */
static op_v3 interface_normal(const op_bsdf *b, float u1, float u2)
{
    op_microfacet mf = interface_mf(b, 0);
    return op_mf_sample(&mf, v3(0.0f, 0.0f, 1.0f), u1, u2);
}

/* A conductor's Fresnel reflectance at cos (1 for the mirror "none"). */
static op_v3 fresnel_conductor(const op_bsdf *b, float ci)
{
    if (b->mirror)
        return v3s(1.0f);
    return v3(fresnel_conductor1(ci, b->cond_eta.x, b->cond_k.x),
              fresnel_conductor1(ci, b->cond_eta.y, b->cond_k.y),
              fresnel_conductor1(ci, b->cond_eta.z, b->cond_k.z));
}

/* The rough conductor (wi.z, wo.z > 0): specular F(wi.h) D(h) G(wi, wo) / (4 cos wi) and its
 * density under the distribution's sampling of h, reflected. */
static op_v3 rough_conductor(const op_bsdf *b, op_v3 wi, op_v3 wo, float *pdf)
{
    op_v3 h = v3_norm(v3_add(wi, wo));
    float d = op_mf_d(&b->mf, h);
    if (d <= 0.0f)
        return v3s(0.0f);
    float g = op_mf_g1(&b->mf, wi, h) * op_mf_g1(&b->mf, wo, h);
    *pdf = op_mf_pdf(&b->mf, wi, h) / (4.0f * v3_dot(wo, h));
    return v3_scale(v3_mul(b->specular, fresnel_conductor(b, v3_dot(wi, h))),
                    d * g / (4.0f * wi.z));
}

/* The rough dielectric interface (Walter et al. 2007), wi and wo on either side: reflection
 * (wo on wi's side) tinted by specular, refraction tinted by transmittance and scaled for
 * radiance by 1 / eta_rel^2 (eta_rel: the index of wo's side over wi's); the density is that
 * of a normal h drawn for wi seen from its own side, then reflection with probability F(wi.h). */
static op_v3 rough_dielectric(const op_bsdf *b, op_v3 wi, op_v3 wo, float *pdf)
{
    *pdf = 0.0f;
    if (wi.z == 0.0f || wo.z == 0.0f)
        return v3s(0.0f);
    int reflect = wi.z * wo.z > 0.0f;
    float e = wi.z > 0.0f ? b->eta : 1.0f / b->eta;
    op_v3 h = reflect ? v3_add(wi, wo) : v3_add(wi, v3_scale(wo, e));
    float hl = v3_len(h);
    if (!(hl > 0.0f))
        return v3s(0.0f);
    h = v3_scale(h, (h.z < 0.0f ? -1.0f : 1.0f) / hl);
    float d = op_mf_d(&b->mf, h);
    float ih = v3_dot(wi, h), oh = v3_dot(wo, h);
    /* h must face wi and wo from their own sides */
    if (d <= 0.0f || ih * wi.z <= 0.0f || oh * wo.z <= 0.0f)
        return v3s(0.0f);
    float ct, f = op_fresnel_dielectric(ih, b->eta, &ct);
    float g = op_mf_g1(&b->mf, wi, h) * op_mf_g1(&b->mf, wo, h);
    float pm = op_mf_pdf(&b->mf, wi.z > 0.0f ? wi : v3_neg(wi), h);
    float ci = fabsf(wi.z);
    if (reflect) {
        *pdf = f * pm / (4.0f * fabsf(oh));
        return v3_scale(b->specular, f * d * g / (4.0f * ci));
    }
    float den = hl; /* |ih + e oh|, without its cancellation */
    *pdf = (1.0f - f) * pm * e * e * fabsf(oh) / (den * den);
    /* the value's Fresnel term from both cosines (the density keeps the sampler's choice) */
    float ft = wi.z > 0.0f ? op_fresnel_dielectric_pair(fabsf(ih), fabsf(oh), b->eta)
                           : op_fresnel_dielectric_pair(fabsf(oh), fabsf(ih), b->eta);
    return v3_scale(b->transmittance,
                    (1.0f - ft) * d * g * fabsf(ih * oh) / (ci * den * den));
}

/* A direction drawn for rough_dielectric: a normal for wi (seen from its own side), then
 * reflection or refraction through it by its Fresnel reflectance. */
static int rough_dielectric_sample(const op_bsdf *b, op_v3 wi, float u1, float u2, float u3,
                                   op_bsdf_sample *s)
{
    if (wi.z == 0.0f)
        return 0;
    op_v3 m = op_mf_sample(&b->mf, wi.z > 0.0f ? wi : v3_neg(wi), u1, u2);
    float ct, c = v3_dot(wi, m), f = op_fresnel_dielectric(c, b->eta, &ct);
    if (c * wi.z <= 0.0f)
        return 0; /* a normal facing away (only drawn without visible normals) */
    if (u3 < f) {
        s->wo = v3_sub(v3_scale(m, 2.0f * c), wi);
    } else {
        /* refraction: wo = -wi / e + m (c / e - sign(c) cos_t) */
        float e = c >= 0.0f ? b->eta : 1.0f / b->eta;
        s->wo = v3_add(v3_scale(wi, -1.0f / e), v3_scale(m, c / e - (c >= 0.0f ? ct : -ct)));
    }
    if ((u3 < f) != (s->wo.z * wi.z > 0.0f))
        return 0; /* reflected through the surface, or refracted back out of it */
    op_v3 fv = rough_dielectric(b, wi, s->wo, &s->pdf);
    if (!(s->pdf > 0.0f))
        return 0;
    s->weight = v3_scale(fv, 1.0f / s->pdf);
    return 1;
}

/* Oren-Nayar's diffuse reflection as Mitsuba defines it (wi.z, wo.z > 0): the full model with
 * its interreflection term, or the qualitative approximation (fast_approx); sigma = alpha /
 * sqrt 2. */
static op_v3 oren_nayar(const op_bsdf *b, op_v3 wi, op_v3 wo)
{
    float sigma = b->alpha * 0.70710678f, s2 = sigma * sigma;
    float si = sqrtf(fmaxf(0.0f, 1.0f - wi.z * wi.z)), so = sqrtf(fmaxf(0.0f, 1.0f - wo.z * wo.z));
    float cos_phi = 0.0f;
    if (si > 1e-4f && so > 1e-4f)
        cos_phi = fminf(fmaxf((wi.x * wo.x + wi.y * wo.y) / (si * so), -1.0f), 1.0f);
    float sin_a, sin_b, tan_b;
    if (wi.z > wo.z) {
        sin_a = so;
        sin_b = si;
        tan_b = si / wi.z;
    } else {
        sin_a = si;
        sin_b = so;
        tan_b = so / wo.z;
    }
    float c1 = 1.0f - 0.5f * s2 / (s2 + 0.33f), tmp = s2 / (s2 + 0.09f);
    if (b->fast_approx)
        return v3_scale(b->reflectance,
                        OP_INV_PI * wo.z * (c1 + 0.45f * tmp * fmaxf(cos_phi, 0.0f) * sin_a * tan_b));
    float ti = acosf(fminf(wi.z, 1.0f)), to = acosf(fminf(wo.z, 1.0f));
    float alpha = fmaxf(ti, to), beta = fminf(ti, to);
    float tmp2 = 4.0f * OP_INV_PI * OP_INV_PI * alpha * beta, tmp3 = 2.0f * beta * OP_INV_PI;
    float c2 = 0.45f * tmp * (cos_phi > 0.0f ? sin_a : sin_a - tmp3 * tmp3 * tmp3);
    float c3 = 0.125f * tmp * tmp2 * tmp2, c4 = 0.17f * s2 / (s2 + 0.13f);
    float tan_half = (sin_a + sin_b) / (sqrtf(fmaxf(0.0f, 1.0f - sin_a * sin_a)) +
                                        sqrtf(fmaxf(0.0f, 1.0f - sin_b * sin_b)));
    float single = c1 + cos_phi * c2 * tan_b + (1.0f - fabsf(cos_phi)) * c3 * tan_half;
    float twice = c4 * (1.0f - cos_phi * tmp3 * tmp3);
    op_v3 r = b->reflectance;
    return v3_scale(v3_add(v3_scale(r, single), v3_scale(v3_mul(r, r), twice)), OP_INV_PI * wo.z);
}

/* Plastic's weights: probability of choosing the specular lobe. */
static float plastic_spec_prob(const op_bsdf *b, float fi)
{
    float ps = fi * v3_max(b->specular);
    float pd = (1.0f - fi) * v3_max(b->reflectance);
    return ps + pd > 0.0f ? ps / (ps + pd) : 0.0f;
}

static float rough_t_at(const op_bsdf *b, float cos)
{
    float x = fminf(fmaxf(cos, 0.0f), 1.0f) * (float)(OP_THROUGH_N - 1);
    int k = (int)x;
    if (k >= OP_THROUGH_N - 1)
        return b->rough_t[OP_THROUGH_N - 1];
    float f = x - (float)k;
    return b->rough_t[k] * (1.0f - f) + b->rough_t[k + 1] * f;
}

/* The diffuse part of plastic (Mitsuba's model, internal scattering approximated by 1 - Fdr):
 * a smooth interface's Fresnel terms, or a rough one's tables (rough_tables). */
static op_v3 plastic_diffuse(const op_bsdf *b, op_v3 wi, op_v3 wo)
{
    float ct, fi, fo, fdr;
    if (b->rough_tables) {
        fi = 1.0f - rough_t_at(b, wi.z);
        fo = 1.0f - rough_t_at(b, wo.z);
        fdr = b->rough_fdr;
    } else {
        fi = op_fresnel_dielectric(wi.z, b->eta, &ct);
        fo = op_fresnel_dielectric(wo.z, b->eta, &ct);
        fdr = -1.440f / (b->eta * b->eta) + 0.710f / b->eta + 0.668f + 0.0636f * b->eta;
    }
    op_v3 d = b->reflectance;
    if (b->nonlinear)
        d = v3(d.x / (1.0f - d.x * fdr), d.y / (1.0f - d.y * fdr), d.z / (1.0f - d.z * fdr));
    else
        d = v3_scale(d, 1.0f / (1.0f - fdr));
    float s = (1.0f - fi) * (1.0f - fo) / (b->eta * b->eta);
    return v3_scale(d, s * OP_INV_PI * wo.z);
}

op_v3 op_bsdf_eval(const op_bsdf *b, op_v3 wi, op_v3 wo, float *pdf)
{
    *pdf = 0.0f;
    if (b->type == OP_BSDF_ROUGHDIELECTRIC)
        return rough_dielectric(b, wi, wo, pdf);
    if (b->twosided && wi.z < 0.0f) {
        wi.z = -wi.z;
        wo.z = -wo.z;
    }
    if (b->type == OP_BSDF_PRINCIPLED)
        return op_principled_eval(&b->pr, wi, wo, pdf);
    if (wi.z <= 0.0f || wo.z <= 0.0f)
        return v3s(0.0f);
    switch (b->type) {
    case OP_BSDF_DIFFUSE:
        *pdf = wo.z * OP_INV_PI;
        return v3_scale(b->reflectance, wo.z * OP_INV_PI);
    case OP_BSDF_PLASTIC: {
        float ct, fi = op_fresnel_dielectric(wi.z, b->eta, &ct);
        *pdf = (1.0f - plastic_spec_prob(b, fi)) * wo.z * OP_INV_PI;
        return plastic_diffuse(b, wi, wo);
    }
    case OP_BSDF_ROUGHPLASTIC: {
        float ct, fi = op_fresnel_dielectric(wi.z, b->eta, &ct);
        float ps = plastic_spec_prob(b, fi), spec_pdf;
        float spec = interface_reflect(b, wi, wo, &spec_pdf);
        *pdf = ps * spec_pdf + (1.0f - ps) * wo.z * OP_INV_PI;
        return v3_add(v3_scale(b->specular, spec), plastic_diffuse(b, wi, wo));
    }
    case OP_BSDF_SHEEN:
        if (b->alpha <= 0.0f)
            return v3s(0.0f);
        return v3_scale(b->specular, interface_reflect(b, wi, wo, pdf));
    case OP_BSDF_ROUGHCONDUCTOR:
        return rough_conductor(b, wi, wo, pdf);
    case OP_BSDF_ROUGHDIFFUSE:
        *pdf = wo.z * OP_INV_PI;
        return oren_nayar(b, wi, wo);
    case OP_BSDF_PHONG:
        return op_phong_eval(&b->phong, wi, wo, pdf);
    case OP_BSDF_WARD:
        return op_ward_eval(&b->ward, wi, wo, pdf);
    case OP_BSDF_THROUGH:
        *pdf = wo.z * OP_INV_PI;
        return v3_scale(v3_mul(b->reflectance, op_bsdf_through_at(b->through, wo.z)),
                        wo.z * OP_INV_PI);
    default:
        return v3s(0.0f);
    }
}

/* Fills the density and weight of the non-delta direction s->wo drawn for b from the combined
 * density op_bsdf_eval reports; 0 when it lies below the surface or has no density. */
static int weigh_sample(const op_bsdf *b, op_v3 wi, op_bsdf_sample *s)
{
    if (s->wo.z <= 0.0f)
        return 0;
    float pdf;
    op_v3 f = op_bsdf_eval(b, wi, s->wo, &pdf);
    if (pdf <= 0.0f)
        return 0;
    s->pdf = pdf;
    s->weight = v3_scale(f, 1.0f / pdf);
    return 1;
}

int op_bsdf_sample_dir(const op_bsdf *b, op_v3 wi, float u1, float u2, float u3,
                       op_bsdf_sample *s)
{
    int flip = 0;
    memset(s, 0, sizeof *s);
    if (b->type == OP_BSDF_ROUGHDIELECTRIC)
        return rough_dielectric_sample(b, wi, u1, u2, u3, s);
    if (b->twosided && wi.z < 0.0f) {
        wi.z = -wi.z;
        flip = 1;
    }
    switch (b->type) {
    case OP_BSDF_DIFFUSE:
        if (wi.z <= 0.0f)
            return 0;
        s->wo = op_sample_cosine(u1, u2);
        s->pdf = s->wo.z * OP_INV_PI;
        s->weight = b->reflectance;
        break;
    case OP_BSDF_DIELECTRIC: {
        float ct, f = op_fresnel_dielectric(wi.z, b->eta, &ct);
        s->delta = 1;
        s->pdf = 1.0f;
        if (u3 < f) {
            s->wo = v3(-wi.x, -wi.y, wi.z);
            s->weight = b->specular;
        } else {
            float e = wi.z >= 0.0f ? b->eta : 1.0f / b->eta;
            /* refraction: wo = -wi / e + n (cos_i / e - cos_t), n toward wi's side */
            float sgn = wi.z >= 0.0f ? 1.0f : -1.0f;
            s->wo = v3(-wi.x / e, -wi.y / e, -sgn * ct);
            /* radiance scaling by 1/e^2 across the interface */
            s->weight = v3_scale(b->transmittance, 1.0f / (e * e));
        }
        return 1;
    }
    case OP_BSDF_CONDUCTOR: {
        if (wi.z <= 0.0f)
            return 0;
        s->wo = v3(-wi.x, -wi.y, wi.z);
        s->delta = 1;
        s->pdf = 1.0f;
        s->weight = v3_mul(b->specular, fresnel_conductor(b, wi.z));
        break;
    }
    case OP_BSDF_ROUGHCONDUCTOR: {
        if (wi.z <= 0.0f)
            return 0;
        op_v3 m = op_mf_sample(&b->mf, wi, u1, u2);
        s->wo = v3_sub(v3_scale(m, 2.0f * v3_dot(wi, m)), wi);
        if (!weigh_sample(b, wi, s))
            return 0;
        break;
    }
    case OP_BSDF_ROUGHDIFFUSE:
        if (wi.z <= 0.0f)
            return 0;
        s->wo = op_sample_cosine(u1, u2);
        if (!weigh_sample(b, wi, s))
            return 0;
        break;
    case OP_BSDF_PHONG:
    case OP_BSDF_WARD:
        if (wi.z <= 0.0f)
            return 0;
        s->wo = b->type == OP_BSDF_PHONG ? op_phong_sample(&b->phong, wi, u1, u2, u3)
                                         : op_ward_sample(&b->ward, wi, u1, u2, u3);
        if (!weigh_sample(b, wi, s))
            return 0;
        break;
    case OP_BSDF_PLASTIC: {
        if (wi.z <= 0.0f)
            return 0;
        float ct, fi = op_fresnel_dielectric(wi.z, b->eta, &ct);
        float ps = plastic_spec_prob(b, fi);
        if (u3 < ps) {
            s->wo = v3(-wi.x, -wi.y, wi.z);
            s->delta = 1;
            s->pdf = ps;
            s->weight = v3_scale(b->specular, fi / ps);
        } else {
            s->wo = op_sample_cosine(u1, u2);
            if (!weigh_sample(b, wi, s))
                return 0;
        }
        break;
    }
    case OP_BSDF_ROUGHPLASTIC: {
        if (wi.z <= 0.0f)
            return 0;
        float ct, fi = op_fresnel_dielectric(wi.z, b->eta, &ct);
        float ps = plastic_spec_prob(b, fi);
        if (u3 < ps) {
            op_v3 m = interface_normal(b, u1, u2);
            s->wo = v3_sub(v3_scale(m, 2.0f * v3_dot(wi, m)), wi);
        } else {
            s->wo = op_sample_cosine(u1, u2);
        }
        if (!weigh_sample(b, wi, s))
            return 0;
        break;
    }
    case OP_BSDF_SHEEN: {
        if (wi.z <= 0.0f)
            return 0;
        if (b->alpha <= 0.0f) {
            float ct;
            s->wo = v3(-wi.x, -wi.y, wi.z);
            s->delta = 1;
            s->pdf = 1.0f;
            s->weight = v3_scale(b->specular, op_fresnel_dielectric(wi.z, b->eta, &ct));
            break;
        }
        op_v3 m = interface_normal(b, u1, u2);
        s->wo = v3_sub(v3_scale(m, 2.0f * v3_dot(wi, m)), wi);
        if (!weigh_sample(b, wi, s))
            return 0;
        break;
    }
    case OP_BSDF_THROUGH:
        if (wi.z <= 0.0f)
            return 0;
        s->wo = op_sample_cosine(u1, u2);
        s->pdf = s->wo.z * OP_INV_PI;
        s->weight = v3_mul(b->reflectance, op_bsdf_through_at(b->through, s->wo.z));
        break;
    case OP_BSDF_PRINCIPLED:
        if (!op_principled_sample(&b->pr, wi, u1, u2, u3, &s->wo, &s->weight, &s->pdf))
            return 0;
        break;
    case OP_BSDF_ROUGHDIELECTRIC: /* above: both sides, never flipped */
    case OP_BSDF_COATING:
        return 0; /* only as a boundary (op_bsdf_boundary), which scene building enforces */
    }
    if (flip)
        s->wo.z = -s->wo.z;
    return 1;
}

int op_bsdf_passable(const op_bsdf *b)
{
    return b->masked || b->thin;
}

int op_bsdf_passage_varies(const op_bsdf *b)
{
    return b->thin || (b->masked && b->opacity_tex.type != OP_TEX_NONE);
}

op_bsdf_passage op_bsdf_passage_at(const op_bsdf *b, float u, float v, float cos_i)
{
    op_bsdf_passage pa = {1.0f, v3s(1.0f), v3s(0.0f), v3s(0.0f)};
    op_v3 opacity = v3s(1.0f);
    float p = 1.0f; /* the probability of meeting the nested surface */
    if (b->masked) {
        opacity = b->opacity;
        if (b->opacity_tex.type != OP_TEX_NONE) {
            op_v3 o = b->opacity_tex.value_lum ? v3s(op_texture_eval_value(&b->opacity_tex, u, v))
                                               : op_texture_eval(&b->opacity_tex, u, v);
            o = v3(fminf(fmaxf(o.x, 0.0f), 1.0f), fminf(fmaxf(o.y, 0.0f), 1.0f),
                   fminf(fmaxf(o.z, 0.0f), 1.0f));
            opacity = v3_mul(opacity, o);
        }
        p = (opacity.x + opacity.y + opacity.z) * (1.0f / 3.0f);
        pa.through = v3_sub(v3s(1.0f), opacity);
        pa.hit = p > 0.0f ? v3_scale(opacity, 1.0f / p) : v3s(0.0f);
    }
    pa.stop = p;
    if (b->thin) {
        /* the slab's reflectance with every inner reflection: R + T^2 R / (1 - R^2) */
        float ct, r = op_fresnel_dielectric(fabsf(cos_i), b->eta, &ct);
        r *= 2.0f / (1.0f + r);
        pa.stop = p * r;
        pa.through = v3_add(pa.through, v3_mul(opacity, v3_scale(b->transmittance, 1.0f - r)));
    }
    if (pa.stop < 1.0f)
        pa.pass = v3_scale(pa.through, 1.0f / (1.0f - pa.stop));
    return pa;
}

op_v3 op_bsdf_albedo(const op_bsdf *b)
{
    switch (b->type) {
    case OP_BSDF_DIFFUSE:
    case OP_BSDF_ROUGHDIFFUSE:
    case OP_BSDF_PLASTIC:
    case OP_BSDF_ROUGHPLASTIC:
        return b->reflectance;
    case OP_BSDF_PRINCIPLED:
        return b->pr.base_color;
    case OP_BSDF_PHONG:
        return b->phong.dg.diffuse;
    case OP_BSDF_WARD:
        return b->ward.dg.diffuse;
    default:
        return b->specular;
    }
}

/* A coating's absorption for light crossing it at cos (the refracted path length thickness /
 * cos_t, as Mitsuba's coating). */
static op_v3 coating_absorption(const op_bsdf *b, float cos)
{
    if (b->type != OP_BSDF_COATING || v3_is_black(b->sigma_a))
        return v3s(1.0f);
    float ct;
    op_fresnel_dielectric(fmaxf(cos, 1e-4f), b->eta, &ct);
    float len = b->thickness / fmaxf(ct, 1e-4f);
    return v3(expf(-b->sigma_a.x * len), expf(-b->sigma_a.y * len), expf(-b->sigma_a.z * len));
}

enum { THROUGH_GRID = 48 }; /* lobe samples per axis when tabulating a rough sheen's albedo */

/* The directional albedo (at most 1) of a sheen lobe (white tint) at cos mu > 0, by its own
 * sampling over a THROUGH_GRID^2 stratified grid. */
static double lobe_albedo(const op_bsdf *lobe, float mu)
{
    op_v3 wi = v3(sqrtf(fmaxf(0.0f, 1.0f - mu * mu)), 0.0f, mu);
    double r = 0.0;
    for (int i = 0; i < THROUGH_GRID * THROUGH_GRID; i++) {
        op_bsdf_sample s;
        float u1 = ((float)(i % THROUGH_GRID) + 0.5f) / THROUGH_GRID;
        float u2 = ((float)(i / THROUGH_GRID) + 0.5f) / THROUGH_GRID;
        if (op_bsdf_sample_dir(lobe, wi, u1, u2, 0.0f, &s))
            r += s.weight.x;
    }
    r /= THROUGH_GRID * THROUGH_GRID;
    return r > 1.0 ? 1.0 : r;
}

/* The energy a rough dielectric interface of relative index eta and distribution mf (drawing
 * visible normals) reflects (*r) and transmits (*t) for light arriving at cos mu > 0: the
 * means over its visible normals m of F(wi.m) G1(wr, m) and (1 - F) G1(wt, m) (wr, wt the
 * reflected and refracted directions), on a THROUGH_GRID^2 stratified grid. */
static void rough_interface(float eta, op_microfacet mf, float mu, double *r, double *t)
{
    op_v3 wi = v3(sqrtf(fmaxf(0.0f, 1.0f - mu * mu)), 0.0f, mu);
    double sr = 0.0, st = 0.0;
    for (int i = 0; i < THROUGH_GRID * THROUGH_GRID; i++) {
        float u1 = ((float)(i % THROUGH_GRID) + 0.5f) / THROUGH_GRID;
        float u2 = ((float)(i / THROUGH_GRID) + 0.5f) / THROUGH_GRID;
        op_v3 m = op_mf_sample(&mf, wi, u1, u2);
        float c = v3_dot(wi, m), ct;
        if (c <= 0.0f)
            continue;
        float f = op_fresnel_dielectric(c, eta, &ct);
        op_v3 wr = v3_sub(v3_scale(m, 2.0f * c), wi);
        if (wr.z > 0.0f)
            sr += f * op_mf_g1(&mf, wr, m);
        if (ct > 0.0f) {
            op_v3 wt = v3_add(v3_scale(wi, -1.0f / eta), v3_scale(m, c / eta - ct));
            if (wt.z < 0.0f)
                st += (1.0f - f) * op_mf_g1(&mf, wt, m);
        }
    }
    *r = sr / (THROUGH_GRID * THROUGH_GRID);
    *t = st / (THROUGH_GRID * THROUGH_GRID);
}

/* Fills a roughplastic's rough_t and rough_fdr (bsdf.h) as Mitsuba tabulates its rough
 * plastic: the energy its interface transmits from outside, T(mu), and the cosine-weighted
 * mean of the energy it reflects back inside, 2 int R(mu; 1 / eta) mu dmu. */
static void roughplastic_tables(op_bsdf *b)
{
    double fdr = 0.0;
    for (int k = 0; k < OP_THROUGH_N; k++) {
        float mu = fmaxf((float)k / (float)(OP_THROUGH_N - 1), 1e-4f);
        double re, te, ri, ti;
        rough_interface(b->eta, interface_mf(b, 1), mu, &re, &te);
        rough_interface(1.0f / b->eta, interface_mf(b, 1), mu, &ri, &ti);
        b->rough_t[k] = (float)te;
        double w = (k == 0 || k == OP_THROUGH_N - 1) ? 0.5 : 1.0; /* trapezoid rule */
        fdr += 2.0 * w * ri * mu / (OP_THROUGH_N - 1);
    }
    b->rough_fdr = (float)fmin(fdr, 0.999);
    b->rough_tables = 1;
}

op_status op_bsdf_boundary(const op_bsdf *b, op_bsdf *sheen, op_bsdf_through *tr, op_error *err)
{
    static const char *names[] = {"diffuse", "dielectric", "conductor", "plastic", "roughplastic",
                                  "roughdielectric", "coating", "sheen", "through",
                                  "roughconductor", "roughdiffuse", "principled", "phong",
                                  "ward"};
    int rough = b->type == OP_BSDF_ROUGHPLASTIC || b->type == OP_BSDF_ROUGHDIELECTRIC;
    if (!(rough || b->type == OP_BSDF_DIELECTRIC || b->type == OP_BSDF_PLASTIC ||
          b->type == OP_BSDF_COATING) || b->masked || b->twosided)
        return op_error_set(err, OP_ERR_INPUT, "a %s%s bsdf cannot be the surface of a translucent "
                            "shape (dielectric, roughdielectric, plastic, roughplastic or coating)",
                            b->masked ? "masked " : (b->twosided && !b->thin ? "twosided " : ""),
                            b->thin ? "thindielectric" : names[b->type]);
    if (b->type == OP_BSDF_ROUGHDIELECTRIC &&
        (b->mf.type != OP_MF_GGX || b->mf.alpha_u != b->mf.alpha_v))
        op_log(OP_LOG_DEBUG, "roughdielectric: as a translucent shape's boundary its distribution "
               "is rendered as isotropic ggx of alpha %g", (double)b->alpha);
    op_bsdf_default(sheen);
    sheen->type = OP_BSDF_SHEEN;
    sheen->eta = b->eta;
    sheen->alpha = rough ? b->alpha : 0.0f;
    sheen->specular = b->specular;
    /* the lobe's directional albedo R(mu) without the tint (which is not energy: Mitsuba's
     * specularReflectance is an artistic factor), by the lobe's own sampling */
    op_bsdf lobe = *sheen;
    lobe.specular = v3s(1.0f);
    double norm = 0.0;
    for (int k = 0; k < OP_THROUGH_N; k++) {
        float mu = (float)k / (float)(OP_THROUGH_N - 1);
        double r = 0.0;
        if (mu <= 0.0f) {
            r = 1.0;
        } else if (!rough) {
            float ct;
            r = op_fresnel_dielectric(mu, b->eta, &ct);
        } else {
            r = lobe_albedo(&lobe, mu);
        }
        tr->t[k] = v3_scale(coating_absorption(b, mu), (float)(1.0 - r));
        /* trapezoid rule for 2 int (1 - R) mu dmu */
        double w = (k == 0 || k == OP_THROUGH_N - 1) ? 0.5 : 1.0;
        norm += 2.0 * w * (1.0 - r) * mu / (OP_THROUGH_N - 1);
    }
    tr->exit_norm = norm > 0.0 ? (float)(1.0 / norm) : 0.0f;
    return OP_OK;
}

op_v3 op_bsdf_through_at(const op_bsdf_through *tr, float cos)
{
    float x = fminf(fmaxf(cos, 0.0f), 1.0f) * (float)(OP_THROUGH_N - 1);
    int k = (int)x;
    if (k >= OP_THROUGH_N - 1)
        return tr->t[OP_THROUGH_N - 1];
    float f = x - (float)k;
    return v3_add(v3_scale(tr->t[k], 1.0f - f), v3_scale(tr->t[k + 1], f));
}

void op_bsdf_sheen_standin(const op_bsdf *sheen, op_v3 albedo, op_bsdf *out)
{
    op_bsdf_default(out);
    out->type = sheen->alpha > 0.0f ? OP_BSDF_ROUGHPLASTIC : OP_BSDF_PLASTIC;
    out->eta = sheen->eta;
    out->alpha = sheen->alpha;
    out->specular = sheen->specular;
    out->reflectance = albedo;
}
