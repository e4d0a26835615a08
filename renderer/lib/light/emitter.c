/* emitter.c - light sources (see emitter.h). */
#include "light/emitter.h"

#include "camera/camera.h"
#include "light/sky.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static op_status read_nonneg_color(op_node *n, const char *name, double def, op_v3 *out,
                                   op_error *err)
{
    double d[3] = {def, def, def}, c[3];
    GET_OR_FAIL(op_node_color(n, name, d, c, err));
    for (int i = 0; i < 3; i++)
        if (!(c[i] >= 0.0) || !isfinite(c[i]))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"%s\">: %s must be "
                                "finite and >= 0", n->file, n->line, n->type, name);
    *out = v3_from_d(c);
    return OP_OK;
}

/* The luminance of envmap pixel (x, y) (negative channels count as 0). */
static double env_luminance(const op_emitter *e, int x, int y)
{
    const float *px = e->env.pixels + ((size_t)y * e->env.width + x) * (size_t)e->env.channels;
    return 0.2126 * fmax(px[0], 0.0) + 0.7152 * fmax(px[1], 0.0) + 0.0722 * fmax(px[2], 0.0);
}

static double env_pixel_weight(const op_emitter *e, int x, int y)
{
    return e->env_cell[(size_t)y * e->env.width + x];
}

/* Builds the envmap's cell weights and its row and column CDFs; a black map is sampled by
 * sin(theta) alone (its emission is zero anyway). A cell is the pixel's square of (u, v); its
 * weight is the mean luminance over it of the bilinear interpolation op_emitter_env_le makes
 * (for pixel-centred texels exactly the luminances filtered by 1/8, 3/4, 1/8 along each axis,
 * u wrapping and v clamped; used for Mitsuba 3's rows too, where it covers every texel the cell
 * interpolates), times sin(theta) at the cell's centre: non-zero wherever the emission is.
 * Returns 0, or -1 when out of memory. */
static int env_build_distribution(op_emitter *e)
{
    int w = e->env.width, h = e->env.height;
    e->env_row_cdf = malloc(((size_t)h + 1) * sizeof(float));
    e->env_col_cdf = malloc((size_t)h * ((size_t)w + 1) * sizeof(float));
    e->env_cell = malloc((size_t)h * (size_t)w * sizeof(float));
    double *rows = malloc((size_t)h * sizeof(double));
    float *across = malloc((size_t)h * (size_t)w * sizeof(float));
    if (!e->env_row_cdf || !e->env_col_cdf || !e->env_cell || !rows || !across) {
        free(rows);
        free(across);
        return -1;
    }
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            across[(size_t)y * w + x] =
                (float)(0.125 * env_luminance(e, (x + w - 1) % w, y) +
                        0.75 * env_luminance(e, x, y) + 0.125 * env_luminance(e, (x + 1) % w, y));
    for (int y = 0; y < h; y++) {
        const float *up = across + (size_t)(y > 0 ? y - 1 : 0) * w;
        const float *mid = across + (size_t)y * w;
        const float *down = across + (size_t)(y + 1 < h ? y + 1 : h - 1) * w;
        double st = sin(M_PI * (y + 0.5) / h);
        for (int x = 0; x < w; x++)
            e->env_cell[(size_t)y * w + x] =
                (float)((0.125 * up[x] + 0.75 * mid[x] + 0.125 * down[x]) * st);
    }
    free(across);
    double total = 0.0;
    for (int y = 0; y < h; y++) {
        float *cdf = e->env_col_cdf + (size_t)y * (w + 1);
        double acc = 0.0;
        for (int x = 0; x < w; x++)
            acc += env_pixel_weight(e, x, y);
        double run = 0.0;
        cdf[0] = 0.0f;
        for (int x = 0; x < w; x++) {
            run += acc > 0.0 ? env_pixel_weight(e, x, y) : 1.0;
            cdf[x + 1] = (float)(run / (acc > 0.0 ? acc : (double)w));
        }
        cdf[w] = 1.0f;
        rows[y] = acc;
        total += acc;
    }
    e->env_weight = total;
    double run = 0.0, norm = 0.0;
    for (int y = 0; y < h; y++)
        norm += total > 0.0 ? rows[y] : sin(M_PI * (y + 0.5) / h);
    e->env_row_cdf[0] = 0.0f;
    for (int y = 0; y < h; y++) {
        run += total > 0.0 ? rows[y] : sin(M_PI * (y + 0.5) / h);
        e->env_row_cdf[y + 1] = (float)(run / norm);
    }
    e->env_row_cdf[h] = 1.0f;
    free(rows);
    return 0;
}

/* The index i in [0, n) with cdf[i] <= u < cdf[i + 1] (cdf has n + 1 entries from 0 to 1,
 * non-decreasing); *frac gets u's position within that interval. */
static int cdf_find(const float *cdf, int n, float u, float *frac)
{
    int lo = 0, hi = n; /* cdf[lo] <= u < cdf[hi] */
    while (hi - lo > 1) {
        int mid = lo + (hi - lo) / 2;
        if (cdf[mid] <= u)
            lo = mid;
        else
            hi = mid;
    }
    float d = cdf[lo + 1] - cdf[lo];
    *frac = d > 0.0f ? fminf((u - cdf[lo]) / d, 0x1.fffffep-1f) : 0.5f;
    return lo;
}

/* Places envmap e (its image read) by toWorld xf with radiance scale `scale`, and builds its
 * sampling distribution; frees the image on failure. */
static op_status env_place(const op_node *node, const op_matrix4 *xf, double scale,
                           op_emitter *e, op_error *err)
{
    e->value = v3s((float)scale);
    /* rows of the world-to-map rotation: the inverse of toWorld's rotation */
    op_matrix4 inv;
    if (!op_matrix4_inverse(xf, &inv) || !op_matrix4_is_finite(&inv)) {
        op_image_free(&e->env);
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"%s\">: toWorld is "
                            "singular", node->file, node->line, node->type);
    }
    double ex[3] = {1, 0, 0}, ey[3] = {0, 1, 0}, ez[3] = {0, 0, 1};
    op_matrix4_vector(&inv, ex, ex);
    op_matrix4_vector(&inv, ey, ey);
    op_matrix4_vector(&inv, ez, ez);
    /* store columns so that local = (dot(d, s), dot(d, t), dot(d, n)) */
    e->frame.s = v3((float)ex[0], (float)ey[0], (float)ez[0]);
    e->frame.t = v3((float)ex[1], (float)ey[1], (float)ez[1]);
    e->frame.n = v3((float)ex[2], (float)ey[2], (float)ez[2]);
    double fx[3] = {1, 0, 0}, fy[3] = {0, 1, 0}, fz[3] = {0, 0, 1};
    op_matrix4_vector(xf, fx, fx);
    op_matrix4_vector(xf, fy, fy);
    op_matrix4_vector(xf, fz, fz);
    e->env_to_world.s = v3_from_d(fx);
    e->env_to_world.t = v3_from_d(fy);
    e->env_to_world.n = v3_from_d(fz);
    const op_v3 *axes[6] = {&e->frame.s, &e->frame.t, &e->frame.n, &e->env_to_world.s,
                            &e->env_to_world.t, &e->env_to_world.n};
    for (int k = 0; k < 6; k++) {
        float len = v3_len(*axes[k]);
        if (!(len > 0.0f) || !isfinite(len)) {
            op_image_free(&e->env);
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"%s\">: "
                                "toWorld's rotation is degenerate in single precision",
                                node->file, node->line, node->type);
        }
    }
    if (env_build_distribution(e) != 0) {
        op_emitter_free(e);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    }
    return OP_OK;
}

/* The <texture> child of node given under name, or NULL. */
static op_node *texture_child(const op_node *node, const char *name)
{
    for (int i = 0; i < node->nchildren; i++) {
        const char *cn = op_node_child_name(node, i);
        if (strcmp(node->children[i]->tag, "texture") == 0 && cn && strcmp(cn, name) == 0)
            return node->children[i];
    }
    return NULL;
}

/* Builds e->tex from node's texture child tex (through textures); a texture that is one value
 * everywhere (Mitsuba 3's rawconstant) is refused as Mitsuba 3 refuses it. */
static op_status build_texture(op_node *node, op_node *tex, op_tex_cache *textures,
                               op_emitter *e, op_error *err)
{
    if (!textures)
        return op_error_set(err, OP_ERR_INTERNAL, "%s:%d: <emitter type=\"%s\">: no texture "
                            "cache", node->file, node->line, node->type);
    GET_OR_FAIL(op_texture_build(tex, textures, &e->tex, err));
    if (e->tex.type == OP_TEX_CONSTANT)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"%s\">: a texture of one "
                            "value is refused here (as in Mitsuba 3): give a colour instead",
                            tex->file, tex->line, node->type);
    return OP_OK;
}

/* Reads the opaline extension visibleToCamera (default true) of an area or environment
 * emitter: false hides the emission from camera rays (it still lights the scene). */
static op_status read_camera_visibility(op_node *node, op_emitter *e, op_error *err)
{
    int visible;
    GET_OR_FAIL(op_node_bool(node, "visibleToCamera", 1, &visible, err));
    e->camera_hidden = !visible;
    return OP_OK;
}

/* The unit axes of toWorld xf into f (s = +X, t = +Y, n = +Z); 0 when one is degenerate. */
static int unit_axes(const op_matrix4 *xf, op_frame *f)
{
    double ax[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    op_v3 *out[3] = {&f->s, &f->t, &f->n};
    for (int k = 0; k < 3; k++) {
        op_matrix4_vector(xf, ax[k], ax[k]);
        if (!v3_unit_from_d(ax[k], out[k]))
            return 0;
    }
    return 1;
}

/* The types op_emitter_build renders. */
static const char *const emitter_types[] = {"point",  "spot", "area",       "directional",
                                            "constant", "envmap", "sky", "collimated",
                                            "projector", NULL};

int op_emitter_type_known(const char *type) { return op_name_listed(emitter_types, type); }

op_status op_emitter_build(op_node *node, const op_trimesh *mesh, int shape,
                           op_tex_cache *textures, long long max_pixels, op_emitter *e,
                           op_error *err)
{
    memset(e, 0, sizeof *e);
    node->used = 1;
    op_matrix4 xf;
    GET_OR_FAIL(op_node_transform(node, "toWorld", &xf, err));
    const char *t = node->type;
    if (strcmp(t, "point") == 0 || strcmp(t, "spot") == 0) {
        double o[3] = {0, 0, 0}, pos[3];
        op_matrix4_point(&xf, o, o);
        GET_OR_FAIL(op_node_vec3(node, "position", o, pos, err));
        e->pos = v3_from_d(pos);
        GET_OR_FAIL(read_nonneg_color(node, "intensity", 1.0, &e->value, err));
        e->type = OP_EM_POINT;
        if (strcmp(t, "spot") == 0) {
            e->type = OP_EM_SPOT;
            double cutoff, beam, z[3] = {0, 0, 1};
            GET_OR_FAIL(op_node_float(node, "cutoffAngle", 20.0, &cutoff, err));
            if (!(cutoff > 0.0) || cutoff > 90.0) {
                double c = cutoff > 90.0 ? 90.0 : 0.01;
                op_log(OP_LOG_WARN, "%s:%d: <emitter type=\"spot\">: cutoffAngle %g is outside "
                       "(0, 90]; clamped to %g", node->file, node->line, cutoff, c);
                cutoff = c;
            }
            GET_OR_FAIL(op_node_float(node, "beamWidth", cutoff * 0.75, &beam, err));
            if (!(beam > 0.0) || beam > cutoff) {
                double c = beam > cutoff ? cutoff : cutoff * 0.75;
                op_log(OP_LOG_WARN, "%s:%d: <emitter type=\"spot\">: beamWidth %g is outside "
                       "(0, cutoffAngle]; clamped to %g", node->file, node->line, beam, c);
                beam = c;
            }
            op_matrix4_vector(&xf, z, z);
            op_v3 axis;
            if (!v3_unit_from_d(z, &axis))
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"spot\">: toWorld "
                                    "is degenerate", node->file, node->line);
            op_node *tex = texture_child(node, "texture");
            if (!tex)
                e->frame = op_frame_from_normal(axis);
            else if (!unit_axes(&xf, &e->frame)) /* the texture goes along toWorld's X and Y */
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"spot\">: toWorld "
                                    "is degenerate", node->file, node->line);
            else
                GET_OR_FAIL(build_texture(node, tex, textures, e, err));
            e->tan_x = (float)tan(cutoff * M_PI / 180.0);
            e->cutoff = (float)(cutoff * M_PI / 180.0);
            e->beam = (float)(beam * M_PI / 180.0);
            e->cos_cutoff = cosf(e->cutoff);
            e->cos_beam = cosf(e->beam);
        }
        return OP_OK;
    }
    if (strcmp(t, "area") == 0) {
        if (!mesh)
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"area\"> must be nested "
                                "in a <shape>", node->file, node->line);
        e->type = OP_EM_AREA;
        e->mesh = mesh;
        e->shape = shape;
        GET_OR_FAIL(read_camera_visibility(node, e, err));
        return read_nonneg_color(node, "radiance", 1.0, &e->value, err);
    }
    if (strcmp(t, "directional") == 0) {
        double z[3] = {0, 0, 1}, d[3];
        if (op_node_has(node, "direction") && op_node_has(node, "toWorld"))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"directional\">: give "
                                "direction or toWorld, not both", node->file, node->line);
        op_matrix4_vector(&xf, z, z);
        GET_OR_FAIL(op_node_vec3(node, "direction", z, d, err));
        e->type = OP_EM_DIRECTIONAL;
        if (!v3_unit_from_d(d, &e->dir))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"directional\">: zero "
                                "or non-finite direction", node->file, node->line);
        return read_nonneg_color(node, "irradiance", 1.0, &e->value, err);
    }
    if (strcmp(t, "collimated") == 0) {
        double o[3] = {0, 0, 0}, z[3] = {0, 0, 1};
        op_matrix4_point(&xf, o, o);
        op_matrix4_vector(&xf, z, z);
        e->type = OP_EM_COLLIMATED;
        e->pos = v3_from_d(o);
        if (!v3_unit_from_d(z, &e->dir) || !isfinite(e->pos.x) || !isfinite(e->pos.y) ||
            !isfinite(e->pos.z))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"collimated\">: toWorld "
                                "is degenerate", node->file, node->line);
        GET_OR_FAIL(read_nonneg_color(node, "power", 1.0, &e->value, err));
        op_log(OP_LOG_WARN, "%s:%d: <emitter type=\"collimated\">: a beam along one ray lights "
               "nothing that path tracing sees (in Mitsuba too: only particle tracing shows it)",
               node->file, node->line);
        return OP_OK;
    }
    if (strcmp(t, "projector") == 0) {
        double o[3] = {0, 0, 0}, tx, ty, scale;
        op_matrix4_point(&xf, o, o);
        if (!unit_axes(&xf, &e->frame))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"projector\">: "
                                "toWorld is degenerate", node->file, node->line);
        op_node *tex = texture_child(node, "irradiance");
        int width = 1, height = 1; /* a constant irradiance is a 1 x 1 image */
        if (tex && op_node_has(node, "irradiance"))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"projector\">: "
                                "irradiance is given both as a colour and as a texture",
                                node->file, node->line);
        if (tex) {
            GET_OR_FAIL(build_texture(node, tex, textures, e, err));
            if (e->tex.type == OP_TEX_BITMAP) {
                width = e->tex.img->width;
                height = e->tex.img->height;
            }
        }
        /* the frustum has the image's aspect ratio */
        GET_OR_FAIL(op_camera_read_fov(node, width, height, &tx, &ty, err));
        GET_OR_FAIL(op_node_float(node, "scale", 1.0, &scale, err));
        if (!(scale >= 0.0) || !isfinite(scale))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"projector\">: scale "
                                "must be finite and >= 0", node->file, node->line);
        e->value = v3s(1.0f);
        if (!tex)
            GET_OR_FAIL(read_nonneg_color(node, "irradiance", 1.0, &e->value, err));
        e->type = OP_EM_PROJECTOR;
        e->pos = v3_from_d(o);
        e->tan_x = (float)tx;
        e->tan_y = (float)ty;
        e->value = v3_scale(e->value, (float)(M_PI * scale));
        return OP_OK;
    }
    if (strcmp(t, "sky") == 0) {
        e->type = OP_EM_ENVMAP;
        GET_OR_FAIL(read_camera_visibility(node, e, err));
        op_sky_model sky;
        GET_OR_FAIL(op_sky_build(node, &xf, max_pixels, &sky, &e->env, err));
        return env_place(node, &xf, 1.0, e, err); /* tabulated at pixel centres */
    }
    if (strcmp(t, "constant") == 0) {
        e->type = OP_EM_CONSTANT;
        GET_OR_FAIL(read_camera_visibility(node, e, err));
        return read_nonneg_color(node, "radiance", 1.0, &e->value, err);
    }
    if (strcmp(t, "envmap") == 0) {
        const char *fn;
        double scale;
        GET_OR_FAIL(op_node_string(node, "filename", NULL, &fn, err));
        GET_OR_FAIL(op_node_float(node, "scale", 1.0, &scale, err));
        GET_OR_FAIL(read_camera_visibility(node, e, err));
        if (!fn)
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"envmap\"> needs a "
                                "filename", node->file, node->line);
        char *path = op_node_resolve(node, fn);
        if (!path)
            return op_error_set(err, OP_ERR_NOMEM, "out of memory");
        e->type = OP_EM_ENVMAP;
        e->env_row_corners = node->dialect == OP_DIALECT_MITSUBA_3;
        op_status st = op_image_read_limited(path, 1, (uint64_t)max_pixels, &e->env, NULL, err);
        if (st == OP_OK && e->env.channels < 3) {
            op_image_free(&e->env);
            st = op_error_set(err, OP_ERR_INPUT, "%s: needs an RGB image", path);
        }
        free(path);
        if (st)
            return op_error_prefix(err, "%s:%d: <emitter type=\"envmap\">: ", node->file,
                                   node->line);
        return env_place(node, &xf, scale, e, err);
    }
    char names[256];
    return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"%s\">: unknown emitter type "
                        "(%s)", node->file, node->line, t,
                        op_names_join(emitter_types, names, sizeof names));
}

void op_emitter_free(op_emitter *e)
{
    if (e->type == OP_EM_ENVMAP) {
        op_image_free(&e->env);
        free(e->env_row_cdf);
        free(e->env_col_cdf);
        free(e->env_cell);
        e->env_row_cdf = e->env_col_cdf = NULL;
        e->env_cell = NULL;
    }
}

int op_emitter_is_env(const op_emitter *e)
{
    return e->type == OP_EM_CONSTANT || e->type == OP_EM_ENVMAP;
}

static float spot_falloff(const op_emitter *e, float cos_theta)
{
    if (cos_theta <= e->cos_cutoff)
        return 0.0f;
    if (cos_theta >= e->cos_beam)
        return 1.0f;
    return (e->cutoff - acosf(fminf(cos_theta, 1.0f))) / (e->cutoff - e->beam);
}

/* The spot's texture in the direction d (away from the light, inside the cone): the cone's
 * tangent plane at distance 1 maps onto the texture's unit square, u along +X and v along +Y
 * of toWorld, the axis at its centre and the cutoff cone touching its edges. */
static op_v3 spot_texture(const op_emitter *e, op_v3 d)
{
    op_v3 local = op_frame_to_local(&e->frame, d);
    float k = 0.5f / (local.z * e->tan_x);
    return op_texture_eval(&e->tex, 0.5f + k * local.x, 0.5f + k * local.y);
}

/* The envmap pixel (*x, *y) that direction d (map space, unit) falls in; *sin_theta gets
 * sin of d's polar angle from +Y. */
static void env_pixel(const op_emitter *e, op_v3 d, int *x, int *y, float *sin_theta)
{
    float u = atan2f(d.x, -d.z) * (0.5f * OP_INV_PI);
    if (u < 0.0f)
        u += 1.0f;
    float cy = fmaxf(-1.0f, fminf(1.0f, d.y));
    float v = acosf(cy) * OP_INV_PI;
    int w = e->env.width, h = e->env.height;
    int px = (int)(u * (float)w), py = (int)(v * (float)h);
    *x = px < 0 ? 0 : (px >= w ? w - 1 : px);
    *y = py < 0 ? 0 : (py >= h ? h - 1 : py);
    *sin_theta = sqrtf(fmaxf(0.0f, 1.0f - cy * cy));
}

/* The envmap's radiance at map-space direction d (unit), before its scale: the bilinear
 * interpolation of its pixels as Mitsuba makes it, u wrapping around, texel centres at
 * u = (x + 0.5) / width, and at v = (y + 0.5) / height (0.6, v clamped) or y / (height - 1)
 * (Mitsuba 3). */
static op_v3 env_bilinear(const op_emitter *e, op_v3 d)
{
    int w = e->env.width, h = e->env.height;
    float u = atan2f(d.x, -d.z) * (0.5f * OP_INV_PI);
    u -= floorf(u);
    float v = acosf(fmaxf(-1.0f, fminf(1.0f, d.y))) * OP_INV_PI;
    float fx = u * (float)w - 0.5f;
    float fy = e->env_row_corners ? v * (float)(h - 1) : v * (float)h - 0.5f;
    fy = fmaxf(0.0f, fminf(fy, (float)(h - 1)));
    float x0f = floorf(fx), y0f = floorf(fy);
    float tx = fx - x0f, ty = fy - y0f;
    int x0 = ((int)x0f % w + w) % w, x1 = (x0 + 1) % w;
    int y0 = (int)y0f < h ? (int)y0f : h - 1, y1 = y0 + 1 < h ? y0 + 1 : h - 1;
    size_t ch = (size_t)e->env.channels;
    const float *p00 = e->env.pixels + ((size_t)y0 * w + x0) * ch;
    const float *p10 = e->env.pixels + ((size_t)y0 * w + x1) * ch;
    const float *p01 = e->env.pixels + ((size_t)y1 * w + x0) * ch;
    const float *p11 = e->env.pixels + ((size_t)y1 * w + x1) * ch;
    float c[3];
    for (int k = 0; k < 3; k++)
        c[k] = (1.0f - ty) * ((1.0f - tx) * p00[k] + tx * p10[k]) +
               ty * ((1.0f - tx) * p01[k] + tx * p11[k]);
    return v3(c[0], c[1], c[2]);
}

op_v3 op_emitter_env_le(const op_emitter *e, op_v3 dir)
{
    if (e->type == OP_EM_CONSTANT)
        return e->value;
    return v3_scale(env_bilinear(e, op_frame_to_local(&e->frame, dir)), e->value.x);
}

/* The density over the unit (u, v) square of envmap pixel (x, y). */
static float env_uv_pdf(const op_emitter *e, int x, int y)
{
    int w = e->env.width, h = e->env.height;
    double p;
    if (e->env_weight > 0.0)
        p = env_pixel_weight(e, x, y) / e->env_weight;
    else /* a black map: rows by sin(theta), columns uniform */
        p = (double)(e->env_row_cdf[y + 1] - e->env_row_cdf[y]) / w;
    return (float)(p * (double)w * (double)h);
}

float op_emitter_env_pdf(const op_emitter *e, op_v3 dir)
{
    if (e->type == OP_EM_CONSTANT)
        return 1.0f / (4.0f * OP_PI);
    int x, y;
    float st;
    env_pixel(e, v3_norm(op_frame_to_local(&e->frame, dir)), &x, &y, &st);
    if (st <= 0.0f)
        return 0.0f;
    return env_uv_pdf(e, x, y) / (2.0f * OP_PI * OP_PI * st);
}

op_v3 op_emitter_area_le(const op_emitter *e, op_v3 n, op_v3 w)
{
    return v3_dot(n, w) > 0.0f ? e->value : v3s(0.0f);
}

float op_emitter_area_pdf(const op_emitter *e, op_v3 n, op_v3 dir, float dist)
{
    float c = fabsf(v3_dot(n, dir)) / fmaxf(v3_len(n), 1e-30f);
    if (c <= 0.0f)
        return 0.0f;
    return dist * dist / (c * e->mesh->area);
}

int op_emitter_sample_dims(const op_emitter *e)
{
    switch (e->type) {
    case OP_EM_POINT:
    case OP_EM_SPOT:
    case OP_EM_DIRECTIONAL:
    case OP_EM_COLLIMATED:
    case OP_EM_PROJECTOR:
        return 0;
    case OP_EM_CONSTANT:
    case OP_EM_ENVMAP:
        return 2;
    case OP_EM_AREA:
        return 3;
    }
    return 3;
}

int op_emitter_sample(const op_emitter *e, op_v3 p, float u1, float u2, float u3,
                      op_light_sample *s)
{
    switch (e->type) {
    case OP_EM_POINT:
    case OP_EM_SPOT: {
        op_v3 d = v3_sub(e->pos, p);
        float d2 = v3_dot(d, d);
        if (d2 <= 0.0f)
            return 0;
        s->dist = sqrtf(d2);
        s->wi = v3_scale(d, 1.0f / s->dist);
        s->pdf = 0.0f;
        float f = 1.0f;
        if (e->type == OP_EM_SPOT)
            f = spot_falloff(e, -v3_dot(s->wi, e->frame.n));
        if (f <= 0.0f)
            return 0;
        s->value = v3_scale(e->value, f / d2);
        if (e->tex.type == OP_TEX_NONE)
            return 1;
        s->value = v3_mul(s->value, spot_texture(e, v3_neg(s->wi)));
        return !v3_is_black(s->value);
    }
    case OP_EM_AREA: {
        int t = op_trimesh_pick(e->mesh, u3);
        float b1, b2;
        op_sample_triangle(u1, u2, &b1, &b2);
        op_v3 a, b, c;
        op_trimesh_tri(e->mesh, t, &a, &b, &c);
        op_v3 q = v3_add(v3_add(v3_scale(a, 1.0f - b1 - b2), v3_scale(b, b1)), v3_scale(c, b2));
        op_v3 n = v3_norm(v3_cross(v3_sub(b, a), v3_sub(c, a)));
        op_v3 d = v3_sub(q, p);
        float dist = v3_len(d);
        if (dist <= 0.0f)
            return 0;
        s->wi = v3_scale(d, 1.0f / dist);
        s->dist = dist;
        float cl = -v3_dot(n, s->wi);
        if (cl <= 0.0f)
            return 0;
        s->pdf = dist * dist / (cl * e->mesh->area);
        s->value = v3_scale(e->value, 1.0f / s->pdf);
        return 1;
    }
    case OP_EM_COLLIMATED: /* a delta in position and direction: no point receives it */
        return 0;
    case OP_EM_PROJECTOR: {
        op_v3 d = v3_sub(p, e->pos), local = op_frame_to_local(&e->frame, d);
        if (!(local.z > 0.0f) || fabsf(local.x) > e->tan_x * local.z ||
            fabsf(local.y) > e->tan_y * local.z)
            return 0;
        float dist = v3_len(d);
        s->dist = dist;
        s->wi = v3_scale(d, -1.0f / dist);
        s->pdf = 0.0f;
        /* pi scale irradiance / (z^2 cos): a plane facing it at z = 1 receives pi scale E */
        op_v3 irradiance = e->value;
        if (e->tex.type != OP_TEX_NONE) /* Mitsuba's sensor (u, v): u to the left of +X */
            irradiance = v3_mul(irradiance,
                                op_texture_eval(&e->tex,
                                                0.5f - 0.5f * local.x / (local.z * e->tan_x),
                                                0.5f - 0.5f * local.y / (local.z * e->tan_y)));
        s->value = v3_scale(irradiance, dist / (local.z * local.z * local.z));
        return !v3_is_black(s->value);
    }
    case OP_EM_DIRECTIONAL:
        s->wi = v3_neg(e->dir);
        s->dist = INFINITY;
        s->pdf = 0.0f;
        s->value = e->value;
        return 1;
    case OP_EM_CONSTANT: {
        s->wi = op_sample_sphere(u1, u2);
        s->dist = INFINITY;
        s->pdf = 1.0f / (4.0f * OP_PI);
        s->value = v3_scale(op_emitter_env_le(e, s->wi), 1.0f / s->pdf);
        return !v3_is_black(s->value);
    }
    case OP_EM_ENVMAP: {
        int w = e->env.width, h = e->env.height;
        float fy, fx;
        int y = cdf_find(e->env_row_cdf, h, u2, &fy);
        int x = cdf_find(e->env_col_cdf + (size_t)y * (w + 1), w, u1, &fx);
        float theta = OP_PI * ((float)y + fy) / (float)h;
        float phi = 2.0f * OP_PI * ((float)x + fx) / (float)w;
        float st = sinf(theta);
        if (st <= 0.0f)
            return 0;
        op_v3 d = v3(st * sinf(phi), cosf(theta), -st * cosf(phi));
        s->wi = v3_norm(op_frame_to_world(&e->env_to_world, d));
        s->dist = INFINITY;
        s->pdf = env_uv_pdf(e, x, y) / (2.0f * OP_PI * OP_PI * st);
        if (!(s->pdf > 0.0f))
            return 0;
        s->value = v3_scale(env_bilinear(e, d), e->value.x / s->pdf);
        return !v3_is_black(s->value);
    }
    }
    return 0;
}
