/* ward.c - Mitsuba 0.6's Ward BRDF and its variants (see ward.h). */
#include "bsdf/ward.h"

#include <string.h>
#include <strings.h>

op_status op_ward_build(op_node *node, op_tex_cache *cache, op_ward *w, op_error *err)
{
    static const char *const names[2] = {"alphaU", "alphaV"};
    GET_OR_FAIL(op_diffuse_glossy_build(node, cache, &w->dg, err));
    const char *variant;
    GET_OR_FAIL(op_node_string(node, "variant", "balanced", &variant, err));
    if (strcasecmp(variant, "ward") == 0)
        w->variant = OP_WARD_ORIGINAL;
    else if (strcasecmp(variant, "ward-duer") == 0)
        w->variant = OP_WARD_DUER;
    else if (strcasecmp(variant, "balanced") == 0)
        w->variant = OP_WARD_BALANCED;
    else
        return op_node_error(node, err, OP_ERR_INPUT, "unknown variant \"%s\" (ward, ward-duer, "
                             "balanced)", variant);
    double alpha, a[2];
    GET_OR_FAIL(op_node_float(node, "alpha", 0.1, &alpha, err));
    for (int k = 0; k < 2; k++) {
        w->alpha_tex[k] = (op_texture){0};
        op_node *t = op_texture_child(node, names[k]);
        if (t) {
            if (op_node_has(node, names[k]))
                return op_node_error(node, err, OP_ERR_INPUT, "%s is given both as a number and "
                                     "as a texture", names[k]);
            if (!cache)
                return op_node_error(node, err, OP_ERR_INTERNAL, "no texture cache");
            GET_OR_FAIL(op_texture_build_value(t, cache, 1e30, &w->alpha_tex[k], err));
        }
        GET_OR_FAIL(op_node_float(node, names[k], alpha, &a[k], err));
        if (!(a[k] > 0.0 && a[k] < 1e6))
            return op_node_error(node, err, OP_ERR_INPUT, "%s %g is not in (0, 1e6)", names[k],
                                 a[k]);
    }
    w->alpha_u = (float)fmax(a[0], 1e-4);
    w->alpha_v = (float)fmax(a[1], 1e-4);
    return OP_OK;
}

int op_ward_textured(const op_ward *w)
{
    return w->alpha_tex[0].type != OP_TEX_NONE || w->alpha_tex[1].type != OP_TEX_NONE ||
           op_diffuse_glossy_textured(&w->dg);
}

int op_ward_is_anisotropic(const op_ward *w)
{
    return w->alpha_u != w->alpha_v || w->alpha_tex[0].type != OP_TEX_NONE ||
           w->alpha_tex[1].type != OP_TEX_NONE;
}

void op_ward_at(const op_ward *w, float u, float v, op_ward *out)
{
    *out = *w;
    op_diffuse_glossy_at(&w->dg, u, v, &out->dg);
    if (w->alpha_tex[0].type != OP_TEX_NONE)
        out->alpha_u = fmaxf(op_texture_eval_value(&w->alpha_tex[0], u, v), 1e-4f);
    if (w->alpha_tex[1].type != OP_TEX_NONE)
        out->alpha_v = fmaxf(op_texture_eval_value(&w->alpha_tex[1], u, v), 1e-4f);
}

/* exp(-((h.x / alphaU)^2 + (h.y / alphaV)^2) / h.z^2) for a half vector h of any length. */
static float ward_exp(const op_ward *w, op_v3 h)
{
    float x = h.x / w->alpha_u, y = h.y / w->alpha_v;
    return expf(-(x * x + y * y) / (h.z * h.z));
}

op_v3 op_ward_eval(const op_ward *w, op_v3 wi, op_v3 wo, float *pdf)
{
    op_v3 h = v3_add(wi, wo);
    float e = ward_exp(w, h), auv = w->alpha_u * w->alpha_v, lobe;
    switch (w->variant) {
    case OP_WARD_ORIGINAL:
        lobe = e / (4.0f * OP_PI * auv * sqrtf(wi.z * wo.z));
        break;
    case OP_WARD_DUER:
        lobe = e / (4.0f * OP_PI * auv * wi.z * wo.z);
        break;
    default: {
        float hz2 = h.z * h.z;
        lobe = e * v3_dot(h, h) / (OP_PI * auv * hz2 * hz2);
        break;
    }
    }
    /* the density of the half vector's sampling, reflected */
    op_v3 hn = v3_norm(h);
    float glossy_pdf = e / (4.0f * OP_PI * auv * v3_dot(hn, wi) * hn.z * hn.z * hn.z);
    return op_diffuse_glossy_mix(&w->dg, wo, lobe * wo.z, glossy_pdf, pdf);
}

op_v3 op_ward_sample(const op_ward *w, op_v3 wi, float u1, float u2, float u3)
{
    if (u3 >= w->dg.glossy_prob)
        return op_sample_cosine(u1, u2);
    float a = 2.0f * OP_PI * u2;
    float phi = atan2f(w->alpha_v * sinf(a), w->alpha_u * cosf(a));
    float cp = cosf(phi), sp = sinf(phi);
    float k = cp * cp / (w->alpha_u * w->alpha_u) + sp * sp / (w->alpha_v * w->alpha_v);
    float tan2 = -logf(1.0f - u1) / k;
    float ct = 1.0f / sqrtf(1.0f + tan2), st = sqrtf(fmaxf(0.0f, 1.0f - ct * ct));
    op_v3 h = v3(st * cp, st * sp, ct);
    return v3_sub(v3_scale(h, 2.0f * v3_dot(wi, h)), wi);
}
