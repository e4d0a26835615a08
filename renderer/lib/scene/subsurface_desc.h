/* subsurface_desc.h - a shape's <subsurface> as the renderer's op_sss_desc (render_scene.h):
 * its parameters read and checked, the dipole's coefficients, a measured material's file found
 * (op_subsurface_read, which opens nothing), then that material, once opened, checked against
 * the element and its mean albedo taken (op_subsurface_bind). */
#ifndef OP_SUBSURFACE_DESC_H
#define OP_SUBSURFACE_DESC_H

#include "scene/render_scene.h"
#include "scene/scene_desc.h"

/* What op_subsurface_read found out about a measured material's file. */
typedef struct op_subsurface_spec {
    char path[4096];      /* the material's file (op_find_material); "" for the dipole */
    op_method method;     /* the method the type attribute names */
    const char *name;     /* the material attribute as written (owned by the tree) */
    int is_long;          /* name is the plugin's long name of preset ("SVD S10 Div100 ...") */
    char preset[256];
    op_method long_method; /* is_long: the method, A and B the long name asks for */
    double log_a, log_b;
} op_subsurface_spec;

/* Fills the zeroed-by-it d from node (scene_dir: the scene file's folder; lim's sss-max-points
 * is the default maxPoints): the parameters, the whole dipole (d->is_dipole), or for a measured
 * material its file in spec (found, not opened; d->material stays NULL). Errors name node. */
op_status op_subsurface_read(op_node *node, const char *scene_dir, const op_scene_limits *lim,
                             op_sss_desc *d, op_subsurface_spec *spec, op_error *err);
/* Prefixes err (a failure opening spec's material) with node and the preset a long name
 * names; returns err's status. */
op_status op_subsurface_error(const op_node *node, const op_subsurface_spec *spec, op_error *err);
/* Checks d->material, opened from spec->path, against node and the kernel limit (its method,
 * a long name's method, A and B) and sets d->albedo_mean from its albedo map. */
op_status op_subsurface_bind(const op_node *node, const op_subsurface_spec *spec,
                             const op_scene_limits *lim, op_sss_desc *d, op_error *err);

#endif
