/* test_support.h - what the cmocka tests share: cmocka itself, temporary paths, and the
 * location of ../shared (tests that need it skip with a message when it is absent). */
#ifndef OP_TEST_SUPPORT_H
#define OP_TEST_SUPPORT_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "opaline.h"
#include "opaline_image.h"
#include "opaline_render.h"

/* A fresh path under the test build's tmp folder: "<tmp>/<test name>-<counter>-<suffix>". */
const char *op_test_tmp_path(const char *suffix);
/* Prints "skipping: why" and marks the program as skipped (see op_test_exit_status); the caller
 * then skips (cmocka's skip()). */
void op_test_skipping(const char *why);
/* The shared folder's path + rel, or NULL (after op_test_skipping) when it is absent. */
const char *op_test_shared_path(const char *rel);
/* A test program's exit status from cmocka_run_group_tests's result: 1 when a test failed,
 * else 77 (ctest's SKIP_RETURN_CODE) after op_test_skipping, else 0. */
int op_test_exit_status(int failures);
/* How many entries of folder dir have names starting with prefix. */
int op_test_count_prefix(const char *dir, const char *prefix);
/* Writes text to path, failing the test when it cannot. */
void op_test_write_text(const char *path, const char *text);
/* Writes text to a fresh temporary file (op_test_tmp_path(suffix)) and returns its path. */
const char *op_test_write_temp(const char *suffix, const char *text);
/* Writes a scene and returns its path (op_test_write_temp): an orthographic sensor over
 * [-1, 1]^2 at height 3 looking down (+x to the right, +y up; res x res pixels, box filter) at
 * a diffuse plane z = 0 of reflectance albedo and side 20, lit by the XML lights. */
const char *op_test_plane_scene(int res, double albedo, const char *lights);
/* Loads and renders the scene at path, failing the test on any error; spp, threads and seed 0
 * keep the defaults. Tiles are 8 x 8. The caller frees the renderer (the scene is freed). */
op_renderer *op_test_render(const char *path, int spp, int threads, uint64_t seed);
/* The same, returning a copy of the image (free it with op_image_free). */
op_image op_test_render_image(const char *path, int spp, int threads, uint64_t seed);
/* Loads the scene at path and runs its subsurface pre-pass as a render would (camera-marked
 * receivers, 2 threads, seed 0), failing the test on any error; *seconds gets the pre-pass's
 * wall time. The caller frees the pre-pass (op_sss_prepass_free) and the scene. */
struct op_sss_prepass *op_test_sss_prepass(const char *path, op_scene **scene, double *seconds);
/* The same with the build's everywhere (1: every point, no camera pass) and threads. */
struct op_sss_prepass *op_test_sss_prepass_with(const char *path, int everywhere, int threads,
                                              op_scene **scene, double *seconds);
/* Writes to path a raw material of 16 x 16 pixels, kernel 5, 1 x 1 cm, whose every row is the
 * same normalized Gaussian (sigma 1 pixel) times albedo[c] in channel c; with vary, row r is
 * further scaled by 0.8 + 0.2 ((7 r) mod 5) / 4 (so that positions matter). */
void op_test_write_gaussian_raw(const char *path, const double albedo[3], int vary);
/* RMSE over the R, G, B channels of two images of the same size and channel count. */
double op_test_image_rmse(const op_image *a, const op_image *b);
/* Fails the test with the error's message unless st is OP_OK. */
#define OP_ASSERT_OK(st, err)                                                                      \
    do {                                                                                           \
        if ((st) != OP_OK)                                                                         \
            fail_msg("%s: %s", op_status_name(st), (err).message);                                 \
    } while (0)

#endif
