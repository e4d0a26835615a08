/* integrator_desc.c - a scene's <integrator> (see integrator_desc.h). */
#include "scene/integrator_desc.h"

#include <stdio.h>
#include <string.h>

#include "opaline.h"

/* Rendered by the path tracer: the same image in expectation, or (the last four) the image
 * their bias vanishes into as they converge. */
static const char *const path_like[] = {
    "path",          "bdpt",          "ptracer",        "pssmlt",      "mlt",
    "erpt",          "recursive_path", "guided_path",   "path_guiding", "volpath",
    "volpath_simple", "volpathmis",    "prb",           "prb_basic",   "prbvolpath",
    "prb_projective", "sppm",          "ppm",           "photonmapper", "vpl",
    NULL};
/* Rendered by the volumetric path tracer. */
static const char *const volumetric[] = {"volpath", "volpath_simple", "volpathmis",
                                                "prbvolpath", NULL};
/* Render the integrator nested in them. */
static const char *const wrappers[] = {"moment", "aov", "irrcache", "adaptive", NULL};

static int in_list(const char *const *list, const char *t)
{
    for (int i = 0; list[i]; i++)
        if (strcmp(list[i], t) == 0)
            return 1;
    return 0;
}

/* Marks n's remaining parameters used and writes their names, comma-separated, into buf. */
static void take_unused(op_node *n, char *buf, size_t cap)
{
    size_t k = 0;
    buf[0] = '\0';
    for (int i = 0; i < n->nprops; i++) {
        if (n->props[i].used)
            continue;
        n->props[i].used = 1;
        if (k < cap)
            k += (size_t)snprintf(buf + k, cap - k, "%s%s", k ? ", " : "",
                                  op_prop_name(&n->props[i]));
    }
}

static op_status unknown(op_node *n, op_error *err)
{
    return op_error_set(err, OP_ERR_INPUT, "%s:%d: <integrator type=\"%s\">: unknown integrator "
                        "(opaline renders path, direct, field, normals, uv, albedo; Mitsuba's "
                        "bdpt, ptracer, pssmlt, mlt, erpt, sppm, ppm, photonmapper, vpl, "
                        "recursive_path, guided_path, volpath, volpath_simple, volpathmis, prb*, "
                        "direct_projective; and the wrappers moment, aov, irrcache, adaptive)",
                        n->file, n->line, n->type);
}

/* The field views: Mitsuba 0.6's field integrator and opaline's own. */
static int field_view(const char *t, op_integrator_type *type)
{
    if (strcmp(t, "normals") == 0 || strcmp(t, "shNormal") == 0 || strcmp(t, "geoNormal") == 0 ||
        strcmp(t, "sh_normal") == 0 || strcmp(t, "geo_normal") == 0)
        *type = OP_INT_NORMALS;
    else if (strcmp(t, "uv") == 0)
        *type = OP_INT_UV;
    else if (strcmp(t, "albedo") == 0)
        *type = OP_INT_ALBEDO;
    else
        return 0;
    return 1;
}

static op_status read_direct(op_node *n, op_integrator *ig, op_error *err)
{
    long long es, bs, both;
    /* Mitsuba 3's shading_samples sets both counts' default */
    GET_OR_FAIL(op_node_int(n, "shadingSamples", 1, &both, err));
    GET_OR_FAIL(op_node_int(n, "emitterSamples", both, &es, err));
    GET_OR_FAIL(op_node_int(n, "bsdfSamples", both, &bs, err));
    if (es < 0 || es > 65536 || bs < 0 || bs > 65536)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <integrator type=\"%s\">: emitterSamples "
                            "%lld and bsdfSamples %lld must be in 0..65536", n->file, n->line,
                            n->type, es, bs);
    int strict;
    GET_OR_FAIL(op_node_bool(n, "strictNormals", 0, &strict, err));
    ig->type = OP_INT_DIRECT;
    ig->emitter_samples = (int)es;
    ig->bsdf_samples = (int)bs;
    return OP_OK;
}

static op_status read_path(op_node *n, op_integrator *ig, op_error *err)
{
    long long md, rr;
    int strict;
    GET_OR_FAIL(op_node_int(n, "maxDepth", -1, &md, err));
    GET_OR_FAIL(op_node_int(n, "rrDepth", 5, &rr, err));
    GET_OR_FAIL(op_node_bool(n, "strictNormals", 0, &strict, err));
    if (md < -1 || md == 0 || md > 100000 || rr < 1 || rr > 100000)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <integrator type=\"%s\">: maxDepth %lld "
                            "(-1 or >= 1) or rrDepth %lld (>= 1) out of range", n->file, n->line,
                            n->type, md, rr);
    ig->type = OP_INT_PATH;
    ig->max_depth = (int)md;
    ig->rr_depth = (int)rr;
    ig->volumetric = in_list(volumetric, n->type);
    if (ig->volumetric)
        return OP_OK;
    if (strcmp(n->type, "path") != 0) {
        char rest[512];
        take_unused(n, rest, sizeof rest);
        op_log(OP_LOG_INFO, "%s:%d: <integrator type=\"%s\">: rendered by opaline's path tracer "
               "(the image it converges to)%s%s", n->file, n->line, n->type,
               rest[0] ? "; not used: " : "", rest);
    }
    return OP_OK;
}

/* An aov without a nested integrator: its one field view, if opaline has it. */
static op_status read_aov_alone(op_node *n, op_integrator *ig, op_error *err)
{
    const char *aovs;
    GET_OR_FAIL(op_node_string(n, "aovs", "", &aovs, err));
    const char *colon = strchr(aovs, ':');
    const char *what = colon ? colon + 1 : aovs;
    if (strchr(aovs, ',') || !field_view(what, &ig->type))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <integrator type=\"aov\">: aovs \"%s\" "
                            "without a nested integrator: opaline renders one of sh_normal, "
                            "geo_normal, uv, albedo as the image, not other or several AOVs",
                            n->file, n->line, aovs);
    return OP_OK;
}

op_status op_integrator_read(op_node *n, op_integrator *ig, op_error *err)
{
    ig->type = OP_INT_DIRECT;
    ig->max_depth = 2;
    ig->rr_depth = 5;
    ig->hide_emitters = 0;
    ig->emitter_samples = ig->bsdf_samples = 1;
    ig->volumetric = 0;
    for (int depth = 0; n; depth++) {
        n->used = 1;
        const char *t = n->type;
        if (depth > 8)
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <integrator type=\"%s\">: wrappers "
                                "nested more than 8 deep", n->file, n->line, t);
        if (in_list(wrappers, t)) {
            op_node *inner = op_node_child(n, "integrator", 0);
            if (op_node_child(n, "integrator", 1))
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <integrator type=\"%s\">: more "
                                    "than one nested integrator (opaline renders one image)",
                                    n->file, n->line, t);
            if (!inner && strcmp(t, "aov") == 0)
                return read_aov_alone(n, ig, err);
            if (!inner)
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <integrator type=\"%s\"> needs a "
                                    "nested <integrator>", n->file, n->line, t);
            char rest[512];
            take_unused(n, rest, sizeof rest);
            op_log(OP_LOG_INFO, "%s:%d: <integrator type=\"%s\">: renders the image of its nested "
                   "integrator%s%s", n->file, n->line, t, rest[0] ? "; not used: " : "", rest);
            n = inner;
            continue;
        }
        if (strcmp(t, "field") == 0) {
            const char *f;
            GET_OR_FAIL(op_node_string(n, "field", "shNormal", &f, err));
            if (!field_view(f, &ig->type))
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <integrator type=\"field\">: "
                                    "field \"%s\" is not shNormal, geoNormal, uv or albedo",
                                    n->file, n->line, f);
            return OP_OK;
        }
        if (field_view(t, &ig->type))
            return OP_OK;
        if (!in_list(path_like, t) && strcmp(t, "direct") != 0 &&
            strcmp(t, "direct_projective") != 0)
            return unknown(n, err);
        GET_OR_FAIL(op_node_bool(n, "hideEmitters", 0, &ig->hide_emitters, err));
        if (in_list(path_like, t))
            return read_path(n, ig, err);
        return read_direct(n, ig, err);
    }
    return OP_OK;
}
