/* test_render_instances.c - a mesh file used by several plain shapes is kept once and placed by
 * Embree instances. The same 32 placements (rotations, non-uniform scales, mirrors,
 * flipNormals) of one OBJ file are rendered twice: naming one file (instances) and naming 32
 * copies of it (world-space copies, the reference). The instanced scene holds far less geometry
 * memory, and its images - shading normals, uv and a path-traced image - equal the reference's
 * up to float rounding (a few pixels on silhouettes may flip). A shape that is an area light
 * keeps its own world-space copy. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "opaline_render.h"
#include "test_support.h"

#define NSHAPES 32
#define RES 64

/* A UV sphere of radius 1 with normals and texture coordinates: 48 x 24 segments. */
static void write_sphere_obj(const char *path)
{
    const int nu = 48, nv = 24;
    size_t cap = 1 << 20, len = 0;
    char *text = malloc(cap);
    assert_non_null(text);
    for (int j = 0; j <= nv; j++)
        for (int i = 0; i <= nu; i++) {
            double th = M_PI * j / nv, ph = 2.0 * M_PI * i / nu;
            double x = sin(th) * cos(ph), y = sin(th) * sin(ph), z = cos(th);
            len += (size_t)snprintf(text + len, cap - len,
                                    "v %.7f %.7f %.7f\nvn %.7f %.7f %.7f\n"
                                    "vt %.6f %.6f\n",
                                    x, y, z, x, y, z, (double)i / nu, (double)j / nv);
        }
    for (int j = 0; j < nv; j++)
        for (int i = 0; i < nu; i++) {
            int a = j * (nu + 1) + i + 1, b = a + 1, c = a + nu + 1, d = c + 1;
            if (j != 0)
                len += (size_t)snprintf(text + len, cap - len, "f %d/%d/%d %d/%d/%d %d/%d/%d\n", a,
                                        a, a, c, c, c, b, b, b);
            if (j != nv - 1)
                len += (size_t)snprintf(text + len, cap - len, "f %d/%d/%d %d/%d/%d %d/%d/%d\n", b,
                                        b, b, c, c, c, d, d, d);
        }
    assert_true(len < cap);
    op_test_write_text(path, text);
    free(text);
}

/* The scene: NSHAPES placements of the sphere, shape i reading files[i]; shape 0 is an area
 * light. */
static const char *scene_text(const char *integrator, char files[][1024])
{
    static char text[32768];
    size_t n = 0, cap = sizeof text;
    n += (size_t)snprintf(
        text + n, cap - n,
        "<scene version=\"0.6.0\">%s"
        " <sensor type=\"perspective\"><float name=\"fov\" value=\"40\"/>"
        "  <transform name=\"toWorld\"><lookat origin=\"0.3,-1,10\" target=\"0,0,0\" up=\"0,1,0\"/>"
        "  </transform><film type=\"hdrfilm\"><integer name=\"width\" value=\"%d\"/>"
        "  <integer name=\"height\" value=\"%d\"/><rfilter type=\"box\"/></film></sensor>"
        " <emitter type=\"directional\"><vector name=\"direction\" x=\"-0.3\" y=\"-0.5\" z=\"-1\"/>"
        "  <rgb name=\"irradiance\" value=\"2\"/></emitter>"
        " <emitter type=\"constant\"><rgb name=\"radiance\" value=\"0.2\"/></emitter>"
        " <shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"8\"/>"
        "  <translate z=\"-0.6\"/></transform></shape>",
        integrator, RES, RES);
    for (int i = 0; i < NSHAPES; i++) {
        double x = -3.15 + 0.9 * (i % 8), y = -1.35 + 0.9 * (i / 8);
        double sx = 0.3 + 0.05 * (i % 3), sy = 0.35 - 0.04 * (i % 4), sz = 0.3;
        if (i % 5 == 2)
            sx = -sx; /* a mirror */
        n += (size_t)snprintf(
            text + n, cap - n,
            " <shape type=\"obj\"><string name=\"filename\" value=\"%s\"/>"
            "  <boolean name=\"flipNormals\" value=\"%s\"/>"
            "  <transform name=\"toWorld\"><scale x=\"%g\" y=\"%g\" z=\"%g\"/>"
            "   <rotate x=\"1\" y=\"0.5\" z=\"0.2\" angle=\"%d\"/><translate x=\"%g\" y=\"%g\"/>"
            "  </transform>%s</shape>",
            files[i], i % 7 == 3 ? "true" : "false", sx, sy, sz, 17 * i, x, y,
            i == 0 ? "<emitter type=\"area\"><rgb name=\"radiance\" value=\"3\"/></emitter>"
                   : "<bsdf type=\"roughplastic\"><float name=\"alpha\" value=\"0.2\"/></bsdf>");
    }
    n += (size_t)snprintf(text + n, cap - n, "</scene>");
    assert_true(n < cap);
    return text;
}

static op_scene *load(const char *text, op_scene_info *info)
{
    op_scene *sc = NULL;
    op_error err;
    OP_ASSERT_OK(op_scene_load(op_test_write_temp("inst.xml", text), NULL, 0, &sc, &err), err);
    op_scene_get_info(sc, info);
    return sc;
}

static op_image render(op_scene *sc, int spp)
{
    op_render_options opt;
    op_render_options_init(&opt);
    opt.threads = 2;
    opt.spp = spp;
    op_renderer *r = op_renderer_new(&opt);
    assert_non_null(r);
    op_error err;
    OP_ASSERT_OK(op_renderer_render(r, sc, &err), err);
    const op_image *img = op_renderer_image(r);
    op_image out;
    OP_ASSERT_OK(op_image_alloc(&out, img->width, img->height, 4, &err), err);
    memcpy(out.pixels, img->pixels, sizeof(float) * 4 * img->width * img->height);
    op_renderer_free(r);
    return out;
}

/* The fraction of pixels whose RGB differ by more than tol, and the mean absolute difference. */
static double differing(const op_image *a, const op_image *b, double tol, double *mean_abs)
{
    int bad = 0, n = a->width * a->height;
    double sum = 0.0;
    for (int i = 0; i < n; i++) {
        double d = 0.0;
        for (int c = 0; c < 3; c++)
            d = fmax(d, fabs(a->pixels[4 * i + c] - b->pixels[4 * i + c]));
        sum += d;
        bad += d > tol;
    }
    *mean_abs = sum / n;
    return (double)bad / n;
}

static void test_instances_match_copies(void **state)
{
    (void)state;
    static char shared[NSHAPES][1024], copies[NSHAPES][1024];
    const char *one = op_test_tmp_path("sphere.obj");
    write_sphere_obj(one);
    for (int i = 0; i < NSHAPES; i++) {
        snprintf(shared[i], sizeof shared[i], "%s", one);
        snprintf(copies[i], sizeof copies[i], "%s", op_test_tmp_path("copy.obj"));
        write_sphere_obj(copies[i]);
    }
    const char *views[3] = {"<integrator type=\"normals\"/>", "<integrator type=\"uv\"/>",
                            "<integrator type=\"path\"><integer name=\"maxDepth\" value=\"3\"/>"
                            "</integrator>"};
    for (int v = 0; v < 3; v++) {
        op_scene_info ia, ib;
        op_scene *a = load(scene_text(views[v], shared), &ia);
        op_scene *b = load(scene_text(views[v], copies), &ib);
        /* shape 0 is a light: it keeps a world-space copy, the other 31 share one mesh */
        assert_int_equal(ia.instances, NSHAPES - 1);
        assert_int_equal(ib.instances, 0);
        assert_int_equal(ia.triangles, ib.triangles);
        if (v == 0) {
            print_message("geometry: %lld bytes instanced, %lld as copies\n", ia.geometry_bytes,
                          ib.geometry_bytes);
            if (!(ia.geometry_bytes < ib.geometry_bytes / 4))
                fail_msg("instanced geometry %lld bytes is not well below the copies' %lld",
                         ia.geometry_bytes, ib.geometry_bytes);
        }
        op_image x = render(a, v == 2 ? 16 : 1), y = render(b, v == 2 ? 16 : 1);
        double mean_abs, frac = differing(&x, &y, 1e-3, &mean_abs);
        print_message("view %d: %.2f %% of pixels differ by > 1e-3, mean |diff| %.2g\n", v,
                      100.0 * frac, mean_abs);
        /* a silhouette pixel may flip; a wrong normal, uv or placement changes whole shapes */
        if (frac > 0.01 || mean_abs > 2e-3)
            fail_msg("view %d: instanced image differs from the copies' (%.2f %% of pixels, mean "
                     "%.3g)",
                     v, 100.0 * frac, mean_abs);
        op_image_free(&x);
        op_image_free(&y);
        op_scene_free(a);
        op_scene_free(b);
    }
}

int main(void)
{
    op_log_set_level(OP_LOG_WARN);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_instances_match_copies),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
