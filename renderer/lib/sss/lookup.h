/* lookup.h - the exitance lookups over a translucent shape's pre-pass result: its lookup set
 * (shape_points.h's look_set), made once the points' exitance is known, and the exitance
 * interpolated between the points near a surface point. Private to the pre-pass (prepass.c),
 * whose op_sss_lookup is the public entry. */
#ifndef OP_SSS_LOOKUP_H
#define OP_SSS_LOOKUP_H

#include "sss/shape_points.h"

/* Makes ss->lk from ss's points and their exitance. */
op_status op_sss_lookup_prepare(sss_shape *ss, op_error *err);
void op_sss_lookup_free(look_set *lk);
/* op_sss_lookup (prepass.h) on one shape. */
int op_sss_shape_lookup(const sss_shape *ss, op_v3 p, op_v3 n, op_v3 *out);

#endif
