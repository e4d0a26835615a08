/* describe.h - a scene described: its tree parsed, film, sampler, camera and integrator built,
 * the limits that need no geometry checked, every file it names found (opened and closed, so
 * that a missing one is refused as the build would and the run's input record lists it), its
 * objects counted and its loaded size estimated, without reading a mesh, opening a material or
 * decoding an image. What --estimate, --list-inputs and --merge-tiles need; the scene builder
 * (scene_build.h) starts from it. */
#ifndef OP_SCENE_DESCRIBE_H
#define OP_SCENE_DESCRIBE_H

#include "scene/render_scene.h"
#include "scene/scene_desc.h"

/* The longitude segments of a sphere's tessellation (half as many latitude bands), the
 * segments of a disk and those around a cylinder. */
#define OP_SPHERE_SEGMENTS 128
#define OP_DISK_SEGMENTS 96
#define OP_CYLINDER_SEGMENTS 128

struct op_scene_description {
    char *path;               /* the scene file */
    char dir[4096];           /* its folder: mesh, envmap and material names are relative to it */
    op_scene_limits limits;
    op_node *root;            /* the parsed tree (owned); NULL once a build has consumed it */
    op_film film;
    op_sampler sampler;
    op_camera camera;
    op_integrator integrator;
    int shapes, emitters, subsurface_shapes;
    long long triangles;      /* exact when no shape reads a mesh file, else -1 */
    char **files;             /* the files the scene names (meshes, images, materials), as
                                 resolved, each once, in the order the build reads them */
    int nfiles, cap_files;
    op_strmap file_keys;      /* the files' names, for listing each once */
    long long load_bytes;     /* the estimated peak memory of building the scene */
    /* the meshes (files, or the unit sphere) that shapes which may become instances place: by
     * op_describe_mesh's key, their index k in mesh_uses, the number of such shapes placing
     * each; two or more make it a prototype the shapes share */
    op_strmap mesh_keys;
    int *mesh_uses;
    int nmeshes, cap_meshes;
};

/* Describes the scene whose parsed tree is root (taken over: freed with the description, also
 * on failure) read from path, within limits, into the zeroed d. On failure d may be partly
 * filled; op_describe_release frees it either way. err must not be NULL. */
op_status op_describe(op_node *root, const char *path, const op_scene_limits *limits,
                      op_scene_description *d, op_error *err);
/* Frees everything d owns (not d itself). */
void op_describe_release(op_scene_description *d);
/* Whether shapes of this type read a mesh file (obj, ply, serialized). */
int op_describe_is_mesh_file(const char *type);
/* Whether a shape node may become an instance: a mesh file or a sphere without an emitter or
 * subsurface (those need world-space triangles: area sampling, irradiance points). */
int op_describe_may_instance(const op_node *node);
/* The mesh a shape node places, for a mesh file's shape or one that may become an instance:
 * its file resolved against the scene's folder (path "" for the unit sphere), its loading
 * options (the shape index: a serialized file's mesh, else 0), and key ("face flip index
 * path", or "sphere") naming one loaded mesh. */
op_status op_describe_mesh(const op_scene_description *d, op_node *node, char *path, size_t n,
                           int *face, int *fliptex, uint32_t *shape_index, char *key, size_t nk,
                           op_error *err);
/* The index k in d->mesh_uses of the mesh key names, or -1. */
int op_describe_mesh_index(const op_scene_description *d, const char *key);
/* What d says about the scene (op_scene_info's fields known before building). */
void op_describe_info(const op_scene_description *d, op_scene_info *info);

#endif
