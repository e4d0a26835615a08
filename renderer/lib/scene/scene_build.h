/* scene_build.h - turns a scene's description (describe.h) into the renderer's scene
 * (render_scene.h): camera, film, sampler, integrator, shapes, BSDFs, emitters, subsurface
 * materials and the acceleration structure. Builds only what shapes, emitters and the camera
 * use; reports unused parameters at the end. */
#ifndef OP_SCENE_BUILD_H
#define OP_SCENE_BUILD_H

#include "scene/render_scene.h"
#include "scene/describe.h"

/* Fills the zeroed scene s from the description d (its film, sampler, camera and integrator,
 * then the rest of its tree), refusing what is over d's limits. On failure s may be partly
 * filled; op_scene_release frees it either way. err must not be NULL (the statuses of nested
 * calls travel through it). */
op_status op_scene_build(const op_scene_description *d, op_scene *s, op_error *err);
/* Frees everything s owns (not s itself). */
void op_scene_release(op_scene *s);

#endif
