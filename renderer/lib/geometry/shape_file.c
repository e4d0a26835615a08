/* shape_file.c - mesh files for shapes, each file loaded once per option set; every
 * op_mesh_cache_get hands out a copy for op_trimesh_finish to place (in world space, or in
 * object space as the prototype instanced shapes share; see op_mesh_cache in shape.h). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geometry/mesh.h"
#include "scene/scene_desc.h" /* op_strmap */
#include "geometry/shape.h"

typedef struct cache_entry {
    char *path;
    int face_normals, flip_tex;
    op_mesh mesh;
} cache_entry;

struct op_mesh_cache {
    cache_entry *e;
    int n, cap;
    op_strmap keys; /* "face flip index path" -> index into e */
};

op_mesh_cache *op_mesh_cache_new(void)
{
    return calloc(1, sizeof(op_mesh_cache));
}

void op_mesh_cache_free(op_mesh_cache *c)
{
    if (!c)
        return;
    for (int i = 0; i < c->n; i++) {
        free(c->e[i].path);
        op_mesh_free(&c->e[i].mesh);
    }
    free(c->e);
    op_strmap_free(&c->keys);
    free(c);
}

/* The file's mesh as read by kind's loader. */
static op_status load_file(const char *path, const char *kind, uint32_t shape_index, op_mesh *out,
                           op_error *err)
{
    if (strcmp(kind, "ply") == 0)
        return op_mesh_load_ply(path, out, err);
    if (strcmp(kind, "serialized") == 0)
        return op_mesh_load_serialized(path, shape_index, out, err);
    return op_mesh_load_obj(path, out, err);
}

static op_status load_entry(op_mesh_cache *c, const char *path, const char *kind,
                            uint32_t shape_index, int face_normals, int flip_tex,
                            const op_mesh **out, op_error *err)
{
    size_t n = strlen(path) + 32;
    char *key = malloc(n);
    if (!key)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    snprintf(key, n, "%d %d %u %s", face_normals != 0, flip_tex != 0, shape_index, path);
    const op_strmap_entry *found = op_strmap_find(&c->keys, key, strlen(key));
    if (found) {
        free(key);
        *out = &c->e[found->index].mesh;
        return OP_OK;
    }
    op_strmap_entry *k = op_strmap_add(&c->keys, key);
    free(key);
    if (!k)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    k->index = c->n; /* a failed load leaves the key: the scene is refused anyway */
    if (c->n == c->cap) {
        int cap = c->cap ? 2 * c->cap : 8;
        cache_entry *e = realloc(c->e, (size_t)cap * sizeof *e);
        if (!e)
            return op_error_set(err, OP_ERR_NOMEM, "out of memory");
        c->e = e;
        c->cap = cap;
    }
    cache_entry *e = &c->e[c->n];
    memset(e, 0, sizeof *e);
    op_status st = load_file(path, kind, shape_index, &e->mesh, err);
    if (st)
        return st;
    if (flip_tex)
        op_mesh_flip_v(&e->mesh);
    if (face_normals)
        op_mesh_drop_normals(&e->mesh);
    else if (!e->mesh.normals && (st = op_mesh_compute_normals(&e->mesh, err)) != OP_OK) {
        op_mesh_free(&e->mesh);
        return st;
    }
    e->path = strdup(path);
    if (!e->path) {
        op_mesh_free(&e->mesh);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    }
    e->face_normals = face_normals;
    e->flip_tex = flip_tex;
    c->n++;
    op_log(OP_LOG_DEBUG, "loaded %s: %u vertices, %u triangles", path, e->mesh.nverts,
           e->mesh.ntris);
    *out = &e->mesh;
    return OP_OK;
}

op_status op_mesh_cache_get(op_mesh_cache *c, const char *path, const char *kind,
                            uint32_t shape_index, int face_normals, int flip_tex, op_trimesh *m,
                            op_error *err)
{
    const op_mesh *src = NULL;
    op_status st = load_entry(c, path, kind, shape_index, face_normals, flip_tex, &src, err);
    if (st)
        return st;
    if (src->ntris == 0 || src->nverts < 3)
        return op_error_set(err, OP_ERR_INPUT, "%s: the mesh has no triangles", path);
    if (src->nverts > (1u << 28) || src->ntris > (1u << 28))
        return op_error_set(err, OP_ERR_INPUT, "%s: the mesh is too large", path);
    st = op_trimesh_alloc(m, (int)src->nverts, (int)src->ntris, src->normals != NULL,
                          src->uvs != NULL, err);
    if (st)
        return st;
    memcpy(m->pos, src->positions, 3 * (size_t)src->nverts * sizeof(float));
    if (src->normals)
        memcpy(m->nrm, src->normals, 3 * (size_t)src->nverts * sizeof(float));
    if (src->uvs)
        memcpy(m->uv, src->uvs, 2 * (size_t)src->nverts * sizeof(float));
    memcpy(m->idx, src->indices, 3 * (size_t)src->ntris * sizeof(uint32_t));
    return OP_OK;
}
