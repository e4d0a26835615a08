/* bsdf.c - the surface scattering models (see bsdf.h). */
#include "bsdf/bsdf.h"

#include <string.h>
#include <strings.h>

/* Named indices of refraction (Mitsuba's table, a subset). */
static const struct {
    const char *name;
    double ior;
} iors[] = {{"vacuum", 1.0},     {"air", 1.00028},        {"water", 1.3330},
            {"ice", 1.31},       {"fused quartz", 1.458}, {"glass", 1.5},
            {"bk7", 1.5046},     {"sapphire", 1.77},      {"diamond", 2.419},
            {"acrylic glass", 1.49}, {"polypropylene", 1.49}, {"pet", 1.575},
            {"polycarbonate", 1.58}, {"ethanol", 1.361},  {"skin", 1.4},
            {"silicone oil", 1.52008}};

/* Conductors: RGB (roughly 650, 550, 450 nm) eta and k. */
static const struct {
    const char *name;
    float eta[3], k[3];
} metals[] = {{"Cu", {0.200f, 0.924f, 1.102f}, {3.912f, 2.452f, 2.142f}},
              {"Au", {0.143f, 0.374f, 1.442f}, {3.983f, 2.385f, 1.603f}},
              {"Ag", {0.155f, 0.117f, 0.138f}, {4.828f, 3.122f, 2.147f}},
              {"Al", {1.657f, 0.880f, 0.521f}, {9.224f, 6.270f, 4.837f}},
              {"Cr", {3.105f, 3.182f, 2.223f}, {3.330f, 3.332f, 3.181f}}};

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
        if (!(*out >= 1.0 && *out < 10.0))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"%s\">: %s %g is not in "
                                "[1, 10)", p->file, p->line, n->type, name, *out);
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

/* The texture child of n given under name (or alias when name has none), or NULL. */
static op_node *texture_child(const op_node *n, const char *name, const char *alias,
                              const char **given)
{
    for (int pass = 0; pass < 2; pass++) {
        const char *want = pass == 0 ? name : alias;
        for (int i = 0; want && i < n->nchildren; i++) {
            const char *cn = op_node_child_name(n, i);
            if (strcmp(n->children[i]->tag, "texture") == 0 && cn && strcmp(cn, want) == 0) {
                *given = want;
                return n->children[i];
            }
        }
    }
    return NULL;
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

/* A rough model's distribution (beckmann, ggx or phong: all rendered as GGX) and alpha
 * (default 0.1, clamped to [0.001, 1] with a warning). */
static op_status read_alpha(op_node *node, float *out, op_error *err)
{
    const char *dist;
    double alpha;
    GET_OR_FAIL(op_node_string(node, "distribution", "beckmann", &dist, err));
    GET_OR_FAIL(op_node_float(node, "alpha", 0.1, &alpha, err));
    if (strcmp(dist, "beckmann") != 0 && strcmp(dist, "ggx") != 0 && strcmp(dist, "phong") != 0)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"%s\">: unknown distribution "
                            "\"%s\"", node->file, node->line, node->type, dist);
    if (strcmp(dist, "ggx") != 0)
        op_log(OP_LOG_DEBUG, "%s:%d: %s: distribution %s rendered as ggx", node->file, node->line,
               node->type, dist);
    if (!(alpha > 0.0 && alpha <= 1.0)) {
        op_log(OP_LOG_WARN, "%s:%d: <bsdf type=\"%s\">: alpha %g clamped to [0.001, 1]",
               node->file, node->line, node->type, alpha);
        alpha = alpha > 1.0 ? 1.0 : 0.001;
    }
    *out = (float)alpha;
    return OP_OK;
}

void op_bsdf_default(op_bsdf *b)
{
    memset(b, 0, sizeof *b);
    b->type = OP_BSDF_DIFFUSE;
    b->reflectance = v3s(0.5f);
}

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
    if (strcmp(node->type, "mask") == 0) {
        op_v3 opacity;
        GET_OR_FAIL(read_reflectance(node, "opacity", NULL, 0.5, &opacity, err));
        op_node *inner = op_node_child(node, "bsdf", 0);
        if (inner)
            GET_OR_FAIL(op_bsdf_build(inner, tex, b, err));
        b->opacity = b->masked ? v3_mul(b->opacity, opacity) : opacity;
        b->masked = 1;
        return OP_OK;
    }
    double int_ior = 1.5046, ext_ior = 1.00028;
    if (strcmp(node->type, "diffuse") == 0) {
        b->type = OP_BSDF_DIFFUSE;
        return read_textured(node, "reflectance", "diffuseReflectance", 0.5, tex, &b->reflectance,
                             &b->refl_tex, err);
    }
    int rough_dielectric = strcmp(node->type, "roughdielectric") == 0;
    if (strcmp(node->type, "dielectric") == 0 || strcmp(node->type, "thindielectric") == 0 ||
        rough_dielectric) {
        b->type = rough_dielectric ? OP_BSDF_ROUGHDIELECTRIC : OP_BSDF_DIELECTRIC;
        GET_OR_FAIL(read_ior(node, "intIOR", "bk7", &int_ior, err));
        GET_OR_FAIL(read_ior(node, "extIOR", "air", &ext_ior, err));
        GET_OR_FAIL(read_reflectance(node, "specularReflectance", NULL, 1.0, &b->specular, err));
        op_v3 t;
        GET_OR_FAIL(read_reflectance(node, "specularTransmittance", NULL, 1.0, &t, err));
        if (rough_dielectric)
            GET_OR_FAIL(read_alpha(node, &b->alpha, err));
        b->eta = (float)(int_ior / ext_ior);
        return OP_OK;
    }
    if (strcmp(node->type, "conductor") == 0) {
        b->type = OP_BSDF_CONDUCTOR;
        const char *mat;
        GET_OR_FAIL(op_node_string(node, "material", "Cu", &mat, err));
        GET_OR_FAIL(read_reflectance(node, "specularReflectance", NULL, 1.0, &b->specular, err));
        GET_OR_FAIL(read_ior(node, "extEta", "air", &ext_ior, err));
        if (op_node_has(node, "eta") || op_node_has(node, "k")) {
            double e[3], k[3], one[3] = {1, 1, 1}, zero[3] = {0, 0, 0};
            GET_OR_FAIL(op_node_color(node, "eta", one, e, err));
            GET_OR_FAIL(op_node_color(node, "k", zero, k, err));
            b->cond_eta = v3_scale(v3_from_d(e), (float)(1.0 / ext_ior));
            b->cond_k = v3_scale(v3_from_d(k), (float)(1.0 / ext_ior));
            return OP_OK;
        }
        if (strcasecmp(mat, "none") == 0) {
            b->mirror = 1;
            return OP_OK;
        }
        for (size_t i = 0; i < sizeof metals / sizeof metals[0]; i++)
            if (strcasecmp(metals[i].name, mat) == 0) {
                b->cond_eta = v3_scale(v3(metals[i].eta[0], metals[i].eta[1], metals[i].eta[2]),
                                       (float)(1.0 / ext_ior));
                b->cond_k = v3_scale(v3(metals[i].k[0], metals[i].k[1], metals[i].k[2]),
                                     (float)(1.0 / ext_ior));
                return OP_OK;
            }
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"conductor\">: unknown material "
                            "\"%s\" (Cu, Au, Ag, Al, Cr, none, or eta/k)", node->file, node->line,
                            mat);
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
        if (rough)
            GET_OR_FAIL(read_alpha(node, &b->alpha, err));
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
    return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"%s\">: unknown BSDF type "
                        "(diffuse, dielectric, conductor, plastic, roughplastic, roughdielectric, "
                        "coating, twosided, mask)",
                        node->file, node->line, node->type);
}

const op_bsdf *op_bsdf_at(const op_bsdf *b, float u, float v, op_bsdf *scratch)
{
    if (b->refl_tex.type == OP_TEX_NONE)
        return b;
    *scratch = *b;
    scratch->reflectance = op_texture_eval(&b->refl_tex, u, v);
    return scratch;
}

int op_bsdf_is_smooth_only(const op_bsdf *b)
{
    return b->type == OP_BSDF_DIELECTRIC || b->type == OP_BSDF_CONDUCTOR ||
           (b->type == OP_BSDF_SHEEN && b->alpha <= 0.0f);
}

/* Unpolarized Fresnel reflectance of a dielectric; cos_i > 0 on the side of the normal (outside).
 * *cos_t receives the cosine of the refracted direction (0 on total internal reflection). */
static float fresnel_dielectric(float cos_i, float eta, float *cos_t)
{
    float e = cos_i >= 0.0f ? eta : 1.0f / eta;
    float ci = fabsf(cos_i);
    float sin2_t = (1.0f - ci * ci) / (e * e);
    if (sin2_t >= 1.0f) {
        *cos_t = 0.0f;
        return 1.0f;
    }
    float ct = sqrtf(1.0f - sin2_t);
    float rs = (ci - e * ct) / (ci + e * ct);
    float rp = (e * ci - ct) / (e * ci + ct);
    *cos_t = ct;
    return 0.5f * (rs * rs + rp * rp);
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

/* GGX (Trowbridge-Reitz) normal distribution and its Smith G1. */
static float ggx_d(op_v3 m, float a)
{
    if (m.z <= 0.0f)
        return 0.0f;
    float a2 = a * a, c2 = m.z * m.z;
    float t = c2 * (a2 - 1.0f) + 1.0f;
    return a2 / (OP_PI * t * t);
}
static float ggx_g1(op_v3 v, float a)
{
    float c2 = v.z * v.z;
    if (c2 <= 0.0f)
        return 0.0f;
    float t2 = (1.0f - c2) / c2;
    return 2.0f / (1.0f + sqrtf(1.0f + a * a * t2));
}

/* A microfacet normal m drawn with density D(m) m.z. */
static op_v3 ggx_sample_m(float u1, float u2, float a)
{
    float t2 = a * a * u1 / fmaxf(1.0f - u1, 1e-7f);
    float cz = 1.0f / sqrtf(1.0f + t2), sz = sqrtf(fmaxf(0.0f, 1.0f - cz * cz));
    float phi = 2.0f * OP_PI * u2;
    return v3(sz * cosf(phi), sz * sinf(phi), cz);
}

/* The GGX reflection of a dielectric interface (f |cos wo|, without the specular tint) and the
 * density of wo under ggx_sample_m's reflection. */
static float ggx_reflect(op_v3 wi, op_v3 wo, float eta, float a, float *pdf)
{
    op_v3 h = v3_norm(v3_add(wi, wo));
    float ct, d = ggx_d(h, a);
    float fh = fresnel_dielectric(v3_dot(wi, h), eta, &ct);
    float g = ggx_g1(wi, a) * ggx_g1(wo, a);
    *pdf = d * h.z / (4.0f * v3_dot(wo, h));
    return fh * d * g / (4.0f * wi.z);
}

/* Plastic's weights: probability of choosing the specular lobe. */
static float plastic_spec_prob(const op_bsdf *b, float fi)
{
    float ps = fi * v3_max(b->specular);
    float pd = (1.0f - fi) * v3_max(b->reflectance);
    return ps + pd > 0.0f ? ps / (ps + pd) : 0.0f;
}

/* The diffuse part of plastic (Mitsuba's model, internal scattering approximated by 1 - Fdr). */
static op_v3 plastic_diffuse(const op_bsdf *b, op_v3 wi, op_v3 wo)
{
    float ct, fi = fresnel_dielectric(wi.z, b->eta, &ct), fo = fresnel_dielectric(wo.z, b->eta, &ct);
    float fdr = -1.440f / (b->eta * b->eta) + 0.710f / b->eta + 0.668f + 0.0636f * b->eta;
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
    if (b->twosided && wi.z < 0.0f) {
        wi.z = -wi.z;
        wo.z = -wo.z;
    }
    if (wi.z <= 0.0f || wo.z <= 0.0f)
        return v3s(0.0f);
    switch (b->type) {
    case OP_BSDF_DIFFUSE:
        *pdf = wo.z * OP_INV_PI;
        return v3_scale(b->reflectance, wo.z * OP_INV_PI);
    case OP_BSDF_PLASTIC: {
        float ct, fi = fresnel_dielectric(wi.z, b->eta, &ct);
        *pdf = (1.0f - plastic_spec_prob(b, fi)) * wo.z * OP_INV_PI;
        return plastic_diffuse(b, wi, wo);
    }
    case OP_BSDF_ROUGHPLASTIC: {
        float ct, fi = fresnel_dielectric(wi.z, b->eta, &ct);
        float ps = plastic_spec_prob(b, fi), spec_pdf;
        float spec = ggx_reflect(wi, wo, b->eta, b->alpha, &spec_pdf);
        *pdf = ps * spec_pdf + (1.0f - ps) * wo.z * OP_INV_PI;
        return v3_add(v3_scale(b->specular, spec), plastic_diffuse(b, wi, wo));
    }
    case OP_BSDF_SHEEN:
        if (b->alpha <= 0.0f)
            return v3s(0.0f);
        return v3_scale(b->specular, ggx_reflect(wi, wo, b->eta, b->alpha, pdf));
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
        float ct, f = fresnel_dielectric(wi.z, b->eta, &ct);
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
            s->weight = v3s(1.0f / (e * e));
        }
        return 1;
    }
    case OP_BSDF_CONDUCTOR: {
        if (wi.z <= 0.0f)
            return 0;
        s->wo = v3(-wi.x, -wi.y, wi.z);
        s->delta = 1;
        s->pdf = 1.0f;
        if (b->mirror)
            s->weight = b->specular;
        else
            s->weight = v3_mul(b->specular,
                               v3(fresnel_conductor1(wi.z, b->cond_eta.x, b->cond_k.x),
                                  fresnel_conductor1(wi.z, b->cond_eta.y, b->cond_k.y),
                                  fresnel_conductor1(wi.z, b->cond_eta.z, b->cond_k.z)));
        break;
    }
    case OP_BSDF_PLASTIC: {
        if (wi.z <= 0.0f)
            return 0;
        float ct, fi = fresnel_dielectric(wi.z, b->eta, &ct);
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
        float ct, fi = fresnel_dielectric(wi.z, b->eta, &ct);
        float ps = plastic_spec_prob(b, fi);
        if (u3 < ps) {
            op_v3 m = ggx_sample_m(u1, u2, b->alpha);
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
            s->weight = v3_scale(b->specular, fresnel_dielectric(wi.z, b->eta, &ct));
            break;
        }
        op_v3 m = ggx_sample_m(u1, u2, b->alpha);
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
    case OP_BSDF_ROUGHDIELECTRIC:
    case OP_BSDF_COATING:
        return 0; /* only as a boundary (op_bsdf_boundary), which scene building enforces */
    }
    if (flip)
        s->wo.z = -s->wo.z;
    return 1;
}

float op_bsdf_opacity_prob(const op_bsdf *b)
{
    if (!b->masked)
        return 1.0f;
    return (b->opacity.x + b->opacity.y + b->opacity.z) * (1.0f / 3.0f);
}

op_v3 op_bsdf_hit_weight(const op_bsdf *b)
{
    float p = op_bsdf_opacity_prob(b);
    return p > 0.0f ? v3_scale(b->masked ? b->opacity : v3s(1.0f), 1.0f / p) : v3s(0.0f);
}

op_v3 op_bsdf_pass_weight(const op_bsdf *b)
{
    float p = op_bsdf_opacity_prob(b);
    return p < 1.0f ? v3_scale(op_bsdf_transmittance(b), 1.0f / (1.0f - p)) : v3s(0.0f);
}

op_v3 op_bsdf_transmittance(const op_bsdf *b)
{
    if (!b->masked)
        return v3s(0.0f);
    return v3_sub(v3s(1.0f), b->opacity);
}

op_v3 op_bsdf_albedo(const op_bsdf *b)
{
    switch (b->type) {
    case OP_BSDF_DIFFUSE:
    case OP_BSDF_PLASTIC:
    case OP_BSDF_ROUGHPLASTIC:
        return b->reflectance;
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
    fresnel_dielectric(fmaxf(cos, 1e-4f), b->eta, &ct);
    float len = b->thickness / fmaxf(ct, 1e-4f);
    return v3(expf(-b->sigma_a.x * len), expf(-b->sigma_a.y * len), expf(-b->sigma_a.z * len));
}

enum { THROUGH_GRID = 48 }; /* lobe samples per axis when tabulating a rough sheen's albedo */

op_status op_bsdf_boundary(const op_bsdf *b, op_bsdf *sheen, op_bsdf_through *tr, op_error *err)
{
    static const char *names[] = {"diffuse", "dielectric", "conductor", "plastic", "roughplastic",
                                  "roughdielectric", "coating", "sheen", "through"};
    int rough = b->type == OP_BSDF_ROUGHPLASTIC || b->type == OP_BSDF_ROUGHDIELECTRIC;
    if (!(rough || b->type == OP_BSDF_DIELECTRIC || b->type == OP_BSDF_PLASTIC ||
          b->type == OP_BSDF_COATING) || b->masked || b->twosided)
        return op_error_set(err, OP_ERR_INPUT, "a %s%s bsdf cannot be the surface of a translucent "
                            "shape (dielectric, roughdielectric, plastic, roughplastic or coating)",
                            b->masked ? "masked " : (b->twosided ? "twosided " : ""),
                            names[b->type]);
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
            r = fresnel_dielectric(mu, b->eta, &ct);
        } else {
            op_v3 wi = v3(sqrtf(fmaxf(0.0f, 1.0f - mu * mu)), 0.0f, mu);
            for (int i = 0; i < THROUGH_GRID * THROUGH_GRID; i++) {
                op_bsdf_sample s;
                float u1 = ((float)(i % THROUGH_GRID) + 0.5f) / THROUGH_GRID;
                float u2 = ((float)(i / THROUGH_GRID) + 0.5f) / THROUGH_GRID;
                if (op_bsdf_sample_dir(&lobe, wi, u1, u2, 0.0f, &s))
                    r += s.weight.x;
            }
            r /= THROUGH_GRID * THROUGH_GRID;
        }
        if (r > 1.0)
            r = 1.0;
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
