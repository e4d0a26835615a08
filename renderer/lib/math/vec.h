/* vec.h - the renderer's small vector math: 3-component float vectors, orthonormal frames
 * and the sampling warps every module shares. Header-only, all static inline. */
#ifndef OP_MATH_VEC_H
#define OP_MATH_VEC_H

#include <math.h>

#define OP_PI 3.14159265358979323846f
#define OP_INV_PI 0.31830988618379067154f

typedef struct op_v3 {
    float x, y, z;
} op_v3;

static inline op_v3 v3(float x, float y, float z)
{
    op_v3 r = {x, y, z};
    return r;
}
static inline op_v3 v3s(float s) { return v3(s, s, s); }
static inline op_v3 v3_add(op_v3 a, op_v3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline op_v3 v3_sub(op_v3 a, op_v3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline op_v3 v3_mul(op_v3 a, op_v3 b) { return v3(a.x * b.x, a.y * b.y, a.z * b.z); }
static inline op_v3 v3_scale(op_v3 a, float s) { return v3(a.x * s, a.y * s, a.z * s); }
static inline op_v3 v3_neg(op_v3 a) { return v3(-a.x, -a.y, -a.z); }
static inline float v3_dot(op_v3 a, op_v3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline op_v3 v3_cross(op_v3 a, op_v3 b)
{
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline float v3_len(op_v3 a) { return sqrtf(v3_dot(a, a)); }
/* Unit vector along a; a zero vector stays zero. */
static inline op_v3 v3_norm(op_v3 a)
{
    float l = v3_len(a);
    return l > 0.0f ? v3_scale(a, 1.0f / l) : a;
}
static inline float v3_max(op_v3 a) { return fmaxf(a.x, fmaxf(a.y, a.z)); }
/* Component-wise minimum and maximum (box corners). */
static inline op_v3 v3_lo(op_v3 a, op_v3 b) { return v3(fminf(a.x, b.x), fminf(a.y, b.y), fminf(a.z, b.z)); }
static inline op_v3 v3_hi(op_v3 a, op_v3 b) { return v3(fmaxf(a.x, b.x), fmaxf(a.y, b.y), fmaxf(a.z, b.z)); }
static inline float v3_lum(op_v3 a) { return 0.2126f * a.x + 0.7152f * a.y + 0.0722f * a.z; }
static inline int v3_is_black(op_v3 a) { return a.x == 0.0f && a.y == 0.0f && a.z == 0.0f; }
static inline op_v3 v3_from_d(const double d[3]) { return v3((float)d[0], (float)d[1], (float)d[2]); }
/* d normalized in double precision (a vector too long or short for float is fine); returns 0
 * when d has no finite, non-zero direction. */
static inline int v3_unit_from_d(const double d[3], op_v3 *out)
{
    double big = fmax(fabs(d[0]), fmax(fabs(d[1]), fabs(d[2])));
    if (!(big > 0.0) || !isfinite(big))
        return 0;
    double x = d[0] / big, y = d[1] / big, z = d[2] / big, len = sqrt(x * x + y * y + z * z);
    *out = v3((float)(x / len), (float)(y / len), (float)(z / len));
    return 1;
}
static inline float v3_get(op_v3 a, int i) { return i == 0 ? a.x : (i == 1 ? a.y : a.z); }

/* An orthonormal frame (s, t, n); local z is n. */
typedef struct op_frame {
    op_v3 s, t, n;
} op_frame;

/* A frame around the unit normal n (Duff et al. 2017, branchless). */
static inline op_frame op_frame_from_normal(op_v3 n)
{
    float sign = copysignf(1.0f, n.z);
    float a = -1.0f / (sign + n.z);
    float b = n.x * n.y * a;
    op_frame f;
    f.s = v3(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x);
    f.t = v3(b, sign + n.y * n.y * a, -n.y);
    f.n = n;
    return f;
}
static inline op_v3 op_frame_to_local(const op_frame *f, op_v3 v)
{
    return v3(v3_dot(v, f->s), v3_dot(v, f->t), v3_dot(v, f->n));
}
static inline op_v3 op_frame_to_world(const op_frame *f, op_v3 v)
{
    return v3_add(v3_add(v3_scale(f->s, v.x), v3_scale(f->t, v.y)), v3_scale(f->n, v.z));
}

/* Cosine-weighted direction on the +z hemisphere from (u1, u2) in [0,1)^2; pdf cos/pi. */
static inline op_v3 op_sample_cosine(float u1, float u2)
{
    float r = sqrtf(u1), phi = 2.0f * OP_PI * u2;
    return v3(r * cosf(phi), r * sinf(phi), sqrtf(fmaxf(0.0f, 1.0f - u1)));
}
/* Uniform direction on the unit sphere; pdf 1/(4 pi). */
static inline op_v3 op_sample_sphere(float u1, float u2)
{
    float z = 1.0f - 2.0f * u1, r = sqrtf(fmaxf(0.0f, 1.0f - z * z)), phi = 2.0f * OP_PI * u2;
    return v3(r * cosf(phi), r * sinf(phi), z);
}
/* Barycentrics (b1, b2) uniform over a triangle. */
static inline void op_sample_triangle(float u1, float u2, float *b1, float *b2)
{
    float su = sqrtf(u1);
    *b1 = 1.0f - su;
    *b2 = u2 * su;
}
/* Power heuristic (beta = 2) weight of a strategy with density a against one with density b. */
static inline float op_mis(float a, float b)
{
    a *= a;
    b *= b;
    return a + b > 0.0f ? a / (a + b) : 0.0f;
}

#endif
