/* medium_desc.h - a scene's <medium> and its <phase> (docs/scene-format.md, Participating
 * media). */
#ifndef OP_MEDIUM_DESC_H
#define OP_MEDIUM_DESC_H

#include "medium/medium.h"
#include "scene/scene_desc.h"

/* Reads a <medium type="homogeneous"> or "heterogeneous"> (with its <volume>s) into m
 * (coefficients per scene unit; op_pmedium_free frees it). Any other type, a bad coefficient,
 * volume or phase function is an OP_ERR_INPUT naming the node's file:line (a bad .vol file:
 * the file). On failure m holds nothing to free. */
op_status op_medium_read(op_node *node, op_pmedium *m, op_error *err);
/* 1 when opaline renders <medium type="type"> (op_medium_read), else 0. */
int op_medium_type_known(const char *type);
/* 1 when opaline renders <phase type="type"> (a medium's phase function), else 0. */
int op_phase_type_known(const char *type);

#endif
