/* scene_build.h - turns a parsed scene description (scene_desc.h) into the renderer's scene
 * (render_scene.h): camera, film, sampler, integrator, shapes, BSDFs, emitters, subsurface
 * materials and the acceleration structure. Builds only what shapes, emitters and the camera
 * use; reports unused parameters at the end. */
#ifndef OP_SCENE_BUILD_H
#define OP_SCENE_BUILD_H

#include "scene/render_scene.h"
#include "scene/scene_desc.h"

/* Fills the zeroed scene s from root (path: the scene file, for relative file names), refusing
 * what is over limits. On failure s may be partly filled; op_scene_release frees it either way.
 * err must not be NULL (the statuses of nested calls travel through it). */
op_status op_scene_build(op_node *root, const char *path, const op_scene_limits *limits,
                         op_scene *s, op_error *err);
/* Frees everything s owns (not s itself). */
void op_scene_release(op_scene *s);

#endif
