/* tree.c - the bounding-box tree of the hierarchical exitance sum (see tree.h). */
#include "sss/tree.h"

#include <float.h>
#include <stdlib.h>
#include <string.h>

/* (key, index) pairs in a total order, so the split (and with it the whole tree) is the same
 * on every run. */
static inline int before(float ka, int ia, float kb, int ib)
{
    return ka < kb || (ka == kb && ia < ib);
}

/* The arrays a split reorders together. */
typedef struct split {
    float *key;
    int *idx;
    op_v3 *p, *n;
} split;

static inline void swap2(const split *a, int i, int j)
{
    float k = a->key[i];
    a->key[i] = a->key[j];
    a->key[j] = k;
    int x = a->idx[i];
    a->idx[i] = a->idx[j];
    a->idx[j] = x;
    op_v3 v = a->p[i];
    a->p[i] = a->p[j];
    a->p[j] = v;
    v = a->n[i];
    a->n[i] = a->n[j];
    a->n[j] = v;
}

/* Reorders the range [0, n) of the arrays so that idx[k] is the k-th in the order above, the
 * ones before it before and the ones after it after (quickselect, median-of-three pivots). */
static void select_kth(const split *a, int n, int k)
{
    float *key = a->key;
    int *idx = a->idx;
    int lo = 0, hi = n - 1;
    while (hi > lo) {
        int mid = lo + (hi - lo) / 2;
        if (before(key[mid], idx[mid], key[lo], idx[lo]))
            swap2(a, mid, lo);
        if (before(key[hi], idx[hi], key[lo], idx[lo]))
            swap2(a, hi, lo);
        if (before(key[mid], idx[mid], key[hi], idx[hi]))
            swap2(a, mid, hi);
        float pk = key[hi];
        int pi = idx[hi], store = lo;
        for (int i = lo; i < hi; i++)
            if (before(key[i], idx[i], pk, pi))
                swap2(a, i, store++);
        swap2(a, hi, store);
        if (store == k)
            return;
        if (store < k)
            lo = store + 1;
        else
            hi = store - 1;
    }
}

/* The box, axis and cone of nd's points (p, n in tree order). */
static void node_bounds(op_sss_tree_node *nd, const op_v3 *p, const op_v3 *n)
{
    op_v3 lo = v3s(FLT_MAX), hi = v3s(-FLT_MAX);
    double ax[3] = {0, 0, 0};
    for (int i = 0; i < nd->count; i++) {
        op_v3 q = p[nd->first + i], m = n[nd->first + i];
        lo = v3(fminf(lo.x, q.x), fminf(lo.y, q.y), fminf(lo.z, q.z));
        hi = v3(fmaxf(hi.x, q.x), fmaxf(hi.y, q.y), fmaxf(hi.z, q.z));
        ax[0] += m.x;
        ax[1] += m.y;
        ax[2] += m.z;
    }
    nd->lo = lo;
    nd->hi = hi;
    nd->center = v3_scale(v3_add(lo, hi), 0.5f);
    nd->radius = 0.5f * v3_len(v3_sub(hi, lo));
    if (!v3_unit_from_d(ax, &nd->axis))
        nd->axis = v3(0.0f, 0.0f, 1.0f);
    nd->cone = 1.0f;
    for (int i = 0; i < nd->count; i++)
        nd->cone = fminf(nd->cone, v3_dot(nd->axis, n[nd->first + i]));
}

op_status op_sss_tree_build(op_sss_tree *t, const op_v3 *p, const op_v3 *n, int npts,
                            op_error *err)
{
    memset(t, 0, sizeof *t);
    /* a split node has more than OP_SSS_LEAF points and halves of at least OP_SSS_LEAF / 2:
     * at most npts / (OP_SSS_LEAF / 2) + 1 leaves */
    int cap = 2 * (npts / (OP_SSS_LEAF / 2) + 1);
    t->nodes = malloc((size_t)cap * sizeof *t->nodes);
    t->order = malloc((size_t)npts * sizeof *t->order);
    float *key = malloc((size_t)npts * sizeof *key);
    t->p = malloc((size_t)npts * sizeof *t->p);
    t->n = malloc((size_t)npts * sizeof *t->n);
    if (!t->nodes || !t->order || !t->p || !t->n || !key) {
        free(key);
        op_sss_tree_free(t);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for the subsurface tree of %d "
                            "points", npts);
    }
    t->npts = npts;
    for (int i = 0; i < npts; i++) {
        t->order[i] = i;
        t->p[i] = p[i];
        t->n[i] = n[i];
    }
    t->nnodes = 1;
    t->nodes[0].first = 0;
    t->nodes[0].count = npts;
    /* nodes are processed in creation order; children are made in pairs */
    for (int k = 0; k < t->nnodes; k++) {
        op_sss_tree_node *nd = &t->nodes[k];
        node_bounds(nd, t->p, t->n);
        nd->child = -1;
        if (nd->count <= OP_SSS_LEAF)
            continue;
        op_v3 e = v3_sub(nd->hi, nd->lo);
        int a = e.x >= e.y && e.x >= e.z ? 0 : e.y >= e.z ? 1 : 2;
        int half = nd->count / 2;
        for (int i = nd->first; i < nd->first + nd->count; i++)
            key[i] = v3_get(t->p[i], a);
        split sp = {key + nd->first, t->order + nd->first, t->p + nd->first, t->n + nd->first};
        select_kth(&sp, nd->count, half);
        nd->child = t->nnodes;
        op_sss_tree_node *c = &t->nodes[t->nnodes];
        c[0].first = nd->first;
        c[0].count = half;
        c[1].first = nd->first + half;
        c[1].count = nd->count - half;
        t->nnodes += 2;
    }
    free(key);
    return OP_OK;
}

void op_sss_tree_free(op_sss_tree *t)
{
    free(t->nodes);
    free(t->order);
    free(t->p);
    free(t->n);
    free(t->w);
    free(t->wn);
    free(t->ga);
    free(t->agg);
    memset(t, 0, sizeof *t);
}

enum { SKIP, AGGREGATE, LEAF, OPEN };

/* How far x lies outside [lo, hi]. */
static inline float gap(float lo, float hi, float x)
{
    return x < lo ? lo - x : x > hi ? x - hi : 0.0f;
}

/* What the sum at p does with node nd; geometry only. */
static int classify(const op_sss_tree_node *nd, const op_sss_radial *k, op_v3 p)
{
    float dx = gap(nd->lo.x, nd->hi.x, p.x), dy = gap(nd->lo.y, nd->hi.y, p.y);
    float dz = gap(nd->lo.z, nd->hi.z, p.z), dbox = sqrtf(dx * dx + dy * dy + dz * dz);
    if (dbox > k->reach)
        return SKIP;
    if (dbox >= k->exact && nd->cone >= 0.5f &&
        nd->radius <= k->theta * v3_len(v3_sub(p, nd->center))) {
        float lim = FLT_MAX;
        for (int c = 0; c < 3; c++)
            if (dbox < k->fade[c])
                lim = fminf(lim, k->size[c]);
        if (nd->radius <= lim)
            return AGGREGATE;
    }
    return nd->child < 0 ? LEAF : OPEN;
}

enum { STACK = 256 };

void op_sss_tree_touch(const op_sss_tree *t, const op_sss_radial *k, op_v3 p, op_v3 n,
                       unsigned char *node_mark)
{
    (void)n;
    int stack[STACK], top = 0;
    stack[top++] = 0;
    while (top > 0) {
        int i = stack[--top];
        const op_sss_tree_node *nd = &t->nodes[i];
        int what = classify(nd, k, p);
        if (what == AGGREGATE || what == LEAF) {
            node_mark[i] = 1;
        } else if (what == OPEN) {
            stack[top++] = nd->child + 1;
            stack[top++] = nd->child;
        }
    }
}

void op_sss_tree_points(const op_sss_tree *t, const unsigned char *node_mark,
                        unsigned char *point_mark)
{
    for (int i = 0; i < t->nnodes; i++) {
        if (!node_mark[i])
            continue;
        const op_sss_tree_node *nd = &t->nodes[i];
        for (int k = 0; k < nd->count; k++)
            point_mark[t->order[nd->first + k]] = 1;
    }
}

op_status op_sss_tree_weigh(op_sss_tree *t, const op_v3 *w, const op_v3 *wn, const op_v3 *ga,
                            op_error *err)
{
    if (!t->ga)
        t->ga = malloc((size_t)t->npts * sizeof *t->ga);
    if (!t->w)
        t->w = malloc((size_t)t->npts * sizeof *t->w);
    if (!t->wn)
        t->wn = malloc((size_t)t->npts * sizeof *t->wn);
    if (!t->agg)
        t->agg = malloc((size_t)t->nnodes * sizeof *t->agg);
    if (!t->w || !t->wn || !t->ga || !t->agg)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for the subsurface tree");
    for (int i = 0; i < t->npts; i++) {
        t->w[i] = w[t->order[i]];
        t->wn[i] = wn[t->order[i]];
        t->ga[i] = ga[t->order[i]];
    }
    /* children come after their parent: in reverse order, a node's children are done before
     * it. A leaf sums its points about its centre; a parent combines its children's weights,
     * centroids and covariances (the parallel-axis theorem), in double. */
    static const int ia[6] = {0, 1, 2, 0, 0, 1}, ib[6] = {0, 1, 2, 1, 2, 2};
    for (int i = t->nnodes - 1; i >= 0; i--) {
        const op_sss_tree_node *nd = &t->nodes[i];
        op_sss_tree_agg *a = &t->agg[i];
        double s0[3] = {0, 0, 0}, s1[3][3], s2[3][6];
        memset(s1, 0, sizeof s1);
        memset(s2, 0, sizeof s2);
        if (nd->child < 0) {
            for (int k = nd->first; k < nd->first + nd->count; k++) {
                double x[3] = {(double)t->p[k].x - nd->center.x, (double)t->p[k].y - nd->center.y,
                               (double)t->p[k].z - nd->center.z};
                const float wk[3] = {t->w[k].x, t->w[k].y, t->w[k].z};
                for (int c = 0; c < 3; c++) {
                    s0[c] += wk[c];
                    for (int q = 0; q < 3; q++)
                        s1[c][q] += wk[c] * x[q];
                    for (int q = 0; q < 6; q++)
                        s2[c][q] += wk[c] * x[ia[q]] * x[ib[q]];
                }
            }
        } else {
            for (int h = 0; h < 2; h++) {
                const op_sss_tree_node *cn = &t->nodes[nd->child + h];
                const op_sss_tree_agg *ca = &t->agg[nd->child + h];
                double off[3] = {(double)cn->center.x - nd->center.x,
                                 (double)cn->center.y - nd->center.y,
                                 (double)cn->center.z - nd->center.z};
                for (int c = 0; c < 3; c++) {
                    double cw = ca->w[c], m[3];
                    for (int q = 0; q < 3; q++)
                        m[q] = off[q] + ca->mean[c][q];
                    s0[c] += cw;
                    for (int q = 0; q < 3; q++)
                        s1[c][q] += cw * m[q];
                    for (int q = 0; q < 6; q++)
                        s2[c][q] += cw * (ca->cov[c][q] + m[ia[q]] * m[ib[q]]);
                }
            }
        }
        for (int c = 0; c < 3; c++) {
            a->w[c] = (float)s0[c];
            double m[3] = {0, 0, 0};
            if (s0[c] > 0.0)
                for (int q = 0; q < 3; q++)
                    m[q] = s1[c][q] / s0[c];
            for (int q = 0; q < 3; q++)
                a->mean[c][q] = (float)m[q];
            for (int q = 0; q < 6; q++)
                a->cov[c][q] = s0[c] > 0.0 ? (float)(s2[c][q] / s0[c] - m[ia[q]] * m[ib[q]]) : 0.0f;
        }
    }
    return OP_OK;
}

/* The aggregate of node i at p: per channel, weight x the profile's second-order expansion
 * about the weighted centroid (E[f(|p - y|)] ~ f(r) + tr(H Cov) / 2, with the Hessian
 * H = f'' u u^T + f'/r (I - u u^T) along u = (p - centroid) / r). */
static void aggregate(const op_sss_tree *t, const op_sss_radial *k, int i, op_v3 p, double m[3])
{
    const op_sss_tree_node *nd = &t->nodes[i];
    const op_sss_tree_agg *a = &t->agg[i];
    for (int c = 0; c < 3; c++) {
        if (!(a->w[c] > 0.0f))
            continue;
        double dx = (double)p.x - nd->center.x - a->mean[c][0];
        double dy = (double)p.y - nd->center.y - a->mean[c][1];
        double dz = (double)p.z - nd->center.z - a->mean[c][2];
        double r = sqrt(dx * dx + dy * dy + dz * dz);
        if (!(r > 0.0))
            continue;
        double f[3];
        k->far(k->user, c, r, f);
        double ux = dx / r, uy = dy / r, uz = dz / r;
        const float *s = a->cov[c];
        double q = s[0] * ux * ux + s[1] * uy * uy + s[2] * uz * uz +
                   2.0 * (s[3] * ux * uy + s[4] * ux * uz + s[5] * uy * uz);
        double tr = (double)s[0] + s[1] + s[2];
        double v = f[0] + 0.5 * (f[2] * q + f[1] / r * (tr - q));
        if (v > 0.0)
            m[c] += a->w[c] * v;
    }
}

op_v3 op_sss_tree_sum(const op_sss_tree *t, const op_sss_radial *k, op_v3 p, op_v3 n)
{
    double m[3] = {0, 0, 0}, near[3] = {0, 0, 0}, norm[3] = {0, 0, 0};
    int stack[STACK], top = 0;
    stack[top++] = 0;
    while (top > 0) {
        int i = stack[--top];
        const op_sss_tree_node *nd = &t->nodes[i];
        switch (classify(nd, k, p)) {
        case AGGREGATE:
            if (v3_dot(nd->axis, n) > 0.0f)
                aggregate(t, k, i, p, m);
            break;
        case LEAF:
            for (int q = nd->first; q < nd->first + nd->count; q++) {
                if (v3_dot(t->n[q], n) <= 0.0f)
                    continue;
                float v[3], r = v3_len(v3_sub(p, t->p[q]));
                if (r <= k->ball) {
                    op_v3 w = t->wn[q], g = t->ga[q];
                    k->near(k->user, r, v);
                    near[0] += (double)w.x * v[0];
                    near[1] += (double)w.y * v[1];
                    near[2] += (double)w.z * v[2];
                    norm[0] += (double)g.x * v[0];
                    norm[1] += (double)g.y * v[1];
                    norm[2] += (double)g.z * v[2];
                    continue;
                }
                op_v3 w = t->w[q];
                if (v3_is_black(w))
                    continue;
                k->near(k->user, r, v);
                m[0] += (double)w.x * v[0];
                m[1] += (double)w.y * v[1];
                m[2] += (double)w.z * v[2];
            }
            break;
        case OPEN:
            stack[top++] = nd->child + 1;
            stack[top++] = nd->child;
            break;
        default:
            break;
        }
    }
    for (int c = 0; c < 3; c++) {
        double s = norm[c] > 0.0 ? k->ball_total[c] / norm[c] : 1.0;
        m[c] += near[c] * (s < 0.5 ? 0.5 : s > 2.0 ? 2.0 : s);
    }
    return v3((float)m[0], (float)m[1], (float)m[2]);
}
