/* test_render_sss_measured.c - a measured (tabulated) material's exitance on a flat patch
 * against a brute-force sum over all pairs of material pixels, computed here from the
 * material's own op_material_eval, independently of the renderer's pre-pass:
 *   M(r) = sum over the patch's pixels s within the kernel of E(s) Rd(pixel(s), r - s)
 * with E at the pixel centres. The patch is 3 x 3 tiles of a heterogeneous 16 x 16 material
 * (rows of different albedo, width and centre offset per pixel; K = 5, 7, 9) under uniform
 * light and under a point light close above it (a spot-like irradiance falling by 40x across a
 * tile); the exitance the camera would see (op_sss_lookup) at every pixel centre of the
 * central tile must match within 1 % relative RMSE per channel, at density 1 and 4. Receivers
 * are every point (no camera marking), 2 threads; 1 thread gives the same bits. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "integrator.h"
#include "opaline_render.h"
#include "render_scene.h"
#include "test_support.h"

enum { W = 16, TILES = 3, N = W * TILES };

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

/* The patch: [-1.5, 1.5]^2 in z = 0, one tile per unit (scale 100 on 1 cm), so patch pixel i
 * (0..N-1) has its centre at -1.5 + (i + 0.5) / W and is material pixel (i + W / 2) mod W
 * (the box projection u = x / tile). Light: uniform (a directional light of irradiance 1
 * straight down) or a point light of intensity I at (LX, LY, LZ). */
static const double LX = 0.1, LY = -0.05, LZ = 0.25, LI = 0.0625;

static double centre(int i)
{
    return -1.5 + (i + 0.5) / (double)W;
}

static double irradiance(int spot, int i, int j)
{
    if (!spot)
        return 1.0;
    double dx = centre(i) - LX, dy = centre(j) - LY;
    return LI * LZ / pow(dx * dx + dy * dy + LZ * LZ, 1.5);
}

/* The patch as a mesh of 6 x 6 squares of 8 x 8 pixels, two triangles each, no texture
 * coordinates (so the box projection): pixel centres lie on the diagonals, which tests that
 * each is laid once. */
static const char *patch_mesh(void)
{
    static char text[8192];
    int n = 0;
    for (int j = 0; j <= 6; j++)
        for (int i = 0; i <= 6; i++)
            n += snprintf(text + n, sizeof text - (size_t)n, "v %g %g 0\n", -1.5 + 0.5 * i,
                          -1.5 + 0.5 * j);
    for (int j = 0; j < 6; j++)
        for (int i = 0; i < 6; i++) {
            int a = j * 7 + i + 1, b = a + 1, c = a + 8, d = a + 7;
            n += snprintf(text + n, sizeof text - (size_t)n, "f %d %d %d\nf %d %d %d\n", a, b,
                          c, a, c, d);
        }
    return op_test_write_temp("patch.obj", text);
}

static op_sss_cache *prepass(const char *mat, int spot, double density, int threads,
                             op_scene **scene)
{
    char em[512], text[4096], mesh[1024];
    snprintf(mesh, sizeof mesh, "%s", patch_mesh());
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
             "  <transform name=\"toWorld\"><lookat origin=\"0,0,4\" target=\"0,0,0\" "
             "   up=\"0,1,0\"/></transform>"
             "  <film type=\"hdrfilm\"><integer name=\"width\" value=\"8\"/>"
             "   <integer name=\"height\" value=\"8\"/></film></sensor>"
             " %s"
             " <shape type=\"obj\"><string name=\"filename\" value=\"%s\"/>"
             "  <subsurface type=\"raw\">"
             "  <string name=\"material\" value=\"%s\"/><float name=\"scale\" value=\"100\"/>"
             "  <float name=\"density\" value=\"%g\"/>"
             "  <integer name=\"irrSamples\" value=\"1\"/></subsurface></shape>"
             "</scene>",
             em, mesh, mat, density);
    const char *path = op_test_write_temp("patch.xml", text);
    op_error err = {0};
    OP_ASSERT_OK(op_scene_load(path, NULL, 0, scene, &err), err);
    op_sss_build_options o = {threads, 0, NULL, NULL, NULL, 1, NULL, &op_path_transport};
    op_sss_cache *cache = NULL;
    OP_ASSERT_OK(op_sss_cache_build(*scene, &o, &cache, &err), err);
    return cache;
}

/* The renderer's exitance at the central tile's pixel centres (3 x W x W) for one setting. */
static void rendered(const char *mat, int spot, double density, int threads, float *out)
{
    op_scene *scene = NULL;
    op_sss_cache *cache = prepass(mat, spot, density, threads, &scene);
    for (int j = W; j < 2 * W; j++)
        for (int i = W; i < 2 * W; i++) {
            op_v3 m;
            op_v3 p = v3((float)centre(i), (float)centre(j), 0.0f);
            assert_true(op_sss_lookup(cache, 0, p, v3(0.0f, 0.0f, 1.0f), &m));
            float *o = out + 3 * ((j - W) * W + (i - W));
            o[0] = m.x;
            o[1] = m.y;
            o[2] = m.z;
        }
    op_sss_cache_free(cache);
    op_scene_free(scene);
}

static void check_material(int K)
{
    char mat[1024];
    snprintf(mat, sizeof mat, "%s", op_test_tmp_path("hetero.opm"));
    write_material(mat, K);
    op_error err = {0};
    op_material *m = NULL;
    OP_ASSERT_OK(op_material_open(mat, &m, &err), err);
    int h = K / 2;
    for (int spot = 0; spot < 2; spot++) {
        /* the brute-force sum at the central tile's pixels */
        static double ref[3 * W * W];
        for (int j = W; j < 2 * W; j++)
            for (int i = W; i < 2 * W; i++)
                for (int c = 0; c < 3; c++) {
                    double sum = 0.0;
                    for (int sj = j - h; sj <= j + h; sj++)
                        for (int si = i - h; si <= i + h; si++)
                            sum += irradiance(spot, si, sj) *
                                   op_material_eval(m, c, (si + W / 2) % W, (sj + W / 2) % W,
                                                    i - si, j - sj);
                    ref[3 * ((j - W) * W + (i - W)) + c] = sum;
                }
        static const double densities[2] = {1.0, 4.0};
        for (int d = 0; d < 2; d++) {
            static float got[3 * W * W];
            rendered(mat, spot, densities[d], 2, got);
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
                printf("K %d %-7s density %g channel %d: relative RMSE %.3f %% (worst pixel "
                       "%.2f %%)\n", K, spot ? "spot" : "uniform", densities[d], c, 100.0 * rel,
                       100.0 * worst);
                if (!(rel < 0.01))
                    fail_msg("K %d, %s light, density %g, channel %d: relative RMSE %.3f %% "
                             "against the brute-force sum (goal < 1 %%)", K,
                             spot ? "spot" : "uniform", densities[d], c, 100.0 * rel);
            }
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

int main(void)
{
    op_log_set_level(OP_LOG_WARN);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_brute_force_k5),
        cmocka_unit_test(test_brute_force_k7),
        cmocka_unit_test(test_brute_force_k9),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
