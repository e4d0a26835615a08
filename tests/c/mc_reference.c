/* mc_reference.c - see mc_reference.h. */
#include "mc_reference.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dataset.h"
#include "dipole_reference.h"
#include "dataset_montecarlo.h"
#include "integrator/integrator.h"
#include "opaline_render.h"
#include "scene/render_scene.h"
#include "test_support.h"

#define NANG 32 /* directions per ring: a multiple of 4, symmetric under the slab's flips */

static double distance_of(const mcref_result *r, int q)
{
    return r->a + (double)(1 << q) * r->L;
}

/* The irradiance of the spot at distance rho from the disk's centre (1 there, 0 outside). */
static double spot_e(const mcref_result *r, double rho)
{
    return rho < r->a ? r->D * r->D * r->D / pow(r->D * r->D + rho * rho, 1.5) : 0.0;
}

/* The mean over the positions (px, py) of (a)'s exitance for row rd (K x K), and in grad (K x K,
 * zeroed by the caller) the derivative of that mean with respect to every kernel value. */
static double ref_exitance(const mcref_result *r, const float *rd, const double *px,
                           const double *py, int npos, double *grad)
{
    const int nr = 48, nphi = 192, K = r->K, half = K / 2;
    double sum = 0.0, inv = 1.0 / (r->pix * r->pix * npos);
    for (int i = 0; i < nr; i++) {
        double rho = r->a * (i + 0.5) / nr, w0 = spot_e(r, rho) * rho * (r->a / nr) *
                                                 (2.0 * M_PI / nphi) * inv;
        for (int j = 0; j < nphi; j++) {
            double phi = 2.0 * M_PI * (j + 0.5) / nphi, yx = rho * cos(phi), yy = rho * sin(phi);
            for (int p = 0; p < npos; p++) {
                double dx = (px[p] - yx) / r->pix, dy = (py[p] - yy) / r->pix;
                double fx = floor(dx), fy = floor(dy), tx = dx - fx, ty = dy - fy;
                int ox = (int)fx, oy = (int)fy;
                for (int b = 0; b < 2; b++) {
                    int oyb = oy + b;
                    if (oyb < -half || oyb > half)
                        continue;
                    for (int c = 0; c < 2; c++) {
                        int oxa = ox + c;
                        if (oxa < -half || oxa > half)
                            continue;
                        int col = (oyb + half) * K + oxa + half;
                        double w = w0 * (c ? tx : 1.0 - tx) * (b ? ty : 1.0 - ty);
                        sum += w * rd[col];
                        grad[col] += w;
                    }
                }
            }
        }
    }
    return sum;
}

/* A slab [-S, S]^2 in z = 0 carrying sss_xml, the emitter given, seen from above by a 32 x 32
 * camera over [-V, V]^2. */
static const char *slab_scene(const char *name, const char *sss_xml, const char *emitter,
                              double S, double V)
{
    static char text[8192];
    double fov = 2.0 * atan(0.25) * 180.0 / M_PI;
    snprintf(text, sizeof text,
             "<scene version=\"0.6.0\"><integrator type=\"path\"/>"
             " <sensor type=\"perspective\"><float name=\"fov\" value=\"%.9g\"/>"
             "  <transform name=\"toWorld\"><lookat origin=\"0,0,%.9g\" target=\"0,0,0\" "
             "   up=\"0,1,0\"/></transform>"
             "  <sampler type=\"independent\"><integer name=\"sampleCount\" value=\"1\"/></sampler>"
             "  <film type=\"hdrfilm\"><integer name=\"width\" value=\"32\"/>"
             "   <integer name=\"height\" value=\"32\"/><rfilter type=\"box\"/></film></sensor>"
             " %s"
             " <shape type=\"rectangle\"><transform name=\"toWorld\">"
             "  <scale x=\"%.9g\" y=\"%.9g\" z=\"1\"/></transform>%s</shape>"
             "</scene>",
             fov, 4.0 * V, emitter, S, S, sss_xml);
    return op_test_write_temp(name, text);
}

static op_v3 lookup(const op_sss_prepass *pre, double x, double y)
{
    op_v3 m;
    if (!op_sss_lookup(pre, 0, v3((float)x, (float)y, 0.0f), v3(0.0f, 0.0f, 1.0f), &m))
        fail_msg("no exitance at (%g, %g) mm: not a receiver", x, y);
    return m;
}

/* The ring positions at radius rho. */
static void ring(double rho, double *px, double *py)
{
    for (int j = 0; j < NANG; j++) {
        double t = 2.0 * M_PI * (j + 0.5) / NANG;
        px[j] = rho * cos(t);
        py[j] = rho * sin(t);
    }
}

/* Mean exitance per channel on the ring at rho. */
static op_v3 ring_exitance(const op_sss_prepass *pre, double rho)
{
    double px[NANG], py[NANG];
    ring(rho, px, py);
    op_v3 s = v3s(0.0f);
    for (int j = 0; j < NANG; j++)
        s = v3_add(s, v3_scale(lookup(pre, px[j], py[j]), 1.0f / NANG));
    return s;
}

static double chan(op_v3 v, int c)
{
    return c == 0 ? v.x : c == 1 ? v.y : v.z;
}

/* The spot's and the uniform light's emitters. */
static void emitters(const mcref_result *r, char *spot, char *uni, size_t cap)
{
    double cut = atan(r->a / r->D) * 180.0 / M_PI;
    snprintf(spot, cap,
             "<emitter type=\"spot\"><transform name=\"toWorld\"><lookat origin=\"0,0,%.9g\" "
             "target=\"0,0,0\"/></transform><spectrum name=\"intensity\" value=\"%.9g\"/>"
             "<float name=\"cutoffAngle\" value=\"%.9g\"/>"
             "<float name=\"beamWidth\" value=\"%.9g\"/></emitter>",
             r->D, r->D * r->D, cut, cut);
    snprintf(uni, cap, "<emitter type=\"directional\"><vector name=\"direction\" x=\"0\" y=\"0\" "
                       "z=\"-1\"/><rgb name=\"irradiance\" value=\"1\"/></emitter>");
}

/* Measures (b) (and (c) when full) in the scenes carrying sss_xml; fills got[3][4] and uni[3]. */
static void measure(const mcref_result *r, const mcref_case *k, const char *sss_xml,
                    double got[3][4], double uni[3], double *seconds, int *points)
{
    char spot[1024], unil[1024];
    emitters(r, spot, unil, sizeof spot);
    int half = r->K / 2;
    double reach = r->a + (half + 1) * r->pix; /* the exitance's support */
    double V = k->full ? reach + 2.0 * r->pix : r->a + 4.5 * r->L;
    double S = fmax(V, r->a + (half + 1.5) * r->pix) + r->pix;
    op_scene *scene = NULL;
    double secs = 0.0;
    const char *path = slab_scene("spot.xml", sss_xml, spot, S, V);
    op_sss_prepass *pre = op_test_sss_prepass(path, &scene, &secs);
    *seconds = secs;
    *points = op_sss_prepass_points(pre, 0);
    for (int q = 0; q < 3; q++) {
        op_v3 m = ring_exitance(pre, distance_of(r, q));
        for (int c = 0; c < 3; c++)
            got[c][q] = chan(m, c);
    }
    for (int c = 0; c < 3; c++)
        got[c][3] = NAN;
    if (k->full) { /* the ring integral of the exitance out to its support */
        double dr = 0.5 * r->pix, tot[3] = {0, 0, 0};
        for (double rho = 0.5 * dr; rho < reach + dr; rho += dr) {
            op_v3 m = ring_exitance(pre, rho);
            for (int c = 0; c < 3; c++)
                tot[c] += 2.0 * M_PI * rho * dr * chan(m, c);
        }
        for (int c = 0; c < 3; c++)
            got[c][3] = tot[c];
    }
    op_sss_prepass_free(pre);
    op_scene_free(scene);
    /* uniform light: the mean over 5 x 5 positions at the centre */
    path = slab_scene("uniform.xml", sss_xml, unil, S, V);
    pre = op_test_sss_prepass(path, &scene, &secs);
    *seconds += secs;
    op_v3 s = v3s(0.0f);
    for (int j = 0; j < 5; j++)
        for (int i = 0; i < 5; i++)
            s = v3_add(s, v3_scale(lookup(pre, r->pix * (i - 2), r->pix * (j - 2)), 1.0f / 25));
    for (int c = 0; c < 3; c++)
        uni[c] = chan(s, c);
    op_sss_prepass_free(pre);
    op_scene_free(scene);
}

void mcref_run(const mcref_case *k, mcref_result *r)
{
    memset(r, 0, sizeof *r);
    const op_medium *m = op_medium_lookup(k->medium);
    assert_non_null(m);
    op_medium grey = *m;
    for (int c = 0; c < 3; c++) {
        grey.sigma_s[c] = m->sigma_s[k->channel];
        grey.sigma_a[c] = m->sigma_a[k->channel];
    }
    r->sp = grey.sigma_s[0];
    r->sa = grey.sigma_a[0];
    r->eta = grey.eta;
    r->L = 1.0 / sqrt(3.0 * r->sa * (r->sa + r->sp));
    r->pix = r->L / k->pix_per_L;
    r->a = 2.0 * r->L;
    r->D = 10.0 * r->a;
    r->p_in = 2.0 * M_PI * r->D * r->D * (1.0 - r->D / sqrt(r->D * r->D + r->a * r->a));
    /* the kernel reaches from the disk's far edge to 4.5 L beyond its near edge (full), or 4.5 L
     * beyond the edge from the centre (fast: (a) and (b) truncate alike) */
    int half = (int)ceil(((k->full ? 2.0 : 1.0) * r->a + 4.5 * r->L) / r->pix);
    r->K = 2 * half + 1;

    /* the Monte Carlo dataset: one pixel, K x K, written as a raw material */
    op_error err = {0};
    op_layout l;
    op_status st = op_layout_homogeneous(&l, 1, 1, r->pix / 10.0, r->pix / 10.0, &grey, &err);
    OP_ASSERT_OK(st, err);
    op_dataset d;
    st = op_dataset_alloc(&d, 1, 1, r->K, 1, &err);
    OP_ASSERT_OK(st, err);
    d.size_x_cm = d.size_y_cm = r->pix / 10.0;
    snprintf(d.name, sizeof d.name, "MCRef%s%d", m->name, k->channel);
    snprintf(d.generator, sizeof d.generator, "montecarlo normal %llu photons",
             (unsigned long long)k->photons);
    op_mc_options o = {.photons = k->photons, .seed = 7, .threads = 2,
                       .incidence = OP_MC_NORMAL, .progress = NULL};
    op_mc_stats ms;
    op_log_level lv = op_log_get_level();
    op_log_set_level(OP_LOG_ERROR); /* no progress lines */
    st = op_mc_generate(&l, &o, &d, &ms, &err);
    op_log_set_level(lv);
    OP_ASSERT_OK(st, err);
    r->mc_seconds = ms.seconds;
    char mat[1024];
    snprintf(mat, sizeof mat, "%s", op_test_tmp_path("mc.opm"));
    st = op_dataset_write(&d, mat, &err);
    OP_ASSERT_OK(st, err);

    /* (a) */
    int cols = r->K * r->K;
    double *grad = malloc((size_t)cols * sizeof(double));
    assert_non_null(grad);
    for (int c = 0; c < 3; c++) {
        r->mc_total[c] = ms.total_reflectance[c];
        double s = 0.0, s2 = 0.0;
        for (int i = 0; i < cols; i++) {
            s += d.rd[c][i];
            s2 += (double)d.se[c][i] * d.se[c][i];
        }
        r->rowsum[c] = s;
        r->rowse[c] = sqrt(s2);
        for (int q = 0; q < 3; q++) {
            double px[NANG], py[NANG], v2 = 0.0;
            ring(distance_of(r, q), px, py);
            memset(grad, 0, (size_t)cols * sizeof(double));
            r->ref[c][q] = ref_exitance(r, d.rd[c], px, py, NANG, grad);
            for (int i = 0; i < cols; i++)
                v2 += grad[i] * grad[i] * (double)d.se[c][i] * d.se[c][i];
            r->se[c][q] = sqrt(v2);
        }
        r->ref[c][3] = r->p_in * s; /* the integral of Rd~ is the row sum */
        r->se[c][3] = r->p_in * r->rowse[c];
    }
    free(grad);

    /* (b) */
    char xml[2048];
    snprintf(xml, sizeof xml,
             "<subsurface type=\"raw\"><string name=\"material\" value=\"%s\"/>"
             "<float name=\"sceneUnitsPerMetre\" value=\"1000\"/><integer name=\"irrSamples\" value=\"1\"/>"
             "</subsurface>",
             mat);
    measure(r, k, xml, r->got, r->uni_got, &r->raw_seconds, &r->points);
    if (k->full) { /* (c) */
        snprintf(xml, sizeof xml,
                 "<subsurface type=\"dipole\"><rgb name=\"sigmaA\" value=\"%.9g\"/>"
                 "<rgb name=\"sigmaS\" value=\"%.9g\"/><float name=\"intIOR\" value=\"%.9g\"/>"
                 "<float name=\"sceneUnitsPerMetre\" value=\"1000\"/><integer name=\"irrSamples\" value=\"1\"/>"
                 "</subsurface>",
                 r->sa, r->sp, r->eta);
        double got[3][4], uni[3];
        int pts;
        measure(r, k, xml, got, uni, &r->dip_seconds, &pts);
        for (int q = 0; q < 4; q++)
            r->dip[q] = got[0][q];
        r->dip_uni = uni[0];
        for (int q = 0; q < 3; q++)
            r->cf[q] = ref_dipole_spot(r->sp, r->sa, r->eta, r->a, r->D, distance_of(r, q));
        r->cf_uni = ref_dipole_total(r->sp, r->sa, r->eta);
        r->cf[3] = r->p_in * r->cf_uni;
    }
    op_dataset_free(&d);
    op_layout_free(&l);
}
