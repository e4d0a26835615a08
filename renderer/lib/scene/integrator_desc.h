/* integrator_desc.h - a scene's <integrator> as the renderer's op_integrator.
 *
 * opaline's tracers are path (path tracing with next-event estimation and multiple importance
 * sampling), direct, and the field views (normals, uv, albedo). Mitsuba's other integrators are
 * mapped by what their image is, not by their name:
 *   - those whose image equals a path tracer's in expectation (bdpt, ptracer, pssmlt, mlt,
 *     erpt, recursive_path, guided_path, prb*, volpath*, ...) or what their bias vanishes into
 *     (sppm, ppm, photonmapper, vpl) render with the path tracer;
 *   - wrappers (moment, aov with a nested integrator, irrcache, adaptive) render their nested
 *     integrator; an aov without one renders its single field view when opaline has it;
 *   - direct_projective is direct.
 * A mapped integrator says so once (info), naming the parameters the path tracer does not use;
 * an unknown one is an error listing what is known. */
#ifndef OP_SCENE_INTEGRATOR_DESC_H
#define OP_SCENE_INTEGRATOR_DESC_H

#include "scene/render_scene.h"
#include "scene/scene_desc.h"

/* Fills ig from the <integrator> node n (NULL: Mitsuba's default, direct). */
op_status op_integrator_read(op_node *n, op_integrator *ig, op_error *err);

#endif
