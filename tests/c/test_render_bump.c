/* test_render_bump.c - Mitsuba's bumpmap and normalmap wrappers: an identity normal map leaves
 * a lit sphere's image as it was (within its noise); a constant tilted normal map on a diffuse
 * plane under a directional light gives the cosine of the angle between the light and the
 * tilted normal, tilted along dp/du and its perpendicular; a linear height ramp tilts the
 * normal by atan(scale * slope / |dp/du|), downhill; and the errors Mitsuba 0.6 makes too. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "scene/render_scene.h"
#include "scene/scene_color.h"
#include "test_support.h"

#define RES 32
#define DEG (3.14159265358979 / 180.0)

/* Writes a Mitsuba 3 scene to a fresh file: the camera at z = 4 looks down at the origin (the
 * rectangle [-1, 1]^2 exactly fills the square image, +x to the right, +y up) through `shape`,
 * with `extra` objects. Returns the path. */
static const char *scene3(const char *name, const char *integrator, const char *shape,
                          const char *extra)
{
    char text[8192];
    int n = snprintf(
        text, sizeof text,
        "<scene version=\"3.0.0\">\n"
        " <integrator type=\"%s\"/>\n"
        " <sensor type=\"perspective\"><float name=\"fov\" value=\"28.072486935852954\"/>\n"
        "  <transform name=\"to_world\"><lookat origin=\"0,0,4\" target=\"0,0,0\" up=\"0,1,0\"/>\n"
        "  </transform>\n"
        "  <sampler type=\"independent\"><integer name=\"sample_count\" value=\"4\"/></sampler>\n"
        "  <film type=\"hdrfilm\"><integer name=\"width\" value=\"%d\"/>\n"
        "   <integer name=\"height\" value=\"%d\"/><rfilter type=\"box\"/></film></sensor>\n"
        "%s\n%s</scene>\n",
        integrator, RES, RES, shape, extra);
    assert_true(n > 0 && n < (int)sizeof text);
    const char *path = op_test_tmp_path(name);
    op_test_write_text(path, text);
    return path;
}

static op_v3 pixel(const op_image *img, int x, int y)
{
    const float *p = img->pixels + (size_t)img->channels * ((size_t)y * (size_t)img->width + x);
    return v3(p[0], p[1], p[2]);
}

/* A directional light of irradiance pi arriving from the unit direction toward it, to. */
static const char *light_from(op_v3 to)
{
    static char buf[512];
    snprintf(buf, sizeof buf,
             " <emitter type=\"directional\"><vector name=\"direction\" x=\"%.9g\" y=\"%.9g\" "
             "z=\"%.9g\"/><rgb name=\"irradiance\" value=\"3.14159265358979\"/></emitter>\n",
             -to.x, -to.y, -to.z);
    return buf;
}

/* Every pixel of img in columns and rows [lo, hi) is want (all channels) within tol. */
static void assert_region(const op_image *img, int lo, int hi, double want, double tol,
                          const char *what)
{
    for (int y = lo; y < hi; y++)
        for (int x = lo; x < hi; x++) {
            op_v3 p = pixel(img, x, y);
            if (fabs(p.x - want) > tol || fabs(p.y - want) > tol || fabs(p.z - want) > tol)
                fail_msg("%s: pixel (%d, %d) is (%g, %g, %g), want %g", what, x, y, p.x, p.y,
                         p.z, want);
        }
}

/* The sphere under a slanted directional light and a constant sky, path traced (3 bounces),
 * with and without an identity normal map (0.5, 0.5, 1) around its diffuse BSDF: the normal
 * map turns the frame's tangent to dp/du, which changes the random directions but not their
 * distribution, so every 8 x 8 block of the difference averages to 0 within 5 standard errors
 * (the errors estimated from the block's own pixels), and the whole images agree within 1 %. */
static void test_identity_normalmap(void **state)
{
    (void)state;
    const char *sky = " <emitter type=\"constant\"><rgb name=\"radiance\" value=\"0.3\"/>"
                      "</emitter>\n";
    char extra[1024];
    snprintf(extra, sizeof extra, "%s%s", sky, light_from(v3_norm(v3(1.0f, 1.0f, 1.0f))));
    const char *plain = "<shape type=\"sphere\"><float name=\"radius\" value=\"0.8\"/>"
                        "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.6\"/></bsdf>"
                        "</shape>";
    const char *mapped =
        "<shape type=\"sphere\"><float name=\"radius\" value=\"0.8\"/>"
        "<bsdf type=\"normalmap\"><texture name=\"normalmap\" type=\"rawconstant\">"
        "<vector name=\"value\" value=\"0.5, 0.5, 1\"/></texture>"
        "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.6\"/></bsdf></bsdf></shape>";
    op_image a = op_test_render_image(scene3("plain.xml", "path", plain, extra), 64, 2, 1);
    op_image b = op_test_render_image(scene3("mapped.xml", "path", mapped, extra), 64, 2, 2);
    double sum_a = 0.0, sum_b = 0.0, worst = 0.0;
    for (int by = 0; by < RES / 8; by++)
        for (int bx = 0; bx < RES / 8; bx++) {
            double s = 0.0, s2 = 0.0;
            for (int y = 8 * by; y < 8 * by + 8; y++)
                for (int x = 8 * bx; x < 8 * bx + 8; x++) {
                    op_v3 pa = pixel(&a, x, y), pb = pixel(&b, x, y);
                    double d = (pb.x + pb.y + pb.z) - (pa.x + pa.y + pa.z);
                    s += d;
                    s2 += d * d;
                    sum_a += pa.x + pa.y + pa.z;
                    sum_b += pb.x + pb.y + pb.z;
                }
            double mean = s / 64.0, var = (s2 - s * s / 64.0) / 63.0;
            double se = sqrt(fmax(var, 0.0) / 64.0);
            double z = fabs(mean) / (se + 1e-12);
            if (z > 5.0 && fabs(mean) > 1e-6)
                fail_msg("block (%d, %d): the normal-mapped image differs by %g (%.1f standard "
                         "errors)", bx, by, mean, z);
            worst = fmax(worst, fabs(mean) > 1e-6 ? z : 0.0);
        }
    if (!(fabs(sum_b / sum_a - 1.0) < 0.01))
        fail_msg("whole image: %g against %g", sum_b, sum_a);
    print_message("identity normal map: worst block %.2f standard errors, image ratio %.4f\n",
                  worst, sum_b / sum_a);
    op_image_free(&a);
    op_image_free(&b);
}

/* A diffuse plane (reflectance 0.5) turned by 90 degrees about z, so that dp/du runs along
 * +y, under light of irradiance pi arriving 30 degrees from the zenith on the +y side, with a
 * constant normal map tilted by 40 degrees: along dp/du toward the light (cos 10 degrees),
 * away from it (cos 70 degrees), or along the other tangent (cos 40 cos 30). The radiance is
 * 0.5 cos(light, tilted normal) exactly without Mitsuba 3's shadowing term, and that times
 * the term with it (the default): 2 / (1 + sqrt(1 + a2 tan^2 30)), a2 = tan^2(40) / 8
 * (Estevez et al. 2019; 1 for the untilted map). */
static void test_tilted_normalmap(void **state)
{
    (void)state;
    double th = 40.0 * DEG, ph = 30.0 * DEG;
    struct {
        double n[3];
        double cos;
        const char *what;
    } cases[] = {
        {{sin(th), 0.0, cos(th)}, cos(ph - th), "tilted along dp/du toward the light"},
        {{-sin(th), 0.0, cos(th)}, cos(ph + th), "tilted along dp/du away from the light"},
        {{0.0, sin(th), cos(th)}, cos(th) * cos(ph), "tilted across dp/du"},
        {{0.0, 0.0, 1.0}, cos(ph), "untilted"},
    };
    const char *light = light_from(v3(0.0f, (float)sin(ph), (float)cos(ph)));
    double a2 = fmin(tan(th) * tan(th) / 8.0, 1.0), t2 = tan(ph) * tan(ph);
    double term = 2.0 / (1.0 + sqrt(1.0 + a2 * t2));
    for (int shadowing = 0; shadowing <= 1; shadowing++)
        for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
            char shape[2048];
            snprintf(shape, sizeof shape,
                     "<shape type=\"rectangle\"><transform name=\"to_world\"><rotate z=\"1\" "
                     "angle=\"90\"/></transform><bsdf type=\"normalmap\">%s"
                     "<texture name=\"normalmap\" type=\"rawconstant\"><vector name=\"value\" "
                     "value=\"%.9g, %.9g, %.9g\"/></texture><bsdf type=\"diffuse\"><rgb "
                     "name=\"reflectance\" value=\"0.5\"/></bsdf></bsdf></shape>",
                     shadowing ? "" : "<boolean name=\"use_shadowing_function\" value=\"false\"/>",
                     0.5 * (cases[k].n[0] + 1.0), 0.5 * (cases[k].n[1] + 1.0),
                     0.5 * (cases[k].n[2] + 1.0));
            op_image img =
                op_test_render_image(scene3("tilt.xml", "direct", shape, light), 4, 2, 0);
            double want = 0.5 * cases[k].cos * (shadowing && cases[k].n[2] < 1.0 ? term : 1.0);
            char what[160];
            snprintf(what, sizeof what, "%s, %s", cases[k].what,
                     shadowing ? "with the shadowing term" : "without the shadowing term");
            assert_region(&img, 2, RES - 2, want, 2e-3, what);
            op_image_free(&img);
        }
}

/* Writes a w x 1 8-bit grey PNG whose stored values are bytes[i] (left to right). */
static const char *ramp_png(const char *name, int w, const unsigned char *bytes)
{
    op_error err = {0};
    op_image img;
    OP_ASSERT_OK(op_image_alloc(&img, w, 1, 3, &err), err);
    for (int i = 0; i < w; i++)
        for (int c = 0; c < 3; c++)
            img.pixels[3 * i + c] = (float)op_srgb_to_linear(bytes[i] / 255.0);
    const char *path = op_test_tmp_path(name);
    OP_ASSERT_OK(op_image_write_png(path, &img, 0.0f, &err), err);
    op_image_free(&img);
    return path;
}

/* A height field rising linearly along u: 16 texels of 16 k / 255 (raw), so the bilinear
 * height's slope is 256 / 255 per unit of u away from the clamped edge half-texels. On the
 * rectangle dp/du = (2, 0, 0), so `scale` s tilts the normal by atan(s 256 / 255 / 2) toward
 * -x: with s = 2 * 255 / 256, 45 degrees. Under light arriving 30 degrees from the zenith on
 * the -x side the plane shows 0.5 cos 15 degrees; with -s, 0.5 cos 75 degrees; with s = 0 (or
 * a flat field), 0.5 cos 30 degrees. */
static void test_bump_ramp(void **state)
{
    (void)state;
    unsigned char ramp[16];
    for (int i = 0; i < 16; i++)
        ramp[i] = (unsigned char)(16 * i);
    const char *png = ramp_png("ramp.png", 16, ramp);
    double ph = 30.0 * DEG, s = 2.0 * 255.0 / 256.0;
    struct {
        double scale, cos;
        const char *what;
    } cases[] = {
        {s, cos(15.0 * DEG), "downhill toward the light"},
        {-s, cos(75.0 * DEG), "scale -s: away from the light"},
        {0.5 * s, cos(ph - atan(0.5)), "scale s / 2: atan(1/2)"},
        {0.0, cos(ph), "scale 0"},
    };
    const char *light = light_from(v3(-(float)sin(ph), 0.0f, (float)cos(ph)));
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        char shape[2048];
        snprintf(shape, sizeof shape,
                 "<shape type=\"rectangle\"><bsdf type=\"bumpmap\">"
                 "<boolean name=\"use_shadowing_function\" value=\"false\"/>"
                 "<float name=\"scale\" value=\"%.9g\"/>"
                 "<texture name=\"height\" type=\"bitmap\"><string name=\"filename\" "
                 "value=\"%s\"/><boolean name=\"raw\" value=\"true\"/><string "
                 "name=\"wrap_mode\" value=\"clamp\"/></texture><bsdf type=\"diffuse\"><rgb "
                 "name=\"reflectance\" value=\"0.5\"/></bsdf></bsdf></shape>",
                 cases[k].scale, png);
        op_image img = op_test_render_image(scene3("bump.xml", "direct", shape, light), 4, 2, 0);
        /* u in (1/32, 31/32) keeps away from the edge half-texels */
        assert_region(&img, 2, RES - 2, 0.5 * cases[k].cos, 2e-3, cases[k].what);
        op_image_free(&img);
    }
}

static void expect_load_error(const char *path, const char *needle)
{
    op_error err = {0};
    op_scene *scene = NULL;
    op_status st = op_scene_load(path, NULL, 0, &scene, &err);
    if (st != OP_ERR_INPUT)
        fail_msg("%s: loaded with status %s, want an input error naming \"%s\"", path,
                 op_status_name(st), needle);
    if (!strstr(err.message, needle))
        fail_msg("message \"%s\" lacks \"%s\"", err.message, needle);
}

/* Mitsuba 0.6 refuses a bump map on a shape without texture coordinates, and a bitmap that
 * does not state its gamma; a wrapper needs one <bsdf> and one <texture>. */
static void test_errors(void **state)
{
    (void)state;
    unsigned char flat[2] = {100, 100};
    const char *png = ramp_png("flat.png", 2, flat);
    char obj[1200];
    snprintf(obj, sizeof obj, "%s", op_test_tmp_path("tri.obj"));
    op_test_write_text(obj, "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nf 1 2 3\n");
    struct {
        const char *shape, *texture_extra, *want;
    } cases[] = {
        {"obj", "<float name=\"gamma\" value=\"1\"/>", "needs the shape's texture coordinates"},
        {"rectangle", "", "states its gamma"},
        {"rectangle", NULL, "needs a nested <bsdf> and a <texture>"},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        char text[4096], texture[1600] = "";
        if (cases[k].texture_extra)
            snprintf(texture, sizeof texture,
                     "<texture type=\"bitmap\"><string name=\"filename\" value=\"%s\"/>%s"
                     "</texture>", png, cases[k].texture_extra);
        snprintf(text, sizeof text,
                 "<scene version=\"0.6.0\"><shape type=\"%s\">%s%s%s<bsdf type=\"bumpmap\">"
                 "%s<bsdf type=\"diffuse\"/></bsdf></shape></scene>\n",
                 cases[k].shape, strcmp(cases[k].shape, "obj") == 0 ? "<string name=\"filename\" "
                 "value=\"" : "", strcmp(cases[k].shape, "obj") == 0 ? obj : "",
                 strcmp(cases[k].shape, "obj") == 0 ? "\"/>" : "", texture);
        const char *path = op_test_tmp_path("err.xml");
        op_test_write_text(path, text);
        expect_load_error(path, cases[k].want);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_identity_normalmap),
        cmocka_unit_test(test_tilted_normalmap),
        cmocka_unit_test(test_bump_ramp),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
