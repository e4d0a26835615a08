/* phong.c - Mitsuba 0.6's modified Phong BRDF (see phong.h). */
#include "bsdf/phong.h"

op_status op_phong_build(op_node *node, op_tex_cache *cache, op_phong *p, op_error *err)
{
    GET_OR_FAIL(op_diffuse_glossy_build(node, cache, &p->dg, err));
    p->exponent_tex = (op_texture){0};
    op_node *t = op_texture_child(node, "exponent");
    if (t) {
        if (op_node_has(node, "exponent"))
            return op_node_error(node, err, OP_ERR_INPUT, "exponent is given both as a number "
                                 "and as a texture");
        if (!cache)
            return op_node_error(node, err, OP_ERR_INTERNAL, "no texture cache");
        GET_OR_FAIL(op_texture_build_value(t, cache, 1e30, &p->exponent_tex, err));
        p->exponent = 30.0f;
        return OP_OK;
    }
    double n;
    GET_OR_FAIL(op_node_float(node, "exponent", 30.0, &n, err));
    if (!(n >= 0.0 && n < 1e6))
        return op_node_error(node, err, OP_ERR_INPUT, "exponent %g is not in [0, 1e6)", n);
    p->exponent = (float)n;
    return OP_OK;
}

int op_phong_textured(const op_phong *p)
{
    return p->exponent_tex.type != OP_TEX_NONE || op_diffuse_glossy_textured(&p->dg);
}

void op_phong_at(const op_phong *p, float u, float v, op_phong *out)
{
    *out = *p;
    op_diffuse_glossy_at(&p->dg, u, v, &out->dg);
    if (p->exponent_tex.type != OP_TEX_NONE)
        out->exponent = fmaxf(op_texture_eval_value(&p->exponent_tex, u, v), 0.0f);
}

op_v3 op_phong_eval(const op_phong *p, op_v3 wi, op_v3 wo, float *pdf)
{
    /* cos alpha: wo against the mirror direction of wi */
    float c = -wi.x * wo.x - wi.y * wo.y + wi.z * wo.z, lobe = 0.0f;
    if (c > 0.0f)
        lobe = powf(c, p->exponent) * (0.5f * OP_INV_PI);
    return op_diffuse_glossy_mix(&p->dg, wo, (p->exponent + 2.0f) * lobe * wo.z,
                                 (p->exponent + 1.0f) * lobe, pdf);
}

op_v3 op_phong_sample(const op_phong *p, op_v3 wi, float u1, float u2, float u3)
{
    if (u3 >= p->dg.glossy_prob)
        return op_sample_cosine(u1, u2);
    float c = powf(u1, 1.0f / (p->exponent + 1.0f));
    float s = sqrtf(fmaxf(0.0f, 1.0f - c * c)), phi = 2.0f * OP_PI * u2;
    op_frame f = op_frame_from_normal(v3(-wi.x, -wi.y, wi.z));
    return op_frame_to_world(&f, v3(s * cosf(phi), s * sinf(phi), c));
}
