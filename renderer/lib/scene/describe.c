/* describe.c - a scene described (see describe.h). */
#include "scene/describe.h"

#include <libgen.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "geometry/mesh.h"
#include "opaline_image.h"
#include "scene/integrator_desc.h"
#include "scene/limits.h"
#include "scene/scene_path.h"
#include "scene/subsurface_desc.h"

/* The loaded-size estimate (op_scene_info.load_bytes), calibrated against the peak resident
 * memory of --check (a build, no sanitizer): 10.6 to 12.4 MB for scenes of a few small
 * shapes (the process, its libraries, Embree); 144 bytes per stored triangle (the mesh as
 * read and as placed, Embree's BVH: the builder's load-memory charge) plus a mesh file's size
 * (mapped), an OBJ's triangles taken from its size at 24 bytes each (spot.obj has 56, the
 * Stanford bunny 35); a material at 3 times its file's size (an SVD preset of 12 MB took
 * 30 MB, a Tucker one of 14 MB took 14 MB); per texel of a texture its linear RGB copy and
 * the decoded file, of an environment map the map and its sampling tables. */
#define BASE_BYTES (16LL << 20)
#define OBJ_BYTES_PER_TRIANGLE 24
#define MATERIAL_FILE_FACTOR 3
#define TEXTURE_BYTES_PER_TEXEL(channels) (12 + 4 * (channels))
#define ENVMAP_BYTES_PER_TEXEL(channels) (16 + 4 * (channels))
/* An image whose header the image reader refuses (the build says why): counted as this many
 * times its file size. */
#define UNKNOWN_IMAGE_FACTOR 64

/* Records path in d->files once; *added: whether it is new. */
static op_status add_file(op_scene_description *d, const char *path, int *added, op_error *err)
{
    *added = 0;
    if (op_strmap_find(&d->file_keys, path, strlen(path)))
        return OP_OK;
    if (!op_array_grow((void **)&d->files, &d->cap_files, d->nfiles, sizeof *d->files) ||
        !(d->files[d->nfiles] = strdup(path)) || !op_strmap_add(&d->file_keys, path))
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    d->nfiles++;
    *added = 1;
    return OP_OK;
}

/* Opens path as its reader would (the same refusal of a missing or unreadable file, and the
 * run's record of inputs), closes it and records it in d->files (*added: whether it is new
 * there). *size: its size. */
static op_status open_file(op_scene_description *d, const char *path, uint64_t *size, int *added,
                           op_error *err)
{
    int fd;
    GET_OR_FAIL(op_file_open(path, &fd, size, err));
    close(fd);
    return add_file(d, path, added, err);
}

/* open_file for node's file, its errors prefixed by node's element. */
static op_status find_file(op_scene_description *d, const op_node *node, const char *path,
                           uint64_t *size, int *added, op_error *err)
{
    if (open_file(d, path, size, added, err))
        return op_error_prefix(err, "%s:%d: <%s type=\"%s\">: ", node->file, node->line, node->tag,
                               node->type ? node->type : "");
    return OP_OK;
}

/* The mesh file a mesh file's shape node names, found as op_node_resolve finds it, and its
 * loading options (Mitsuba's serialized shape has a shapeIndex and no flipTexCoords); key
 * gets "face flip index path" identifying one loaded mesh. */
static op_status file_mesh(op_node *node, char *path, size_t n, int *face, int *fliptex,
                           uint32_t *shape_index, char *key, size_t nk, op_error *err)
{
    const char *t = node->type, *fn;
    GET_OR_FAIL(op_node_string(node, "filename", NULL, &fn, err));
    if (!fn)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <shape type=\"%s\"> needs a filename",
                            node->file, node->line, t);
    GET_OR_FAIL(op_node_bool(node, "faceNormals", 0, face, err));
    *fliptex = 0;
    *shape_index = 0;
    if (strcmp(t, "serialized") == 0) {
        long long index;
        GET_OR_FAIL(op_node_int(node, "shapeIndex", 0, &index, err));
        if (index < 0 || index > UINT32_MAX)
            return op_prop_error(node, op_node_prop(node, "shapeIndex"), err, OP_ERR_INPUT,
                                 "%lld is not in 0..%u", index, UINT32_MAX);
        *shape_index = (uint32_t)index;
    } else {
        GET_OR_FAIL(op_node_bool(node, "flipTexCoords", strcmp(t, "obj") == 0, fliptex, err));
    }
    char *found = op_node_resolve(node, fn);
    if (!found)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    snprintf(path, n, "%s", found);
    free(found);
    snprintf(key, nk, "%d %d %u %s", *face, *fliptex, *shape_index, path);
    return OP_OK;
}

int op_describe_is_mesh_file(const char *type)
{
    return strcmp(type, "obj") == 0 || strcmp(type, "ply") == 0 ||
           strcmp(type, "serialized") == 0;
}

int op_describe_may_instance(const op_node *node)
{
    if (!op_describe_is_mesh_file(node->type) && strcmp(node->type, "sphere") != 0)
        return 0;
    for (int i = 0; i < node->nchildren; i++)
        if (strcmp(node->children[i]->tag, "emitter") == 0 ||
            strcmp(node->children[i]->tag, "subsurface") == 0 ||
            strcmp(node->children[i]->tag, "sensor") == 0)
            return 0;
    return 1;
}

op_status op_describe_mesh(const op_scene_description *d, op_node *node, char *path, size_t n,
                           int *face, int *fliptex, uint32_t *shape_index, char *key, size_t nk,
                           op_error *err)
{
    if (strcmp(node->type, "sphere") != 0)
        return file_mesh(node, path, n, face, fliptex, shape_index, key, nk, err);
    *face = *fliptex = 0;
    *shape_index = 0;
    snprintf(path, n, "%s", "");
    snprintf(key, nk, "%s", "sphere");
    return OP_OK;
}

/* Counts the uses of each shared mesh by shapes that may become instances. Nodes whose
 * parameters are bad are skipped here (building them reports the error). */
static op_status count_mesh_uses(op_scene_description *d, op_node *root, op_error *err)
{
    for (int i = 0; i < root->nchildren; i++) {
        op_node *c = root->children[i];
        if (strcmp(c->tag, "shape") != 0 || !op_describe_may_instance(c))
            continue;
        char path[4096], key[4200];
        int face, fliptex;
        uint32_t index;
        op_error scratch;
        if (op_describe_mesh(d, c, path, sizeof path, &face, &fliptex, &index, key, sizeof key,
                             &scratch))
            continue;
        op_strmap_entry *e = op_strmap_find(&d->mesh_keys, key, strlen(key));
        if (!e) {
            int k = d->nmeshes;
            if (!op_array_grow((void **)&d->mesh_uses, &d->cap_meshes, k, sizeof *d->mesh_uses) ||
                !(e = op_strmap_add(&d->mesh_keys, key)))
                return op_error_set(err, OP_ERR_NOMEM, "out of memory");
            e->index = k;
            d->mesh_uses[k] = 0;
            d->nmeshes++;
        }
        d->mesh_uses[e->index]++;
    }
    return OP_OK;
}

int op_describe_mesh_index(const op_scene_description *d, const char *key)
{
    const op_strmap_entry *e = op_strmap_find(&d->mesh_keys, key, strlen(key));
    return e ? e->index : -1;
}

/* Finds the image file path of node (a bitmap texture, or an envmap) and adds its estimated
 * memory. */
static op_status find_image(op_scene_description *d, const op_node *node, const char *path,
                            int envmap, op_error *err)
{
    uint64_t size = 0;
    int added = 0;
    GET_OR_FAIL(find_file(d, node, path, &size, &added, err));
    if (!added) /* the texture cache holds it once */
        return OP_OK;
    int w, h, channels;
    op_error ignored;
    if (op_image_read_size(path, &w, &h, &channels, &ignored) != OP_OK)
        d->load_bytes += (long long)size * UNKNOWN_IMAGE_FACTOR;
    else
        d->load_bytes += (long long)w * h * (envmap ? ENVMAP_BYTES_PER_TEXEL(channels) :
                                                      TEXTURE_BYTES_PER_TEXEL(channels));
    return OP_OK;
}

/* The bitmap textures anywhere under node (a bsdf, its nested bsdfs and textures; an emitter). */
static op_status find_textures(op_scene_description *d, op_node *node, op_error *err)
{
    for (int i = 0; i < node->nchildren; i++) {
        op_node *c = node->children[i];
        if (strcmp(c->tag, "texture") == 0 && c->type && strcmp(c->type, "bitmap") == 0) {
            const char *fn;
            GET_OR_FAIL(op_node_string(c, "filename", NULL, &fn, err));
            if (!fn || !fn[0])
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <texture type=\"bitmap\"> needs a "
                                    "<string name=\"filename\">", c->file, c->line);
            char *path = op_node_resolve(c, fn);
            if (!path)
                return op_error_set(err, OP_ERR_NOMEM, "out of memory");
            op_status st = find_image(d, c, path, 0, err);
            free(path);
            GET_OR_FAIL(st);
        } else if (strcmp(c->tag, "bsdf") == 0 || strcmp(c->tag, "texture") == 0) {
            GET_OR_FAIL(find_textures(d, c, err));
        }
    }
    return OP_OK;
}

/* The grid volumes (.vol files) anywhere under node, in the media of shapes and the sensor:
 * recorded once each, loaded as floats (a uint8 grid's file is a quarter of that). */
static op_status find_volumes(op_scene_description *d, op_node *node, op_error *err)
{
    for (int i = 0; i < node->nchildren; i++) {
        op_node *c = node->children[i];
        if (strcmp(c->tag, "volume") == 0 && c->type && strcmp(c->type, "gridvolume") == 0) {
            const char *fn;
            GET_OR_FAIL(op_node_string(c, "filename", NULL, &fn, err));
            if (!fn || !fn[0])
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <volume type=\"gridvolume\"> "
                                    "needs a <string name=\"filename\">", c->file, c->line);
            char *path = op_node_resolve(c, fn);
            if (!path)
                return op_error_set(err, OP_ERR_NOMEM, "out of memory");
            uint64_t size = 0;
            int added = 0;
            op_status st = find_file(d, c, path, &size, &added, err);
            free(path);
            GET_OR_FAIL(st);
            if (added)
                d->load_bytes += (long long)size * 4;
        } else if (strcmp(c->tag, "shape") == 0 || strcmp(c->tag, "sensor") == 0 ||
                   strcmp(c->tag, "medium") == 0) {
            GET_OR_FAIL(find_volumes(d, c, err));
        }
    }
    return OP_OK;
}

/* The triangles of a mesh file as far as its header tells: a serialized mesh's count (*exact
 * then set); a PLY's faces (at least twice its vertices, as a closed mesh of quads has); an
 * OBJ's, or a file's whose header is refused (the build says why), from its size. */
static long long file_triangles(const char *kind, const char *path, uint32_t shape_index,
                                uint64_t size, int *exact)
{
    uint64_t verts, faces;
    op_error ignored;
    *exact = strcmp(kind, "serialized") == 0 &&
             op_mesh_serialized_counts(path, shape_index, &verts, &faces, &ignored) == OP_OK;
    if (*exact)
        return (long long)faces;
    if (strcmp(kind, "ply") == 0 && op_mesh_ply_counts(path, &verts, &faces, &ignored) == OP_OK)
        return (long long)(faces > 2 * verts ? faces : 2 * verts);
    return (long long)(size / OBJ_BYTES_PER_TRIANGLE);
}

/* A shape: its mesh file, or its built-in triangles (counted against the triangles and
 * load-memory limits in tally as the build counts them: a shared unit sphere once,
 * *sphere_counted then set), and the files of its bsdf and subsurface. */
static op_status describe_shape(op_scene_description *d, op_node *node, op_limit_tally *tally,
                                int *sphere_counted, op_error *err)
{
    const char *t = node->type;
    d->shapes++;
    if (op_describe_is_mesh_file(t)) {
        char path[4096], key[4200];
        uint64_t size = 0;
        int face, fliptex, added = 0, exact;
        uint32_t index;
        GET_OR_FAIL(op_describe_mesh(d, node, path, sizeof path, &face, &fliptex, &index, key,
                                     sizeof key, err));
        GET_OR_FAIL(find_file(d, node, path, &size, &added, err));
        d->triangles = -1;
        long long n = file_triangles(t, path, index, size, &exact);
        d->load_bytes += (long long)size + n * OP_LOAD_BYTES_PER_TRIANGLE;
        /* a serialized mesh may hold a thousand times its file's size: its own count is
         * checked against the limits here, before the build allocates for it */
        op_limit_tally alone = {0, 0};
        if (exact && op_limit_add_triangles(&d->limits, &alone, n, err))
            return op_error_prefix(err, "%s:%d: <shape type=\"%s\">: ", node->file, node->line,
                                   t);
    } else {
        op_trimesh m;
        memset(&m, 0, sizeof m);
        op_status st = OP_OK;
        if (strcmp(t, "sphere") == 0)
            st = op_shape_sphere(&m, OP_SPHERE_SEGMENTS, err);
        else if (strcmp(t, "rectangle") == 0)
            st = op_shape_rectangle(&m, err);
        else if (strcmp(t, "cube") == 0)
            st = op_shape_cube(&m, err);
        else if (strcmp(t, "disk") == 0)
            st = op_shape_disk(&m, OP_DISK_SEGMENTS, err);
        else if (strcmp(t, "cylinder") == 0)
            st = op_shape_cylinder(&m, OP_CYLINDER_SEGMENTS, err);
        else
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <shape type=\"%s\">: unknown shape type "
                                "(obj, ply, serialized, sphere, rectangle, cube, disk, cylinder)",
                                node->file, node->line, t);
        long long n = m.ntris;
        op_trimesh_free(&m);
        GET_OR_FAIL(st);
        int k = op_describe_may_instance(node) ? op_describe_mesh_index(d, "sphere") : -1;
        int shared = k >= 0 && d->mesh_uses[k] >= 2;
        if (d->triangles >= 0)
            d->triangles += n; /* as op_scene_info counts them: an instance's too */
        if (!shared || !*sphere_counted) {
            *sphere_counted |= shared;
            d->load_bytes += n * OP_LOAD_BYTES_PER_TRIANGLE;
            if (op_limit_add_triangles(&d->limits, tally, n, err))
                return op_error_prefix(err, "%s:%d: <shape type=\"%s\">: ", node->file,
                                       node->line, t);
        }
    }
    op_node *bsdf = NULL, *sss = NULL;
    for (int i = 0; i < node->nchildren; i++) {
        op_node *c = node->children[i];
        if (strcmp(c->tag, "bsdf") == 0 && !bsdf)
            bsdf = c;
        else if (strcmp(c->tag, "emitter") == 0)
            d->emitters++;
        else if (strcmp(c->tag, "subsurface") == 0 && !sss)
            sss = c;
    }
    if (bsdf && !sss)
        GET_OR_FAIL(find_textures(d, bsdf, err));
    if (!sss)
        return OP_OK;
    d->subsurface_shapes++;
    op_sss_desc desc;
    op_subsurface_spec spec;
    GET_OR_FAIL(op_subsurface_read(sss, d->dir, &d->limits, &desc, &spec, err));
    if (!desc.is_dipole) {
        uint64_t size = 0;
        int added = 0;
        if (open_file(d, spec.path, &size, &added, err))
            return op_subsurface_error(sss, &spec, err);
        if (added) /* opened once, shared by the shapes that name it */
            d->load_bytes += (long long)size * MATERIAL_FILE_FACTOR;
    }
    return bsdf ? find_textures(d, bsdf, err) : OP_OK;
}

op_status op_describe(op_node *root, const char *path, const op_scene_limits *limits,
                      op_scene_description *d, op_error *err)
{
    d->root = root;
    d->limits = *limits;
    d->path = strdup(path);
    char *tmp = strdup(path);
    if (!d->path || !tmp) {
        free(tmp);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    }
    snprintf(d->dir, sizeof d->dir, "%s", dirname(tmp));
    free(tmp);
    d->load_bytes = BASE_BYTES;
    GET_OR_FAIL(count_mesh_uses(d, root, err));
    op_limit_tally tally = {0, 0}; /* the built-in shapes' triangles, counted as the build does */
    int sphere_counted = 0;
    root->used = 1;
    op_node *sensor = NULL, *integrator = NULL, *film = NULL, *sampler = NULL;
    int on_shape = 0; /* the sensor is a shape's child */
    for (int i = 0; i < root->nchildren; i++) {
        op_node *c = root->children[i];
        if (strcmp(c->tag, "sensor") == 0) {
            if (sensor)
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: a second <sensor> (only one is "
                                    "supported)", c->file, c->line);
            sensor = c;
        } else if (strcmp(c->tag, "integrator") == 0) {
            integrator = c;
        } else if (strcmp(c->tag, "shape") == 0) {
            for (int k = 0; k < c->nchildren; k++) {
                op_node *m = c->children[k];
                if (strcmp(m->tag, "sensor") != 0)
                    continue;
                if (sensor)
                    return op_error_set(err, OP_ERR_INPUT, "%s:%d: a second <sensor> (only one "
                                        "is supported)", m->file, m->line);
                if (!m->type || strcmp(m->type, "irradiancemeter") != 0)
                    return op_error_set(err, OP_ERR_INPUT, "%s:%d: <sensor type=\"%s\"> inside "
                                        "<shape>: only an irradiancemeter lies on a shape",
                                        m->file, m->line, m->type ? m->type : "");
                sensor = m;
                on_shape = 1;
            }
        }
    }
    if (sensor && !on_shape && sensor->type && strcmp(sensor->type, "irradiancemeter") == 0)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <sensor type=\"irradiancemeter\"> must be "
                            "the child of the <shape> it measures", sensor->file, sensor->line);
    if (sensor)
        for (int i = 0; i < sensor->nchildren; i++) {
            op_node *c = sensor->children[i];
            if (strcmp(c->tag, "film") == 0)
                film = c;
            else if (strcmp(c->tag, "sampler") == 0)
                sampler = c;
            else if (strcmp(c->tag, "medium") != 0) /* the one it sits in: scene_build.c */
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <%s> is not supported inside "
                                    "<sensor>", c->file, c->line, c->tag);
        }
    GET_OR_FAIL(op_film_build(film, &d->film, err));
    GET_OR_FAIL(op_sampler_build(sampler, &d->sampler, err));
    GET_OR_FAIL(op_camera_build(sensor, d->film.full_width, d->film.full_height, &d->camera, err));
    if (sensor && d->camera.type != OP_CAMERA_IRRADIANCEMETER)
        GET_OR_FAIL(op_limit_position(&d->limits, sensor, "the camera's position",
                                      d->camera.origin, err));
    GET_OR_FAIL(op_integrator_read(integrator, &d->integrator, err));
    for (int i = 0; i < root->nchildren; i++) {
        op_node *c = root->children[i];
        if (strcmp(c->tag, "shape") == 0) {
            GET_OR_FAIL(describe_shape(d, c, &tally, &sphere_counted, err));
        } else if (strcmp(c->tag, "emitter") == 0 && strcmp(c->type, "area") == 0) {
            /* defined here with an id (Mitsuba 3's way), it lights the shapes that <ref> it */
            if (!c->id)
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"area\"> must be "
                                    "nested in a <shape>, or have an id a <shape> refers to",
                                    c->file, c->line);
        } else if (strcmp(c->tag, "emitter") == 0) {
            d->emitters++;
            GET_OR_FAIL(find_textures(d, c, err)); /* a spot's or a projector's */
            if (strcmp(c->type, "envmap") == 0) {
                const char *fn;
                GET_OR_FAIL(op_node_string(c, "filename", NULL, &fn, err));
                if (!fn)
                    return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"envmap\"> "
                                        "needs a filename", c->file, c->line);
                char *file = op_node_resolve(c, fn);
                if (!file)
                    return op_error_set(err, OP_ERR_NOMEM, "out of memory");
                op_status st = find_image(d, c, file, 1, err);
                free(file);
                if (st != OP_OK)
                    return st;
            }
        } else if (strcmp(c->tag, "bsdf") != 0 && strcmp(c->tag, "texture") != 0 &&
                   strcmp(c->tag, "subsurface") != 0 && strcmp(c->tag, "sensor") != 0 &&
                   strcmp(c->tag, "integrator") != 0 && strcmp(c->tag, "medium") != 0 &&
                   strcmp(c->tag, "phase") != 0) {
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <%s type=\"%s\"> is not supported",
                                c->file, c->line, c->tag, c->type ? c->type : "");
        }
    }
    GET_OR_FAIL(find_volumes(d, root, err));
    /* the pre-pass finds what the camera sees through a pinhole's rays (sss/prepass.c) */
    if (d->subsurface_shapes && (d->camera.type == OP_CAMERA_ORTHOGRAPHIC ||
                                 d->camera.type == OP_CAMERA_IRRADIANCEMETER ||
                                 (d->camera.type == OP_CAMERA_THINLENS && d->camera.aperture > 0)))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <sensor type=\"%s\">: translucent shapes "
                            "(<subsurface>) are rendered through pinhole sensors only "
                            "(perspective, radiancemeter, thinlens of apertureRadius 0)",
                            sensor->file, sensor->line, sensor->type);
    return OP_OK;
}

void op_describe_release(op_scene_description *d)
{
    op_desc_free(d->root);
    op_strmap_free(&d->mesh_keys);
    op_strmap_free(&d->file_keys);
    free(d->mesh_uses);
    for (int i = 0; i < d->nfiles; i++)
        free(d->files[i]);
    free(d->files);
    free(d->path);
}

void op_describe_info(const op_scene_description *d, op_scene_info *info)
{
    static const char *names[] = {"path", "direct", "normals", "uv", "albedo"};
    memset(info, 0, sizeof *info);
    info->width = d->film.width;
    info->height = d->film.height;
    info->full_width = d->film.full_width;
    info->full_height = d->film.full_height;
    info->spp = d->sampler.spp;
    info->film_type = d->film.ldr ? "ldrfilm" : d->film.mfilm ? "mfilm" : "hdrfilm";
    info->film_filename = d->film.filename[0] ? d->film.filename : NULL;
    info->film_extension = d->film.extension;
    info->integrator = names[d->integrator.type];
    info->shapes = d->shapes;
    info->triangles = d->triangles;
    info->emitters = d->emitters;
    info->subsurface_shapes = d->subsurface_shapes;
    info->instances = -1;
    info->geometry_bytes = -1;
    info->load_bytes = d->load_bytes;
    info->files = (const char *const *)d->files;
    info->nfiles = d->nfiles;
}
