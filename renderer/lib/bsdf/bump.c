/* bump.c - bump and normal maps: the tilted shading frame (see bump.h). */
#include "bsdf/bump.h"

#include <string.h>

op_status op_bump_build(op_node *node, op_tex_cache *cache, op_bump *bump, op_node **inner,
                        op_error *err)
{
    memset(bump, 0, sizeof *bump);
    int normal = strcmp(node->type, "normalmap") == 0;
    int m3 = node->dialect == OP_DIALECT_MITSUBA_3;
    op_node *tex = NULL;
    *inner = NULL;
    for (int i = 0; i < node->nchildren; i++) {
        op_node *c = node->children[i];
        op_node **slot = strcmp(c->tag, "bsdf") == 0      ? inner
                         : strcmp(c->tag, "texture") == 0 ? &tex
                                                          : NULL;
        if (!slot)
            continue;
        if (*slot)
            return op_node_error(node, err, OP_ERR_INPUT, "takes one nested <%s>, not more",
                                 c->tag);
        *slot = c;
    }
    if (!*inner || !tex)
        return op_node_error(node, err, OP_ERR_INPUT, "needs a nested <bsdf> and a <texture> (%s)",
                             normal ? "the tangent-space normals" : "the height field");
    if (!m3 && strcmp(tex->type, "bitmap") == 0 && !op_node_has(tex, "gamma"))
        return op_node_error(tex, err, OP_ERR_INPUT, "as a %s, a bitmap states its gamma, as "
                             "Mitsuba 0.6 demands (<float name=\"gamma\" value=\"1\"/> for most "
                             "files)", normal ? "normal map" : "bump map");
    double scale = 1.0;
    if (!normal && m3)
        GET_OR_FAIL(op_node_float(node, "scale", 1.0, &scale, err));
    if (!isfinite(scale))
        return op_node_error(node, err, OP_ERR_INPUT, "scale must be finite");
    bump->flip_invalid = 0;
    bump->shadowing = 0;
    if (m3) {
        GET_OR_FAIL(op_node_bool(node, "flipInvalidNormals", 1, &bump->flip_invalid, err));
        GET_OR_FAIL(op_node_bool(node, "useShadowingFunction", 1, &bump->shadowing, err));
    }
    GET_OR_FAIL(op_texture_build(tex, cache, &bump->tex, err));
    bump->type = normal ? OP_BUMP_NORMAL : OP_BUMP_HEIGHT;
    bump->scale = (float)scale;
    bump->needs_uv = !m3;
    return OP_OK;
}

op_frame op_frame_from_tangent(op_v3 ns, op_v3 dpdu)
{
    op_v3 s = v3_sub(dpdu, v3_scale(ns, v3_dot(ns, dpdu)));
    float len = v3_len(s);
    if (!(len > 1e-20f) || !isfinite(len))
        return op_frame_from_normal(ns);
    op_frame f;
    f.n = ns;
    f.s = v3_scale(s, 1.0f / len);
    f.t = v3_cross(ns, f.s);
    return f;
}

/* The frame around the tilted normal n (unit, world) whose s follows dpdu, with Mitsuba 3's
 * mirroring of a normal that wi sees from the other side than the untilted one. */
static op_frame tilted(const op_bump *b, const op_frame *sh, op_v3 n, op_v3 dpdu, op_v3 wi)
{
    op_v3 nl = op_frame_to_local(sh, n), wl = op_frame_to_local(sh, wi);
    if (b->flip_invalid && wl.z * v3_dot(wl, nl) <= 0.0f)
        n = op_frame_to_world(sh, v3(-nl.x, -nl.y, nl.z));
    return op_frame_from_tangent(n, dpdu);
}

op_frame op_bump_frame(const op_bump *b, const op_frame *sh, op_v3 ng, op_v3 dpdu, op_v3 dpdv,
                       float u, float v, op_v3 wi)
{
    if (b->type == OP_BUMP_NORMAL) {
        op_v3 c = op_texture_eval(&b->tex, u, v);
        op_v3 n = op_frame_to_world(sh, v3(2.0f * c.x - 1.0f, 2.0f * c.y - 1.0f,
                                           2.0f * c.z - 1.0f));
        float len = v3_len(n);
        if (!(len > 1e-6f))
            return *sh;
        return tilted(b, sh, v3_scale(n, 1.0f / len), sh->s, wi);
    }
    if (b->type != OP_BUMP_HEIGHT)
        return *sh;
    float gu, gv;
    op_texture_lum_grad(&b->tex, u, v, &gu, &gv);
    op_v3 du = v3_add(dpdu, v3_scale(sh->n, b->scale * gu - v3_dot(sh->n, dpdu)));
    op_v3 dv = v3_add(dpdv, v3_scale(sh->n, b->scale * gv - v3_dot(sh->n, dpdv)));
    op_v3 n = v3_cross(du, dv);
    float len = v3_len(n);
    if (!(len > 1e-30f) || !isfinite(len))
        return *sh;
    n = v3_scale(n, 1.0f / len);
    if (v3_dot(n, ng) < 0.0f)
        n = v3_neg(n);
    return tilted(b, sh, n, dpdu, wi);
}
