/* subsurface_desc.c - a shape's <subsurface> (see subsurface_desc.h). */
#include "scene/subsurface_desc.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "opaline_render.h"
#include "scene/material_name.h"

/* The homogeneous dipole: a named medium or explicit coefficients, turned into coefficients per
 * scene unit. With sceneUnitsPerMetre (opaline's meaning) the table and explicit coefficients
 * are in 1/mm: per scene unit x 1000 / sceneUnitsPerMetre. Without it, Mitsuba's meaning
 * (0.6 and 3 alike): explicit coefficients are per scene unit and the table's entries x 100,
 * all multiplied by `scale` (default 1). Both given is an error. */
static op_status build_dipole(op_node *node, op_sss_desc *d, op_error *err)
{
    const char *name;
    double sa[3], ss[3], g = 0.0, eta = 1.5046, ext, in;
    int explicit_ss = op_node_has(node, "sigmaA") || op_node_has(node, "sigmaS");
    int explicit_ta = op_node_has(node, "sigmaT") || op_node_has(node, "albedo");
    GET_OR_FAIL(op_node_string(node, "material", NULL, &name, err));
    if ((explicit_ss && explicit_ta) || ((explicit_ss || explicit_ta) && name))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <subsurface type=\"dipole\">: give either "
                            "a material, or sigmaA and sigmaS, or sigmaT and albedo", node->file,
                            node->line);
    if (explicit_ss) {
        GET_OR_FAIL(op_node_color(node, "sigmaA", NULL, sa, err));
        GET_OR_FAIL(op_node_color(node, "sigmaS", NULL, ss, err));
    } else if (explicit_ta) {
        double st[3], al[3];
        GET_OR_FAIL(op_node_color(node, "sigmaT", NULL, st, err));
        GET_OR_FAIL(op_node_color(node, "albedo", NULL, al, err));
        for (int c = 0; c < 3; c++) {
            if (!(al[c] >= 0.0 && al[c] <= 1.0))
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <subsurface type=\"dipole\">: "
                                    "albedo %g is not in [0, 1]", node->file, node->line, al[c]);
            ss[c] = al[c] * st[c];
            sa[c] = st[c] - ss[c];
        }
    } else {
        if (!name)
            name = "Skin1";
        if (!op_sss_dipole_lookup(name, ss, sa, &eta))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <subsurface type=\"dipole\">: unknown "
                                "material \"%s\" (%s; or give sigmaA and sigmaS)", node->file,
                                node->line, name, op_sss_dipole_names());
    }
    if (explicit_ss || explicit_ta) {
        GET_OR_FAIL(op_node_float(node, "g", 0.0, &g, err));
        if (!(g > -1.0 && g < 1.0))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <subsurface type=\"dipole\">: g %g must "
                                "be in (-1, 1)", node->file, node->line, g);
    }
    GET_OR_FAIL(op_node_float(node, "intIOR", eta, &in, err));
    GET_OR_FAIL(op_node_float(node, "extIOR", 1.0, &ext, err));
    eta = ext > 0.0 ? in / ext : 0.0;
    if (!(eta >= 1.0 && eta <= 3.0))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <subsurface type=\"dipole\">: intIOR / "
                            "extIOR = %g must be in [1, 3] (the dipole's boundary fit)",
                            node->file, node->line, eta);
    double per_unit;
    if (d->units_given) {
        per_unit = 1000.0 / d->scale; /* 1/mm -> 1/scene unit */
    } else {
        double mult;
        GET_OR_FAIL(op_node_float(node, "scale", 1.0, &mult, err));
        if (!(mult > 0.0 && mult < 1e9))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <subsurface type=\"dipole\">: scale "
                                "%g must be > 0", node->file, node->line, mult);
        per_unit = (explicit_ss || explicit_ta ? 1.0 : 100.0) * mult;
        d->scale = 1000.0 / per_unit; /* the same coefficients, as sceneUnitsPerMetre */
    }
    d->is_dipole = 1;
    d->dipole.eta = eta;
    double alb[3];
    for (int c = 0; c < 3; c++) {
        if (!(sa[c] >= 0.0 && ss[c] >= 0.0 && isfinite(sa[c]) && isfinite(ss[c]) &&
              sa[c] + ss[c] * (1.0 - g) > 0.0))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <subsurface type=\"dipole\">: channel "
                                "%d: sigmaA %g and sigmaS %g must be >= 0, finite, and not both 0",
                                node->file, node->line, c, sa[c], ss[c]);
        d->dipole.sigma_a[c] = sa[c] * per_unit;
        d->dipole.sigma_sp[c] = ss[c] * (1.0 - g) * per_unit;
        alb[c] = fmin(op_sss_dipole_total(&d->dipole, c), 1.0);
    }
    d->albedo_mean = v3((float)alb[0], (float)alb[1], (float)alb[2]);
    return OP_OK;
}

op_status op_subsurface_read(op_node *node, const char *scene_dir, const op_scene_limits *lim,
                             op_sss_desc *d, op_subsurface_spec *spec, op_error *err)
{
    node->used = 1;
    memset(d, 0, sizeof *d);
    memset(spec, 0, sizeof *spec);
    const char *t = node->type;
    char low[32];
    size_t nl = 0;
    for (; t[nl] && nl + 1 < sizeof low; nl++)
        low[nl] = (char)(t[nl] >= 'A' && t[nl] <= 'Z' ? t[nl] - 'A' + 'a' : t[nl]);
    low[nl] = '\0';
    int dipole = strcmp(low, "dipole") == 0;
    op_method want = op_method_from_name(low);
    if (!dipole && want == OP_METHOD_COUNT) {
        char types[128] = "";
        for (int m = 0; m < OP_METHOD_COUNT; m++)
            snprintf(types + strlen(types), sizeof types - strlen(types), "%s, ",
                     op_method_name((op_method)m));
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <subsurface type=\"%s\">: unknown type "
                            "(%sdipole)", node->file, node->line, t, types);
    }
    const char *name = NULL;
    long long irr, maxp;
    /* sceneUnitsPerMetre is opaline's; on a measured material (no Mitsuba meaning to clash
     * with) scale is read as it, as files written before it had its own name say */
    d->units_given = op_node_has(node, "sceneUnitsPerMetre");
    if (d->units_given && op_node_has(node, "scale"))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <subsurface type=\"%s\">: give either "
                            "sceneUnitsPerMetre (scene units per metre of material) or scale (%s), "
                            "not both", node->file, node->line, t, dipole ? "Mitsuba's "
                            "multiplier of the coefficients" : "its older name");
    if (!dipole && !d->units_given && op_node_has(node, "scale")) {
        GET_OR_FAIL(op_node_float(node, "scale", 1.0, &d->scale, err));
        op_log(OP_LOG_WARN, "%s:%d: <subsurface type=\"%s\">: scale is read as "
               "sceneUnitsPerMetre, its name now (on a dipole, scale means Mitsuba's multiplier "
               "of the coefficients)", node->file, node->line, t);
    } else {
        GET_OR_FAIL(op_node_float(node, "sceneUnitsPerMetre", 1.0, &d->scale, err));
    }
    GET_OR_FAIL(op_node_int(node, "irrSamples", 16, &irr, err));
    GET_OR_FAIL(op_node_float(node, "density", 1.0, &d->density, err));
    GET_OR_FAIL(op_node_int(node, "maxPoints", lim->sss_max_points, &maxp, err));
    if (!(d->scale > 0.0 && d->scale < 1e9))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <subsurface>: sceneUnitsPerMetre %g must be > 0",
                            node->file, node->line, d->scale);
    if (irr < 1 || irr > 65536 || maxp < 1 || maxp > 50000000 ||
        !(d->density > 0.0 && d->density <= 64.0))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <subsurface>: need irrSamples in 1..65536, "
                            "maxPoints in 1..5e7, density in (0, 64]", node->file, node->line);
    d->irr_samples = (int)irr;
    d->max_points = (int)maxp;
    spec->method = want;
    if (dipole)
        return build_dipole(node, d, err);
    GET_OR_FAIL(op_node_string(node, "material", NULL, &name, err));
    if (!name)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <subsurface type=\"%s\"> needs <string "
                            "name=\"material\">", node->file, node->line, t);
    /* the plugin's long names ("SVD S10 Div100 Add1 for Rd Chess4x4 ...") name a preset */
    spec->name = name;
    spec->long_method = OP_METHOD_COUNT;
    spec->is_long = op_parse_long_material_name(name, spec->preset, sizeof spec->preset,
                                                &spec->long_method, &spec->log_a, &spec->log_b);
    if (op_find_material(spec->is_long ? spec->preset : name, scene_dir, NULL, NULL, spec->path,
                         sizeof spec->path, err))
        return op_subsurface_error(node, spec, err);
    return OP_OK;
}

op_status op_subsurface_error(const op_node *node, const op_subsurface_spec *spec, op_error *err)
{
    if (spec->is_long)
        return op_error_prefix(err, "%s:%d: <subsurface>: \"%s\" names preset %s: ", node->file,
                               node->line, spec->name, spec->preset);
    return op_error_prefix(err, "%s:%d: <subsurface>: ", node->file, node->line);
}

op_status op_subsurface_bind(const op_node *node, const op_subsurface_spec *spec,
                             const op_scene_limits *lim, op_sss_desc *d, op_error *err)
{
    const char *t = node->type, *path = spec->path, *name = spec->name, *preset = spec->preset;
    op_method want = spec->method, long_method = spec->long_method;
    double log_a = spec->log_a, log_b = spec->log_b;
    int is_long = spec->is_long;
    op_status st;
    const op_material_info *info = op_material_get_info(d->material);
    if (info->kernel > lim->kernel)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <subsurface>: %s has kernel size %d, over "
                            "the limit of %d (kernel; the pre-pass costs K^2 per irradiance point; "
                            "raise it with --limit kernel=VALUE)", node->file, node->line, path,
                            info->kernel, lim->kernel);
    if (info->method != want)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <subsurface type=\"%s\">: %s holds a %s "
                            "material (its META says method=%s): the type must agree with it",
                            node->file, node->line, t, path, op_method_name(info->method),
                            op_method_name(info->method));
    if (is_long) {
        if (long_method != info->method)
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <subsurface>: \"%s\" names a %s "
                                "material, but %s holds a %s material", node->file, node->line,
                                name, op_method_name(long_method), path,
                                op_method_name(info->method));
        if ((log_a > 0.0 && fabs(log_a - info->log_a) > 1e-9 * fabs(log_a)) ||
            (log_b > 0.0 && fabs(log_b - info->log_b) > 1e-9 * fabs(log_b)))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <subsurface>: \"%s\" asks for Div%g "
                                "Add%g (A = %g, B = %g) but %s was made with A = %g, B = %g",
                                node->file, node->line, name, log_a, log_b, log_a, log_b, path,
                                info->log_a, info->log_b);
        op_log(OP_LOG_DEBUG, "%s:%d: material \"%s\" is preset %s (%s)", node->file, node->line,
               name, preset, path);
    }
    size_t px = (size_t)info->width * (size_t)info->height;
    float *alb = malloc(px * (size_t)info->channels * sizeof(float));
    if (!alb)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    st = op_material_albedo_map(d->material, alb, err);
    if (st) {
        free(alb);
        return st;
    }
    double mean[3] = {0, 0, 0};
    for (int c = 0; c < info->channels; c++) {
        for (size_t i = 0; i < px; i++)
            mean[c] += alb[(size_t)c * px + i];
        mean[c] /= (double)px;
    }
    free(alb);
    if (info->channels == 1)
        mean[1] = mean[2] = mean[0];
    d->albedo_mean = v3((float)fmin(mean[0], 1.0), (float)fmin(mean[1], 1.0),
                        (float)fmin(mean[2], 1.0));
    return OP_OK;
}

