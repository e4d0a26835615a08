/* diffuse_glossy.c - the diffuse and glossy weights of phong and ward (see diffuse_glossy.h). */
#include "bsdf/diffuse_glossy.h"

#include <string.h>

/* Mitsuba's luminance of linear sRGB. */
static float luminance(op_v3 c)
{
    return 0.212671f * c.x + 0.715160f * c.y + 0.072169f * c.z;
}

/* Weight name as a colour (negative channels raised to 0 with a warning) or a texture; *max
 * and *mean: its maximum and mean over the surface. */
static op_status read_weight(op_node *n, const char *name, double def, op_tex_cache *cache,
                             op_v3 *c, op_texture *tex, op_v3 *max, op_v3 *mean, op_error *err)
{
    op_node *t = op_texture_child(n, name);
    if (t) {
        if (op_node_has(n, name))
            return op_node_error(n, err, OP_ERR_INPUT, "%s is given both as a colour and as a "
                                 "texture", name);
        if (!cache)
            return op_node_error(n, err, OP_ERR_INTERNAL, "no texture cache");
        GET_OR_FAIL(op_texture_build(t, cache, tex, err));
        op_texture_stats(tex, max, mean);
        *c = *mean;
        return OP_OK;
    }
    double d[3] = {def, def, def}, v[3];
    GET_OR_FAIL(op_node_color(n, name, d, v, err));
    if (!(v[0] >= 0.0 && v[1] >= 0.0 && v[2] >= 0.0)) {
        op_log(OP_LOG_WARN, "%s:%d: <bsdf type=\"%s\">: negative %s raised to 0", n->file,
               n->line, n->type, name);
        for (int k = 0; k < 3; k++)
            v[k] = v[k] >= 0.0 ? v[k] : 0.0;
    }
    *c = *max = *mean = v3_from_d(v);
    return OP_OK;
}

op_status op_diffuse_glossy_build(op_node *node, op_tex_cache *cache, op_diffuse_glossy *dg,
                                  op_error *err)
{
    memset(dg, 0, sizeof *dg);
    op_v3 dmax, dmean, smax, smean;
    GET_OR_FAIL(read_weight(node, "diffuseReflectance", 0.5, cache, &dg->diffuse,
                            &dg->diffuse_tex, &dmax, &dmean, err));
    GET_OR_FAIL(read_weight(node, "specularReflectance", 0.2, cache, &dg->specular,
                            &dg->specular_tex, &smax, &smean, err));
    int conserve;
    GET_OR_FAIL(op_node_bool(node, "ensureEnergyConservation", 1, &conserve, err));
    float top = v3_max(v3_add(dmax, smax));
    dg->scale = 1.0f;
    if (conserve && top > 1.0f) {
        dg->scale = 0.99f / top;
        op_log(OP_LOG_WARN, "%s:%d: <bsdf type=\"%s\">: diffuseReflectance and "
               "specularReflectance add up to %g; both scaled by %g (as Mitsuba does)",
               node->file, node->line, node->type, (double)top, (double)dg->scale);
        dg->diffuse = v3_scale(dg->diffuse, dg->scale);
        dg->specular = v3_scale(dg->specular, dg->scale);
    }
    float ld = luminance(dmean), ls = luminance(smean);
    dg->glossy_prob = ld + ls > 0.0f ? ls / (ld + ls) : 0.0f;
    return OP_OK;
}

int op_diffuse_glossy_textured(const op_diffuse_glossy *dg)
{
    return dg->diffuse_tex.type != OP_TEX_NONE || dg->specular_tex.type != OP_TEX_NONE;
}

void op_diffuse_glossy_at(const op_diffuse_glossy *dg, float u, float v, op_diffuse_glossy *out)
{
    *out = *dg;
    if (dg->diffuse_tex.type != OP_TEX_NONE)
        out->diffuse = v3_scale(op_texture_eval(&dg->diffuse_tex, u, v), dg->scale);
    if (dg->specular_tex.type != OP_TEX_NONE)
        out->specular = v3_scale(op_texture_eval(&dg->specular_tex, u, v), dg->scale);
}

op_v3 op_diffuse_glossy_mix(const op_diffuse_glossy *dg, op_v3 wo, float glossy_f,
                            float glossy_pdf, float *pdf)
{
    float cosine = wo.z * OP_INV_PI;
    *pdf = dg->glossy_prob * glossy_pdf + (1.0f - dg->glossy_prob) * cosine;
    return v3_add(v3_scale(dg->diffuse, cosine), v3_scale(dg->specular, glossy_f));
}
