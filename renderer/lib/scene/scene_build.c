/* scene_build.c - the scene builder (see scene_build.h). */
#include "scene/scene_build.h"

#include "scene/material_name.h"
#include "sss/layout.h"
#include "sss/prepass.h"

#include <errno.h>
#include <limits.h>
#include <libgen.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

/* The build tree's presets folder (the build sets it), searched last so that an uninstalled
 * build/bin/opaline-render finds the presets the build made. */
#ifndef OPALINE_DEFAULT_PRESETS_DIR
#define OPALINE_DEFAULT_PRESETS_DIR "presets"
#endif
/* The installed presets folder, relative to the prefix of the running program (bin/..). */
#define OPALINE_INSTALLED_PRESETS_SUBDIR "share/opaline/presets"

/* The longitude segments of a sphere's tessellation (half as many latitude bands). */
#define SPHERE_SEGMENTS 128
/* The load-memory estimate's bytes per stored triangle: the peak of --check on a PLY grid of
 * 2 million triangles, 281 MB (the mapped file, the mesh as read and as placed, Embree's BVH). */
#define LOAD_BYTES_PER_TRIANGLE 144

/* Growing arrays and what the builder needs while it works. */
typedef struct builder {
    op_scene *s;
    const op_scene_limits *lim;
    char dir[4096];
    int cap_shapes, cap_bsdfs, cap_emitters, cap_sss, cap_mats;
    op_strmap bsdf_index;       /* a built bsdf node's address ("%p") -> its index, to share
                                   referenced ones */
    char **mat_paths;           /* resolved path of each opened material */
    op_mesh_cache *meshes;
    /* mesh files that plain shapes (no emitter, no subsurface) use, found before building:
     * those used by two or more become shared prototypes, the shapes their instances */
    op_strmap file_keys;         /* shared_mesh's key -> its index k in the arrays below */
    int *file_uses, *file_proto; /* file_proto: index into s->protos, or -1 */
    int nfiles, cap_files;
    long long triangles;  /* stored so far (a prototype once), against lim->triangles */
    long long load_bytes; /* the estimated memory of what is loaded so far, against
                             lim->load_memory */
    int images_charged;   /* the texture cache's images counted in load_bytes */
} builder;

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

/* Refuses a position of node's object farther from the origin than the coordinate limit
 * (also a non-finite one): single precision cannot place anything there. */
static op_status check_position(const builder *b, const op_node *node, const char *what, op_v3 p,
                                op_error *err)
{
    double lim = b->lim->coordinate;
    if (fabsf(p.x) <= lim && fabsf(p.y) <= lim && fabsf(p.z) <= lim)
        return OP_OK;
    return op_error_set(err, OP_ERR_INPUT, "%s:%d: <%s type=\"%s\">: %s (%g, %g, %g) is beyond "
                        "the coordinate limit of %g scene units from the origin (single-precision "
                        "ray tracing; move the scene toward the origin or raise the limit with "
                        "--limit coordinate=VALUE)", node->file, node->line, node->tag,
                        node->type ? node->type : "", what, p.x, p.y, p.z, lim);
}

static int file_exists(const char *p)
{
    struct stat st;
    return stat(p, &st) == 0 && S_ISREG(st.st_mode);
}

/* dir + "/" + name (name alone when absolute or dir is empty), truncated to n - 1 bytes. */
static void join(char *out, size_t n, const char *dir, const char *name)
{
    size_t k = 0;
    const char *parts[3] = {NULL, NULL, name};
    if (name[0] != '/' && dir && dir[0]) {
        parts[0] = dir;
        parts[1] = "/";
    }
    for (int p = 0; p < 3; p++)
        for (const char *c = parts[p]; c && *c && k + 1 < n; c++)
            out[k++] = *c;
    out[k] = '\0';
}

/* Writes PREFIX/share/opaline/presets into out, PREFIX being the folder above the one of the
 * running program (/proc/self/exe, links resolved): an installed tree finds its own presets
 * wherever it was installed or moved to. Writes "" when the program's path is unknown. */
static void installed_presets_dir(char *out, size_t n)
{
    char exe[4096];
    out[0] = '\0';
    ssize_t len = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (len <= 0 || (size_t)len >= sizeof exe - 1)
        return;
    exe[len] = '\0';
    for (int up = 0; up < 2; up++) { /* drop the program's name, then its bin folder */
        char *slash = strrchr(exe, '/');
        if (!slash)
            return;
        *slash = '\0';
    }
    int w = snprintf(out, n, "%s/%s", exe, OPALINE_INSTALLED_PRESETS_SUBDIR);
    if (w < 0 || (size_t)w >= n) /* too long to name: not searched */
        out[0] = '\0';
}

op_status op_preset_folders(const char *scene_dir, op_folder_fn each, void *user,
                            op_error *err)
{
    if (scene_dir && each(user, scene_dir[0] ? scene_dir : "."))
        return OP_OK;
    const char *env = getenv("OPALINE_PRESETS_PATH");
    if (env && env[0]) {
        char *copy = strdup(env);
        if (!copy)
            return op_error_set(err, OP_ERR_NOMEM, "out of memory");
        char *save = NULL;
        for (char *d = strtok_r(copy, ":", &save); d; d = strtok_r(NULL, ":", &save))
            if (each(user, d)) {
                free(copy);
                return OP_OK;
            }
        free(copy);
    }
    char installed[4096];
    installed_presets_dir(installed, sizeof installed);
    if (installed[0] && each(user, installed))
        return OP_OK;
    each(user, OPALINE_DEFAULT_PRESETS_DIR);
    return OP_OK;
}

typedef struct preset_search {
    const char *name;
    char *out;
    size_t n;
    char searched[4096]; /* the folders searched, comma-separated */
    int found;
    op_folder_fn each;   /* also told of every folder searched, or NULL */
    void *user;
} preset_search;

/* Whether folder/name.opm is a regular file (its path is left in out either way; said at
 * debug level when found). */
static int preset_in(void *user, const char *folder)
{
    preset_search *ps = user;
    snprintf(ps->out, ps->n, "%s/%s.opm", folder, ps->name);
    size_t sl = strlen(ps->searched);
    snprintf(ps->searched + sl, sizeof ps->searched - sl, "%s%s", sl ? ", " : "", folder);
    if (ps->each)
        ps->each(ps->user, folder);
    if (!file_exists(ps->out))
        return 0;
    op_log(OP_LOG_DEBUG, "material preset \"%s\" is %s", ps->name, ps->out);
    ps->found = 1;
    return 1;
}

op_status op_find_material(const char *name, const char *scene_dir, op_folder_fn each,
                           void *user, char *out, size_t n, op_error *err)
{
    size_t len = strlen(name);
    int is_path = strchr(name, '/') != NULL || (len > 4 && strcasecmp(name + len - 4, ".opm") == 0);
    if (is_path) { /* opening it says what is wrong with it, if anything */
        join(out, n, scene_dir, name);
        return OP_OK;
    }
    preset_search ps = {name, out, n, "", 0, each, user};
    op_status st = op_preset_folders(scene_dir ? scene_dir : "", preset_in, &ps, err);
    if (st || ps.found)
        return st;
    return op_error_set(err, OP_ERR_INPUT, "material preset \"%s\" not found (searched %s; set "
                        "OPALINE_PRESETS_PATH or give an .opm path)", name, ps.searched);
}

static op_status add_bsdf(builder *b, op_node *node, int *index, op_error *err)
{
    op_scene *s = b->s;
    char key[32];
    snprintf(key, sizeof key, "%p", (const void *)node);
    const op_strmap_entry *known = node ? op_strmap_find(&b->bsdf_index, key, strlen(key)) : NULL;
    if (known) {
        *index = known->index;
        return OP_OK;
    }
    if (!op_array_grow((void **)&s->bsdfs, &b->cap_bsdfs, s->nbsdfs, sizeof *s->bsdfs))
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    if (node)
        GET_OR_FAIL(op_bsdf_build(node, s->textures, &s->bsdfs[s->nbsdfs], err));
    else
        op_bsdf_default(&s->bsdfs[s->nbsdfs]);
    op_strmap_entry *e = node ? op_strmap_add(&b->bsdf_index, key) : NULL;
    if (node && !e)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    if (e)
        e->index = s->nbsdfs;
    *index = s->nbsdfs++;
    return OP_OK;
}

/* Adds bytes, what the part the caller read (named by what) is estimated to take, to the
 * scene's load-memory estimate and refuses it over the limit (callers name the element). */
static op_status charge(builder *b, long long bytes, const char *what, op_error *err)
{
    b->load_bytes += bytes;
    if (b->load_bytes <= b->lim->load_memory)
        return OP_OK;
    return op_error_set(err, OP_ERR_INPUT, "with %s (%lld bytes) the scene is estimated to take "
                        "%lld bytes to load, more than the limit of %lld bytes (load-memory; "
                        "raise it with --limit load-memory=VALUE)", what, bytes, b->load_bytes,
                        b->lim->load_memory);
}

/* Counts the n triangles of a mesh just read against the triangles and load-memory limits
 * (callers name the shape). */
static op_status add_triangles(builder *b, long long n, op_error *err)
{
    b->triangles += n;
    if (b->triangles > b->lim->triangles)
        return op_error_set(err, OP_ERR_INPUT, "with its %lld triangles the scene holds more than "
                            "the limit of %lld triangles (triangles; raise it with --limit "
                            "triangles=VALUE)", n, b->lim->triangles);
    return charge(b, n * LOAD_BYTES_PER_TRIANGLE, "its triangles", err);
}

/* Counts the images node's object read (the texture cache's new ones, and e's environment map
 * when e is not NULL) against the load-memory limit. Each was bounded by image-pixels before
 * it was decoded. */
static op_status add_images(builder *b, const op_node *node, const op_emitter *e, op_error *err)
{
    long long bytes = 0;
    for (; b->images_charged < op_tex_cache_count(b->s->textures); b->images_charged++) {
        const op_image *im = op_tex_cache_image(b->s->textures, b->images_charged);
        bytes += (long long)im->width * im->height * im->channels * (long long)sizeof(float);
    }
    if (e && e->env.pixels)
        bytes += (long long)e->env.width * e->env.height * e->env.channels *
                 (long long)sizeof(float);
    if (bytes == 0 || charge(b, bytes, "its images", err) == OP_OK)
        return OP_OK;
    return op_error_prefix(err, "%s:%d: <%s type=\"%s\">: ", node->file, node->line, node->tag,
                           node->type ? node->type : "");
}

static op_status add_emitter(builder *b, op_node *node, const op_trimesh *mesh, int shape,
                             int *index, op_error *err)
{
    op_scene *s = b->s;
    if (!op_array_grow((void **)&s->emitters, &b->cap_emitters, s->nemitters, sizeof *s->emitters))
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    op_emitter *e = &s->emitters[s->nemitters];
    op_status st = op_emitter_build(node, mesh, shape, b->dir, b->lim->image_pixels, e, err);
    if (st == OP_OK && (e->type == OP_EM_POINT || e->type == OP_EM_SPOT))
        st = check_position(b, node, "the light's position", e->pos, err);
    if (st) {
        op_emitter_free(e);
        return st;
    }
    if (op_emitter_is_env(&s->emitters[s->nemitters])) {
        if (s->env >= 0) {
            op_emitter_free(e);
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"%s\">: a scene may have "
                                "only one environment emitter", node->file, node->line, node->type);
        }
        s->env = s->nemitters;
    }
    *index = s->nemitters++; /* owned by the scene from here on */
    return add_images(b, node, e, err);
}

static op_status open_material(builder *b, const char *path, op_material **out, op_error *err)
{
    op_scene *s = b->s;
    for (int i = 0; i < s->nmaterials; i++)
        if (strcmp(b->mat_paths[i], path) == 0) {
            *out = s->materials[i];
            return OP_OK;
        }
    int cap = b->cap_mats;
    if (!op_array_grow((void **)&s->materials, &b->cap_mats, s->nmaterials,
                       sizeof *s->materials) ||
        !op_array_grow((void **)&b->mat_paths, &cap, s->nmaterials, sizeof *b->mat_paths))
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    op_material *m;
    GET_OR_FAIL(op_material_open(path, &m, err));
    b->mat_paths[s->nmaterials] = strdup(path);
    s->materials[s->nmaterials++] = m;
    if (!b->mat_paths[s->nmaterials - 1])
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    *out = m;
    return OP_OK;
}

/* The homogeneous dipole: a named medium or explicit coefficients, all in 1/mm, turned into
 * coefficients per scene unit (metres, times `scale`: 1000 / scale per mm). */
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
    double per_unit = 1000.0 / d->scale; /* 1/mm -> 1/scene unit */
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

static op_status add_subsurface(builder *b, op_node *node, int *index, op_error *err)
{
    op_scene *s = b->s;
    node->used = 1;
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
    if (!op_array_grow((void **)&s->sss, &b->cap_sss, s->nsss, sizeof *s->sss))
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    op_sss_desc *d = &s->sss[s->nsss];
    memset(d, 0, sizeof *d);
    const char *name = NULL;
    long long irr, maxp;
    GET_OR_FAIL(op_node_float(node, "scale", 1.0, &d->scale, err));
    GET_OR_FAIL(op_node_int(node, "irrSamples", 16, &irr, err));
    GET_OR_FAIL(op_node_float(node, "density", 1.0, &d->density, err));
    GET_OR_FAIL(op_node_int(node, "maxPoints", b->lim->sss_max_points, &maxp, err));
    if (!(d->scale > 0.0 && d->scale < 1e9))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <subsurface>: scale %g must be > 0",
                            node->file, node->line, d->scale);
    if (irr < 1 || irr > 65536 || maxp < 1 || maxp > 50000000 ||
        !(d->density > 0.0 && d->density <= 64.0))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <subsurface>: need irrSamples in 1..65536, "
                            "maxPoints in 1..5e7, density in (0, 64]", node->file, node->line);
    d->irr_samples = (int)irr;
    d->max_points = (int)maxp;
    if (dipole) {
        GET_OR_FAIL(build_dipole(node, d, err));
        *index = s->nsss++;
        return OP_OK;
    }
    GET_OR_FAIL(op_node_string(node, "material", NULL, &name, err));
    if (!name)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <subsurface type=\"%s\"> needs <string "
                            "name=\"material\">", node->file, node->line, t);
    /* the plugin's long names ("SVD S10 Div100 Add1 for Rd Chess4x4 ...") name a preset */
    char preset[256];
    double log_a = 0.0, log_b = 0.0;
    op_method long_method = OP_METHOD_COUNT;
    int is_long = op_parse_long_material_name(name, preset, sizeof preset, &long_method, &log_a, &log_b);
    char path[4096];
    op_status st = op_find_material(is_long ? preset : name, b->dir, NULL, NULL, path, sizeof path,
                                     err);
    if (st == OP_OK)
        st = open_material(b, path, &d->material, err);
    if (st) {
        if (is_long)
            return op_error_prefix(err, "%s:%d: <subsurface>: \"%s\" names preset %s: ", node->file,
                                   node->line, name, preset);
        return op_error_prefix(err, "%s:%d: <subsurface>: ", node->file, node->line);
    }
    const op_material_info *info = op_material_get_info(d->material);
    if (info->kernel > b->lim->kernel)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <subsurface>: %s has kernel size %d, over "
                            "the limit of %d (kernel; the pre-pass costs K^2 per irradiance point; "
                            "raise it with --limit kernel=VALUE)", node->file, node->line, path,
                            info->kernel, b->lim->kernel);
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
    *index = s->nsss++;
    return OP_OK;
}

/* The mesh file an obj/ply shape node names, resolved against the scene's folder, and its
 * loading options; key gets "face flip path" identifying one loaded mesh. */
static op_status file_mesh(builder *b, op_node *node, char *path, size_t n, int *face,
                           int *fliptex, char *key, size_t nk, op_error *err)
{
    const char *t = node->type, *fn;
    GET_OR_FAIL(op_node_string(node, "filename", NULL, &fn, err));
    if (!fn)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <shape type=\"%s\"> needs a filename",
                            node->file, node->line, t);
    GET_OR_FAIL(op_node_bool(node, "faceNormals", 0, face, err));
    GET_OR_FAIL(op_node_bool(node, "flipTexCoords", strcmp(t, "obj") == 0, fliptex, err));
    join(path, n, b->dir, fn);
    snprintf(key, nk, "%d %d %s", *face, *fliptex, path);
    return OP_OK;
}

/* Whether a shape node may become an instance: a mesh file or a sphere without an emitter or
 * subsurface (those need world-space triangles: area sampling, irradiance points). */
static int may_instance(const op_node *node)
{
    if (strcmp(node->type, "obj") != 0 && strcmp(node->type, "ply") != 0 &&
        strcmp(node->type, "sphere") != 0)
        return 0;
    for (int i = 0; i < node->nchildren; i++)
        if (strcmp(node->children[i]->tag, "emitter") == 0 ||
            strcmp(node->children[i]->tag, "subsurface") == 0)
            return 0;
    return 1;
}

/* The mesh a shape node that may become an instance places: its file (file_mesh), or for a
 * sphere the unit sphere, key "sphere" and path "". */
static op_status shared_mesh(builder *b, op_node *node, char *path, size_t n, int *face,
                             int *fliptex, char *key, size_t nk, op_error *err)
{
    if (strcmp(node->type, "sphere") != 0)
        return file_mesh(b, node, path, n, face, fliptex, key, nk, err);
    *face = *fliptex = 0;
    snprintf(path, n, "%s", "");
    snprintf(key, nk, "%s", "sphere");
    return OP_OK;
}

/* Counts the uses of each shared mesh by shapes that may become instances. Nodes whose
 * parameters are bad are skipped here (building them reports the error). */
static op_status count_file_uses(builder *b, op_node *root, op_error *err)
{
    for (int i = 0; i < root->nchildren; i++) {
        op_node *c = root->children[i];
        if (strcmp(c->tag, "shape") != 0 || !may_instance(c))
            continue;
        char path[4096], key[4200];
        int face, fliptex;
        op_error scratch;
        if (shared_mesh(b, c, path, sizeof path, &face, &fliptex, key, sizeof key, &scratch))
            continue;
        op_strmap_entry *e = op_strmap_find(&b->file_keys, key, strlen(key));
        if (!e) {
            int k = b->nfiles, cap = b->cap_files;
            if (!op_array_grow((void **)&b->file_uses, &b->cap_files, k, sizeof *b->file_uses) ||
                !op_array_grow((void **)&b->file_proto, &cap, k, sizeof *b->file_proto) ||
                !(e = op_strmap_add(&b->file_keys, key)))
                return op_error_set(err, OP_ERR_NOMEM, "out of memory");
            e->index = k;
            b->file_uses[k] = 0;
            b->file_proto[k] = -1;
            b->nfiles++;
        }
        b->file_uses[e->index]++;
    }
    return OP_OK;
}

/* The object-space prototype of entry k (loaded, or for a sphere tessellated, on first use)
 * in *index. */
static op_status file_prototype(builder *b, int k, const char *path, const char *kind, int face,
                                int fliptex, int *index, op_error *err)
{
    op_scene *s = b->s;
    if (b->file_proto[k] >= 0) {
        *index = b->file_proto[k];
        return OP_OK;
    }
    op_trimesh *grown = realloc(s->protos, (size_t)(s->nprotos + 1) * sizeof *grown);
    if (!grown)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    s->protos = grown;
    op_trimesh *m = &s->protos[s->nprotos];
    if (strcmp(kind, "sphere") == 0)
        GET_OR_FAIL(op_shape_sphere(m, SPHERE_SEGMENTS, err));
    else
        GET_OR_FAIL(op_mesh_cache_get(b->meshes, path, kind, face, fliptex, m, err));
    op_matrix4 id = op_matrix4_identity();
    op_status st = add_triangles(b, m->ntris, err);
    if (st == OP_OK)
        st = op_trimesh_finish(m, &id, 0, err);
    if (st) {
        op_trimesh_free(m);
        return st;
    }
    *index = b->file_proto[k] = s->nprotos++;
    return OP_OK;
}

/* Builds shape sh's geometry from its node: a world-space mesh, or an instance of a shared
 * prototype when the node may be one and its mesh (file, or the unit sphere) is used by two or
 * more such shapes. */
static op_status build_mesh(builder *b, op_node *node, op_shape_rec *sh, op_error *err)
{
    const char *t = node->type;
    op_trimesh *m = &sh->mesh;
    op_matrix4 xf;
    int flip;
    GET_OR_FAIL(op_node_transform(node, "toWorld", &xf, err));
    GET_OR_FAIL(op_node_bool(node, "flipNormals", 0, &flip, err));
    int file = strcmp(t, "obj") == 0 || strcmp(t, "ply") == 0;
    if (file && op_node_has(node, "maxSmoothAngle")) {
        double a;
        GET_OR_FAIL(op_node_float(node, "maxSmoothAngle", 0.0, &a, err));
        op_log(OP_LOG_WARN, "%s:%d: <shape>: maxSmoothAngle is not supported; smooth normals "
               "are used", node->file, node->line);
    }
    if (strcmp(t, "sphere") == 0) {
        double c[3], zero[3] = {0, 0, 0}, r;
        GET_OR_FAIL(op_node_vec3(node, "center", zero, c, err));
        GET_OR_FAIL(op_node_float(node, "radius", 1.0, &r, err));
        if (!(r > 0.0) || !(r <= b->lim->coordinate))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <shape type=\"sphere\">: radius %g must "
                                "be > 0 and within the coordinate limit of %g", node->file,
                                node->line, r, b->lim->coordinate);
        op_matrix4 tr = op_matrix4_translate(c[0], c[1], c[2]), sc = op_matrix4_scale(r, r, r);
        op_matrix4 local = op_matrix4_mul(&tr, &sc);
        xf = op_matrix4_mul(&xf, &local);
    }
    op_status st;
    int face = 0, fliptex = 0;
    char path[4096] = "", key[4200] = "";
    if (file || may_instance(node))
        GET_OR_FAIL(shared_mesh(b, node, path, sizeof path, &face, &fliptex, key, sizeof key, err));
    const op_strmap_entry *e = op_strmap_find(&b->file_keys, key, strlen(key));
    int k = e ? e->index : -1;
    if (may_instance(node) && k >= 0 && b->file_uses[k] >= 2) {
        int p = 0;
        st = file_prototype(b, k, path, t, face, fliptex, &p, err);
        if (st == OP_OK)
            st = op_placement_make(&xf, flip, &sh->place, err);
        if (st)
            return op_error_prefix(err, "%s:%d: <shape type=\"%s\">: ", node->file,
                                   node->line, t);
        *m = b->s->protos[p]; /* borrowed */
        sh->instanced = 1;
        sh->proto = p;
        op_v3 lo, hi;
        op_placement_bounds(&sh->place, m, &lo, &hi);
        if ((st = check_position(b, node, "a corner of its bounds", lo, err)) == OP_OK)
            st = check_position(b, node, "a corner of its bounds", hi, err);
        return st;
    }
    if (file) {
        st = op_mesh_cache_get(b->meshes, path, t, face, fliptex, m, err);
    } else if (strcmp(t, "sphere") == 0) {
        st = op_shape_sphere(m, SPHERE_SEGMENTS, err);
    } else if (strcmp(t, "rectangle") == 0) {
        st = op_shape_rectangle(m, err);
    } else if (strcmp(t, "cube") == 0) {
        st = op_shape_cube(m, err);
    } else if (strcmp(t, "disk") == 0) {
        st = op_shape_disk(m, 96, err);
    } else {
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <shape type=\"%s\">: unknown shape type "
                            "(obj, ply, sphere, rectangle, cube, disk)", node->file, node->line, t);
    }
    if (st == OP_OK)
        st = add_triangles(b, m->ntris, err);
    if (st == OP_OK)
        st = op_trimesh_finish(m, &xf, flip, err);
    if (st) {
        op_trimesh_free(m); /* not yet the scene's: add_shape counts the shape on success only */
        return op_error_prefix(err, "%s:%d: <shape type=\"%s\">: ", node->file, node->line, t);
    }
    if ((st = check_position(b, node, "a corner of its bounds", m->bmin, err)) == OP_OK)
        st = check_position(b, node, "a corner of its bounds", m->bmax, err);
    if (st)
        op_trimesh_free(m);
    return st;
}

/* The surface reflection of a translucent shape from the <bsdf> beside its <subsurface>
 * (docs/subsurface-rendering.md, The surface's reflection). */
static op_status add_boundary(builder *b, op_node *node, op_sss_desc *d, op_error *err)
{
    static const char *types[] = {"dielectric", "roughdielectric", "plastic", "roughplastic",
                                  "coating"};
    int ok = 0;
    for (size_t i = 0; i < sizeof types / sizeof types[0]; i++)
        ok |= strcmp(node->type, types[i]) == 0;
    if (!ok)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"%s\"> cannot be the surface of "
                            "a shape with a <subsurface> (dielectric, roughdielectric, plastic, "
                            "roughplastic or coating)", node->file, node->line, node->type);
    if (op_node_child(node, "bsdf", 0))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"%s\"> over a <subsurface> takes "
                            "no nested <bsdf> (the subsurface is what lies beneath)", node->file,
                            node->line, node->type);
    if (op_node_has(node, "diffuseReflectance") || op_node_has(node, "reflectance") ||
        op_node_child(node, "texture", 0))
        op_log(OP_LOG_WARN, "%s:%d: <bsdf type=\"%s\">: the diffuse reflectance is replaced by "
               "the subsurface", node->file, node->line, node->type);
    op_bsdf given;
    GET_OR_FAIL(op_bsdf_build(node, b->s->textures, &given, err));
    if (op_bsdf_boundary(&given, &d->sheen, &d->through, err))
        return op_error_prefix(err, "%s:%d: ", node->file, node->line);
    d->has_boundary = 1;
    return OP_OK;
}

static op_status add_shape(builder *b, op_node *node, op_error *err)
{
    op_scene *s = b->s;
    node->used = 1;
    if (!op_array_grow((void **)&s->shapes, &b->cap_shapes, s->nshapes, sizeof *s->shapes))
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    int index = s->nshapes;
    op_shape_rec *sh = &s->shapes[index];
    memset(sh, 0, sizeof *sh);
    sh->bsdf = sh->emitter = sh->sss = -1;
    snprintf(sh->label, sizeof sh->label, "%s:%d", node->file, node->line);
    GET_OR_FAIL(build_mesh(b, node, sh, err));
    s->nshapes++; /* owns its mesh from here on */
    op_node *bsdf = NULL, *em = NULL, *sss = NULL;
    for (int i = 0; i < node->nchildren; i++) {
        op_node *c = node->children[i];
        if (strcmp(c->tag, "bsdf") == 0 && !bsdf)
            bsdf = c;
        else if (strcmp(c->tag, "emitter") == 0 && !em)
            em = c;
        else if (strcmp(c->tag, "subsurface") == 0 && !sss)
            sss = c;
        else
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <%s> %sis not supported inside <shape>",
                                c->file, c->line, c->tag,
                                (strcmp(c->tag, "bsdf") == 0 || strcmp(c->tag, "emitter") == 0 ||
                                 strcmp(c->tag, "subsurface") == 0) ? "a second time " : "");
    }
    int bi = -1, ei = -1, si = -1;
    GET_OR_FAIL(add_bsdf(b, sss ? NULL : bsdf, &bi, err));
    s->shapes[index].bsdf = bi;
    op_bsdf_type bt = s->bsdfs[bi].type;
    if (!sss && (bt == OP_BSDF_ROUGHDIELECTRIC || bt == OP_BSDF_COATING))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"%s\"> is rendered only as the "
                            "surface of a shape with a <subsurface>", bsdf->file, bsdf->line,
                            bsdf->type);
    if (em) {
        if (strcmp(em->type, "area") != 0)
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: only an area emitter may be nested in a "
                                "shape", em->file, em->line);
        GET_OR_FAIL(add_emitter(b, em, &s->shapes[index].mesh, index, &ei, err));
        s->shapes[index].emitter = ei;
    }
    if (sss) {
        GET_OR_FAIL(add_subsurface(b, sss, &si, err));
        s->shapes[index].sss = si;
        if (bsdf)
            GET_OR_FAIL(add_boundary(b, bsdf, &s->sss[si], err));
    }
    return add_images(b, node, NULL, err);
}

static op_status build_integrator(op_node *n, op_integrator *ig, op_error *err)
{
    ig->type = OP_INT_DIRECT;
    ig->max_depth = 2;
    ig->rr_depth = 5;
    ig->hide_emitters = 0;
    ig->emitter_samples = ig->bsdf_samples = 1;
    if (!n)
        return OP_OK;
    n->used = 1;
    const char *t = n->type;
    long long md, rr;
    if (strcmp(t, "field") == 0) {
        const char *f;
        GET_OR_FAIL(op_node_string(n, "field", "shNormal", &f, err));
        if (strcmp(f, "shNormal") == 0 || strcmp(f, "geoNormal") == 0)
            ig->type = OP_INT_NORMALS;
        else if (strcmp(f, "uv") == 0)
            ig->type = OP_INT_UV;
        else if (strcmp(f, "albedo") == 0)
            ig->type = OP_INT_ALBEDO;
        else
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <integrator type=\"field\">: field "
                                "\"%s\" is not shNormal, geoNormal, uv or albedo", n->file, n->line,
                                f);
        return OP_OK;
    }
    if (strcmp(t, "normals") == 0) {
        ig->type = OP_INT_NORMALS;
        return OP_OK;
    }
    if (strcmp(t, "uv") == 0) {
        ig->type = OP_INT_UV;
        return OP_OK;
    }
    if (strcmp(t, "albedo") == 0) {
        ig->type = OP_INT_ALBEDO;
        return OP_OK;
    }
    if (strcmp(t, "path") != 0 && strcmp(t, "direct") != 0)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <integrator type=\"%s\">: unknown "
                            "integrator (path, direct, field, normals, uv, albedo)", n->file,
                            n->line, t);
    ig->type = strcmp(t, "path") == 0 ? OP_INT_PATH : OP_INT_DIRECT;
    GET_OR_FAIL(op_node_bool(n, "hideEmitters", 0, &ig->hide_emitters, err));
    if (ig->type == OP_INT_DIRECT) {
        long long es, bs;
        GET_OR_FAIL(op_node_int(n, "emitterSamples", 1, &es, err));
        GET_OR_FAIL(op_node_int(n, "bsdfSamples", 1, &bs, err));
        if (es < 0 || es > 65536 || bs < 0 || bs > 65536)
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <integrator type=\"direct\">: "
                                "emitterSamples %lld and bsdfSamples %lld must be in 0..65536",
                                n->file, n->line, es, bs);
        int strict;
        GET_OR_FAIL(op_node_bool(n, "strictNormals", 0, &strict, err));
        ig->emitter_samples = (int)es;
        ig->bsdf_samples = (int)bs;
        return OP_OK;
    }
    GET_OR_FAIL(op_node_int(n, "maxDepth", -1, &md, err));
    GET_OR_FAIL(op_node_int(n, "rrDepth", 5, &rr, err));
    int strict;
    GET_OR_FAIL(op_node_bool(n, "strictNormals", 0, &strict, err));
    if (md < -1 || md == 0 || md > 100000 || rr < 1 || rr > 100000)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <integrator type=\"path\">: maxDepth %lld "
                            "(-1 or >= 1) or rrDepth %lld (>= 1) out of range", n->file, n->line,
                            md, rr);
    ig->max_depth = (int)md;
    ig->rr_depth = (int)rr;
    return OP_OK;
}

static op_status build_all(builder *b, op_node *root, op_error *err)
{
    op_scene *s = b->s;
    root->used = 1;
    op_node *sensor = NULL, *integrator = NULL, *film = NULL, *sampler = NULL;
    for (int i = 0; i < root->nchildren; i++) {
        op_node *c = root->children[i];
        if (strcmp(c->tag, "sensor") == 0) {
            if (sensor)
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: a second <sensor> (only one is "
                                    "supported)", c->file, c->line);
            sensor = c;
        } else if (strcmp(c->tag, "integrator") == 0) {
            integrator = c;
        }
    }
    if (sensor)
        for (int i = 0; i < sensor->nchildren; i++) {
            op_node *c = sensor->children[i];
            if (strcmp(c->tag, "film") == 0)
                film = c;
            else if (strcmp(c->tag, "sampler") == 0)
                sampler = c;
            else
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <%s> is not supported inside "
                                    "<sensor>", c->file, c->line, c->tag);
        }
    GET_OR_FAIL(op_film_build(film, &s->film, err));
    GET_OR_FAIL(op_sampler_build(sampler, &s->sampler, err));
    GET_OR_FAIL(op_camera_build(sensor, s->film.full_width, s->film.full_height, &s->camera, err));
    if (sensor)
        GET_OR_FAIL(check_position(b, sensor, "the camera's position", s->camera.origin, err));
    GET_OR_FAIL(build_integrator(integrator, &s->integrator, err));
    GET_OR_FAIL(count_file_uses(b, root, err));
    for (int i = 0; i < root->nchildren; i++) {
        op_node *c = root->children[i];
        int idx = -1;
        if (strcmp(c->tag, "shape") == 0) {
            GET_OR_FAIL(add_shape(b, c, err));
        } else if (strcmp(c->tag, "emitter") == 0) {
            if (strcmp(c->type, "area") == 0)
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"area\"> must be "
                                    "nested in a <shape>", c->file, c->line);
            GET_OR_FAIL(add_emitter(b, c, NULL, -1, &idx, err));
        } else if (strcmp(c->tag, "bsdf") == 0 || strcmp(c->tag, "texture") == 0 ||
                   strcmp(c->tag, "subsurface") == 0 || strcmp(c->tag, "sensor") == 0 ||
                   strcmp(c->tag, "integrator") == 0) {
            /* built where referenced (or above); unreferenced ones are reported as unused */
        } else {
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <%s type=\"%s\"> is not supported",
                                c->file, c->line, c->tag, c->type ? c->type : "");
        }
    }
    /* shapes no longer move: point area emitters at their meshes */
    for (int i = 0; i < s->nemitters; i++)
        if (s->emitters[i].type == OP_EM_AREA)
            s->emitters[i].mesh = &s->shapes[s->emitters[i].shape].mesh;
    for (int i = 0; i < s->nshapes; i++)
        if (s->shapes[i].sss < 0 && s->bsdfs[s->shapes[i].bsdf].masked)
            s->has_masks = 1;
    if (s->nshapes == 0)
        op_log(OP_LOG_WARN, "%s: the scene has no shapes", s->path);
    if (s->nemitters == 0 && s->integrator.type <= OP_INT_DIRECT)
        op_log(OP_LOG_WARN, "%s: the scene has no emitters; the image will be black", s->path);
    op_v3 lo = v3s(INFINITY), hi = v3s(-INFINITY);
    for (int i = 0; i < s->nshapes; i++) {
        const op_shape_rec *sh = &s->shapes[i];
        const op_trimesh *m = &sh->mesh;
        for (int k = 0; k < m->nverts; k++) {
            op_v3 p = v3(m->pos[3 * k], m->pos[3 * k + 1], m->pos[3 * k + 2]);
            if (sh->instanced)
                p = op_place_point(&sh->place, p);
            lo = v3(fminf(lo.x, p.x), fminf(lo.y, p.y), fminf(lo.z, p.z));
            hi = v3(fmaxf(hi.x, p.x), fmaxf(hi.y, p.y), fmaxf(hi.z, p.z));
        }
    }
    if (s->nshapes == 0)
        lo = hi = v3s(0.0f);
    s->bmin = lo;
    s->bmax = hi;
    GET_OR_FAIL(op_sss_plan(s, b->lim->sss_points, err));
    op_accel_shape *shapes = calloc((size_t)(s->nshapes ? s->nshapes : 1), sizeof *shapes);
    if (!shapes)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    for (int i = 0; i < s->nshapes; i++) {
        const op_shape_rec *sh = &s->shapes[i];
        shapes[i].mesh = &sh->mesh;
        shapes[i].place = NULL;
        if (sh->instanced) { /* its prototype: instances share its BVH */
            shapes[i].mesh = &s->protos[sh->proto];
            shapes[i].place = &sh->place;
            shapes[i].proto = sh->proto;
        }
    }
    op_status st = op_accel_build(shapes, s->nshapes, &s->accel, err);
    free(shapes);
    return st;
}

op_status op_scene_build(op_node *root, const char *path, const op_scene_limits *limits,
                         op_scene *s, op_error *err)
{
    builder b;
    memset(&b, 0, sizeof b);
    b.s = s;
    b.lim = limits;
    s->env = -1;
    s->path = strdup(path);
    char *tmp = strdup(path);
    b.meshes = op_mesh_cache_new();
    s->textures = op_tex_cache_new(limits->image_pixels);
    if (!s->path || !tmp || !b.meshes || !s->textures) {
        free(tmp);
        op_mesh_cache_free(b.meshes);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    }
    snprintf(b.dir, sizeof b.dir, "%s", dirname(tmp));
    free(tmp);
    op_status st = build_all(&b, root, err);
    s->material_paths = b.mat_paths; /* the pre-pass cache's key reads them */
    op_strmap_free(&b.file_keys);
    free(b.file_uses);
    free(b.file_proto);
    op_strmap_free(&b.bsdf_index);
    op_mesh_cache_free(b.meshes);
    if (st == OP_OK)
        op_desc_report_unused(root);
    return st;
}

void op_scene_release(op_scene *s)
{
    for (int i = 0; i < s->nshapes; i++)
        if (!s->shapes[i].instanced)
            op_trimesh_free(&s->shapes[i].mesh);
    free(s->shapes);
    for (int i = 0; i < s->nprotos; i++)
        op_trimesh_free(&s->protos[i]);
    free(s->protos);
    free(s->bsdfs);
    for (int i = 0; i < s->nemitters; i++)
        op_emitter_free(&s->emitters[i]);
    free(s->emitters);
    free(s->sss);
    for (int i = 0; i < s->nmaterials; i++) {
        op_material_close(s->materials[i]);
        free(s->material_paths[i]);
    }
    free(s->materials);
    free(s->material_paths);
    op_tex_cache_free(s->textures);
    op_accel_free(s->accel);
    free(s->path);
}
