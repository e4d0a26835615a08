/* test_render_sss_measured.c - a measured (tabulated) material's exitance on a flat patch
 * against a brute-force sum over all pairs of material pixels, computed here from the
 * material's own op_material_eval, independently of the renderer's pre-pass:
 *   M(r) = sum over the patch's pixels s within the kernel of E(s) Rd(pixel(s), r - s)
 * with E at the pixel centres. The patch is 3 x 3 tiles of a heterogeneous 16 x 16 material
 * (rows of different albedo, width and centre offset per pixel; K = 5, 7, 9) under uniform
 * light and under a point light close above it (a spot-like irradiance falling by 40x across a
 * tile); the exitance the camera would see (op_sss_lookup) at every pixel centre of the
 * central tile must match within 1 % relative RMSE per channel, at density 1 and 4. Receivers
 * are every point (no camera marking), 2 threads; 1 thread gives the same bits. A patch of
 * 11 x 11 tiles with a maxPoints below its pixels, seen close up, must still get one point per
 * material pixel where the view needs them and the same exitance (test_large_shape). */
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "integrator/integrator.h"
#include "opaline_material.h"
#include "opaline_material_write.h"
#include "opaline_render.h"
#include "scene/render_scene.h"
#include "sss/measured_points.h"
#include "test_support.h"

enum { W = 16, TILES = 3, BIG = 11 };

/* The shape of the row of pixel (x, y), channel c, at offset (dx, dy): an anisotropic
 * Gaussian whose width and centre depend on the pixel and the channel (neither symmetric nor
 * the same everywhere); albedo() is the row's sum. */
static double shape(int K, int x, int y, int c, int dx, int dy)
{
    double sx = 0.6 + 0.25 * K / 5.0 * (0.5 + ((x + 2 * y) % 4) / 4.0) + 0.2 * c;
    double sy = 0.5 + 0.2 * K / 5.0 * (0.5 + ((3 * x + y) % 5) / 5.0);
    double mx = 0.4 * (((x + y) % 3) - 1), my = 0.3 * ((y % 3) - 1);
    double ex = (dx - mx) / sx, ey = (dy - my) / sy;
    return exp(-0.5 * (ex * ex + ey * ey));
}

static double albedo(int x, int y, int c)
{
    return (0.35 + 0.15 * c) * (0.6 + 0.4 * (((x * 5 + y * 3) % 7) / 6.0));
}

/* A raw material of W x W pixels, kernel K, 1 x 1 cm, rows of shape() scaled to sum to
 * albedo(). */
static void write_material(const char *path, int K)
{
    op_material_info info;
    memset(&info, 0, sizeof info);
    info.method = OP_METHOD_RAW;
    info.width = info.height = W;
    info.kernel = K;
    info.channels = 3;
    info.size_x_cm = info.size_y_cm = 1.0;
    snprintf(info.name, sizeof info.name, "Hetero");
    snprintf(info.generator, sizeof info.generator, "test_render_sss_measured");
    int h = K / 2;
    float *rd = malloc((size_t)W * W * K * K * sizeof *rd);
    assert_non_null(rd);
    op_error err = {0};
    op_material_writer *wr;
    OP_ASSERT_OK(op_material_writer_open(path, &info, &wr, &err), err);
    static const char *tags[3] = {"RD.R", "RD.G", "RD.B"};
    for (int c = 0; c < 3; c++) {
        for (int y = 0; y < W; y++)
            for (int x = 0; x < W; x++) {
                float *row = rd + (size_t)(y * W + x) * K * K;
                double sum = 0.0;
                for (int dy = -h; dy <= h; dy++)
                    for (int dx = -h; dx <= h; dx++)
                        sum += shape(K, x, y, c, dx, dy);
                for (int dy = -h; dy <= h; dy++)
                    for (int dx = -h; dx <= h; dx++)
                        row[(dy + h) * K + dx + h] =
                            (float)(albedo(x, y, c) * shape(K, x, y, c, dx, dy) / sum);
            }
        OP_ASSERT_OK(op_material_writer_add(wr, tags[c], rd,
                                            (uint64_t)W * W * K * K * sizeof(float), &err),
                     err);
    }
    OP_ASSERT_OK(op_material_writer_commit(wr, &err), err);
    free(rd);
}

/* The patch: [-T/2, T/2]^2 in z = 0 for T = TILES (or BIG) tiles, one tile per unit (scale 100
 * on 1 cm), so patch pixel i (0..T W - 1) has its centre at -T/2 + (i + 0.5) / W and is material
 * pixel (i + T W / 2) mod W (the box projection u = x / tile). Light: uniform (a directional
 * light of irradiance 1 straight down) or a point light of intensity I at (LX, LY, LZ). */
static const double LX = 0.1, LY = -0.05, LZ = 0.25, LI = 0.0625;

static double centre(int tiles, int i)
{
    return -0.5 * tiles + (i + 0.5) / (double)W;
}

static double irradiance(int tiles, int spot, int i, int j)
{
    if (!spot)
        return 1.0;
    double dx = centre(tiles, i) - LX, dy = centre(tiles, j) - LY;
    return LI * LZ / pow(dx * dx + dy * dy + LZ * LZ, 1.5);
}

/* The patch as a mesh of squares of 8 x 8 pixels, two triangles each, no texture coordinates
 * (so the box projection): pixel centres lie on the diagonals, which tests that each is laid
 * once. */
static const char *patch_mesh(int tiles)
{
    static char text[65536];
    int n = 0, q = 2 * tiles;
    for (int j = 0; j <= q; j++)
        for (int i = 0; i <= q; i++)
            n += snprintf(text + n, sizeof text - (size_t)n, "v %g %g 0\n", -0.5 * tiles + 0.5 * i,
                          -0.5 * tiles + 0.5 * j);
    for (int j = 0; j < q; j++)
        for (int i = 0; i < q; i++) {
            int a = j * (q + 1) + i + 1, b = a + 1, c = a + q + 2, d = a + q + 1;
            n += snprintf(text + n, sizeof text - (size_t)n, "f %d %d %d\nf %d %d %d\n", a, b,
                          c, a, c, d);
        }
    assert_true(n < (int)sizeof text);
    return op_test_write_temp("patch.obj", text);
}

/* The pre-pass of the patch of `tiles` tiles: maxPoints max_points (0: the default), receivers
 * every point (everywhere) or those the camera (looking down at the centre from height 4, or
 * `height`) needs. */
static op_sss_prepass *prepass_patch(const char *mat, int tiles, int spot, double density,
                                   int threads, int max_points, int everywhere, double height,
                                   double scale, op_scene **scene)
{
    char em[512], text[4096], mesh[1024], cap[128] = "";
    snprintf(mesh, sizeof mesh, "%s", patch_mesh(tiles));
    if (max_points > 0)
        snprintf(cap, sizeof cap, "<integer name=\"maxPoints\" value=\"%d\"/>", max_points);
    if (spot)
        snprintf(em, sizeof em,
                 "<emitter type=\"point\"><point name=\"position\" x=\"%g\" y=\"%g\" z=\"%g\"/>"
                 "<spectrum name=\"intensity\" value=\"%.9g\"/></emitter>",
                 LX, LY, LZ, LI);
    else
        snprintf(em, sizeof em,
                 "<emitter type=\"directional\"><vector name=\"direction\" x=\"0\" y=\"0\" "
                 "z=\"-1\"/><rgb name=\"irradiance\" value=\"1\"/></emitter>");
    snprintf(text, sizeof text,
             "<scene version=\"0.6.0\"><integrator type=\"path\"/>"
             " <sensor type=\"perspective\"><float name=\"fov\" value=\"30\"/>"
             "  <transform name=\"toWorld\"><lookat origin=\"0,0,%g\" target=\"0,0,0\" "
             "   up=\"0,1,0\"/></transform>"
             "  <film type=\"hdrfilm\"><integer name=\"width\" value=\"8\"/>"
             "   <integer name=\"height\" value=\"8\"/></film></sensor>"
             " %s"
             " <shape type=\"obj\"><string name=\"filename\" value=\"%s\"/>"
             "  <subsurface type=\"raw\">"
             "  <string name=\"material\" value=\"%s\"/><float name=\"sceneUnitsPerMetre\" value=\"%.9g\"/>"
             "  <float name=\"density\" value=\"%g\"/>%s"
             "  <integer name=\"irrSamples\" value=\"1\"/></subsurface></shape>"
             "</scene>",
             height, em, mesh, mat, scale, density, cap);
    const char *path = op_test_write_temp("patch.xml", text);
    op_error err = {0};
    OP_ASSERT_OK(op_scene_load(path, NULL, 0, scene, &err), err);
    op_sss_prepass_options o = {threads, 0, NULL, NULL, NULL, everywhere, NULL,
                                &op_path_transport};
    op_sss_prepass *pre = NULL;
    OP_ASSERT_OK(op_sss_prepass_run(*scene, &o, &pre, &err), err);
    return pre;
}

static op_sss_prepass *prepass(const char *mat, int spot, double density, int threads,
                             op_scene **scene)
{
    return prepass_patch(mat, TILES, spot, density, threads, 0, 1, 4.0, 100.0, scene);
}

/* The exitance op_sss_lookup gives at the central tile's pixel centres (3 x W x W) of a
 * pre-pass of the patch of `tiles` tiles. */
static void lookup_tile(const op_sss_prepass *pre, int tiles, float *out)
{
    int c0 = tiles / 2 * W;
    for (int j = c0; j < c0 + W; j++)
        for (int i = c0; i < c0 + W; i++) {
            op_v3 m;
            op_v3 p = v3((float)centre(tiles, i), (float)centre(tiles, j), 0.0f);
            assert_true(op_sss_lookup(pre, 0, p, v3(0.0f, 0.0f, 1.0f), &m));
            float *o = out + 3 * ((j - c0) * W + (i - c0));
            o[0] = m.x;
            o[1] = m.y;
            o[2] = m.z;
        }
}

/* The brute-force sum at the central tile's pixels of the patch of `tiles` tiles (3 x W x W). */
static void brute_force(const op_material *m, int K, int tiles, int spot, double *ref)
{
    int h = K / 2, c0 = tiles / 2 * W, shift = tiles * W / 2;
    for (int j = c0; j < c0 + W; j++)
        for (int i = c0; i < c0 + W; i++)
            for (int c = 0; c < 3; c++) {
                double sum = 0.0;
                for (int sj = j - h; sj <= j + h; sj++)
                    for (int si = i - h; si <= i + h; si++)
                        sum += irradiance(tiles, spot, si, sj) *
                               op_material_eval(m, c, (si + shift) % W, (sj + shift) % W, i - si,
                                                j - sj);
                ref[3 * ((j - c0) * W + (i - c0)) + c] = sum;
            }
}

/* The relative RMSE per channel of got against ref (3 x W x W), printed; fails above 1 %. */
static void compare(const float *got, const double *ref, const char *what)
{
    for (int c = 0; c < 3; c++) {
        double se = 0.0, mean = 0.0, worst = 0.0;
        for (int k = 0; k < W * W; k++) {
            double e = got[3 * k + c] - ref[3 * k + c];
            se += e * e;
            mean += ref[3 * k + c];
            worst = fmax(worst, fabs(e) / ref[3 * k + c]);
        }
        mean /= W * W;
        double rel = sqrt(se / (W * W)) / mean;
        printf("%s channel %d: relative RMSE %.3f %% (worst pixel %.2f %%)\n", what, c,
               100.0 * rel, 100.0 * worst);
        if (!(rel < 0.01))
            fail_msg("%s, channel %d: relative RMSE %.3f %% against the brute-force sum (goal "
                     "< 1 %%)", what, c, 100.0 * rel);
    }
}

/* The renderer's exitance at the central tile's pixel centres (3 x W x W) for one setting. */
static void rendered(const char *mat, int spot, double density, int threads, float *out)
{
    op_scene *scene = NULL;
    op_sss_prepass *pre = prepass(mat, spot, density, threads, &scene);
    lookup_tile(pre, TILES, out);
    op_sss_prepass_free(pre);
    op_scene_free(scene);
}

/* Writes the heterogeneous material of kernel K to mat (a temporary path) and opens it. */
static op_material *make_material(int K, char mat[1024])
{
    snprintf(mat, 1024, "%s", op_test_tmp_path("hetero.opm"));
    write_material(mat, K);
    op_error err = {0};
    op_material *m = NULL;
    OP_ASSERT_OK(op_material_open(mat, &m, &err), err);
    return m;
}

/* The points a camera-marked (or everywhere) pre-pass of the BIG patch at height 2.5 lays, and
 * into out (unless NULL) the central tile's exitance; the material at its physical size
 * (stretch 1) or shown stretch times smaller by its map (scale 100 / stretch). */
static long long big_patch(const char *mat, int spot, int threads, int max_points, int everywhere,
                           double stretch, float *out)
{
    op_scene *scene = NULL;
    op_sss_prepass *c = prepass_patch(mat, BIG, spot, 1.0, threads, max_points, everywhere, 2.5,
                                    100.0 / stretch, &scene);
    op_sss_stats st;
    op_sss_prepass_stats(c, &st);
    if (out)
        lookup_tile(c, BIG, out);
    if (out && st.points < BIG * BIG * W * W * stretch * stretch * 0.9) { /* windowed: a
                                                 * corner far outside the view
                                                 * has no point near it, so no exitance */
        op_v3 m, corner = v3(0.1f - 0.5f * BIG, 0.1f - 0.5f * BIG, 0.0f);
        assert_false(op_sss_lookup(c, 0, corner, v3(0.0f, 0.0f, 1.0f), &m));
        assert_true(m.x == 0.0f && m.y == 0.0f && m.z == 0.0f);
    }
    op_sss_prepass_free(c);
    op_scene_free(scene);
    return st.points;
}

static void check_material(int K)
{
    char mat[1024];
    op_material *m = make_material(K, mat);
    for (int spot = 0; spot < 2; spot++) {
        static double ref[3 * W * W];
        brute_force(m, K, TILES, spot, ref);
        static const double densities[2] = {1.0, 4.0};
        for (int d = 0; d < 2; d++) {
            static float got[3 * W * W];
            rendered(mat, spot, densities[d], 2, got);
            char what[96];
            snprintf(what, sizeof what, "K %d %-7s density %g", K, spot ? "spot" : "uniform",
                     densities[d]);
            compare(got, ref, what);
            if (d == 0 && spot) {
                static float one[3 * W * W];
                rendered(mat, spot, densities[d], 1, one);
                assert_memory_equal(one, got, sizeof one);
            }
        }
    }
    op_material_close(m);
}

static void test_brute_force_k5(void **state)
{
    (void)state;
    check_material(5);
}

static void test_brute_force_k7(void **state)
{
    (void)state;
    check_material(7);
}

static void test_brute_force_k9(void **state)
{
    (void)state;
    check_material(9);
}

/* A shape much larger than its material sample (BIG x BIG tiles: 30976 pixels) with maxPoints
 * 16000: seen close up, it lays only the points near the view, at the pixel centres (one per
 * material pixel, not coarsened), and the central tile's exitance matches the brute-force sum
 * and is bit for bit that of the whole layout (maxPoints above the pixels, 1 thread); with
 * every point a receiver the view needs more than maxPoints and the shape is coarsened to it. */
static void test_large_shape(void **state)
{
    (void)state;
    enum { K = 9, CAP = 16000, FULL = BIG * BIG * W * W };
    char mat[1024];
    op_material *m = make_material(K, mat);
    for (int spot = 0; spot < 2; spot++) {
        static double ref[3 * W * W];
        static float got[3 * W * W], whole[3 * W * W];
        brute_force(m, K, BIG, spot, ref);
        long long laid = big_patch(mat, spot, 2, CAP, 0, 1.0, got);
        printf("large shape, %s light: %lld points laid of %d (maxPoints %d)\n",
               spot ? "spot" : "uniform", laid, FULL, CAP);
        assert_true(laid > 0 && laid < CAP);
        compare(got, ref, spot ? "large shape, spot" : "large shape, uniform");
        assert_int_equal(big_patch(mat, spot, 1, 2 * FULL, 0, 1.0, whole), FULL);
        assert_memory_equal(got, whole, sizeof got);
    }
    assert_int_equal(big_patch(mat, 0, 2, CAP, 1, 1.0, NULL), CAP);
    op_material_close(m);
}

/* The same patch with a map that shows the material 1.25 times smaller than its physical size
 * (the area-uniform layout, 48400 points at one per material pixel area): seen close up with
 * maxPoints 16000 it lays only the points near the view, and the central tile's exitance is
 * bit for bit that of the whole layout; with every point a receiver it is coarsened. */
static void test_large_stretched_shape(void **state)
{
    (void)state;
    enum { K = 9, CAP = 16000, FULL = 48400 };
    const double stretch = 1.25;
    char mat[1024];
    op_material *m = make_material(K, mat);
    for (int spot = 0; spot < 2; spot++) {
        static float got[3 * W * W], whole[3 * W * W];
        long long laid = big_patch(mat, spot, 2, CAP, 0, stretch, got);
        printf("large stretched shape, %s light: %lld points laid of %d (maxPoints %d)\n",
               spot ? "spot" : "uniform", laid, FULL, CAP);
        assert_true(laid > 0 && laid < CAP);
        assert_int_equal(big_patch(mat, spot, 1, 2 * FULL, 0, stretch, whole), FULL);
        assert_memory_equal(got, whole, sizeof got);
    }
    assert_int_equal(big_patch(mat, 0, 2, CAP, 1, stretch, NULL), CAP);
    op_material_close(m);
}

/* The rasterizer's sites of one triangle, recorded (raster_test's visit). */
typedef struct sites {
    long long n, index[4096];
    double x[4096], y[4096];
} sites;

static void record(void *user, const op_sss_site *st)
{
    sites *s = user;
    assert_true(s->n < 4096);
    s->index[s->n] = st->index;
    s->x[s->n] = st->x;
    s->y[s->n++] = st->y;
}

/* A 12 x 10 pixel rectangle cut into jittered triangles (some vertices exactly on sample
 * centres, so edges through samples): every sample of the rectangle is laid exactly once
 * (op_sss_measured_count summed over the triangles), each triangle's raster visits as many sites
 * as its count, indexed 0, 1, ... in order, and clipped rasters over a partition of the sample
 * plane give the same sites with the same indices. */
static void test_raster(void **state)
{
    (void)state;
    enum { X = 12, Y = 10, Q = 4 };
    static const double steps[2] = {1.0, 0.5};
    for (int si = 0; si < 2; si++) {
        double step = steps[si], v[Q + 1][Q + 1][2];
        for (int j = 0; j <= Q; j++)
            for (int i = 0; i <= Q; i++) {
                int inner = i > 0 && i < Q && j > 0 && j < Q;
                /* jitter; every third inner vertex exactly on a sample centre */
                double jx = inner ? ((i * 7 + j * 3) % 5 - 2) * 0.37 : 0.0;
                double jy = inner ? ((i * 2 + j * 5) % 7 - 3) * 0.29 : 0.0;
                v[j][i][0] = X * (double)i / Q + jx;
                v[j][i][1] = Y * (double)j / Q + jy;
                if (inner && (i + j) % 3 == 0) {
                    v[j][i][0] = (floor(v[j][i][0] / step) + 0.5) * step;
                    v[j][i][1] = (floor(v[j][i][1] / step) + 0.5) * step;
                }
            }
        long long total = 0;
        for (int j = 0; j < Q; j++)
            for (int i = 0; i < Q; i++)
                for (int h = 0; h < 2; h++) {
                    double xy[3][2];
                    const double *c[3] = {v[j][i], h ? v[j + 1][i + 1] : v[j][i + 1],
                                          h ? v[j + 1][i] : v[j + 1][i + 1]};
                    for (int k = 0; k < 3; k++)
                        memcpy(xy[k], c[k], sizeof xy[k]);
                    long long n = op_sss_measured_count(xy, step);
                    static sites all, part;
                    all.n = part.n = 0;
                    assert_int_equal(op_sss_measured_raster(xy, step, record, &all), n);
                    assert_int_equal(all.n, n);
                    for (long long k = 0; k < n; k++)
                        assert_int_equal(all.index[k], k);
                    long long cut = (long long)(X / (2 * step)), cy = (long long)(Y / (3 * step));
                    const long long clips[4][4] = {{LLONG_MIN, cut, LLONG_MIN, cy},
                                                   {cut + 1, LLONG_MAX, LLONG_MIN, cy},
                                                   {LLONG_MIN, cut, cy + 1, LLONG_MAX},
                                                   {cut + 1, LLONG_MAX, cy + 1, LLONG_MAX}};
                    long long visited = 0;
                    for (int q = 0; q < 4; q++)
                        visited += op_sss_measured_raster_clip(xy, step, clips[q], record, &part);
                    assert_int_equal(visited, n);
                    for (long long k = 0; k < part.n; k++) { /* each site as the full raster has it */
                        long long at = part.index[k];
                        assert_true(at >= 0 && at < n);
                        assert_true(part.x[k] == all.x[at] && part.y[k] == all.y[at]);
                    }
                    total += n;
                }
        printf("raster, step %g: %lld samples in %d x %d pixels\n", step, total, X, Y);
        assert_int_equal(total, (long long)(X * Y / (step * step)));
    }
}

int main(void)
{
    op_log_set_level(OP_LOG_WARN);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_brute_force_k5),
        cmocka_unit_test(test_brute_force_k7),
        cmocka_unit_test(test_brute_force_k9),
        cmocka_unit_test(test_large_shape),
        cmocka_unit_test(test_large_stretched_shape),
        cmocka_unit_test(test_raster),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
