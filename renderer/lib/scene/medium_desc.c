/* medium_desc.c - a scene's <medium> (see medium_desc.h). */
#include "scene/medium_desc.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "opaline.h"

/* The types read_phase and op_medium_read render. */
static const char *const phase_types[] = {"isotropic", "hg", "rayleigh", NULL};
static const char *const medium_types[] = {"homogeneous", "heterogeneous", NULL};

int op_phase_type_known(const char *type) { return op_name_listed(phase_types, type); }
int op_medium_type_known(const char *type) { return op_name_listed(medium_types, type); }

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
    if (strcmp(ph->type, "rayleigh") == 0) {
        p->type = OP_PHASE_RAYLEIGH;
        return OP_OK;
    }
    char names[64];
    if (strcmp(ph->type, "hg") != 0)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <phase type=\"%s\">: unknown phase "
                            "function (opaline reads %s)", ph->file, ph->line, ph->type,
                            op_names_join(phase_types, names, sizeof names));
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
static op_status read_homogeneous(op_node *node, op_pmedium *m, op_error *err)
{
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

/* The world -> unit cube map of a volume node: the inverse of its toWorld, then, where the
 * grid's own box places it (Mitsuba 0.6 always, Mitsuba 3 with use_grid_bbox), that box onto
 * the cube. */
static op_status volume_map(op_node *vn, const op_volume *v, int grid_box, op_matrix4 *out,
                            op_error *err)
{
    op_matrix4 to_world, inv;
    GET_OR_FAIL(op_node_transform(vn, "toWorld", &to_world, err));
    if (!op_matrix4_inverse(&to_world, &inv))
        return op_node_error(vn, err, OP_ERR_INPUT, "toWorld is not invertible");
    *out = inv;
    if (!grid_box)
        return OP_OK;
    double lo[3], hi[3];
    op_volume_file_bbox(v, lo, hi);
    if (vn->dialect != OP_DIALECT_MITSUBA_3 && op_node_has(vn, "min"))
        GET_OR_FAIL(op_node_vec3(vn, "min", lo, lo, err));
    if (vn->dialect != OP_DIALECT_MITSUBA_3 && op_node_has(vn, "max"))
        GET_OR_FAIL(op_node_vec3(vn, "max", hi, hi, err));
    for (int a = 0; a < 3; a++)
        if (!(isfinite(lo[a]) && isfinite(hi[a]) && hi[a] > lo[a]))
            return op_node_error(vn, err, OP_ERR_INPUT, "the grid's bounding box (%g, %g, %g) - "
                                 "(%g, %g, %g) is empty or not finite", lo[0], lo[1], lo[2],
                                 hi[0], hi[1], hi[2]);
    op_matrix4 t = op_matrix4_translate(-lo[0], -lo[1], -lo[2]);
    op_matrix4 sc =
        op_matrix4_scale(1.0 / (hi[0] - lo[0]), 1.0 / (hi[1] - lo[1]), 1.0 / (hi[2] - lo[2]));
    op_matrix4 box = op_matrix4_mul(&sc, &t);
    *out = op_matrix4_mul(&box, &inv);
    return OP_OK;
}

/* A nested <volume>: gridvolume (a .vol file) or constvolume (value). bounded: 0 outside its
 * cube (Mitsuba 3's extinction, which bounds the medium). */
static op_status read_volume_node(op_node *vn, int bounded, op_volume **out, op_error *err)
{
    vn->used = 1;
    int m3 = vn->dialect == OP_DIALECT_MITSUBA_3, grid_box = !m3;
    op_volume *v = NULL;
    if (strcmp(vn->type, "constvolume") == 0) {
        double one[3] = {1, 1, 1}, val[3];
        GET_OR_FAIL(op_node_color(vn, "value", one, val, err));
        v = op_volume_constant(v3_from_d(val));
        if (!v)
            return op_error_set(err, OP_ERR_NOMEM, "out of memory");
        grid_box = 0;
        bounded = bounded && m3;
    } else if (strcmp(vn->type, "gridvolume") == 0) {
        const char *file, *filter, *wrap;
        op_volume_filter filter_mode = OP_VOLUME_TRILINEAR;
        op_volume_wrap wrap_mode = OP_VOLUME_CLAMP;
        GET_OR_FAIL(op_node_string(vn, "filename", NULL, &file, err));
        if (!file)
            return op_node_error(vn, err, OP_ERR_INPUT, "no filename");
        if (m3) {
            int raw, accel;
            GET_OR_FAIL(op_node_bool(vn, "useGridBbox", 0, &grid_box, err));
            GET_OR_FAIL(op_node_bool(vn, "raw", 0, &raw, err)); /* RGB: no conversion either way */
            GET_OR_FAIL(op_node_bool(vn, "accel", 1, &accel, err));
            GET_OR_FAIL(op_node_string(vn, "filterType", "trilinear", &filter, err));
            GET_OR_FAIL(op_node_string(vn, "wrapMode", "clamp", &wrap, err));
            if (strcmp(filter, "trilinear") == 0)
                filter_mode = OP_VOLUME_TRILINEAR;
            else if (strcmp(filter, "nearest") == 0)
                filter_mode = OP_VOLUME_NEAREST;
            else
                return op_node_error(vn, err, OP_ERR_INPUT, "filter_type \"%s\": not "
                                     "\"trilinear\" or \"nearest\"", filter);
            if (strcmp(wrap, "clamp") == 0)
                wrap_mode = OP_VOLUME_CLAMP;
            else if (strcmp(wrap, "repeat") == 0)
                wrap_mode = OP_VOLUME_REPEAT;
            else if (strcmp(wrap, "mirror") == 0)
                wrap_mode = OP_VOLUME_MIRROR;
            else
                return op_node_error(vn, err, OP_ERR_INPUT, "wrap_mode \"%s\": not \"clamp\", "
                                     "\"repeat\" or \"mirror\"", wrap);
        } else {
            int send;
            GET_OR_FAIL(op_node_bool(vn, "sendData", 0, &send, err)); /* network transfer only */
        }
        char *path = op_node_resolve(vn, file);
        if (!path)
            return op_error_set(err, OP_ERR_NOMEM, "out of memory");
        op_status st = op_volume_read(path, &v, err);
        free(path);
        if (st != OP_OK)
            return st;
        op_volume_set_lookup(v, filter_mode, wrap_mode);
        bounded = bounded || !m3;
    } else {
        return op_node_error(vn, err, OP_ERR_INPUT, "unknown volume type (opaline reads "
                             "gridvolume and constvolume)");
    }
    op_matrix4 map;
    op_status st = volume_map(vn, v, grid_box, &map, err);
    if (st == OP_OK &&
        !op_volume_place(v, &map, m3 ? OP_VOLUME_CELLS : OP_VOLUME_VERTICES, bounded))
        st = op_node_error(vn, err, OP_ERR_INPUT, "toWorld is not finite");
    if (st != OP_OK) {
        op_volume_free(v);
        return st;
    }
    *out = v;
    return OP_OK;
}

/* The volume medium node n gives under one of names (a nested <volume> of that name, or a
 * float, rgb or spectrum property: a constant), else one of value def (NULL: *out stays NULL). */
static op_status read_volume(op_node *n, const char *const names[2], int bounded, const double *def,
                             op_volume **out, op_error *err)
{
    *out = NULL;
    for (int i = 0; i < n->nchildren; i++) {
        const char *cn = op_node_child_name(n, i);
        if (strcmp(n->children[i]->tag, "volume") != 0 || !cn ||
            (strcmp(cn, names[0]) != 0 && strcmp(cn, names[1]) != 0))
            continue;
        if (*out) {
            op_volume_free(*out);
            *out = NULL;
            return op_node_error(n, err, OP_ERR_INPUT, "more than one %s volume", names[0]);
        }
        GET_OR_FAIL(read_volume_node(n->children[i], bounded, out, err));
    }
    if (*out || (!op_node_has(n, names[1]) && !def))
        return OP_OK;
    double val[3];
    GET_OR_FAIL(op_node_color(n, names[1], def ? def : (const double[3]){0, 0, 0}, val, err));
    *out = op_volume_constant(v3_from_d(val));
    if (!*out)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    if (bounded && n->dialect == OP_DIALECT_MITSUBA_3) {
        op_matrix4 id = op_matrix4_identity(); /* Mitsuba 3 bounds it by the unit cube */
        op_volume_place(*out, &id, OP_VOLUME_CELLS, 1);
    }
    return OP_OK;
}

static float smallest(op_v3 a)
{
    return fminf(a.x, fminf(a.y, a.z));
}

/* Mitsuba 0.6: `density` volume x scale = sigma_t, `albedo` volume, `method` woodcock or
 * simpson (both rendered by unbiased tracking), `stepSize` unused. Mitsuba 3: `sigma_t` and
 * `albedo` volumes or constants (defaults 1 and 0.75), sigma_t x `scale`; sigma_t bounds the
 * medium by its volume's cube. */
static op_status read_heterogeneous(op_node *node, op_pmedium *m, op_error *err)
{
    int m3 = node->dialect == OP_DIALECT_MITSUBA_3;
    static const char *const st_names[2][2] = {{"density", "density"}, {"sigma_t", "sigmaT"}};
    static const char *const al_names[2] = {"albedo", "albedo"};
    double one[3] = {1, 1, 1}, a75[3] = {0.75, 0.75, 0.75}, scale, step;
    const char *method;
    GET_OR_FAIL(op_node_float(node, "scale", 1.0, &scale, err));
    if (!(scale >= 0.0 && scale < 1e12))
        return op_node_error(node, err, OP_ERR_INPUT, "scale %g must be >= 0", scale);
    if (!m3) {
        GET_OR_FAIL(op_node_string(node, "method", "woodcock", &method, err));
        GET_OR_FAIL(op_node_float(node, "stepSize", 0.0, &step, err)); /* tracking needs none */
        if (strcmp(method, "simpson") == 0)
            op_log(OP_LOG_INFO, "%s: method \"simpson\" is rendered by unbiased delta and ratio "
                   "tracking, as \"woodcock\"", m->label);
        else if (strcmp(method, "woodcock") != 0)
            return op_node_error(node, err, OP_ERR_INPUT, "unknown method \"%s\" (woodcock "
                                 "or simpson)", method);
    }
    m->scale = (float)scale;
    GET_OR_FAIL(read_volume(node, st_names[m3], 1, m3 ? one : NULL, &m->extinction, err));
    GET_OR_FAIL(read_volume(node, al_names, 0, m3 ? a75 : NULL, &m->albedo, err));
    const char *ext_name = st_names[m3][0];
    if (!m->extinction || !m->albedo)
        return op_node_error(node, err, OP_ERR_INPUT, "no %s volume (a heterogeneous medium "
                             "needs %s and albedo)", m->extinction ? "albedo" : ext_name,
                             ext_name);
    if (smallest(op_volume_min(m->albedo)) < 0.0f)
        return op_node_error(node, err, OP_ERR_INPUT, "negative albedo values (smallest %g)",
                             (double)smallest(op_volume_min(m->albedo)));
    op_v3 lo = op_volume_min(m->extinction), hi = op_volume_max(m->extinction);
    if (smallest(lo) < 0.0f) /* resampled grids undershoot a little (lajolla's smoke) */
        op_log(OP_LOG_WARN, "%s: <medium type=\"heterogeneous\">: negative %s values "
               "(smallest %g) are taken as 0", m->label, ext_name, (double)smallest(lo));
    m->majorant = m->scale * v3_max(hi);
    if (!(isfinite(m->majorant) && m->majorant < 1e30f))
        return op_node_error(node, err, OP_ERR_INPUT, "the largest %s %g times scale %g is "
                             "not finite", ext_name, (double)v3_max(hi), scale);
    return read_phase(node, &m->phase, err);
}

op_status op_medium_read(op_node *node, op_pmedium *m, op_error *err)
{
    node->used = 1;
    memset(m, 0, sizeof *m);
    snprintf(m->label, sizeof m->label, "%s:%d", node->file, node->line);
    op_status st;
    if (strcmp(node->type, "homogeneous") == 0)
        st = read_homogeneous(node, m, err);
    else if (strcmp(node->type, "heterogeneous") == 0)
        st = read_heterogeneous(node, m, err);
    else {
        char names[64];
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <medium type=\"%s\"> is not supported "
                            "(opaline renders %s media)", node->file, node->line, node->type,
                            op_names_join(medium_types, names, sizeof names));
    }
    if (st != OP_OK)
        op_pmedium_free(m);
    return st;
}
