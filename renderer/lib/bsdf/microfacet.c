/* microfacet.c - microfacet distributions (see microfacet.h). */
#include "bsdf/microfacet.h"

#define OP_INV_SQRT_PI 0.56418958354775628695f

op_microfacet op_mf_make(op_mf_type type, float alpha_u, float alpha_v, int visible)
{
    op_microfacet d;
    d.type = type;
    d.alpha_u = fmaxf(alpha_u, 1e-4f);
    d.alpha_v = fmaxf(alpha_v, 1e-4f);
    d.exp_u = fmaxf(2.0f / (d.alpha_u * d.alpha_u) - 2.0f, 0.0f);
    d.exp_v = fmaxf(2.0f / (d.alpha_v * d.alpha_v) - 2.0f, 0.0f);
    d.visible = type != OP_MF_PHONG && visible;
    return d;
}

static int isotropic(const op_microfacet *d)
{
    return d->alpha_u == d->alpha_v;
}

/* The Phong exponent in the azimuth of v (Ashikhmin-Shirley's interpolation). */
static float phong_exponent(const op_microfacet *d, op_v3 v)
{
    float s2 = v.x * v.x + v.y * v.y;
    if (isotropic(d) || s2 <= 1e-30f)
        return d->exp_u;
    return (d->exp_u * v.x * v.x + d->exp_v * v.y * v.y) / s2;
}

float op_mf_d(const op_microfacet *d, op_v3 m)
{
    if (m.z <= 0.0f)
        return 0.0f;
    float c2 = m.z * m.z;
    if (d->type == OP_MF_PHONG)
        return sqrtf((d->exp_u + 2.0f) * (d->exp_v + 2.0f)) * (0.5f * OP_INV_PI) *
               powf(m.z, phong_exponent(d, m));
    if (d->type == OP_MF_GGX && isotropic(d)) {
        float a2 = d->alpha_u * d->alpha_u;
        float t = c2 * (a2 - 1.0f) + 1.0f;
        return a2 / (OP_PI * t * t);
    }
    float e = (m.x * m.x) / (d->alpha_u * d->alpha_u) + (m.y * m.y) / (d->alpha_v * d->alpha_v);
    if (d->type == OP_MF_BECKMANN)
        return expf(-e / c2) / (OP_PI * d->alpha_u * d->alpha_v * c2 * c2);
    float root = c2 + e;
    return 1.0f / (OP_PI * d->alpha_u * d->alpha_v * root * root);
}

/* The roughness along the azimuth of v. */
static float projected_alpha(const op_microfacet *d, op_v3 v)
{
    float s2 = v.x * v.x + v.y * v.y;
    if (isotropic(d) || s2 <= 1e-30f)
        return d->alpha_u;
    return sqrtf((v.x * v.x * d->alpha_u * d->alpha_u + v.y * v.y * d->alpha_v * d->alpha_v) / s2);
}

float op_mf_g1(const op_microfacet *d, op_v3 v, op_v3 m)
{
    if (v3_dot(v, m) * v.z <= 0.0f)
        return 0.0f;
    float c2 = v.z * v.z;
    float t2 = (1.0f - c2) / c2; /* tan^2 */
    if (t2 <= 0.0f)
        return 1.0f;
    float a = projected_alpha(d, v);
    if (d->type == OP_MF_GGX)
        return 2.0f / (1.0f + sqrtf(1.0f + a * a * t2));
    /* Beckmann: Lambda(b) = (erf(b) - 1) / 2 + exp(-b^2) / (2 b sqrt(pi)), b = 1 / (a tan) */
    float b = 1.0f / (a * sqrtf(t2));
    if (b > 6.0f)
        return 1.0f;
    float lambda = 0.5f * (erff(b) - 1.0f) + expf(-b * b) * (0.5f * OP_INV_SQRT_PI) / b;
    return 1.0f / (1.0f + lambda);
}

/* The inverse error function (Giles 2010, single precision). */
static float erfinv(float x)
{
    float w = -logf((1.0f - x) * (1.0f + x)), p;
    if (w < 5.0f) {
        w -= 2.5f;
        p = 2.81022636e-08f;
        p = 3.43273939e-07f + p * w;
        p = -3.5233877e-06f + p * w;
        p = -4.39150654e-06f + p * w;
        p = 0.00021858087f + p * w;
        p = -0.00125372503f + p * w;
        p = -0.00417768164f + p * w;
        p = 0.246640727f + p * w;
        p = 1.50140941f + p * w;
    } else {
        w = sqrtf(w) - 3.0f;
        p = -0.000200214257f;
        p = 0.000100950558f + p * w;
        p = 0.00134934322f + p * w;
        p = -0.00367342844f + p * w;
        p = 0.00573950773f + p * w;
        p = -0.0076224613f + p * w;
        p = 0.00943887047f + p * w;
        p = 1.00167406f + p * w;
        p = 2.83297682f + p * w;
    }
    return p * x;
}

/* A normal drawn with density D(m) m.z: the unit-roughness slope's radius by inversion, its
 * direction stretched by (alpha_u, alpha_v) (Ashikhmin-Shirley's quadrant warp for Phong). */
static op_v3 sample_all(const op_microfacet *d, float u1, float u2)
{
    float phi, cz;
    if (d->type == OP_MF_PHONG) {
        float e = d->exp_u;
        phi = 2.0f * OP_PI * u2;
        if (!isotropic(d)) {
            /* the first quadrant's warp, mirrored into the quadrant u2 falls in */
            int q = (int)(u2 * 4.0f);
            float u = u2 * 4.0f - (float)q;
            if (q > 3)
                q = 3;
            if (q & 1)
                u = 1.0f - u;
            phi = atanf(sqrtf((d->exp_u + 2.0f) / (d->exp_v + 2.0f)) * tanf(0.5f * OP_PI * u));
            float c = cosf(phi), s = sinf(phi);
            e = d->exp_u * c * c + d->exp_v * s * s;
            phi = (q == 0) ? phi : (q == 1) ? OP_PI - phi : (q == 2) ? OP_PI + phi : 2.0f * OP_PI - phi;
        }
        cz = powf(u1, 1.0f / (e + 2.0f));
    } else {
        float a2;
        if (isotropic(d)) {
            phi = 2.0f * OP_PI * u2;
            a2 = d->alpha_u * d->alpha_u;
        } else {
            phi = atan2f(d->alpha_v * sinf(2.0f * OP_PI * u2), d->alpha_u * cosf(2.0f * OP_PI * u2));
            float c = cosf(phi) / d->alpha_u, s = sinf(phi) / d->alpha_v;
            a2 = 1.0f / (c * c + s * s);
        }
        float t2 = d->type == OP_MF_GGX ? a2 * u1 / fmaxf(1.0f - u1, 1e-7f)
                                         : -a2 * logf(fmaxf(1.0f - u1, 1e-7f));
        cz = 1.0f / sqrtf(1.0f + t2);
    }
    float sz = sqrtf(fmaxf(0.0f, 1.0f - cz * cz));
    return v3(sz * cosf(phi), sz * sinf(phi), cz);
}

/* The slope (x along the incident azimuth) of a visible normal of the unit-roughness Beckmann
 * distribution seen at polar angle theta: x by inverting its marginal CDF in the erf domain
 * (Newton steps kept inside a bisection bracket), y given x by the Gaussian's inverse. */
static void beckmann_slope11(float theta, float u1, float u2, float *sx, float *sy)
{
    if (theta < 1e-4f) {
        float r = sqrtf(-logf(fmaxf(1.0f - u1, 1e-7f))), phi = 2.0f * OP_PI * u2;
        *sx = r * cosf(phi);
        *sy = r * sinf(phi);
        return;
    }
    float tan_t = tanf(theta), cot_t = 1.0f / tan_t;
    float lo = -1.0f, hi = erff(cot_t);
    float u = fminf(fmaxf(u1, 1e-6f), 1.0f - 1e-6f);
    float norm = 1.0f / (1.0f + hi + OP_INV_SQRT_PI * tan_t * expf(-cot_t * cot_t));
    float b = lo + u * (hi - lo);
    for (int it = 0; it < 32; it++) {
        if (!(b > lo && b < hi))
            b = 0.5f * (lo + hi);
        float e = erfinv(b);
        float value = norm * (1.0f + b + OP_INV_SQRT_PI * tan_t * expf(-e * e)) - u;
        if (fabsf(value) < 1e-6f)
            break;
        if (value > 0.0f)
            hi = b;
        else
            lo = b;
        float slope = norm * (1.0f - e * tan_t);
        b = slope > 0.0f ? b - value / slope : 0.5f * (lo + hi);
    }
    *sx = erfinv(b);
    *sy = erfinv(2.0f * fminf(fmaxf(u2, 1e-6f), 1.0f - 1e-6f) - 1.0f);
}

/* A visible normal of GGX (Heitz 2018: a point on the projected hemisphere of the stretched
 * configuration, unstretched). */
static op_v3 ggx_visible(const op_microfacet *d, op_v3 wi, float u1, float u2)
{
    op_v3 vh = v3_norm(v3(d->alpha_u * wi.x, d->alpha_v * wi.y, wi.z));
    float l2 = vh.x * vh.x + vh.y * vh.y;
    op_v3 t1 = l2 > 0.0f ? v3_scale(v3(-vh.y, vh.x, 0.0f), 1.0f / sqrtf(l2)) : v3(1.0f, 0.0f, 0.0f);
    op_v3 t2 = v3_cross(vh, t1);
    float r = sqrtf(u1), phi = 2.0f * OP_PI * u2;
    float p1 = r * cosf(phi), p2 = r * sinf(phi);
    float s = 0.5f * (1.0f + vh.z);
    p2 = (1.0f - s) * sqrtf(fmaxf(0.0f, 1.0f - p1 * p1)) + s * p2;
    op_v3 nh = v3_add(v3_add(v3_scale(t1, p1), v3_scale(t2, p2)),
                      v3_scale(vh, sqrtf(fmaxf(0.0f, 1.0f - p1 * p1 - p2 * p2))));
    return v3_norm(v3(d->alpha_u * nh.x, d->alpha_v * nh.y, fmaxf(nh.z, 1e-6f)));
}

/* A visible normal of Beckmann (Heitz and d'Eon 2014: stretch, sample the unit slope, rotate,
 * unstretch). */
static op_v3 beckmann_visible(const op_microfacet *d, op_v3 wi, float u1, float u2)
{
    op_v3 ws = v3_norm(v3(d->alpha_u * wi.x, d->alpha_v * wi.y, wi.z));
    float theta = 0.0f, phi = 0.0f;
    if (ws.z < 0.99999f) {
        theta = acosf(ws.z);
        phi = atan2f(ws.y, ws.x);
    }
    float x, y;
    beckmann_slope11(theta, u1, u2, &x, &y);
    float c = cosf(phi), s = sinf(phi);
    float sx = (c * x - s * y) * d->alpha_u, sy = (s * x + c * y) * d->alpha_v;
    return v3_norm(v3(-sx, -sy, 1.0f));
}

op_v3 op_mf_sample(const op_microfacet *d, op_v3 wi, float u1, float u2)
{
    if (!d->visible)
        return sample_all(d, u1, u2);
    return d->type == OP_MF_GGX ? ggx_visible(d, wi, u1, u2) : beckmann_visible(d, wi, u1, u2);
}

float op_mf_pdf(const op_microfacet *d, op_v3 wi, op_v3 m)
{
    if (!d->visible)
        return op_mf_d(d, m) * m.z;
    if (wi.z <= 0.0f)
        return 0.0f;
    return op_mf_g1(d, wi, m) * fmaxf(v3_dot(wi, m), 0.0f) * op_mf_d(d, m) / wi.z;
}
