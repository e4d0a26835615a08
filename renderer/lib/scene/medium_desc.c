/* medium_desc.c - a scene's <medium> (see medium_desc.h). */
#include "scene/medium_desc.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "opaline.h"

/* Reads the <phase> nested in medium node n (none: isotropic). */
static op_status read_phase(op_node *n, op_phase *p, op_error *err)
{
    p->type = OP_PHASE_ISOTROPIC;
    p->g = 0.0f;
    op_node *ph = op_node_child(n, "phase", 0);
    if (!ph)
        return OP_OK;
    ph->used = 1;
    if (op_node_child(n, "phase", 1))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <medium>: more than one <phase>", n->file,
                            n->line);
    if (strcmp(ph->type, "isotropic") == 0)
        return OP_OK;
    if (strcmp(ph->type, "hg") != 0)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <phase type=\"%s\">: unknown phase "
                            "function (opaline reads isotropic and hg)", ph->file, ph->line,
                            ph->type);
    double g;
    GET_OR_FAIL(op_node_float(ph, "g", 0.8, &g, err));
    if (!(g > -1.0 && g < 1.0))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <phase type=\"hg\">: g %g must be in "
                            "(-1, 1)", ph->file, ph->line, g);
    p->type = OP_PHASE_HG;
    p->g = (float)g;
    return OP_OK;
}

/* Coefficients: sigmaA and sigmaS, or sigmaT and albedo (per scene unit), or a `material` of
 * libopaline's media table (1/mm, reduced scattering taken as sigmaS) x 100 as Mitsuba 0.6
 * reads its presets; nothing given: Mitsuba 0.6's Skin1, Mitsuba 3's sigma_t 1 and albedo 0.75.
 * All times `scale`. */
op_status op_medium_read(op_node *node, op_pmedium *m, op_error *err)
{
    node->used = 1;
    memset(m, 0, sizeof *m);
    snprintf(m->label, sizeof m->label, "%s:%d", node->file, node->line);
    if (strcmp(node->type, "homogeneous") != 0)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <medium type=\"%s\"> is not supported "
                            "(opaline renders homogeneous media)", node->file, node->line,
                            node->type);
    const char *name;
    double sa[3], ss[3], scale;
    int explicit_ss = op_node_has(node, "sigmaA") || op_node_has(node, "sigmaS");
    int explicit_ta = op_node_has(node, "sigmaT") || op_node_has(node, "albedo");
    GET_OR_FAIL(op_node_string(node, "material", NULL, &name, err));
    if ((explicit_ss && explicit_ta) || ((explicit_ss || explicit_ta) && name))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <medium type=\"homogeneous\">: give either "
                            "a material, or sigmaA and sigmaS, or sigmaT and albedo", node->file,
                            node->line);
    int m3 = node->dialect == OP_DIALECT_MITSUBA_3;
    if (explicit_ss) {
        double zero[3] = {0, 0, 0};
        GET_OR_FAIL(op_node_color(node, "sigmaA", zero, sa, err));
        GET_OR_FAIL(op_node_color(node, "sigmaS", zero, ss, err));
    } else if (explicit_ta || (m3 && !name)) {
        double st[3], al[3], one[3] = {1, 1, 1}, a75[3] = {0.75, 0.75, 0.75};
        GET_OR_FAIL(op_node_color(node, "sigmaT", one, st, err));
        GET_OR_FAIL(op_node_color(node, "albedo", a75, al, err));
        for (int c = 0; c < 3; c++) {
            if (!(al[c] >= 0.0 && al[c] <= 1.0))
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <medium type=\"homogeneous\">: "
                                    "albedo %g is not in [0, 1]", node->file, node->line, al[c]);
            ss[c] = al[c] * st[c];
            sa[c] = st[c] - ss[c];
        }
    } else {
        const op_medium *t = op_medium_lookup(name ? name : "Skin1");
        if (!t)
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <medium type=\"homogeneous\">: unknown "
                                "material \"%s\" (%s; or give sigmaA and sigmaS)", node->file,
                                node->line, name, op_medium_names());
        for (int c = 0; c < 3; c++) {
            ss[c] = 100.0 * t->sigma_s[c];
            sa[c] = 100.0 * t->sigma_a[c];
        }
    }
    GET_OR_FAIL(op_node_float(node, "scale", 1.0, &scale, err));
    if (!(scale >= 0.0 && scale < 1e12))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <medium type=\"homogeneous\">: scale %g "
                            "must be >= 0", node->file, node->line, scale);
    for (int c = 0; c < 3; c++) {
        sa[c] *= scale;
        ss[c] *= scale;
        if (!(sa[c] >= 0.0 && ss[c] >= 0.0 && isfinite(sa[c] + ss[c]) && sa[c] + ss[c] < 1e30))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <medium type=\"homogeneous\">: "
                                "channel %d: sigmaA %g and sigmaS %g must be >= 0 and finite",
                                node->file, node->line, c, sa[c], ss[c]);
    }
    m->sigma_a = v3_from_d(sa);
    m->sigma_s = v3_from_d(ss);
    m->sigma_t = v3_add(m->sigma_a, m->sigma_s);
    return read_phase(node, &m->phase, err);
}
