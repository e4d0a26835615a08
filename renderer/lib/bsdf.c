/* bsdf.c - the surface scattering models (see bsdf.h). */
#include "bsdf.h"

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
    if (strcmp(node->type, "dielectric") == 0 || strcmp(node->type, "thindielectric") == 0) {
        b->type = OP_BSDF_DIELECTRIC;
        GET_OR_FAIL(read_ior(node, "intIOR", "bk7", &int_ior, err));
        GET_OR_FAIL(read_ior(node, "extIOR", "air", &ext_ior, err));
        GET_OR_FAIL(read_reflectance(node, "specularReflectance", NULL, 1.0, &b->specular, err));
        op_v3 t;
        GET_OR_FAIL(read_reflectance(node, "specularTransmittance", NULL, 1.0, &t, err));
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
        if (rough) {
            const char *dist;
            double alpha;
            GET_OR_FAIL(op_node_string(node, "distribution", "beckmann", &dist, err));
            GET_OR_FAIL(op_node_float(node, "alpha", 0.1, &alpha, err));
            if (strcmp(dist, "beckmann") != 0 && strcmp(dist, "ggx") != 0 &&
                strcmp(dist, "phong") != 0)
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"roughplastic\">: "
                                    "unknown distribution \"%s\"", node->file, node->line, dist);
            if (strcmp(dist, "ggx") != 0)
                op_log(OP_LOG_DEBUG, "%s:%d: roughplastic: distribution %s rendered as ggx",
                       node->file, node->line, dist);
            if (!(alpha > 0.0 && alpha <= 1.0)) {
                op_log(OP_LOG_WARN, "%s:%d: <bsdf type=\"roughplastic\">: alpha %g clamped to "
                       "[0.001, 1]", node->file, node->line, alpha);
                alpha = alpha > 1.0 ? 1.0 : 0.001;
            }
            b->alpha = (float)alpha;
        }
        return OP_OK;
    }
    return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"%s\">: unknown BSDF type "
                        "(diffuse, dielectric, conductor, plastic, roughplastic, twosided, mask)",
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
    return b->type == OP_BSDF_DIELECTRIC || b->type == OP_BSDF_CONDUCTOR;
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
        float ps = plastic_spec_prob(b, fi);
        op_v3 h = v3_norm(v3_add(wi, wo));
        float d = ggx_d(h, b->alpha);
        float fh = fresnel_dielectric(v3_dot(wi, h), b->eta, &ct);
        float g = ggx_g1(wi, b->alpha) * ggx_g1(wo, b->alpha);
        float spec = fh * d * g / (4.0f * wi.z);
        float spec_pdf = d * h.z / (4.0f * v3_dot(wo, h));
        *pdf = ps * spec_pdf + (1.0f - ps) * wo.z * OP_INV_PI;
        return v3_add(v3_scale(b->specular, spec), plastic_diffuse(b, wi, wo));
    }
    default:
        return v3s(0.0f);
    }
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
            float pdf;
            op_v3 f = op_bsdf_eval(b, wi, s->wo, &pdf);
            if (pdf <= 0.0f)
                return 0;
            s->pdf = pdf;
            s->weight = v3_scale(f, 1.0f / pdf);
        }
        break;
    }
    case OP_BSDF_ROUGHPLASTIC: {
        if (wi.z <= 0.0f)
            return 0;
        float ct, fi = fresnel_dielectric(wi.z, b->eta, &ct);
        float ps = plastic_spec_prob(b, fi);
        if (u3 < ps) {
            /* sample the GGX normal distribution D(m) m.z */
            float a2 = b->alpha * b->alpha;
            float t2 = a2 * u1 / fmaxf(1.0f - u1, 1e-7f);
            float cz = 1.0f / sqrtf(1.0f + t2), sz = sqrtf(fmaxf(0.0f, 1.0f - cz * cz));
            float phi = 2.0f * OP_PI * u2;
            op_v3 m = v3(sz * cosf(phi), sz * sinf(phi), cz);
            s->wo = v3_sub(v3_scale(m, 2.0f * v3_dot(wi, m)), wi);
        } else {
            s->wo = op_sample_cosine(u1, u2);
        }
        if (s->wo.z <= 0.0f)
            return 0;
        float pdf;
        op_v3 f = op_bsdf_eval(b, wi, s->wo, &pdf);
        if (pdf <= 0.0f)
            return 0;
        s->pdf = pdf;
        s->weight = v3_scale(f, 1.0f / pdf);
        break;
    }
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
