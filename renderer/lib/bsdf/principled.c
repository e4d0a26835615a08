/* principled.c - Mitsuba 3's principled and principledthin BSDFs (see principled.h). */
#include "bsdf/principled.h"

#include <string.h>

#include "bsdf/fresnel.h"
#include "bsdf/microfacet.h"

/* Each weight's name (camelCase, dialect.h), default and largest value. */
static const struct {
    const char *name;
    float def, max;
} weights[OP_PR_N] = {
    [OP_PR_ROUGHNESS] = {"roughness", 0.5f, 1.0f},
    [OP_PR_ANISOTROPIC] = {"anisotropic", 0.0f, 1.0f},
    [OP_PR_METALLIC] = {"metallic", 0.0f, 1.0f},
    [OP_PR_SPEC_TRANS] = {"specTrans", 0.0f, 1.0f},
    [OP_PR_SPEC_TINT] = {"specTint", 0.0f, 1.0f},
    [OP_PR_SHEEN] = {"sheen", 0.0f, 1.0f},
    [OP_PR_SHEEN_TINT] = {"sheenTint", 0.0f, 1.0f},
    [OP_PR_FLATNESS] = {"flatness", 0.0f, 1.0f},
    [OP_PR_CLEARCOAT] = {"clearcoat", 0.0f, 1.0f},
    [OP_PR_CLEARCOAT_GLOSS] = {"clearcoatGloss", 0.0f, 1.0f},
    [OP_PR_DIFF_TRANS] = {"diffTrans", 0.0f, 2.0f},
    [OP_PR_ETA] = {"eta", 1.5f, 10.0f},
};

/* The sampling rates' names, in op_principled.rate's order. */
static const char *const rates_full[] = {"mainSpecularSamplingRate", "clearcoatSamplingRate",
                                         "diffuseReflectanceSamplingRate", NULL};
static const char *const rates_thin[] = {"specularReflectanceSamplingRate",
                                         "specularTransmittanceSamplingRate",
                                         "diffuseReflectanceSamplingRate",
                                         "diffuseTransmittanceSamplingRate"};

/* Weight k as a constant (clamped to [0, max] with a warning) or a texture; *given: whether
 * the file sets it to a texture or to a non-zero number (Mitsuba's test for a lobe). */
static op_status read_weight(op_node *n, op_pr_param k, op_tex_cache *cache, op_principled *p,
                             int *given, op_error *err)
{
    const char *name = weights[k].name;
    op_node *t = op_texture_child(n, name);
    p->v[k] = weights[k].def;
    if (t) {
        if (op_node_has(n, name))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"%s\">: %s is given both "
                                "as a number and as a texture", n->file, n->line, n->type, name);
        if (!cache)
            return op_error_set(err, OP_ERR_INTERNAL, "%s:%d: <bsdf type=\"%s\">: no texture "
                                "cache", n->file, n->line, n->type);
        GET_OR_FAIL(op_texture_build_value(t, cache, weights[k].max > 1.0f ? 1e30 : 1.0,
                                           &p->tex[k], err));
        p->textured = 1;
        *given = 1;
        return OP_OK;
    }
    double d;
    GET_OR_FAIL(op_node_float(n, name, weights[k].def, &d, err));
    *given = op_node_has(n, name) && d != 0.0;
    if (!(d >= 0.0 && d <= weights[k].max)) {
        op_log(OP_LOG_WARN, "%s:%d: <bsdf type=\"%s\">: %s %g clamped to [0, %g]", n->file,
               n->line, n->type, name, d, (double)weights[k].max);
        d = d > weights[k].max ? weights[k].max : 0.0;
    }
    p->v[k] = (float)d;
    return OP_OK;
}

op_status op_principled_build(op_node *node, op_tex_cache *tex, op_principled *p, op_error *err)
{
    memset(p, 0, sizeof *p);
    p->thin = strcmp(node->type, "principledthin") == 0;
    op_node *bt = op_texture_child(node, "baseColor");
    double grey[3] = {0.5, 0.5, 0.5}, c[3];
    if (bt) {
        if (op_node_has(node, "baseColor"))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"%s\">: baseColor is given "
                                "both as a colour and as a texture", node->file, node->line,
                                node->type);
        if (!tex)
            return op_error_set(err, OP_ERR_INTERNAL, "%s:%d: <bsdf type=\"%s\">: no texture "
                                "cache", node->file, node->line, node->type);
        GET_OR_FAIL(op_texture_build(bt, tex, &p->base_tex, err));
        p->textured = 1;
        p->base_color = v3s(0.5f);
    } else {
        GET_OR_FAIL(op_node_color(node, "baseColor", grey, c, err));
        if (!(c[0] >= 0.0 && c[1] >= 0.0 && c[2] >= 0.0))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"%s\">: baseColor must "
                                "not be negative", node->file, node->line, node->type);
        p->base_color = v3_from_d(c);
    }
    int given[OP_PR_N] = {0};
    for (int k = 0; k < OP_PR_N; k++) {
        int full_only = k == OP_PR_METALLIC || k == OP_PR_CLEARCOAT || k == OP_PR_CLEARCOAT_GLOSS;
        if (p->thin ? full_only : (k == OP_PR_DIFF_TRANS || k == OP_PR_ETA))
            continue;
        GET_OR_FAIL(read_weight(node, (op_pr_param)k, tex, p, &given[k], err));
    }
    const char *const *rates = p->thin ? rates_thin : rates_full;
    for (int i = 0; i < 4 && rates[i]; i++) {
        double r;
        GET_OR_FAIL(op_node_float(node, rates[i], 1.0, &r, err));
        if (!(r >= 0.0 && r < 1e30))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"%s\">: %s must be >= 0",
                                node->file, node->line, node->type, rates[i]);
        p->rate[i] = (float)r;
    }
    if (p->thin) {
        if (!(p->v[OP_PR_ETA] > 0.0f))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"principledthin\">: eta "
                                "must be > 0", node->file, node->line);
        return OP_OK;
    }
    /* principled: the index from eta, or from specular (Burley's mapping of the normal-incidence
     * reflectance 0.08 specular); neither may make a transmitting lobe index-matched */
    int has_eta = op_node_has(node, "eta"), has_spec = op_node_has(node, "specular");
    if (has_eta && has_spec)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"principled\">: give eta or "
                            "specular, not both", node->file, node->line);
    double eta, spec;
    if (has_eta) {
        GET_OR_FAIL(op_node_float(node, "eta", 1.5, &eta, err));
        if (!(eta > 0.0 && eta < 10.0))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"principled\">: eta %g "
                                "is not in (0, 10)", node->file, node->line, eta);
        if (given[OP_PR_SPEC_TRANS] && eta == 1.0)
            eta = 1.001;
    } else {
        GET_OR_FAIL(op_node_float(node, "specular", 0.5, &spec, err));
        if (!(spec >= 0.0 && spec < 12.5))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"principled\">: specular "
                                "%g is not in [0, 12.5)", node->file, node->line, spec);
        if (given[OP_PR_SPEC_TRANS] && spec == 0.0)
            spec = 1e-3;
        eta = 2.0 / (1.0 - sqrt(0.08 * spec)) - 1.0;
    }
    p->v[OP_PR_ETA] = (float)eta;
    return OP_OK;
}

static float luminance(op_v3 c)
{
    return 0.212671f * c.x + 0.715160f * c.y + 0.072169f * c.z;
}

void op_principled_at(const op_principled *p, float u, float v, op_principled *out)
{
    *out = *p;
    if (p->base_tex.type != OP_TEX_NONE)
        out->base_color = op_texture_eval(&p->base_tex, u, v);
    for (int k = 0; k < OP_PR_N; k++)
        if (p->tex[k].type != OP_TEX_NONE)
            out->v[k] = op_texture_eval_value(&p->tex[k], u, v);
    out->v[OP_PR_ETA] = fmaxf(out->v[OP_PR_ETA], 1e-3f);
}

/* (1 - cos)^5, cos clamped to [0, 1]. */
static float schlick_weight(float cos)
{
    float m = fminf(fmaxf(1.0f - cos, 0.0f), 1.0f);
    return m * m * m * m * m;
}

/* Schlick's approximation of normal-incidence reflectance r0 at cos_i (> 0 outside), taken at
 * the refracted angle when leaving the denser side. */
static op_v3 schlick(op_v3 r0, float cos_i, float eta)
{
    float eta_it = cos_i >= 0.0f ? eta : 1.0f / eta, eta_ti = 1.0f / eta_it;
    float ct2 = 1.0f - (1.0f - cos_i * cos_i) * eta_ti * eta_ti;
    float w = schlick_weight(eta_it > 1.0f ? fabsf(cos_i) : sqrtf(fmaxf(ct2, 0.0f)));
    return v3_add(r0, v3_scale(v3_sub(v3s(1.0f), r0), w));
}

static float r0_of(float eta)
{
    float t = (eta - 1.0f) / (eta + 1.0f);
    return t * t;
}

/* base / luminance(base), white when black. */
static op_v3 tint_of(op_v3 base)
{
    float lum = luminance(base);
    return lum > 0.0f ? v3_scale(base, 1.0f / lum) : v3s(1.0f);
}

/* The main lobe's GGX of roughness r: alpha r^2, stretched along x and shrunk along y by the
 * anisotropy. */
static op_microfacet main_lobe(float r, float anisotropic)
{
    float aspect = sqrtf(1.0f - 0.9f * anisotropic), r2 = r * r;
    return op_mf_make(OP_MF_GGX, fmaxf(0.001f, r2 / aspect), fmaxf(0.001f, r2 * aspect), 1);
}

/* Burley's GTR1 (the clearcoat's distribution) of roughness a, and its density in m (D cos). */
static float gtr1(float a, op_v3 m)
{
    float a2 = a * a, c2 = m.z * m.z;
    float d = (a2 - 1.0f) / (OP_PI * logf(a2) * (1.0f + (a2 - 1.0f) * c2));
    return d * m.z > 1e-20f ? d : 0.0f;
}

static op_v3 gtr1_sample(float a, float u1, float u2)
{
    float a2 = a * a, phi = 2.0f * OP_PI * u1;
    float c2 = (1.0f - powf(a2, 1.0f - u2)) / (1.0f - a2);
    float s = sqrtf(fmaxf(0.0f, 1.0f - c2)), c = sqrtf(fmaxf(0.0f, c2));
    return v3(cosf(phi) * s, sinf(phi) * s, c);
}

static float clearcoat_alpha(float gloss)
{
    return 0.1f * (1.0f - gloss) + 0.001f * gloss;
}

/* Burley's diffuse with retro-reflection, flattened toward the Hanrahan-Krueger fake subsurface
 * by flatness (cos_d: the half vector's cosine with wo), without base_color / pi. */
static float diffuse_shape(const op_principled *p, float ci, float co, float cos_d)
{
    float fo = schlick_weight(co), fi = schlick_weight(ci);
    float f_diff = (1.0f - 0.5f * fi) * (1.0f - 0.5f * fo);
    float rr = 2.0f * p->v[OP_PR_ROUGHNESS] * cos_d * cos_d;
    float f_retro = rr * (fo + fi + fo * fi * (rr - 1.0f));
    float flat = p->v[OP_PR_FLATNESS];
    if (flat <= 0.0f)
        return f_diff + f_retro;
    float fss90 = 0.5f * rr;
    float fss = (1.0f + (fss90 - 1.0f) * fo) * (1.0f + (fss90 - 1.0f) * fi);
    float f_ss = 1.25f * (fss * (1.0f / (co + ci) - 0.5f) + 0.5f);
    return (f_diff + f_retro) * (1.0f - flat) + f_ss * flat;
}

/* The sheen lobe's f |cos wo| (without the lobe's weight). */
static op_v3 sheen_lobe(const op_principled *p, float co, float cos_d)
{
    float tint = p->v[OP_PR_SHEEN_TINT];
    op_v3 c = v3s(1.0f);
    if (tint > 0.0f)
        c = v3_add(v3s(1.0f - tint), v3_scale(tint_of(p->base_color), tint));
    return v3_scale(c, p->v[OP_PR_SHEEN] * schlick_weight(fabsf(cos_d)) * co);
}

static op_v3 v3_sqrt(op_v3 a)
{
    return v3(sqrtf(fmaxf(a.x, 0.0f)), sqrtf(fmaxf(a.y, 0.0f)), sqrtf(fmaxf(a.z, 0.0f)));
}

static op_v3 reflect(op_v3 wi, op_v3 m)
{
    return v3_sub(v3_scale(m, 2.0f * v3_dot(wi, m)), wi);
}

/* principled: value and density. */
static op_v3 eval_full(const op_principled *p, op_v3 wi, op_v3 wo, float *pdf)
{
    *pdf = 0.0f;
    float ci = wi.z, co = wo.z;
    float met = p->v[OP_PR_METALLIC], st = p->v[OP_PR_SPEC_TRANS], cc = p->v[OP_PR_CLEARCOAT];
    float brdf = (1.0f - met) * (1.0f - st), bsdf = (1.0f - met) * st;
    int front = ci > 0.0f, reflect_ = ci * co > 0.0f, refract_ = ci * co < 0.0f;
    if (ci == 0.0f || (!front && !(bsdf > 0.0f)) || !(reflect_ || refract_))
        return v3s(0.0f);
    float eta = p->v[OP_PR_ETA], eta_path = front ? eta : 1.0f / eta;
    op_v3 h = v3_add(wi, v3_scale(wo, reflect_ ? 1.0f : eta_path));
    float hl = v3_len(h);
    if (!(hl > 0.0f))
        return v3s(0.0f);
    op_v3 wh = v3_scale(h, (h.z < 0.0f ? -1.0f : 1.0f) / hl);
    float s = front ? 1.0f : -1.0f, ih = v3_dot(wi, wh), oh = v3_dot(wo, wh);
    int compat_r = reflect_ && ih * s > 0.0f && oh * s > 0.0f;
    int compat_t = refract_ && ih * s > 0.0f && -oh * s > 0.0f;
    float ct, f = op_fresnel_dielectric(ih, eta, &ct);
    op_microfacet mf = main_lobe(p->v[OP_PR_ROUGHNESS], p->v[OP_PR_ANISOTROPIC]);
    float d = op_mf_d(&mf, wh), g = op_mf_g1(&mf, wi, wh) * op_mf_g1(&mf, wo, wh);
    op_v3 base = p->base_color, val = v3s(0.0f);
    if (compat_r && f > 0.0f) {
        op_v3 fp;
        if (front) {
            float tint = p->v[OP_PR_SPEC_TINT];
            fp = v3s((1.0f - met) * (1.0f - tint) * f);
            if (met > 0.0f)
                fp = v3_add(fp, v3_scale(schlick(base, ih, eta), met));
            if (tint > 0.0f) {
                op_v3 r0 = v3_scale(tint_of(base), r0_of(ih >= 0.0f ? eta : 1.0f / eta));
                fp = v3_add(fp, v3_scale(schlick(r0, ih, eta), (1.0f - met) * tint));
            }
        } else {
            fp = v3s(bsdf * f);
        }
        val = v3_add(val, v3_scale(fp, d * g / (4.0f * fabsf(ci))));
    }
    float den = ih + eta_path * oh;
    if (compat_t && bsdf > 0.0f && f < 1.0f)
        val = v3_add(val, v3_scale(v3_sqrt(base),
                                   bsdf * fabsf((1.0f - f) * d * g * ih * oh / (ci * den * den))));
    float a_cc = clearcoat_alpha(p->v[OP_PR_CLEARCOAT_GLOSS]);
    if (cc > 0.0f && compat_r && front) {
        op_microfacet g_cc = op_mf_make(OP_MF_GGX, 0.25f, 0.25f, 0);
        float fcc = schlick(v3s(0.04f), ih, eta).x;
        float gcc = op_mf_g1(&g_cc, wi, wh) * op_mf_g1(&g_cc, wo, wh);
        val = v3_add(val, v3s(0.25f * cc * fcc * gtr1(a_cc, wh) * gcc * fabsf(co)));
    }
    if (reflect_ && front) {
        float cos_d = v3_dot(wh, wo);
        if (brdf > 0.0f)
            val = v3_add(val, v3_scale(base, brdf * co * OP_INV_PI *
                                                 diffuse_shape(p, ci, co, cos_d)));
        if (p->v[OP_PR_SHEEN] > 0.0f && met < 1.0f)
            val = v3_add(val, v3_scale(sheen_lobe(p, co, cos_d), 1.0f - met));
    }
    /* the density: lobe choice (main reflection, main transmission, clearcoat, diffuse) */
    float rs = p->rate[0];
    float psr = front ? rs * (1.0f - bsdf * (1.0f - f)) : f;
    float pst = front ? rs * bsdf * (1.0f - f) : 1.0f - f;
    float pcc = front ? 0.25f * cc * p->rate[1] : 0.0f;
    float pd = front ? brdf * p->rate[2] : 0.0f;
    float tot = psr + pst + pcc + pd;
    if (!(tot > 0.0f))
        return val;
    float dwh = reflect_ ? 1.0f / (4.0f * oh) : eta_path * eta_path * oh / (den * den);
    dwh = fabsf(dwh);
    float vis = op_mf_pdf(&mf, v3_scale(wi, s), wh);
    float sum = 0.0f;
    if (compat_r)
        sum += (psr * vis + pcc * (wh.z > 0.0f ? wh.z * gtr1(a_cc, wh) : 0.0f)) * dwh;
    if (compat_t)
        sum += pst * vis * dwh;
    if (reflect_)
        sum += pd * fmaxf(co, 0.0f) * OP_INV_PI;
    *pdf = sum / tot;
    return val;
}

/* principledthin: value and density (both sides alike: wi is brought to the upper side). */
static op_v3 eval_thin(const op_principled *p, op_v3 wi, op_v3 wo, float *pdf)
{
    *pdf = 0.0f;
    if (wi.z == 0.0f)
        return v3s(0.0f);
    float s = wi.z > 0.0f ? 1.0f : -1.0f;
    wi = v3_scale(wi, s);
    wo = v3_scale(wo, s);
    float ci = wi.z, co = wo.z;
    int reflect_ = co > 0.0f, refract_ = co < 0.0f;
    float st = p->v[OP_PR_SPEC_TRANS], dt = 0.5f * p->v[OP_PR_DIFF_TRANS], eta = p->v[OP_PR_ETA];
    float r = p->v[OP_PR_ROUGHNESS], an = p->v[OP_PR_ANISOTROPIC];
    op_v3 wr = v3(wo.x, wo.y, fabsf(wo.z));
    op_v3 wh = v3_norm(v3_add(wi, wr));
    float ih = v3_dot(wi, wh), oh = v3_dot(wo, wh);
    int compat_r = reflect_ && ih > 0.0f && oh > 0.0f;
    int compat_t = refract_ && ih > 0.0f && -oh > 0.0f;
    op_microfacet mr = main_lobe(r, an), mt = main_lobe((0.65f * eta - 0.35f) * r, an);
    op_v3 base = p->base_color, val = v3s(0.0f);
    float ct, f = op_fresnel_dielectric(ih, eta, &ct);
    if (st > 0.0f && compat_r) {
        float tint = p->v[OP_PR_SPEC_TINT];
        op_v3 ft = v3s(f * (1.0f - tint));
        if (tint > 0.0f)
            ft = v3_add(ft, v3_scale(schlick(v3_scale(tint_of(base), r0_of(eta)), ih, eta), tint));
        float g = op_mf_g1(&mr, wi, wh) * op_mf_g1(&mr, wo, wh);
        val = v3_add(val, v3_scale(ft, st * op_mf_d(&mr, wh) * g / (4.0f * ci)));
    }
    if (st > 0.0f && compat_t) {
        float g = op_mf_g1(&mt, wi, wh) * op_mf_g1(&mt, wo, wh);
        val = v3_add(val, v3_scale(base, st * (1.0f - f) * op_mf_d(&mt, wh) * g / (4.0f * ci)));
    }
    if (reflect_ && st < 1.0f && dt < 1.0f) {
        float cos_d = v3_dot(wh, wo), w = (1.0f - st) * (1.0f - dt);
        val = v3_add(val, v3_scale(base, w * co * OP_INV_PI * diffuse_shape(p, ci, co, cos_d)));
        if (p->v[OP_PR_SHEEN] > 0.0f)
            val = v3_add(val, v3_scale(sheen_lobe(p, co, cos_d), w));
    }
    if (refract_ && st < 1.0f && dt > 0.0f)
        val = v3_add(val, v3_scale(base, (1.0f - st) * dt * OP_INV_PI * -co));
    float psr = 0.5f * st * p->rate[0], pst = 0.5f * st * p->rate[1];
    float pdr = (1.0f - st) * (1.0f - dt) * p->rate[2], pdt = (1.0f - st) * dt * p->rate[3];
    float tot = psr + pst + pdr + pdt;
    if (!(tot > 0.0f))
        return val;
    float dwh = fabsf(1.0f / (4.0f * v3_dot(wr, wh))), sum = 0.0f;
    if (compat_r)
        sum += psr * op_mf_pdf(&mr, wi, wh) * dwh;
    if (compat_t)
        sum += pst * op_mf_pdf(&mt, wi, wh) * dwh;
    if (reflect_)
        sum += pdr * co * OP_INV_PI;
    if (refract_)
        sum += pdt * -co * OP_INV_PI;
    *pdf = sum / tot;
    return val;
}

op_v3 op_principled_eval(const op_principled *p, op_v3 wi, op_v3 wo, float *pdf)
{
    return p->thin ? eval_thin(p, wi, wo, pdf) : eval_full(p, wi, wo, pdf);
}

/* principled's direction: the lobe by u3 (rescaled within the main lobe to choose reflection
 * or transmission by its Fresnel term); 0 when it leaves on the wrong side. */
static int sample_full(const op_principled *p, op_v3 wi, float u1, float u2, float u3, op_v3 *wo)
{
    float met = p->v[OP_PR_METALLIC], st = p->v[OP_PR_SPEC_TRANS], cc = p->v[OP_PR_CLEARCOAT];
    float brdf = (1.0f - met) * (1.0f - st), bsdf = (1.0f - met) * st;
    int front = wi.z > 0.0f;
    if (wi.z == 0.0f || (!front && !(bsdf > 0.0f)))
        return 0;
    float pd = front ? brdf * p->rate[2] : 0.0f, pcc = front ? 0.25f * cc * p->rate[1] : 0.0f;
    float ps = front ? p->rate[0] : 1.0f, x = u3 * (pd + pcc + ps);
    if (x < pd) {
        *wo = op_sample_cosine(u1, u2);
        return 1;
    }
    if (x < pd + pcc || !(ps > 0.0f)) {
        op_v3 m = gtr1_sample(clearcoat_alpha(p->v[OP_PR_CLEARCOAT_GLOSS]), u1, u2);
        *wo = reflect(wi, m);
        return v3_dot(wi, m) > 0.0f && v3_dot(*wo, m) > 0.0f && wo->z > 0.0f;
    }
    float s = front ? 1.0f : -1.0f, eta = p->v[OP_PR_ETA];
    op_microfacet mf = main_lobe(p->v[OP_PR_ROUGHNESS], p->v[OP_PR_ANISOTROPIC]);
    op_v3 m = op_mf_sample(&mf, v3_scale(wi, s), u1, u2);
    float c = v3_dot(wi, m), ct, f = op_fresnel_dielectric(c, eta, &ct);
    float ptrans = (front ? bsdf : 1.0f) * (1.0f - f);
    float ur = fminf((x - pd - pcc) / ps, 1.0f);
    if (ur < ptrans) {
        float e = c >= 0.0f ? eta : 1.0f / eta;
        *wo = v3_add(v3_scale(wi, -1.0f / e), v3_scale(m, c / e - (c >= 0.0f ? ct : -ct)));
        return c * s > 0.0f && -v3_dot(*wo, m) * s > 0.0f && wi.z * wo->z < 0.0f;
    }
    *wo = reflect(wi, m);
    return c * s > 0.0f && v3_dot(*wo, m) * s > 0.0f && wi.z * wo->z > 0.0f;
}

/* principledthin's direction (wi brought to the upper side and the result back). */
static int sample_thin(const op_principled *p, op_v3 wi, float u1, float u2, float u3, op_v3 *wo)
{
    if (wi.z == 0.0f)
        return 0;
    float s = wi.z > 0.0f ? 1.0f : -1.0f;
    wi = v3_scale(wi, s);
    float st = p->v[OP_PR_SPEC_TRANS], dt = 0.5f * p->v[OP_PR_DIFF_TRANS];
    float psr = 0.5f * st * p->rate[0], pst = 0.5f * st * p->rate[1];
    float pdr = (1.0f - st) * (1.0f - dt) * p->rate[2], pdt = (1.0f - st) * dt * p->rate[3];
    float tot = psr + pst + pdr + pdt, x = u3 * tot;
    int ok = 1;
    if (!(tot > 0.0f))
        return 0;
    if (x < psr + pst) {
        float r = p->v[OP_PR_ROUGHNESS], an = p->v[OP_PR_ANISOTROPIC];
        int trans = x >= psr;
        op_microfacet mf = main_lobe(trans ? (0.65f * p->v[OP_PR_ETA] - 0.35f) * r : r, an);
        op_v3 m = op_mf_sample(&mf, wi, u1, u2);
        op_v3 w = reflect(wi, m);
        ok = v3_dot(wi, m) > 0.0f && w.z > 0.0f;
        if (trans) {
            w.z = -w.z;
            ok = ok && v3_dot(w, m) < 0.0f;
        } else {
            ok = ok && v3_dot(w, m) > 0.0f;
        }
        *wo = w;
    } else {
        *wo = op_sample_cosine(u1, u2);
        if (x >= psr + pst + pdr)
            wo->z = -wo->z;
    }
    *wo = v3_scale(*wo, s);
    return ok;
}

int op_principled_sample(const op_principled *p, op_v3 wi, float u1, float u2, float u3,
                         op_v3 *wo, op_v3 *weight, float *pdf)
{
    int ok = p->thin ? sample_thin(p, wi, u1, u2, u3, wo) : sample_full(p, wi, u1, u2, u3, wo);
    if (!ok)
        return 0;
    op_v3 f = op_principled_eval(p, wi, *wo, pdf);
    if (!(*pdf > 0.0f))
        return 0;
    *weight = v3_scale(f, 1.0f / *pdf);
    return 1;
}
