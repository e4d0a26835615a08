/* limits.c - the scene limits (see limits.h and opaline_render.h). */
#include "scene/limits.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

void op_scene_limits_init(op_scene_limits *lim)
{
    lim->coordinate = 1e7;
    lim->image_pixels = 1LL << 27;
    lim->kernel = 255;
    lim->sss_points = 50000000;
    lim->sss_max_points = 250000; /* the quality cap per shape: a shape that needs more is coarser, with a warning */
    lim->include_bytes = 1LL << 30;
    lim->include_count = 100000;
    lim->attribute_bytes = 1LL << 28;
    lim->triangles = 100000000;
    lim->load_memory = 1LL << 35;
}

op_status op_scene_limits_set(op_scene_limits *lim, const char *assignment, op_error *err)
{
    /* each limit's hard range: what the renderer's data types and single precision allow;
     * kind: 'd' a double, 'i' an int, 'l' a long long field */
    static const struct {
        const char *name;
        double max;
        char kind;
        size_t offset;
    } known[] = {
        {"coordinate", 1e15, 'd', offsetof(op_scene_limits, coordinate)},
        {"image-pixels", 1LL << 30, 'l', offsetof(op_scene_limits, image_pixels)},
        {"kernel", 4095, 'i', offsetof(op_scene_limits, kernel)},
        {"sss-points", 1e9, 'l', offsetof(op_scene_limits, sss_points)},
        {"sss-max-points", 5e7, 'i', offsetof(op_scene_limits, sss_max_points)},
        {"include-bytes", 1LL << 40, 'l', offsetof(op_scene_limits, include_bytes)},
        {"include-count", 1e9, 'l', offsetof(op_scene_limits, include_count)},
        {"attribute-bytes", 1LL << 40, 'l', offsetof(op_scene_limits, attribute_bytes)},
        {"triangles", INT_MAX, 'l', offsetof(op_scene_limits, triangles)},
        {"load-memory", 1LL << 50, 'l', offsetof(op_scene_limits, load_memory)},
    };
    enum { NKNOWN = sizeof known / sizeof known[0] };
    const char *eq = strchr(assignment, '=');
    size_t n = eq ? (size_t)(eq - assignment) : strlen(assignment);
    int k = 0;
    while (k < NKNOWN && !(strlen(known[k].name) == n && strncmp(known[k].name, assignment, n) == 0))
        k++;
    if (k == NKNOWN || !eq)
        return op_error_set(err, OP_ERR_INPUT, "limit '%s': expected NAME=VALUE with NAME one of "
                            "coordinate, image-pixels, kernel, sss-points, sss-max-points, "
                            "include-bytes, include-count, attribute-bytes, triangles, load-memory",
                            assignment);
    char *end;
    errno = 0;
    double v = strtod(eq + 1, &end);
    int whole = known[k].kind != 'd';
    if (end == eq + 1 || *end || errno == ERANGE || !(v > 0.0) || v > known[k].max ||
        (whole && v != floor(v)))
        return op_error_set(err, OP_ERR_INPUT, "limit %s: '%s' is not a %s in (0, %g]",
                            known[k].name, eq + 1, whole ? "whole number" : "number",
                            known[k].max);
    char *field = (char *)lim + known[k].offset;
    if (known[k].kind == 'd')
        *(double *)field = v;
    else if (known[k].kind == 'i')
        *(int *)field = (int)v;
    else
        *(long long *)field = (long long)v;
    return OP_OK;
}

op_status op_limit_position(const op_scene_limits *limits, const op_node *node, const char *what,
                            op_v3 p, op_error *err)
{
    double lim = limits->coordinate;
    if (fabsf(p.x) <= lim && fabsf(p.y) <= lim && fabsf(p.z) <= lim)
        return OP_OK;
    return op_error_set(err, OP_ERR_INPUT, "%s:%d: <%s type=\"%s\">: %s (%g, %g, %g) is beyond "
                        "the coordinate limit of %g scene units from the origin (single-precision "
                        "ray tracing; move the scene toward the origin or raise the limit with "
                        "--limit coordinate=VALUE)", node->file, node->line, node->tag,
                        node->type ? node->type : "", what, p.x, p.y, p.z, lim);
}

op_status op_limit_add_bytes(const op_scene_limits *limits, op_limit_tally *t, long long bytes,
                             const char *what, op_error *err)
{
    t->bytes += bytes;
    if (t->bytes <= limits->load_memory)
        return OP_OK;
    return op_error_set(err, OP_ERR_INPUT, "with %s (%lld bytes) the scene is estimated to take "
                        "%lld bytes to load, more than the limit of %lld bytes (load-memory; "
                        "raise it with --limit load-memory=VALUE)", what, bytes, t->bytes,
                        limits->load_memory);
}

op_status op_limit_add_triangles(const op_scene_limits *limits, op_limit_tally *t, long long n,
                                 op_error *err)
{
    t->triangles += n;
    if (t->triangles > limits->triangles)
        return op_error_set(err, OP_ERR_INPUT, "with its %lld triangles the scene holds more than "
                            "the limit of %lld triangles (triangles; raise it with --limit "
                            "triangles=VALUE)", n, limits->triangles);
    return op_limit_add_bytes(limits, t, n * OP_LOAD_BYTES_PER_TRIANGLE, "its triangles", err);
}
