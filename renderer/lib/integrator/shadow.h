/* shadow.h - what a shadow ray carries between a path vertex and a light sample: the
 * passable surfaces it crosses (masks, thin dielectrics, index-matched boundaries) and, for the
 * volumetric path tracer, the media between them. Shared by integrator.c and volpath.c. */
#ifndef OP_SHADOW_H
#define OP_SHADOW_H

#include "geometry/isect.h"
#include "math/rng.h"

/* The media a shadow ray crosses: it starts in medium med (-1: none), enters and leaves media
 * at the shapes that bound them, and heterogeneous media's transmittance is estimated with
 * rng. */
typedef struct op_shadow_media {
    int med;
    op_rng *rng;
} op_shadow_media;

/* The medium a ray leaving surface point it in direction w is in, given cur before (cur
 * where the shape bounds no medium; its side given by the geometric normal). */
int op_medium_after(const op_scene *s, const op_isect *it, op_v3 w, int cur);

/* Transmittance of the segment org + t dir, t in (0, tmax): 0 when an opaque surface lies on
 * it, else the product of what the passable surfaces it crosses let through (exact) and, with
 * media != NULL, of the media along it; media NULL ignores media (the path tracer's view). */
op_v3 op_shadow_transmittance(const op_scene *s, op_v3 org, op_v3 dir, float tmax,
                              const op_shadow_media *media);

#endif
