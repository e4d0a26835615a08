/* scene_build.c - the scene builder (see scene_build.h). */
#include "scene/scene_build.h"

#include "scene/describe.h"
#include "scene/limits.h"
#include "scene/material_name.h"
#include "scene/medium_desc.h"
#include "scene/scene_path.h"
#include "scene/subsurface_desc.h"
#include "sss/layout.h"
#include "sss/prepass.h"

#include <limits.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>


/* Growing arrays and what the builder needs while it works. */
typedef struct builder {
    op_scene *s;
    const op_scene_description *d;
    const op_scene_limits *lim;
    const char *dir;
    int cap_shapes, cap_bsdfs, cap_emitters, cap_sss, cap_mats, cap_media;
    op_strmap medium_index;     /* a built medium node's address -> its index, as bsdf_index */
    op_strmap bsdf_index;       /* a built bsdf node's address ("%p") -> its index, to share
                                   referenced ones */
    char **mat_paths;           /* resolved path of each opened material */
    op_mesh_cache *meshes;
    int *file_proto;      /* per mesh k the description counted (op_describe_mesh_index): its
                             prototype's index into s->protos once loaded, or -1 */
    op_limit_tally tally; /* the triangles stored so far (a prototype once) and the estimated
                             memory of what is loaded, against the limits */
    int images_charged;   /* the texture cache's images counted in tally */
} builder;

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

/* A null (index-matched) boundary: a mask of opacity 0, which every ray passes straight
 * through without a bounce (a passable surface to the integrators). */
static op_status add_null_bsdf(builder *b, int *index, op_error *err)
{
    op_scene *s = b->s;
    if (!op_array_grow((void **)&s->bsdfs, &b->cap_bsdfs, s->nbsdfs, sizeof *s->bsdfs))
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    op_bsdf *n = &s->bsdfs[s->nbsdfs];
    op_bsdf_default(n);
    n->masked = 1;
    n->opacity = v3s(0.0f);
    *index = s->nbsdfs++;
    return OP_OK;
}

/* The medium of <medium> node, built once however many objects refer to it. */
static op_status add_medium(builder *b, op_node *node, int *index, op_error *err)
{
    op_scene *s = b->s;
    char key[32];
    snprintf(key, sizeof key, "%p", (const void *)node);
    const op_strmap_entry *known = op_strmap_find(&b->medium_index, key, strlen(key));
    if (known) {
        *index = known->index;
        return OP_OK;
    }
    if (!op_array_grow((void **)&s->media, &b->cap_media, s->nmedia, sizeof *s->media))
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    GET_OR_FAIL(op_medium_read(node, &s->media[s->nmedia], err));
    *index = s->nmedia++; /* owned by the scene from here */
    op_strmap_entry *e = op_strmap_add(&b->medium_index, key);
    if (!e)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    e->index = *index;
    return OP_OK;
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
    if (bytes == 0 || op_limit_add_bytes(b->lim, &b->tally, bytes, "its images", err) == OP_OK)
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
    op_status st = op_emitter_build(node, mesh, shape, s->textures, b->lim->image_pixels, e, err);
    if (st == OP_OK && (e->type == OP_EM_POINT || e->type == OP_EM_SPOT ||
                        e->type == OP_EM_COLLIMATED || e->type == OP_EM_PROJECTOR))
        st = op_limit_position(b->lim, node, "the light's position", e->pos, err);
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

static op_status add_subsurface(builder *b, op_node *node, int *index, op_error *err)
{
    op_scene *s = b->s;
    if (!op_array_grow((void **)&s->sss, &b->cap_sss, s->nsss, sizeof *s->sss))
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    op_sss_desc *d = &s->sss[s->nsss];
    op_subsurface_spec spec;
    GET_OR_FAIL(op_subsurface_read(node, b->dir, b->lim, d, &spec, err));
    if (!d->is_dipole) {
        if (open_material(b, spec.path, &d->material, err))
            return op_subsurface_error(node, &spec, err);
        GET_OR_FAIL(op_subsurface_bind(node, &spec, b->lim, d, err));
    }
    *index = s->nsss++;
    return OP_OK;
}

/* The object-space prototype of entry k (loaded, or for a sphere tessellated, on first use)
 * in *index. */
static op_status file_prototype(builder *b, int k, const char *path, const char *kind,
                                uint32_t shape_index, int face, int fliptex, int *index,
                                op_error *err)
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
        GET_OR_FAIL(op_shape_sphere(m, OP_SPHERE_SEGMENTS, err));
    else
        GET_OR_FAIL(op_mesh_cache_get(b->meshes, path, kind, shape_index, face, fliptex, m, err));
    op_matrix4 id = op_matrix4_identity();
    op_status st = op_limit_add_triangles(b->lim, &b->tally, m->ntris, err);
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
    int file = op_describe_is_mesh_file(t);
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
    if (strcmp(t, "cylinder") == 0) {
        double p0[3], p1[3], zero[3] = {0, 0, 0}, z[3] = {0, 0, 1}, r;
        op_matrix4 local;
        GET_OR_FAIL(op_node_vec3(node, "p0", zero, p0, err));
        GET_OR_FAIL(op_node_vec3(node, "p1", z, p1, err));
        GET_OR_FAIL(op_node_float(node, "radius", 1.0, &r, err));
        if (op_cylinder_placement(p0, p1, r, &local, err))
            return op_error_prefix(err, "%s:%d: <shape type=\"cylinder\">: ", node->file,
                                   node->line);
        xf = op_matrix4_mul(&xf, &local);
    }
    op_status st;
    int face = 0, fliptex = 0;
    uint32_t shape_index = 0;
    char path[4096] = "", key[4200] = "";
    if (file || op_describe_may_instance(node))
        GET_OR_FAIL(op_describe_mesh(b->d, node, path, sizeof path, &face, &fliptex, &shape_index,
                                     key, sizeof key, err));
    int k = op_describe_mesh_index(b->d, key);
    if (op_describe_may_instance(node) && k >= 0 && b->d->mesh_uses[k] >= 2) {
        int p = 0;
        st = file_prototype(b, k, path, t, shape_index, face, fliptex, &p, err);
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
        if ((st = op_limit_position(b->lim, node, "a corner of its bounds", lo, err)) == OP_OK)
            st = op_limit_position(b->lim, node, "a corner of its bounds", hi, err);
        return st;
    }
    if (file) {
        st = op_mesh_cache_get(b->meshes, path, t, shape_index, face, fliptex, m, err);
    } else if (strcmp(t, "sphere") == 0) {
        st = op_shape_sphere(m, OP_SPHERE_SEGMENTS, err);
    } else if (strcmp(t, "rectangle") == 0) {
        st = op_shape_rectangle(m, err);
    } else if (strcmp(t, "cube") == 0) {
        st = op_shape_cube(m, err);
    } else if (strcmp(t, "disk") == 0) {
        st = op_shape_disk(m, OP_DISK_SEGMENTS, err);
    } else if (strcmp(t, "cylinder") == 0) {
        st = op_shape_cylinder(m, OP_CYLINDER_SEGMENTS, err);
    } else {
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <shape type=\"%s\">: unknown shape type "
                            "(obj, ply, serialized, sphere, rectangle, cube, disk, cylinder)",
                            node->file, node->line, t);
    }
    if (st == OP_OK)
        st = op_limit_add_triangles(b->lim, &b->tally, m->ntris, err);
    if (st == OP_OK)
        st = op_trimesh_finish(m, &xf, flip, err);
    if (st) {
        op_trimesh_free(m); /* not yet the scene's: add_shape counts the shape on success only */
        return op_error_prefix(err, "%s:%d: <shape type=\"%s\">: ", node->file, node->line, t);
    }
    if ((st = op_limit_position(b->lim, node, "a corner of its bounds", m->bmin, err)) == OP_OK)
        st = op_limit_position(b->lim, node, "a corner of its bounds", m->bmax, err);
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
    sh->bsdf = sh->emitter = sh->sss = sh->interior = sh->exterior = -1;
    snprintf(sh->label, sizeof sh->label, "%s:%d", node->file, node->line);
    GET_OR_FAIL(build_mesh(b, node, sh, err));
    s->nshapes++; /* owns its mesh from here on */
    op_node *bsdf = NULL, *em = NULL, *sss = NULL, *meter = NULL;
    int interior = -1, exterior = -1;
    for (int i = 0; i < node->nchildren; i++) {
        op_node *c = node->children[i];
        const char *cn = op_node_child_name(node, i);
        if (strcmp(c->tag, "medium") == 0) {
            int *side = cn && strcmp(cn, "interior") == 0   ? &interior
                        : cn && strcmp(cn, "exterior") == 0 ? &exterior
                                                            : NULL;
            if (!side || *side >= 0)
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <medium> inside <shape> must be "
                                    "named interior or exterior, each once", c->file, c->line);
            GET_OR_FAIL(add_medium(b, c, side, err));
        } else if (strcmp(c->tag, "bsdf") == 0 && !bsdf)
            bsdf = c;
        else if (strcmp(c->tag, "emitter") == 0 && !em)
            em = c;
        else if (strcmp(c->tag, "subsurface") == 0 && !sss)
            sss = c;
        else if (strcmp(c->tag, "sensor") == 0 && !meter) /* the irradiancemeter (describe.c) */
            meter = c;
        else
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <%s> %sis not supported inside <shape>",
                                c->file, c->line, c->tag,
                                (strcmp(c->tag, "bsdf") == 0 || strcmp(c->tag, "emitter") == 0 ||
                                 strcmp(c->tag, "subsurface") == 0 ||
                                 strcmp(c->tag, "sensor") == 0) ? "a second time " : "");
    }
    int bi = -1, ei = -1, si = -1;
    int transition = interior >= 0 || exterior >= 0;
    s->shapes[index].interior = interior;
    s->shapes[index].exterior = exterior;
    if (sss && transition)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <shape>: a <subsurface> shape cannot also "
                            "be a medium's boundary (give the medium, or the subsurface)",
                            node->file, node->line);
    if (meter) {
        if (bsdf && strcmp(bsdf->type, "null") == 0)
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <shape>: an irradiancemeter's shape "
                                "cannot be index-matched (<bsdf type=\"null\">)", node->file,
                                node->line);
        s->camera.shape = index;
        s->camera.surface_rectangle = strcmp(node->type, "rectangle") == 0;
        if (op_node_child(meter, "medium", 0)) {
            if (op_node_child(meter, "medium", 1))
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <sensor>: more than one <medium>",
                                    meter->file, meter->line);
            GET_OR_FAIL(add_medium(b, op_node_child(meter, "medium", 0), &s->camera_medium, err));
        }
        if (exterior >= 0) /* the meter looks out of its shape's front, into its exterior */
            s->camera_medium = exterior;
    }
    /* a medium's boundary without a bsdf: index-matched in Mitsuba 0.6, diffuse in Mitsuba 3 */
    if ((bsdf && strcmp(bsdf->type, "null") == 0) ||
        (!bsdf && !em && !meter && transition && node->dialect == OP_DIALECT_MITSUBA_0)) {
        if (bsdf)
            op_node_mark_used(bsdf);
        bsdf = NULL;
        GET_OR_FAIL(add_null_bsdf(b, &bi, err));
    } else {
        GET_OR_FAIL(add_bsdf(b, sss ? NULL : bsdf, &bi, err));
    }
    s->shapes[index].bsdf = bi;
    op_bsdf_type bt = s->bsdfs[bi].type;
    if (s->bsdfs[bi].bump.needs_uv && !s->shapes[index].mesh.uv)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <bsdf type=\"%s\">: a bump or normal map "
                            "needs the shape's texture coordinates, which this shape lacks (as "
                            "Mitsuba 0.6 requires)", bsdf->file, bsdf->line, bsdf->type);
    if (!sss && bt == OP_BSDF_COATING)
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

static op_status build_all(builder *b, op_node *root, op_error *err)
{
    op_scene *s = b->s;
    s->film = b->d->film;
    s->sampler = b->d->sampler;
    s->camera = b->d->camera;
    s->integrator = b->d->integrator;
    s->camera_medium = -1;
    for (int i = 0; i < root->nchildren; i++) {
        op_node *c = root->children[i];
        int idx = -1;
        if (strcmp(c->tag, "shape") == 0) {
            GET_OR_FAIL(add_shape(b, c, err));
        } else if (strcmp(c->tag, "emitter") == 0 && strcmp(c->type, "area") != 0) {
            GET_OR_FAIL(add_emitter(b, c, NULL, -1, &idx, err));
        } else if (strcmp(c->tag, "sensor") == 0 && op_node_child(c, "medium", 0)) {
            if (op_node_child(c, "medium", 1))
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <sensor>: more than one <medium>",
                                    c->file, c->line);
            GET_OR_FAIL(add_medium(b, op_node_child(c, "medium", 0), &s->camera_medium, err));
        } /* the rest (an area emitter with an id among them) is built where referenced (the
             description refused what is not supported); unreferenced objects are reported
             as unused */
    }
    /* shapes no longer move: point area emitters and the irradiancemeter at their meshes */
    for (int i = 0; i < s->nemitters; i++)
        if (s->emitters[i].type == OP_EM_AREA)
            s->emitters[i].mesh = &s->shapes[s->emitters[i].shape].mesh;
    if (s->camera.type == OP_CAMERA_IRRADIANCEMETER) {
        if (s->camera.shape < 0) /* the description finds it in a shape the build builds */
            return op_error_set(err, OP_ERR_INTERNAL, "%s: the irradiancemeter's shape was not "
                                "built", s->path);
        s->camera.surface = &s->shapes[s->camera.shape].mesh;
    }
    for (int i = 0; i < s->nshapes; i++)
        if (s->shapes[i].sss < 0 && op_bsdf_passable(&s->bsdfs[s->shapes[i].bsdf]))
            s->has_passable = 1;
    if (s->nshapes == 0)
        op_log(OP_LOG_WARN, "%s: the scene has no shapes", s->path);
    int volumetric = s->integrator.type == OP_INT_PATH && s->integrator.volumetric;
    if (volumetric && s->nmedia > 0 && s->nsss > 0)
        return op_error_set(err, OP_ERR_INPUT, "%s: volpath renders participating media or "
                            "translucent (<subsurface>) shapes, not both in one scene", s->path);
    if (s->nmedia > 0 && !volumetric)
        op_log(OP_LOG_WARN, "%s: the scene's participating media are ignored by this integrator "
               "(as Mitsuba's path does; their null boundaries are passed through): use "
               "volpath to render them", s->path);
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
    s->sss_plan = calloc((size_t)(s->nsss ? s->nsss : 1), sizeof *s->sss_plan);
    if (!s->sss_plan)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    GET_OR_FAIL(op_sss_plan(s, b->lim->sss_points, s->sss_plan, err));
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

/* Whether the builders render an object of element tag and this type: theirs to say. */
static int type_known(const char *tag, const char *type)
{
    if (strcmp(tag, "bsdf") == 0)
        return op_bsdf_type_known(type);
    if (strcmp(tag, "texture") == 0)
        return op_texture_type_known(type);
    if (strcmp(tag, "emitter") == 0)
        return op_emitter_type_known(type);
    if (strcmp(tag, "medium") == 0)
        return op_medium_type_known(type);
    if (strcmp(tag, "phase") == 0)
        return op_phase_type_known(type);
    return 1; /* other elements: their types are not checked here */
}

op_status op_scene_build(const op_scene_description *d, op_scene *s, op_error *err)
{
    builder b;
    memset(&b, 0, sizeof b);
    b.s = s;
    b.d = d;
    b.lim = &d->limits;
    b.dir = d->dir;
    s->env = -1;
    s->path = strdup(d->path);
    b.meshes = op_mesh_cache_new();
    s->textures = op_tex_cache_new(d->limits.image_pixels);
    b.file_proto = malloc((size_t)(d->nmeshes ? d->nmeshes : 1) * sizeof *b.file_proto);
    if (!s->path || !b.meshes || !s->textures || !b.file_proto) {
        op_mesh_cache_free(b.meshes);
        free(b.file_proto);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    }
    for (int k = 0; k < d->nmeshes; k++)
        b.file_proto[k] = -1;
    op_status st = build_all(&b, d->root, err);
    s->material_paths = b.mat_paths; /* the pre-pass cache's key reads them */
    free(b.file_proto);
    op_strmap_free(&b.bsdf_index);
    op_strmap_free(&b.medium_index);
    op_mesh_cache_free(b.meshes);
    if (st == OP_OK)
        op_desc_report_unused(d->root, type_known);
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
    for (int i = 0; i < s->nmedia; i++)
        op_pmedium_free(&s->media[i]);
    free(s->media);
    free(s->sss_plan);
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
