/* layout.h - where a translucent shape's irradiance points go: how many of them a shape
 * needs (op_sss_plan, before any work) and where they are laid (op_sss_lay_points): the
 * area-uniform layout, a measured material's pixel centres (sss/measured_points.h), and for a shape
 * needing more than its maxPoints only the points near the view (the dipole in levels around
 * it, a measured material at the finest level whose points near the view fit), else the whole
 * shape coarsened to maxPoints. docs/subsurface-rendering.md describes each layout. */
#ifndef OP_SSS_LAYOUT_H
#define OP_SSS_LAYOUT_H

#include "sss/shape_points.h"

/* Plans, before any work, the irradiance points of every translucent shape of the built scene
 * (its bounds set) into plan (scene->nsss entries, by sss index): checks that a material pixel in scene units is finite, positive and within
 * what single precision can grid across the scene, fixes each shape's point count (about
 * `density` per material pixel area, computed in double; a measured material needing more than
 * INT32_MAX 4^l times fewer, area-uniform; a shape needing more than its maxPoints is windowed:
 * at most maxPoints of them are laid, those near the view, else it is coarsened to maxPoints)
 * and refuses a total (of what may be laid) over max_total ("sss-points"). */
op_status op_sss_plan(const op_scene *scene, long long max_total, op_sss_plan_entry *plan,
                      op_error *err);

/* Lays the points of shape sh (ss->desc and ss->plan set) and fills ss's layout fields (its pixel size,
 * spacing, points and their indices in the whole layout). A windowed shape (op_sss_plan_entry.
 * windowed) lays those near the camera segments' hits on it (rows: gh rows of hits, pix the
 * angle between neighbouring rays; NULL: the whole shape is in view) when they are at most
 * maxPoints; a measured material's otherwise those of the first coarser level that fit, and
 * any shape's else maxPoints points over the whole shape, with a warning where the image can
 * show the coarsening (a measured material's points farther apart than its finest pixel). */
op_status op_sss_lay_points(const op_scene *scene, const op_shape_rec *sh, sss_shape *ss,
                            const cam_row *rows, int gh, float pix, op_error *err);

#endif
