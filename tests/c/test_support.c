/* test_support.c - see test_support.h. */
#include "test_support.h"

#include "integrator/integrator.h"
#include "sss/prepass.h"
#include "opaline_material.h"
#include "opaline_material_write.h"

#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

const char *op_test_tmp_path(const char *suffix)
{
    static char buf[8][1024];
    static int counter;
    const char *tmp = getenv("OPALINE_TEST_TMP");
    if (!tmp || !*tmp)
        tmp = "/tmp";
    char *out = buf[counter % 8];
    snprintf(out, sizeof buf[0], "%s/t%ld-%d-%s", tmp, (long)getpid(), counter, suffix);
    counter++;
    return out;
}

static int skipped;

void op_test_skipping(const char *why)
{
    fprintf(stderr, "skipping: %s\n", why);
    skipped = 1;
}

const char *op_test_shared_path(const char *rel)
{
    static char buf[4][1024];
    static int counter;
    const char *dir = getenv("OPALINE_SHARED_DIR");
    char *out = buf[counter++ % 4];
    struct stat st;
    snprintf(out, sizeof buf[0], "%s/%s", dir ? dir : "../shared", rel);
    if (stat(out, &st) != 0) {
        char why[1200];
        snprintf(why, sizeof why, "%s is absent (shared test material is not beside the checkout)",
                 out);
        op_test_skipping(why);
        return NULL;
    }
    return out;
}

int op_test_exit_status(int failures)
{
    return failures ? 1 : skipped ? 77 : 0;
}

int op_test_count_prefix(const char *dir, const char *prefix)
{
    DIR *d = opendir(dir);
    assert_non_null(d);
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)))
        n += strncmp(e->d_name, prefix, strlen(prefix)) == 0;
    closedir(d);
    return n;
}

void op_test_write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    assert_true(fputs(text, f) >= 0);
    assert_int_equal(fclose(f), 0);
}

const char *op_test_write_temp(const char *suffix, const char *text)
{
    const char *path = op_test_tmp_path(suffix);
    op_test_write_text(path, text);
    return path;
}

const char *op_test_plane_scene(int res, double albedo, const char *lights)
{
    static const char form[] =
        "<scene version=\"0.6.0\"><sensor type=\"orthographic\"><transform name=\"toWorld\">"
        " <lookat origin=\"0,0,3\" target=\"0,0,0\" up=\"0,1,0\"/></transform>"
        " <sampler type=\"ldsampler\"/><film type=\"hdrfilm\">"
        " <integer name=\"width\" value=\"%d\"/><integer name=\"height\" value=\"%d\"/>"
        " <rfilter type=\"box\"/></film></sensor>"
        "<shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"10\"/></transform>"
        " <bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"%g\"/></bsdf></shape>"
        "%s</scene>";
    size_t cap = sizeof form + strlen(lights) + 64;
    char *text = malloc(cap);
    assert_non_null(text);
    int n = snprintf(text, cap, form, res, res, albedo, lights);
    assert_true(n > 0 && (size_t)n < cap);
    const char *path = op_test_write_temp("scene.xml", text);
    free(text);
    return path;
}

op_renderer *op_test_render(const char *path, int spp, int threads, uint64_t seed)
{
    op_error err = {0};
    op_scene *scene = NULL;
    op_status st = op_scene_load(path, NULL, 0, &scene, &err);
    OP_ASSERT_OK(st, err);
    op_render_options opt;
    op_render_options_init(&opt);
    opt.spp = spp;
    opt.threads = threads;
    opt.seed = seed;
    opt.tile_size = 8; /* many tiles even in small test images, so threads really interleave */
    op_renderer *r = op_renderer_new(&opt);
    assert_non_null(r);
    st = op_renderer_render(r, scene, &err);
    OP_ASSERT_OK(st, err);
    op_scene_free(scene);
    return r;
}

op_image op_test_render_image(const char *path, int spp, int threads, uint64_t seed)
{
    op_renderer *r = op_test_render(path, spp, threads, seed);
    const op_image *img = op_renderer_image(r);
    assert_non_null(img);
    op_error err = {0};
    op_image copy = {0};
    op_status st = op_image_alloc(&copy, img->width, img->height, img->channels, &err);
    OP_ASSERT_OK(st, err);
    memcpy(copy.pixels, img->pixels,
           (size_t)img->width * img->height * (size_t)img->channels * sizeof(float));
    op_renderer_free(r);
    return copy;
}

double op_test_image_rmse(const op_image *a, const op_image *b)
{
    assert_int_equal(a->width, b->width);
    assert_int_equal(a->height, b->height);
    assert_int_equal(a->channels, b->channels);
    double s = 0;
    size_t n = (size_t)a->width * a->height;
    int ch = a->channels;
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3 && c < ch; c++) {
            double d = (double)a->pixels[ch * i + c] - b->pixels[ch * i + c];
            s += d * d;
        }
    return sqrt(s / ((ch < 3 ? ch : 3) * (double)n));
}

void op_test_write_gaussian_raw(const char *path, const double albedo[3], int vary)
{
    op_material_info info;
    memset(&info, 0, sizeof info);
    info.method = OP_METHOD_RAW;
    info.width = info.height = 16;
    info.kernel = 5;
    info.channels = 3;
    info.size_x_cm = info.size_y_cm = 1.0;
    snprintf(info.name, sizeof info.name, "Gaussian");
    snprintf(info.generator, sizeof info.generator, "op_test_write_gaussian_raw");
    int K = 5, rows = 16 * 16;
    float w[25];
    double sum = 0;
    for (int y = 0; y < K; y++)
        for (int x = 0; x < K; x++)
            sum += w[y * K + x] = (float)exp(-0.5 * ((x - 2) * (x - 2) + (y - 2) * (y - 2)));
    float *rd = malloc((size_t)rows * K * K * sizeof(float));
    assert_non_null(rd);
    op_error err = {0};
    op_material_writer *wr;
    op_status st = op_material_writer_open(path, &info, &wr, &err);
    OP_ASSERT_OK(st, err);
    static const char *tags[3] = {"RD.R", "RD.G", "RD.B"};
    for (int c = 0; c < 3; c++) {
        for (int r = 0; r < rows; r++)
            for (int k = 0; k < K * K; k++)
                rd[(size_t)r * K * K + k] =
                    (float)(albedo[c] * (vary ? 0.8 + 0.2 * ((r * 7) % 5) / 4.0 : 1.0) * w[k] / sum);
        st = op_material_writer_add(wr, tags[c], rd, (uint64_t)rows * K * K * sizeof(float), &err);
        OP_ASSERT_OK(st, err);
    }
    st = op_material_writer_commit(wr, &err);
    OP_ASSERT_OK(st, err);
    free(rd);
}

op_sss_prepass *op_test_sss_prepass(const char *path, op_scene **scene, double *seconds)
{
    return op_test_sss_prepass_with(path, 0, 2, scene, seconds);
}

op_sss_prepass *op_test_sss_prepass_with(const char *path, int everywhere, int threads,
                                       op_scene **scene, double *seconds)
{
    op_error err = {0};
    op_status st = op_scene_load(path, NULL, 0, scene, &err);
    OP_ASSERT_OK(st, err);
    op_sss_prepass_options o = {threads, 0, NULL, NULL, NULL, everywhere, NULL,
                                &op_path_transport};
    op_sss_prepass *cache = NULL;
    st = op_sss_prepass_run(*scene, &o, &cache, &err);
    OP_ASSERT_OK(st, err);
    op_sss_stats stats;
    op_sss_prepass_stats(cache, &stats);
    *seconds = stats.seconds;
    return cache;
}
