/* test_bsdf_models.c - every BSDF op_bsdf_build makes (and a translucent shape's boundary lobe),
 * each at a few roughnesses and indices, tested as Mitsuba's and pbrt's BSDF tests do:
 *  - furnace: the directional albedo, by Monte Carlo through op_bsdf_sample_dir, is at most 1
 *    (within 4 standard errors; light refracted into a denser medium counted as energy, i.e.
 *    without the radiance scaling 1 / eta^2) and equals what the model predicts where that is
 *    known (diffuse: its reflectance; smooth conductor: the exact Fresnel reflectance; smooth
 *    dielectric: F + (1 - F) / eta^2; rough conductor "none" and rough dielectric at low
 *    roughness: close to 1, Smith's model losing only a little energy there; Mitsuba 3's
 *    principled, whose diffuse is not energy conserving, only where it reduces to a GGX
 *    conductor or dielectric; a narrow modified Phong lobe: diffuse + specular cos wi; Duer's
 *    Ward, unbounded: above 1 near grazing incidence, as Mitsuba documents, and the original
 *    and balanced Ward at most 1 there);
 *  - reciprocity: f(wi, wo) = f(wo, wi) for reflection, f(wi, wo) eta^2 = f(wo, wi) for
 *    refraction (eta: the index of wo's side over wi's, radiance-scaled BTDF), also swept over
 *    rough dielectrics' grazing exits;
 *  - sampling: the directions drawn fit the density op_bsdf_eval reports (a chi-square test of
 *    their histogram over 10 x 20 equal-area bins of the sphere against the density integrated
 *    over each bin by Simpson's rule, sparse bins pooled; significance 1 % over all tests,
 *    Sidak-corrected), and eval == weight * pdf for each non-delta sample. A density that is
 *    only slightly wrong (the samples of alpha 0.3, the density of alpha 0.33) must be rejected,
 *    so the test is known to be able to fail.
 * CHI2_DEBUG=1 in the environment prints every chi-square test's p-value and its most deviant
 * bins. */
#include "test_support.h"

#include <complex.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bsdf/bsdf.h"
#include "math/rng.h"
#include "scene/scene_desc.h"

enum expect {
    EXPECT_BOUND,       /* albedo <= 1 only */
    EXPECT_REFLECTANCE, /* albedo == the diffuse reflectance */
    EXPECT_CONDUCTOR,   /* albedo == the exact Fresnel reflectance of the conductor */
    EXPECT_DIELECTRIC,  /* albedo == F + (1 - F) / eta^2 */
    EXPECT_NEAR_ONE,    /* energy in [0.95, 1] */
    EXPECT_PHONG,       /* a narrow modified Phong lobe: albedo == diffuse + specular cos wi
                           where the lobe lies above the surface (cos wi >= 0.5) */
    EXPECT_UNBOUNDED    /* no bound: Duer's Ward, which Mitsuba documents as not always
                           conserving energy (test_ward_duer_gains_energy) */
};

typedef struct model {
    const char *xml;  /* the <bsdf> element */
    enum expect expect;
    int chi2;         /* has a non-delta part smooth enough for the binned test */
    int boundary;     /* test op_bsdf_boundary's reflection lobe of it instead */
} model;

#define M3(bsdf) "<scene version=\"3.0.0\">" bsdf "</scene>"

static const model models[] = {
    {"<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.8, 0.5, 0.2\"/></bsdf>",
     EXPECT_REFLECTANCE, 1, 0},
    {"<bsdf type=\"twosided\"><bsdf type=\"diffuse\"/></bsdf>", EXPECT_REFLECTANCE, 1, 0},
    {"<bsdf type=\"roughdiffuse\"><rgb name=\"reflectance\" value=\"0.9\"/></bsdf>", EXPECT_BOUND,
     1, 0},
    {"<bsdf type=\"roughdiffuse\"><float name=\"alpha\" value=\"0.8\"/>"
     "<rgb name=\"reflectance\" value=\"0.9\"/></bsdf>", EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"roughdiffuse\"><float name=\"alpha\" value=\"0.8\"/>"
     "<boolean name=\"useFastApprox\" value=\"true\"/></bsdf>", EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"conductor\"/>", EXPECT_CONDUCTOR, 0, 0},
    {"<bsdf type=\"conductor\"><string name=\"material\" value=\"Au\"/>"
     "<string name=\"extEta\" value=\"water\"/></bsdf>", EXPECT_CONDUCTOR, 0, 0},
    {"<bsdf type=\"conductor\"><string name=\"material\" value=\"none\"/></bsdf>",
     EXPECT_CONDUCTOR, 0, 0},
    {"<bsdf type=\"plastic\"/>", EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"plastic\"><float name=\"intIOR\" value=\"1.9\"/>"
     "<boolean name=\"nonlinear\" value=\"true\"/></bsdf>", EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"roughplastic\"/>", EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"roughplastic\"><float name=\"alpha\" value=\"0.4\"/>"
     "<string name=\"distribution\" value=\"ggx\"/></bsdf>", EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"roughconductor\"/>", EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"roughconductor\"><float name=\"alpha\" value=\"0.05\"/>"
     "<string name=\"material\" value=\"none\"/></bsdf>", EXPECT_NEAR_ONE, 0, 0},
    {"<bsdf type=\"roughconductor\"><float name=\"alpha\" value=\"0.05\"/>"
     "<string name=\"distribution\" value=\"ggx\"/>"
     "<string name=\"material\" value=\"none\"/></bsdf>", EXPECT_NEAR_ONE, 0, 0},
    {"<bsdf type=\"roughconductor\"><float name=\"alpha\" value=\"0.3\"/>"
     "<string name=\"distribution\" value=\"ggx\"/>"
     "<string name=\"material\" value=\"none\"/></bsdf>", EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"roughconductor\"><float name=\"alpha\" value=\"0.6\"/>"
     "<string name=\"distribution\" value=\"ggx\"/>"
     "<string name=\"material\" value=\"Al\"/></bsdf>", EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"roughconductor\"><float name=\"alpha\" value=\"0.5\"/>"
     "<boolean name=\"sampleVisible\" value=\"false\"/></bsdf>", EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"roughconductor\"><float name=\"alpha\" value=\"0.3\"/>"
     "<string name=\"distribution\" value=\"ggx\"/>"
     "<boolean name=\"sampleVisible\" value=\"false\"/></bsdf>", EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"roughconductor\"><float name=\"alpha\" value=\"0.2\"/>"
     "<string name=\"distribution\" value=\"phong\"/></bsdf>", EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"roughconductor\"><float name=\"alphaU\" value=\"0.1\"/>"
     "<float name=\"alphaV\" value=\"0.4\"/><string name=\"distribution\" value=\"as\"/></bsdf>",
     EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"roughconductor\"><float name=\"alphaU\" value=\"0.1\"/>"
     "<float name=\"alphaV\" value=\"0.4\"/><string name=\"distribution\" value=\"ggx\"/></bsdf>",
     EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"roughconductor\"><float name=\"alphaU\" value=\"0.4\"/>"
     "<float name=\"alphaV\" value=\"0.15\"/></bsdf>", EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"roughconductor\"><rgb name=\"eta\" value=\"0.2, 0.9, 1.1\"/>"
     "<rgb name=\"k\" value=\"3.9, 2.4, 2.1\"/><float name=\"alpha\" value=\"0.2\"/></bsdf>",
     EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"twosided\"><bsdf type=\"roughconductor\">"
     "<string name=\"distribution\" value=\"ggx\"/><float name=\"alpha\" value=\"0.3\"/>"
     "</bsdf></bsdf>", EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"dielectric\"/>", EXPECT_DIELECTRIC, 0, 0},
    {"<bsdf type=\"dielectric\"><string name=\"intIOR\" value=\"water\"/>"
     "<float name=\"extIOR\" value=\"1.5\"/></bsdf>", EXPECT_DIELECTRIC, 0, 0},
    {"<bsdf type=\"roughdielectric\"/>", EXPECT_NEAR_ONE, 1, 0},
    {"<bsdf type=\"roughdielectric\"><float name=\"alpha\" value=\"0.3\"/>"
     "<string name=\"distribution\" value=\"ggx\"/></bsdf>", EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"roughdielectric\"><float name=\"alpha\" value=\"0.05\"/>"
     "<string name=\"distribution\" value=\"ggx\"/><string name=\"intIOR\" value=\"water\"/>"
     "<float name=\"extIOR\" value=\"1.5\"/></bsdf>", EXPECT_NEAR_ONE, 0, 0},
    {"<bsdf type=\"roughdielectric\"><float name=\"alpha\" value=\"0.3\"/>"
     "<string name=\"intIOR\" value=\"water\"/><string name=\"extIOR\" value=\"bk7\"/></bsdf>",
     EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"roughdielectric\"><float name=\"alphaU\" value=\"0.1\"/>"
     "<float name=\"alphaV\" value=\"0.3\"/><string name=\"distribution\" value=\"ggx\"/></bsdf>",
     EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"roughdielectric\"><float name=\"alpha\" value=\"0.2\"/>"
     "<boolean name=\"sampleVisible\" value=\"false\"/></bsdf>", EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"roughdielectric\"><float name=\"alpha\" value=\"0.3\"/>"
     "<string name=\"distribution\" value=\"phong\"/><float name=\"intIOR\" value=\"2.4\"/>"
     "</bsdf>", EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"roughdielectric\"><float name=\"alpha\" value=\"0.3\"/></bsdf>", EXPECT_BOUND,
     1, 1},
    {"<bsdf type=\"coating\"/>", EXPECT_BOUND, 0, 1},
    /* Mitsuba 3's principled: its diffuse (with retro-reflection and sheen) is not energy
     * conserving by design, so only its bound with a darker base, and energy close to 1 where
     * it is a GGX conductor (metallic 1, Schlick's F of a white base: 1) or dielectric
     * (spec_trans 1, white base) of low roughness */
    {M3("<bsdf type=\"principled\"/>"), EXPECT_BOUND, 1, 0},
    {M3("<bsdf type=\"principled\"><rgb name=\"base_color\" value=\"1\"/>"
     "<float name=\"metallic\" value=\"1\"/><float name=\"roughness\" value=\"0.2\"/></bsdf>"),
     EXPECT_NEAR_ONE, 0, 0},
    {M3("<bsdf type=\"principled\"><rgb name=\"base_color\" value=\"0.9, 0.6, 0.3\"/>"
     "<float name=\"metallic\" value=\"1\"/><float name=\"roughness\" value=\"0.45\"/>"
     "<float name=\"anisotropic\" value=\"0.7\"/></bsdf>"), EXPECT_BOUND, 1, 0},
    {M3("<bsdf type=\"principled\"><rgb name=\"base_color\" value=\"1\"/>"
     "<float name=\"spec_trans\" value=\"1\"/><float name=\"roughness\" value=\"0.2\"/>"
     "<float name=\"eta\" value=\"1.5\"/></bsdf>"), EXPECT_NEAR_ONE, 0, 0},
    {M3("<bsdf type=\"principled\"><rgb name=\"base_color\" value=\"0.8, 0.9, 1\"/>"
     "<float name=\"spec_trans\" value=\"1\"/><float name=\"roughness\" value=\"0.5\"/>"
     "<float name=\"specular\" value=\"0.7\"/></bsdf>"), EXPECT_BOUND, 1, 0},
    {M3("<bsdf type=\"principled\"><rgb name=\"base_color\" value=\"0.3, 0.6, 0.8\"/>"
     "<float name=\"spec_trans\" value=\"0.6\"/><float name=\"metallic\" value=\"0.2\"/>"
     "<float name=\"anisotropic\" value=\"0.5\"/><float name=\"roughness\" value=\"0.4\"/>"
     "<float name=\"eta\" value=\"1.3\"/><float name=\"clearcoat\" value=\"0.5\"/></bsdf>"),
     EXPECT_BOUND, 1, 0},
    {M3("<bsdf type=\"principled\"><rgb name=\"base_color\" value=\"0.5\"/>"
     "<float name=\"clearcoat\" value=\"1\"/><float name=\"clearcoat_gloss\" value=\"0.3\"/>"
     "<float name=\"roughness\" value=\"0.7\"/></bsdf>"), EXPECT_BOUND, 1, 0},
    {M3("<bsdf type=\"principled\"><rgb name=\"base_color\" value=\"0.6, 0.4, 0.2\"/>"
     "<float name=\"anisotropic\" value=\"0.8\"/><float name=\"roughness\" value=\"0.6\"/>"
     "<float name=\"metallic\" value=\"0.4\"/><float name=\"spec_tint\" value=\"0.5\"/>"
     "<float name=\"sheen\" value=\"1\"/><float name=\"sheen_tint\" value=\"0.5\"/>"
     "<float name=\"flatness\" value=\"0.5\"/><float name=\"main_specular_sampling_rate\" "
     "value=\"0.5\"/></bsdf>"), EXPECT_BOUND, 1, 0},
    {M3("<bsdf type=\"twosided\"><bsdf type=\"principled\"><float name=\"metallic\" "
     "value=\"0.5\"/></bsdf></bsdf>"), EXPECT_BOUND, 1, 0},
    {M3("<bsdf type=\"principledthin\"/>"), EXPECT_BOUND, 1, 0},
    {M3("<bsdf type=\"principledthin\"><rgb name=\"base_color\" value=\"1\"/>"
     "<float name=\"spec_trans\" value=\"1\"/><float name=\"roughness\" value=\"0.2\"/>"
     "</bsdf>"), EXPECT_NEAR_ONE, 0, 0},
    {M3("<bsdf type=\"principledthin\"><rgb name=\"base_color\" value=\"0.7, 0.3, 0.3\"/>"
     "<float name=\"spec_trans\" value=\"0.6\"/><float name=\"diff_trans\" value=\"1.4\"/>"
     "<float name=\"anisotropic\" value=\"0.5\"/><float name=\"roughness\" value=\"0.5\"/>"
     "<float name=\"eta\" value=\"1.33\"/><float name=\"sheen\" value=\"0.8\"/>"
     "<float name=\"spec_tint\" value=\"0.3\"/></bsdf>"), EXPECT_BOUND, 1, 0},
    /* last, so that the models above keep their random directions (each model's seed is its
     * index) */
    {"<bsdf type=\"roughplastic\"><float name=\"alpha\" value=\"0.4\"/>"
     "<string name=\"distribution\" value=\"beckmann\"/></bsdf>", EXPECT_BOUND, 1, 0},
    /* Mitsuba 0.6's phong and ward (all of them reciprocal) */
    {"<bsdf type=\"phong\"/>", EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"phong\"><rgb name=\"diffuseReflectance\" value=\"0.94, 0.87, 0.74\"/>"
     "<rgb name=\"specularReflectance\" value=\"0.034, 0.032, 0.029\"/>"
     "<float name=\"exponent\" value=\"1.07\"/></bsdf>", EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"phong\"><rgb name=\"diffuseReflectance\" value=\"0.1, 0.05, 0\"/>"
     "<rgb name=\"specularReflectance\" value=\"0.9, 0.7, 0.5\"/>"
     "<float name=\"exponent\" value=\"300\"/></bsdf>", EXPECT_PHONG, 1, 0},
    {"<bsdf type=\"ward\"/>", EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"ward\"><float name=\"alphaU\" value=\"0.1\"/>"
     "<float name=\"alphaV\" value=\"0.4\"/><spectrum name=\"diffuseReflectance\" "
     "value=\"0\"/><spectrum name=\"specularReflectance\" value=\"1\"/></bsdf>",
     EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"ward\"><string name=\"variant\" value=\"ward\"/>"
     "<float name=\"alphaU\" value=\"0.3\"/><float name=\"alphaV\" value=\"0.15\"/>"
     "<spectrum name=\"diffuseReflectance\" value=\"0\"/>"
     "<spectrum name=\"specularReflectance\" value=\"1\"/></bsdf>", EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"ward\"><string name=\"variant\" value=\"ward-duer\"/>"
     "<float name=\"alpha\" value=\"0.2\"/><rgb name=\"diffuseReflectance\" "
     "value=\"0.3, 0.2, 0.1\"/></bsdf>", EXPECT_BOUND, 1, 0},
    {"<bsdf type=\"ward\"><string name=\"variant\" value=\"ward-duer\"/>"
     "<float name=\"alpha\" value=\"0.5\"/><spectrum name=\"diffuseReflectance\" "
     "value=\"0\"/><spectrum name=\"specularReflectance\" value=\"1\"/></bsdf>",
     EXPECT_UNBOUNDED, 1, 0},
    {"<bsdf type=\"twosided\"><bsdf type=\"ward\"><float name=\"alpha\" value=\"0.4\"/>"
     "<spectrum name=\"diffuseReflectance\" value=\"0\"/>"
     "<rgb name=\"specularReflectance\" value=\"0.616, 0.475, 0.352\"/></bsdf></bsdf>",
     EXPECT_BOUND, 1, 0},
};
enum { NMODELS = sizeof models / sizeof models[0] };

/* The incident directions: cosines (negative: from inside, for transmissive models), all at
 * azimuth 0.7 so that anisotropy shows. */
static const float cosines[] = {0.95f, 0.6f, 0.2f, -0.9f, -0.4f};
enum { NCOS = sizeof cosines / sizeof cosines[0] };

enum { FURNACE_N = 100000, CHI2_N = 100000, NZ = 10, NPHI = 20, SUB_T = 48, SUB_P = 16 };
#define SIGNIFICANCE 0.01

static op_v3 dir_at(float cos_t, float phi)
{
    float s = sqrtf(fmaxf(0.0f, 1.0f - cos_t * cos_t));
    return v3(s * cosf(phi), s * sinf(phi), cos_t);
}

/* Builds model m (its boundary lobe when m->boundary) into *b. */
static void build(const model *m, op_bsdf *b)
{
    char text[2048];
    if (strncmp(m->xml, "<scene", 6) == 0) /* a whole scene (a Mitsuba 3 one) */
        snprintf(text, sizeof text, "%s", m->xml);
    else
        snprintf(text, sizeof text, "<scene version=\"0.6.0\">%s</scene>", m->xml);
    const char *path = op_test_write_temp("bsdf.xml", text);
    op_node *root = NULL;
    op_error err = {0};
    OP_ASSERT_OK(op_desc_parse(path, NULL, 0, NULL, &root, &err), err);
    op_bsdf given;
    OP_ASSERT_OK(op_bsdf_build(root->children[0], NULL, &given, &err), err);
    op_desc_free(root);
    if (!m->boundary) {
        *b = given;
        return;
    }
    static op_bsdf_through through;
    OP_ASSERT_OK(op_bsdf_boundary(&given, b, &through, &err), err);
}

static int transmits(const op_bsdf *b)
{
    return b->type == OP_BSDF_DIELECTRIC || b->type == OP_BSDF_ROUGHDIELECTRIC ||
           (b->type == OP_BSDF_PRINCIPLED && (b->pr.thin || b->pr.v[OP_PR_SPEC_TRANS] > 0.0f));
}

/* Whether wi may come from below the surface for b. */
static int both_sides(const op_bsdf *b)
{
    return transmits(b) || b->twosided;
}

/* The index of wo's side over wi's, for a refraction of b from wi. */
static float eta_rel(const op_bsdf *b, op_v3 wi)
{
    if (b->type == OP_BSDF_PRINCIPLED) /* a thin sheet: the same medium on both sides */
        return b->pr.thin ? 1.0f : (wi.z > 0.0f ? b->pr.v[OP_PR_ETA] : 1.0f / b->pr.v[OP_PR_ETA]);
    return wi.z > 0.0f ? b->eta : 1.0f / b->eta;
}

static double fresnel_dielectric(double ci, double eta)
{
    double s2 = (1.0 - ci * ci) / (eta * eta);
    if (s2 >= 1.0)
        return 1.0;
    double ct = sqrt(1.0 - s2);
    double rs = (ci - eta * ct) / (ci + eta * ct), rp = (eta * ci - ct) / (eta * ci + ct);
    return 0.5 * (rs * rs + rp * rp);
}

/* The exact Fresnel reflectance of a conductor of complex index eta + i k (unpolarized). */
static double fresnel_conductor(double ci, double eta, double k)
{
    double complex n = eta + I * k;
    double si2 = 1.0 - ci * ci;
    double complex ct = csqrt(1.0 - si2 / (n * n));
    double complex rs = (ci - n * ct) / (ci + n * ct), rp = (n * ci - ct) / (n * ci + ct);
    return 0.5 * (creal(rs * conj(rs)) + creal(rp * conj(rp)));
}

/* (a) the directional albedo at every incident direction, per channel. */
static void furnace_one(const model *m)
{
    op_bsdf b;
    build(m, &b);
    for (int c = 0; c < NCOS; c++) {
        if (cosines[c] < 0.0f && !both_sides(&b))
            continue;
        op_v3 wi = dir_at(cosines[c], 0.7f);
        op_rng rng = op_rng_seed(11, (uint64_t)c, 3);
        double sum[3] = {0, 0, 0}, sum2[3] = {0, 0, 0}, energy = 0.0, energy2 = 0.0;
        for (int i = 0; i < FURNACE_N; i++) {
            float u1 = op_rng_float(&rng), u2 = op_rng_float(&rng), u3 = op_rng_float(&rng);
            op_bsdf_sample s;
            if (!op_bsdf_sample_dir(&b, wi, u1, u2, u3, &s))
                continue;
            double w[3] = {s.weight.x, s.weight.y, s.weight.z};
            double scale = 1.0;
            if (s.wo.z * wi.z < 0.0f && transmits(&b)) {
                double e = eta_rel(&b, wi);
                scale = e * e;
            }
            for (int k = 0; k < 3; k++) {
                sum[k] += w[k];
                sum2[k] += w[k] * w[k];
            }
            double en = fmax(w[0], fmax(w[1], w[2])) * scale;
            energy += en;
            energy2 += en * en;
        }
        double mean_e = energy / FURNACE_N;
        double se_e = sqrt(fmax(energy2 / FURNACE_N - mean_e * mean_e, 0.0) / FURNACE_N);
        if (m->expect != EXPECT_UNBOUNDED && mean_e > 1.0 + 4.0 * se_e + 1e-4)
            fail_msg("%s at cos %g: albedo %.5f > 1 (standard error %.5f)", m->xml,
                     (double)cosines[c], mean_e, se_e);
        double ci = fabs((double)wi.z);
        for (int k = 0; k < 3; k++) {
            double mean = sum[k] / FURNACE_N;
            double se = sqrt(fmax(sum2[k] / FURNACE_N - mean * mean, 0.0) / FURNACE_N);
            double want = NAN, tol = 4.0 * se + 1e-4;
            if (m->expect == EXPECT_REFLECTANCE)
                want = v3_get(b.reflectance, k), tol = 1e-5;
            else if (m->expect == EXPECT_CONDUCTOR)
                want = b.mirror ? 1.0
                                : fresnel_conductor(ci, v3_get(b.cond_eta, k),
                                                    v3_get(b.cond_k, k)),
                tol = 1e-3;
            else if (m->expect == EXPECT_PHONG && ci >= 0.5)
                want = v3_get(b.phong.dg.diffuse, k) + v3_get(b.phong.dg.specular, k) * ci;
            else if (m->expect == EXPECT_DIELECTRIC) {
                double e = eta_rel(&b, wi), f = fresnel_dielectric(ci, e);
                want = f + (1.0 - f) / (e * e);
            }
            if (!isnan(want) && fabs(mean - want) > tol)
                fail_msg("%s at cos %g, channel %d: albedo %.5f, expected %.5f (+- %.5f)", m->xml,
                         (double)cosines[c], k, mean, want, tol);
        }
        if (m->expect == EXPECT_NEAR_ONE && fabs((double)wi.z) >= 0.5 && mean_e < 0.95)
            fail_msg("%s at cos %g: energy %.5f, expected close to 1", m->xml,
                     (double)cosines[c], mean_e);
    }
}

/* The directional albedo of b at cos ci by FURNACE_N samples (the largest channel). */
static double albedo_at(const op_bsdf *b, float ci)
{
    op_v3 wi = dir_at(ci, 0.7f);
    op_rng rng = op_rng_seed(13, 0, 0);
    double sum = 0.0;
    for (int i = 0; i < FURNACE_N; i++) {
        float u1 = op_rng_float(&rng), u2 = op_rng_float(&rng), u3 = op_rng_float(&rng);
        op_bsdf_sample s;
        if (op_bsdf_sample_dir(b, wi, u1, u2, u3, &s))
            sum += v3_max(s.weight);
    }
    return sum / FURNACE_N;
}

/* Ward's three normalisations near grazing incidence (cos 0.1, alpha 0.5, white specular):
 * Duer's reflects more than it receives (about 1.21 by quadrature), the balanced and the
 * original ones at most 1. */
static void test_ward_duer_gains_energy(void **state)
{
    (void)state;
    static const char *const variants[] = {"ward-duer", "balanced", "ward"};
    for (int k = 0; k < 3; k++) {
        char xml[512];
        snprintf(xml, sizeof xml, "<bsdf type=\"ward\"><string name=\"variant\" value=\"%s\"/>"
                 "<float name=\"alpha\" value=\"0.5\"/><spectrum name=\"diffuseReflectance\" "
                 "value=\"0\"/><spectrum name=\"specularReflectance\" value=\"1\"/></bsdf>",
                 variants[k]);
        model m = {xml, EXPECT_BOUND, 0, 0};
        op_bsdf b;
        build(&m, &b);
        double a = albedo_at(&b, 0.1f);
        if (k == 0 ? !(a > 1.1 && a < 1.3) : !(a <= 1.0))
            fail_msg("ward %s at cos 0.1: albedo %.4f", variants[k], a);
    }
}

static void test_furnace(void **state)
{
    (void)state;
    for (int i = 0; i < NMODELS; i++)
        furnace_one(&models[i]);
}

/* (b) reciprocity over random pairs of directions (both on one side, or, for transmissive
 * models, on either). */
static void test_reciprocity(void **state)
{
    (void)state;
    for (int i = 0; i < NMODELS; i++) {
        op_bsdf b;
        build(&models[i], &b);
        op_rng rng = op_rng_seed(5, (uint64_t)i, 0);
        int nonzero = 0;
        for (int n = 0; n < 4000; n++) {
            op_v3 wi = op_sample_sphere(op_rng_float(&rng), op_rng_float(&rng));
            op_v3 wo = op_sample_sphere(op_rng_float(&rng), op_rng_float(&rng));
            if (!both_sides(&b)) {
                wi.z = fabsf(wi.z);
                wo.z = fabsf(wo.z);
            } else if (!transmits(&b) && (wi.z > 0.0f) != (wo.z > 0.0f)) {
                wo.z = -wo.z;
            }
            if (fabsf(wi.z) < 1e-3f || fabsf(wo.z) < 1e-3f)
                continue;
            /* principledthin's transmission is not reciprocal as Mitsuba 3 defines it: its
             * half vector is that of the reflection mirrored through the sheet, and which
             * facets may pass light is judged from wo's side only */
            if (b.type == OP_BSDF_PRINCIPLED && b.pr.thin && wi.z * wo.z < 0.0f)
                continue;
            float p1, p2;
            op_v3 f1 = op_bsdf_eval(&b, wi, wo, &p1), f2 = op_bsdf_eval(&b, wo, wi, &p2);
            double scale = 1.0;
            if (wi.z * wo.z < 0.0f) {
                double e = eta_rel(&b, wi);
                scale = e * e;
            }
            for (int k = 0; k < 3; k++) {
                double a = v3_get(f1, k) / fabs((double)wo.z) * scale;
                double c = v3_get(f2, k) / fabs((double)wi.z);
                if (!(fabs(a - c) <= 1e-2 * fmax(a, c) + 1e-6))
                    fail_msg("%s: f(wi, wo) %g != f(wo, wi) %g at wi (%g %g %g) wo (%g %g %g)",
                             models[i].xml, a, c, (double)wi.x, (double)wi.y, (double)wi.z,
                             (double)wo.x, (double)wo.y, (double)wo.z);
                nonzero += a > 0.0;
            }
        }
        if (models[i].chi2 && nonzero == 0)
            fail_msg("%s: no pair with a non-zero value", models[i].xml);
    }
}

/* (b) again for rough dielectrics where light leaves through a facet at a grazing angle (from
 * inside near the critical angle), where the transmission is most sensitive to rounding:
 * directions inside at cos -0.95 .. -0.3, outside at cos 0.002 .. 0.3. */
static void test_rough_dielectric_grazing_reciprocity(void **state)
{
    (void)state;
    static const char *const xml[] = {
        "<bsdf type=\"roughdielectric\"><float name=\"alpha\" value=\"0.2\"/>"
        "<boolean name=\"sampleVisible\" value=\"false\"/></bsdf>",
        "<bsdf type=\"roughdielectric\"><float name=\"alpha\" value=\"0.05\"/></bsdf>",
        "<bsdf type=\"roughdielectric\"><float name=\"alpha\" value=\"0.2\"/>"
        "<string name=\"distribution\" value=\"ggx\"/></bsdf>",
        "<bsdf type=\"roughdielectric\"><float name=\"alpha\" value=\"0.5\"/>"
        "<string name=\"distribution\" value=\"ggx\"/><float name=\"intIOR\" value=\"2.4\"/>"
        "</bsdf>"};
    for (size_t i = 0; i < sizeof xml / sizeof xml[0]; i++) {
        model m = {xml[i], EXPECT_BOUND, 0, 0};
        op_bsdf b;
        build(&m, &b);
        op_rng rng = op_rng_seed(23, (uint64_t)i, 0);
        int nonzero = 0;
        double worst = 0.0;
        for (int n = 0; n < 20000; n++) {
            float ci = -0.95f + 0.65f * op_rng_float(&rng);
            float co = 0.002f + 0.298f * op_rng_float(&rng);
            op_v3 wi = dir_at(ci, 2.0f * OP_PI * op_rng_float(&rng));
            op_v3 wo = dir_at(co, 2.0f * OP_PI * op_rng_float(&rng));
            float p1, p2;
            op_v3 f1 = op_bsdf_eval(&b, wi, wo, &p1), f2 = op_bsdf_eval(&b, wo, wi, &p2);
            double e = eta_rel(&b, wi);
            double a = f1.x / fabs((double)wo.z) * e * e, c = f2.x / fabs((double)wi.z);
            if (fmax(a, c) <= 1e-6)
                continue;
            nonzero++;
            worst = fmax(worst, fabs(a - c) / fmax(a, c));
            if (!(fabs(a - c) <= 1e-2 * fmax(a, c)))
                fail_msg("%s: f(wi, wo) %g != f(wo, wi) %g at wi (%g %g %g) wo (%g %g %g)", xml[i],
                         a, c, (double)wi.x, (double)wi.y, (double)wi.z, (double)wo.x,
                         (double)wo.y, (double)wo.z);
        }
        if (getenv("CHI2_DEBUG"))
            fprintf(stderr, "%s: %d pairs, worst relative difference %g\n", xml[i], nonzero, worst);
        if (nonzero < 100)
            fail_msg("%s: only %d pairs with a non-zero value", xml[i], nonzero);
    }
}

/* The regularized upper incomplete gamma function Q(a, x). */
static double gamma_q(double a, double x)
{
    if (x <= 0.0)
        return 1.0;
    double lg = lgamma(a);
    if (x < a + 1.0) {
        double term = 1.0 / a, sum = term;
        for (int n = 1; n < 1000; n++) {
            term *= x / (a + n);
            sum += term;
            if (term < sum * 1e-15)
                break;
        }
        return 1.0 - sum * exp(-x + a * log(x) - lg);
    }
    /* Lentz's continued fraction */
    double b = x + 1.0 - a, c = 1.0 / 1e-300, d = 1.0 / b, h = d;
    for (int n = 1; n < 1000; n++) {
        double an = -n * (n - a);
        b += 2.0;
        d = an * d + b;
        if (fabs(d) < 1e-300)
            d = 1e-300;
        c = b + an / c;
        if (fabs(c) < 1e-300)
            c = 1e-300;
        d = 1.0 / d;
        double del = d * c;
        h *= del;
        if (fabs(del - 1.0) < 1e-15)
            break;
    }
    return exp(-x + a * log(x) - lg) * h;
}

/* The density op_bsdf_eval reports for dens integrated over each bin, times n: Simpson's rule
 * in (theta, phi) within each bin (dw = sin theta dtheta dphi), which resolves lobes near the
 * poles that the equal-area bins compress in cos theta. */
static void expected_counts(const op_bsdf *dens, op_v3 wi, double n, double *expect)
{
    enum { GT = SUB_T + 1, GP = NPHI * SUB_P + 1 };
    static double grid[GT][GP];
    double hp = 2.0 * M_PI / (GP - 1);
    for (int bz = 0; bz < NZ; bz++) {
        double t0 = acos(-1.0 + 2.0 * (bz + 1) / NZ), t1 = acos(-1.0 + 2.0 * bz / NZ);
        double ht = (t1 - t0) / SUB_T;
        for (int i = 0; i < GT; i++) {
            /* the end nodes just inside the bin: a direction on the horizon is on neither side */
            double t = t0 + ht * (i == 0 ? 1e-5 : (i == SUB_T ? SUB_T - 1e-5 : i));
            for (int j = 0; j < GP; j++) {
                double phi = hp * j;
                op_v3 wo = v3((float)(sin(t) * cos(phi)), (float)(sin(t) * sin(phi)), (float)cos(t));
                float pdf;
                op_bsdf_eval(dens, wi, wo, &pdf);
                grid[i][j] = pdf * sin(t);
            }
        }
        for (int bp = 0; bp < NPHI; bp++) {
            double sum = 0.0;
            for (int i = 0; i <= SUB_T; i++)
                for (int j = 0; j <= SUB_P; j++) {
                    double wt = (i == 0 || i == SUB_T) ? 1.0 : (i % 2 ? 4.0 : 2.0);
                    double wp = (j == 0 || j == SUB_P) ? 1.0 : (j % 2 ? 4.0 : 2.0);
                    sum += wt * wp * grid[i][bp * SUB_P + j];
                }
            expect[bz * NPHI + bp] = n * sum * ht * hp / 9.0;
        }
    }
}

static int bin_of(op_v3 w)
{
    int bz = (int)((w.z + 1.0f) * 0.5f * NZ);
    float phi = atan2f(w.y, w.x);
    if (phi < 0.0f)
        phi += 2.0f * OP_PI;
    int bp = (int)(phi / (2.0f * OP_PI) * NPHI);
    bz = bz < 0 ? 0 : (bz >= NZ ? NZ - 1 : bz);
    bp = bp < 0 ? 0 : (bp >= NPHI ? NPHI - 1 : bp);
    return bz * NPHI + bp;
}

/* The chi-square test's p-value for CHI2_N directions drawn by samp from wi against the density
 * of dens; directions not drawn (absorbed, delta) count in one more bin. Checks eval == weight *
 * pdf for the first samples. */
static double chi2_pvalue(const op_bsdf *samp, const op_bsdf *dens, op_v3 wi, uint64_t seed,
                          const char *what)
{
    enum { NB = NZ * NPHI + 1 };
    double obs[NB] = {0}, expect[NB];
    expected_counts(dens, wi, CHI2_N, expect);
    op_rng rng = op_rng_seed(seed, 17, 29);
    double drawn = 0.0, integral = 0.0;
    for (int i = 0; i < CHI2_N; i++) {
        float u1 = op_rng_float(&rng), u2 = op_rng_float(&rng), u3 = op_rng_float(&rng);
        op_bsdf_sample s;
        if (!op_bsdf_sample_dir(samp, wi, u1, u2, u3, &s) || s.delta)
            continue;
        obs[bin_of(s.wo)] += 1.0;
        drawn += 1.0;
        if (i < 4000) {
            float pdf;
            op_v3 f = op_bsdf_eval(samp, wi, s.wo, &pdf);
            if (!(fabsf(pdf - s.pdf) <= 1e-3f * fmaxf(pdf, s.pdf)))
                fail_msg("%s: sampled pdf %g, eval's %g", what, (double)s.pdf, (double)pdf);
            for (int k = 0; k < 3; k++) {
                double a = v3_get(f, k), c = (double)v3_get(s.weight, k) * s.pdf;
                if (!(fabs(a - c) <= 1e-3 * fmax(a, c) + 1e-7))
                    fail_msg("%s: eval %g != weight * pdf %g", what, a, c);
            }
        }
    }
    for (int i = 0; i < NB - 1; i++)
        integral += expect[i];
    obs[NB - 1] = CHI2_N - drawn;
    expect[NB - 1] = fmax(CHI2_N - integral, 0.0);
    /* pool the bins expecting fewer than 5 into one */
    double chi2 = 0.0, pool_o = 0.0, pool_e = 0.0;
    int dof = -1;
    for (int i = 0; i < NB; i++) {
        if (expect[i] < 5.0) {
            pool_o += obs[i];
            pool_e += expect[i];
            continue;
        }
        double d = obs[i] - expect[i];
        chi2 += d * d / expect[i];
        dof++;
    }
    if (pool_e > 0.0) {
        double d = pool_o - pool_e;
        chi2 += d * d / pool_e;
        dof++;
    } else if (pool_o > 0.0) {
        return 0.0; /* directions where the density is 0 */
    }
    if (getenv("CHI2_DEBUG"))
        for (int i = 0; i < NB; i++) {
            double d = obs[i] - expect[i];
            if (expect[i] >= 5.0 && d * d / expect[i] > 12.0)
                fprintf(stderr, "  %s bin z%d phi%d: observed %g expected %g\n", what, i / NPHI,
                        i % NPHI, obs[i], expect[i]);
        }
    if (dof < 1)
        return 1.0;
    return gamma_q(0.5 * dof, 0.5 * chi2);
}

static int chi2_count(void)
{
    int n = 0;
    for (int i = 0; i < NMODELS; i++) {
        if (!models[i].chi2)
            continue;
        op_bsdf b;
        build(&models[i], &b);
        for (int c = 0; c < NCOS; c++)
            n += cosines[c] > 0.0f || both_sides(&b);
    }
    return n;
}

/* (c) chi-square tests of every model with a non-delta part at every incident direction. */
static void test_chi2(void **state)
{
    (void)state;
    int ntests = chi2_count(), failures = 0;
    double threshold = 1.0 - pow(1.0 - SIGNIFICANCE, 1.0 / ntests);
    for (int i = 0; i < NMODELS; i++) {
        if (!models[i].chi2)
            continue;
        op_bsdf b;
        build(&models[i], &b);
        for (int c = 0; c < NCOS; c++) {
            if (cosines[c] < 0.0f && !both_sides(&b))
                continue;
            op_v3 wi = dir_at(cosines[c], 0.7f);
            double p = chi2_pvalue(&b, &b, wi, (uint64_t)(i * NCOS + c), models[i].xml);
            if (getenv("CHI2_DEBUG"))
                fprintf(stderr, "p %g %s %g\n", p, models[i].xml, (double)cosines[c]);
            if (p < threshold) {
                print_error("%s at cos %g: chi-square p-value %g below %g\n", models[i].xml,
                            (double)cosines[c], p, threshold);
                failures++;
            }
        }
    }
    if (failures)
        fail_msg("%d of %d chi-square tests failed", failures, ntests);
}

/* The chi-square test rejects samples of GGX alpha 0.3 against the density of alpha 0.33, of
 * a rough dielectric of index 1.5 against that of 1.55, and a density scaled by 1.02. */
static void test_chi2_rejects_wrong_density(void **state)
{
    (void)state;
    model m = {"<bsdf type=\"roughconductor\"><string name=\"distribution\" value=\"ggx\"/>"
               "<float name=\"alpha\" value=\"0.3\"/></bsdf>", EXPECT_BOUND, 1, 0};
    op_bsdf b, wrong;
    build(&m, &b);
    wrong = b;
    wrong.mf = op_mf_make(OP_MF_GGX, 0.33f, 0.33f, 1);
    op_v3 wi = dir_at(0.6f, 0.7f);
    double p = chi2_pvalue(&b, &wrong, wi, 1, "alpha 0.33 for 0.3");
    if (!(p < 1e-6))
        fail_msg("a density of alpha 0.33 passes for samples of 0.3 (p %g)", p);
    model d = {"<bsdf type=\"roughdielectric\"><string name=\"distribution\" value=\"ggx\"/>"
               "<float name=\"alpha\" value=\"0.3\"/><float name=\"intIOR\" value=\"1.5\"/>"
               "<float name=\"extIOR\" value=\"1\"/></bsdf>", EXPECT_BOUND, 1, 0};
    build(&d, &b);
    wrong = b;
    wrong.eta = 1.55f;
    p = chi2_pvalue(&b, &wrong, wi, 2, "index 1.55 for 1.5");
    if (!(p < 1e-6))
        fail_msg("a density of index 1.55 passes for samples of 1.5 (p %g)", p);
    /* principled: a main lobe of roughness 0.55 for 0.5, and a transmission share of spec_trans
     * 0.55 for 0.5 */
    model pr = {M3("<bsdf type=\"principled\"><float name=\"spec_trans\" value=\"0.5\"/>"
                   "<float name=\"clearcoat\" value=\"1\"/></bsdf>"), EXPECT_BOUND, 1, 0};
    build(&pr, &b);
    wrong = b;
    wrong.pr.v[OP_PR_ROUGHNESS] = 0.55f;
    p = chi2_pvalue(&b, &wrong, wi, 3, "principled roughness 0.55 for 0.5");
    if (!(p < 1e-6))
        fail_msg("a principled density of roughness 0.55 passes for samples of 0.5 (p %g)", p);
    wrong = b;
    wrong.pr.v[OP_PR_SPEC_TRANS] = 0.55f;
    p = chi2_pvalue(&b, &wrong, wi, 4, "principled spec_trans 0.55 for 0.5");
    if (!(p < 1e-6))
        fail_msg("a principled density of spec_trans 0.55 passes for samples of 0.5 (p %g)", p);
}

/* Conductor names: every name of Mitsuba 0.6's documentation is known, and copper agrees with
 * the RGB copper opaline used before the table (0.200 0.924 1.102 / 3.912 2.452 2.142). */
/* A rough plastic's interface tables (as Mitsuba tabulates them): nearly smooth, they are the
 * smooth interface's Fresnel terms (T = 1 - F, the internal diffuse reflectance the Egan and
 * Hilgeman fit); very rough, reflection plus transmission loses energy (Smith shadowing) and
 * light from inside escapes far more often than through a smooth one. */
static void test_roughplastic_tables(void **state)
{
    (void)state;
    model smooth = {"<bsdf type=\"roughplastic\"><float name=\"alpha\" value=\"0.001\"/>"
                    "<float name=\"intIOR\" value=\"1.5\"/></bsdf>", EXPECT_BOUND, 0, 0};
    op_bsdf b;
    build(&smooth, &b);
    assert_true(b.rough_tables);
    for (int k = 1; k < OP_THROUGH_N; k += 7) {
        float mu = (float)k / (float)(OP_THROUGH_N - 1);
        /* Fresnel of a smooth interface, independently */
        float e = 1.5f, st2 = (1.0f - mu * mu) / (e * e), ct = sqrtf(1.0f - st2);
        float rs = (mu - e * ct) / (mu + e * ct), rp = (e * mu - ct) / (e * mu + ct);
        float f = 0.5f * (rs * rs + rp * rp);
        if (fabsf(b.rough_t[k] - (1.0f - f)) > 0.01f)
            fail_msg("mu %.3f: T %.4f, smooth 1 - F %.4f", (double)mu, (double)b.rough_t[k],
                     (double)(1.0f - f));
    }
    double fdr = -1.4399 / 2.25 + 0.7099 / 1.5 + 0.6681 + 0.0636 * 1.5;
    if (fabs(b.rough_fdr - fdr) > 0.01)
        fail_msg("internal diffuse reflectance %.4f, Egan-Hilgeman %.4f", (double)b.rough_fdr, fdr);
    model rough = {"<bsdf type=\"roughplastic\"><float name=\"alpha\" value=\"1\"/>"
                   "<float name=\"intIOR\" value=\"1.5\"/></bsdf>", EXPECT_BOUND, 0, 0};
    op_bsdf r;
    build(&rough, &r);
    assert_true(r.rough_fdr < b.rough_fdr - 0.1f);
    assert_true(r.rough_t[OP_THROUGH_N / 2] < b.rough_t[OP_THROUGH_N / 2]);
}

/* A principled weight from a checkerboard: Mitsuba 3's single-channel lookup, whose colours
 * are the other way round from the colour lookup (its published textured-principled
 * references render so): at (0.25, 0.25) color1, at (0.75, 0.25) color0. diff_trans reaches
 * 2, beyond a reflectance's range. */
static void test_principled_textures(void **state)
{
    (void)state;
    const char *xml =
        "<scene version=\"3.0.0\"><bsdf type=\"principledthin\">"
        "<texture name=\"spec_trans\" type=\"checkerboard\"><float name=\"color0\" "
        "value=\"0.7\"/><float name=\"color1\" value=\"0.1\"/></texture>"
        "<texture name=\"diff_trans\" type=\"checkerboard\"><float name=\"color0\" "
        "value=\"2\"/><float name=\"color1\" value=\"0.4\"/></texture>"
        "<texture name=\"base_color\" type=\"checkerboard\"><rgb name=\"color0\" "
        "value=\"0.9, 0.5, 0.1\"/><float name=\"color1\" value=\"0.2\"/></texture>"
        "</bsdf></scene>";
    const char *path = op_test_write_temp("principled_tex.xml", xml);
    op_node *root = NULL;
    op_error err = {0};
    OP_ASSERT_OK(op_desc_parse(path, NULL, 0, NULL, &root, &err), err);
    op_tex_cache *cache = op_tex_cache_new(1 << 20);
    op_bsdf b, scratch;
    OP_ASSERT_OK(op_bsdf_build(root->children[0], cache, &b, &err), err);
    op_desc_free(root);
    const op_bsdf *at = op_bsdf_at(&b, 0.25f, 0.25f, &scratch);
    assert_float_equal(at->pr.v[OP_PR_SPEC_TRANS], 0.1, 1e-6);
    assert_float_equal(at->pr.v[OP_PR_DIFF_TRANS], 0.4, 1e-6);
    assert_float_equal(at->pr.base_color.x, 0.9, 1e-6); /* a colour: color0 */
    at = op_bsdf_at(&b, 0.75f, 0.25f, &scratch);
    assert_float_equal(at->pr.v[OP_PR_SPEC_TRANS], 0.7, 1e-6);
    assert_float_equal(at->pr.v[OP_PR_DIFF_TRANS], 2.0, 1e-6);
    assert_float_equal(at->pr.base_color.x, 0.2, 1e-6);
    op_tex_cache_free(cache);
}

/* A rough conductor's alphas as textures of one value: a Mitsuba 3 checkerboard gives color1
 * where its colour is color0 (as Mitsuba 3's single-value lookup does), a Mitsuba 0.6 one
 * color0; a colour texture's value is its luminance (3) or mean (0.6); alpha sets both.
 * want[0..1]: alphaU, alphaV in the checkerboard's color0 cell, want[2..3] in a color1 cell. */
static void check_rough_textures(const char *version, const float want[4])
{
    int m3 = version[0] == '3';
    char xml[2048];
    snprintf(xml, sizeof xml,
             "<scene version=\"%s\"><bsdf type=\"roughconductor\">"
             "<texture name=\"%s\" type=\"checkerboard\"><float name=\"color0\" "
             "value=\"0.05\"/><float name=\"color1\" value=\"0.3\"/></texture>"
             "<texture name=\"%s\" type=\"checkerboard\"><rgb name=\"color0\" "
             "value=\"0.1, 0.2, 0.9\"/><float name=\"color1\" value=\"0.3\"/></texture>"
             "</bsdf><bsdf type=\"roughdielectric\"><texture name=\"alpha\" "
             "type=\"checkerboard\"><float name=\"color0\" value=\"0.05\"/><float "
             "name=\"color1\" value=\"0.3\"/></texture></bsdf></scene>",
             version, m3 ? "alpha_u" : "alphaU", m3 ? "alpha_v" : "alphaV");
    const char *path = op_test_write_temp("rough_tex.xml", xml);
    op_node *root = NULL;
    op_error err = {0};
    OP_ASSERT_OK(op_desc_parse(path, NULL, 0, NULL, &root, &err), err);
    op_tex_cache *cache = op_tex_cache_new(1 << 20);
    op_bsdf b, d, scratch;
    OP_ASSERT_OK(op_bsdf_build(root->children[0], cache, &b, &err), err);
    OP_ASSERT_OK(op_bsdf_build(root->children[1], cache, &d, &err), err);
    op_desc_free(root);
    const op_bsdf *at = op_bsdf_at(&b, 0.25f, 0.25f, &scratch); /* the color0 cell */
    assert_float_equal(at->mf.alpha_u, want[0], 1e-6);
    assert_float_equal(at->mf.alpha_v, want[1], 1e-5);
    at = op_bsdf_at(&b, 0.75f, 0.25f, &scratch);
    assert_float_equal(at->mf.alpha_u, want[2], 1e-6);
    assert_float_equal(at->mf.alpha_v, want[3], 1e-5);
    at = op_bsdf_at(&d, 0.25f, 0.25f, &scratch);
    assert_float_equal(at->mf.alpha_u, want[0], 1e-6);
    assert_float_equal(at->mf.alpha_v, want[0], 1e-6);
    assert_float_equal(at->alpha, want[0], 1e-6);
    op_tex_cache_free(cache);
}

static void test_rough_textures(void **state)
{
    (void)state;
    float lum = 0.212671f * 0.1f + 0.715160f * 0.2f + 0.072169f * 0.9f;
    const float m3[4] = {0.3f, 0.3f, 0.05f, lum}, m06[4] = {0.05f, 0.4f, 0.3f, 0.3f};
    check_rough_textures("3.0.0", m3);
    check_rough_textures("0.6.0", m06);
}

static void test_conductor_names(void **state)
{
    (void)state;
    static const char *names[] = {"a-C", "Ag", "Al", "AlAs", "AlSb", "Au", "Be", "Cr", "CsI",
                                  "Cu", "Cu2O", "CuO", "d-C", "Hg", "HgTe", "Ir", "K", "Li",
                                  "MgO", "Mo", "Na_palik", "Nb", "Ni_palik", "Rh", "Se", "SiC",
                                  "SnTe", "Ta", "Te", "ThF4", "TiC", "TiN", "TiO2", "VC",
                                  "V_palik", "VN", "W", "Cu_palik", "none"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        char xml[256];
        snprintf(xml, sizeof xml, "<bsdf type=\"roughconductor\"><string name=\"material\" "
                 "value=\"%s\"/></bsdf>", names[i]);
        model m = {xml, EXPECT_BOUND, 0, 0};
        op_bsdf b;
        build(&m, &b);
        assert_true(b.mirror == (strcmp(names[i], "none") == 0));
        if (!b.mirror && !(v3_max(b.cond_k) >= 0.0f && v3_max(b.cond_eta) > 0.0f))
            fail_msg("%s: eta (%g %g %g) k (%g %g %g)", names[i], (double)b.cond_eta.x,
                     (double)b.cond_eta.y, (double)b.cond_eta.z, (double)b.cond_k.x,
                     (double)b.cond_k.y, (double)b.cond_k.z);
    }
    op_bsdf cu;
    model m = {"<bsdf type=\"conductor\"><float name=\"extEta\" value=\"1\"/></bsdf>",
               EXPECT_BOUND, 0, 0};
    build(&m, &cu);
    assert_float_equal(cu.cond_eta.x, 0.2004, 1e-3);
    assert_float_equal(cu.cond_eta.y, 0.9240, 1e-3);
    assert_float_equal(cu.cond_eta.z, 1.1022, 1e-3);
    assert_float_equal(cu.cond_k.x, 3.9129, 1e-3);
    assert_float_equal(cu.cond_k.y, 2.4528, 1e-3);
    assert_float_equal(cu.cond_k.z, 2.1421, 1e-3);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_conductor_names),
        cmocka_unit_test(test_roughplastic_tables),
        cmocka_unit_test(test_principled_textures),
        cmocka_unit_test(test_rough_textures),
        cmocka_unit_test(test_furnace),
        cmocka_unit_test(test_ward_duer_gains_energy),
        cmocka_unit_test(test_reciprocity),
        cmocka_unit_test(test_rough_dielectric_grazing_reciprocity),
        cmocka_unit_test(test_chi2),
        cmocka_unit_test(test_chi2_rejects_wrong_density),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
