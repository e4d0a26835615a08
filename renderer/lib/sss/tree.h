/* tree.h - the hierarchical evaluation of a translucent shape's exitance sum
 * M_j = sum_i w_i Rd(|x_j - x_i|) over its irradiance points (after Jensen and Buhler 2002).
 *
 * A binary bounding-box tree over the points, built once per shape from their positions and
 * normals only (median splits along the longest box axis, leaves of at most OP_SSS_LEAF
 * points). A receiver walks it in one fixed order: a node whose box lies beyond the profile's
 * reach is skipped; a node far enough (see op_sss_radial) stands in for its points as one
 * aggregate per channel (total weight, weighted centroid and covariance: the profile expanded
 * to second order about the centroid); the points of the leaves left are summed pair by pair
 * with the exact near profile, same-side normals only. Which nodes a receiver uses depends on
 * geometry alone, so the sources a set of receivers needs are known before any weight is
 * (op_sss_tree_touch), and a receiver's sum is the same bits for any thread count and for any
 * other set of receivers whose sources are complete. */
#ifndef OP_SSS_TREE_H
#define OP_SSS_TREE_H

#include "opaline.h"
#include "math/vec.h"

enum { OP_SSS_LEAF = 8 };

/* The radial profile a tree sums, and when a node may stand in for its points. */
typedef struct op_sss_radial {
    /* the exact pair value per unit weight at distance r >= 0, per channel */
    void (*near)(const void *user, float r, float out[3]);
    /* channel c's profile and its first two derivatives at r > 0 (the aggregate's expansion) */
    void (*far)(const void *user, int c, double r, double f[3]);
    const void *user;
    float reach;   /* a node whose box lies farther than this contributes nothing */
    float exact;   /* a node with a point closer than this is never aggregated */
    float theta;   /* a node is aggregated only when its radius is at most theta x its distance */
    float size[3]; /* per channel: the largest node radius aggregated while the channel counts */
    float fade[3]; /* per channel: beyond this distance the channel no longer limits the size */
    /* the normalization of the pairs closer than `ball` (at most `exact`): the near profile
     * summed over the points within ball, times their areas, should be ball_total. Sources
     * hand on their weight scaled to that (op_sss_tree_weigh's wn = w g), and a receiver's
     * near part is scaled by ball_total / (its sum of g A near(r)), clamped to [1/2, 2]:
     * exact for uniform light, each source's energy kept */
    float ball;
    float ball_total[3];
} op_sss_radial;

typedef struct op_sss_tree_node {
    op_v3 lo, hi, center; /* box, and its centre */
    float radius;         /* half the box's diagonal */
    op_v3 axis;           /* mean normal (unit) */
    float cone;           /* smallest cosine between axis and a point's normal */
    int first, count;     /* its points: tree order first .. first + count - 1 */
    int child;            /* children child and child + 1, or -1 for a leaf */
} op_sss_tree_node;

/* Per node and channel: the weight, its centroid (offset from the node's centre) and the
 * covariance xx, yy, zz, xy, xz, yz about the centroid. */
typedef struct op_sss_tree_agg {
    float w[3];
    float mean[3][3];
    float cov[3][6];
} op_sss_tree_agg;

typedef struct op_sss_tree {
    op_sss_tree_node *nodes;
    int nnodes, npts;
    int *order;      /* tree order -> point index */
    op_v3 *p, *n;    /* positions and normals in tree order */
    op_v3 *w, *wn, *ga; /* weights w, normalized weights w g and areas g A in tree order */
    op_sss_tree_agg *agg; /* per node (op_sss_tree_weigh) */
} op_sss_tree;

/* Builds the tree over npts >= 1 points (positions p, unit normals n). */
op_status op_sss_tree_build(op_sss_tree *t, const op_v3 *p, const op_v3 *n, int npts,
                            op_error *err);
void op_sss_tree_free(op_sss_tree *t);

/* Marks in node_mark (one byte per node, set to 1, never cleared) the nodes the sum at the
 * receiver (p, n) uses: aggregates and leaves. */
void op_sss_tree_touch(const op_sss_tree *t, const op_sss_radial *k, op_v3 p, op_v3 n,
                       unsigned char *node_mark);
/* Sets point_mark[i] = 1 for every point i under a marked node. */
void op_sss_tree_points(const op_sss_tree *t, const unsigned char *node_mark,
                        unsigned char *point_mark);

/* Takes the points' weights w, normalized weights wn and normalized areas ga (per point
 * index, 3 channels; see op_sss_radial) and computes every node's aggregate (of w); a node's
 * aggregate is exact only when all its points' weights are final. */
op_status op_sss_tree_weigh(op_sss_tree *t, const op_v3 *w, const op_v3 *wn, const op_v3 *ga,
                            op_error *err);

/* The sum at the receiver (p, n), per channel. */
op_v3 op_sss_tree_sum(const op_sss_tree *t, const op_sss_radial *k, op_v3 p, op_v3 n);

#endif
