/* texture.c - bitmap and checkerboard textures and the image cache (see texture.h). */
#include "bsdf/texture.h"

#include "scene/scene_color.h"

#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

/* One image as a texture uses it: the file's values through the gamma asked for. */
typedef struct tex_entry {
    char *path;
    double gamma; /* as given: 0 automatic, -1 sRGB, else an exponent */
    op_image img;
} tex_entry;

struct op_tex_cache {
    tex_entry **entries; /* each allocated alone, so that textures' pointers stay valid */
    int n, cap;
    long long max_pixels;
};

op_tex_cache *op_tex_cache_new(long long max_pixels)
{
    op_tex_cache *c = calloc(1, sizeof(op_tex_cache));
    if (c)
        c->max_pixels = max_pixels;
    return c;
}

void op_tex_cache_free(op_tex_cache *c)
{
    if (!c)
        return;
    for (int i = 0; i < c->n; i++) {
        free(c->entries[i]->path);
        op_image_free(&c->entries[i]->img);
        free(c->entries[i]);
    }
    free(c->entries);
    free(c);
}

int op_tex_cache_count(const op_tex_cache *c)
{
    return c ? c->n : 0;
}

const op_image *op_tex_cache_image(const op_tex_cache *c, int i)
{
    return &c->entries[i]->img;
}

/* Turns the stored values of a just-read file into linear RGB in [0, 1] (3 channels, alpha
 * dropped, grey replicated): sRGB-decoded when srgb, raised to gamma otherwise. Returns the
 * count of values that were out of range or not finite (clamped). */
static size_t to_linear_rgb(const op_image *in, int srgb, double gamma, op_image *out)
{
    size_t px = (size_t)in->width * (size_t)in->height, clamped = 0;
    int c = in->channels;
    for (size_t i = 0; i < px; i++)
        for (int k = 0; k < 3; k++) {
            double v = in->pixels[i * (size_t)c + (size_t)(c >= 3 ? k : 0)];
            if (srgb)
                v = op_srgb_to_linear(v);
            else if (gamma != 1.0 && v > 0.0)
                v = pow(v, gamma);
            if (!(v >= 0.0)) { /* also NaN */
                clamped++;
                v = 0.0;
            } else if (v > 1.0) {
                clamped++;
                v = 1.0;
            }
            out->pixels[3 * i + (size_t)k] = (float)v;
        }
    return clamped;
}

/* The cached image of (path, gamma), reading the file on first use. */
static op_status cache_get(op_tex_cache *c, const op_node *node, const char *path, double gamma,
                           const op_image **out, op_error *err)
{
    for (int i = 0; i < c->n; i++)
        if (c->entries[i]->gamma == gamma && strcmp(c->entries[i]->path, path) == 0) {
            *out = &c->entries[i]->img;
            return OP_OK;
        }
    if (c->n == c->cap) {
        int cap = c->cap ? 2 * c->cap : 8;
        tex_entry **grown = realloc(c->entries, (size_t)cap * sizeof *grown);
        if (!grown)
            return op_error_set(err, OP_ERR_NOMEM, "out of memory");
        c->entries = grown;
        c->cap = cap;
    }
    op_image raw;
    int encoded = 0;
    op_status st = op_image_read_limited(path, 0, (uint64_t)c->max_pixels, &raw, &encoded, err);
    if (st) {
        if (st == OP_ERR_IO && access(path, F_OK) != 0 && err)
            err->status = OP_ERR_INPUT; /* a missing file is a fault of the scene (exit 2) */
        return op_error_prefix(err, "%s:%d: <texture type=\"bitmap\">: ", node->file, node->line);
    }
    tex_entry *e = calloc(1, sizeof *e);
    if (e)
        e->path = strdup(path);
    if (!e || !e->path || op_image_alloc(&e->img, raw.width, raw.height, 3, err) != OP_OK) {
        op_image_free(&raw);
        if (e)
            free(e->path);
        free(e);
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    }
    e->gamma = gamma;
    int srgb = gamma == -1.0 || (gamma == 0.0 && encoded);
    double g = gamma > 0.0 ? gamma : 1.0;
    size_t clamped = to_linear_rgb(&raw, srgb, g, &e->img);
    if (clamped)
        op_log(OP_LOG_WARN, "%s:%d: <texture type=\"bitmap\">: %s: %zu values outside [0, 1] "
               "clamped (a reflectance cannot exceed 1)", node->file, node->line, path, clamped);
    op_log(OP_LOG_DEBUG, "%s:%d: texture %s: %dx%d, %s", node->file, node->line, path,
           raw.width, raw.height, srgb ? "sRGB-decoded" : g == 1.0 ? "linear" : "gamma");
    op_image_free(&raw);
    c->entries[c->n++] = e;
    *out = &e->img;
    return OP_OK;
}

static op_status parse_wrap(const op_node *node, const char *name, const char *s, op_tex_wrap *w,
                            op_error *err)
{
    static const struct {
        const char *name;
        op_tex_wrap wrap;
    } modes[] = {{"repeat", OP_WRAP_REPEAT}, {"mirror", OP_WRAP_MIRROR},
                 {"clamp", OP_WRAP_CLAMP},   {"zero", OP_WRAP_ZERO},
                 {"black", OP_WRAP_ZERO},    {"one", OP_WRAP_ONE},
                 {"white", OP_WRAP_ONE}};
    for (size_t i = 0; i < sizeof modes / sizeof modes[0]; i++)
        if (strcasecmp(s, modes[i].name) == 0) {
            *w = modes[i].wrap;
            return OP_OK;
        }
    const op_prop *p = op_node_prop(node, name);
    return op_error_set(err, OP_ERR_INPUT, "%s:%d: <texture type=\"bitmap\">: unknown %s \"%s\" "
                        "(repeat, mirror, clamp, zero, one)", p ? p->file : node->file,
                        p ? p->line : node->line, name, s);
}

static op_status build_bitmap(op_node *node, op_tex_cache *cache, op_texture *t, op_error *err)
{
    const char *fn, *wrap, *wu, *wv, *filter;
    double gamma, aniso;
    int keep_cache;
    GET_OR_FAIL(op_node_string(node, "filename", NULL, &fn, err));
    if (!fn || !fn[0])
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <texture type=\"bitmap\"> needs a "
                            "<string name=\"filename\">", node->file, node->line);
    GET_OR_FAIL(op_node_string(node, "wrapMode", "repeat", &wrap, err));
    GET_OR_FAIL(op_node_string(node, "wrapModeU", wrap, &wu, err));
    GET_OR_FAIL(op_node_string(node, "wrapModeV", wrap, &wv, err));
    GET_OR_FAIL(parse_wrap(node, op_node_has(node, "wrapModeU") ? "wrapModeU" : "wrapMode", wu,
                           &t->wrap_u, err));
    GET_OR_FAIL(parse_wrap(node, op_node_has(node, "wrapModeV") ? "wrapModeV" : "wrapMode", wv,
                           &t->wrap_v, err));
    GET_OR_FAIL(op_node_string(node, "filterType", NULL, &filter, err));
    GET_OR_FAIL(op_node_float(node, "maxAnisotropy", 20.0, &aniso, err));
    GET_OR_FAIL(op_node_bool(node, "cache", 0, &keep_cache, err)); /* no MIP map files here */
    if (filter && strcasecmp(filter, "nearest") == 0) {
        t->nearest = 1;
    } else if (filter && (strcasecmp(filter, "ewa") == 0 ||
                          strcasecmp(filter, "trilinear") == 0)) {
        op_log(OP_LOG_INFO, "%s:%d: <texture type=\"bitmap\">: filterType \"%s\" is rendered as "
               "bilinear (opaline builds no MIP maps; pixel samples average the texture)",
               node->file, node->line, filter);
    } else if (filter && strcasecmp(filter, "bilinear") != 0) {
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <texture type=\"bitmap\">: unknown "
                            "filterType \"%s\" (ewa, trilinear, bilinear, nearest)", node->file,
                            node->line, filter);
    }
    GET_OR_FAIL(op_node_float(node, "gamma", 0.0, &gamma, err));
    int raw = 0;
    if (node->dialect == OP_DIALECT_MITSUBA_3) {
        const char *format; /* the precision Mitsuba 3 stores the image in */
        GET_OR_FAIL(op_node_bool(node, "raw", 0, &raw, err)); /* the stored values */
        GET_OR_FAIL(op_node_string(node, "format", "variant", &format, err));
    }
    if (raw && op_node_has(node, "gamma"))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <texture type=\"bitmap\">: give raw or "
                            "gamma, not both", node->file, node->line);
    if (raw)
        gamma = 1.0;
    if (!(gamma == 0.0 || gamma == -1.0 || (gamma > 0.0 && gamma <= 10.0)))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <texture type=\"bitmap\">: gamma %g must "
                            "be -1 (sRGB), 0 (automatic) or in (0, 10]", node->file, node->line,
                            gamma);
    char *path = op_node_resolve(node, fn);
    if (!path)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    op_status st = cache_get(cache, node, path, gamma, &t->img, err);
    free(path);
    if (st)
        return st;
    t->type = OP_TEX_BITMAP;
    return OP_OK;
}

/* The types the texture builders render (rawconstant: Mitsuba 3's only). */
static const char *const texture_types[] = {"bitmap", "checkerboard", "rawconstant", NULL};

int op_texture_type_known(const char *type) { return op_name_listed(texture_types, type); }

/* op_texture_build, checkerboard colours allowed in [0, cmax]. */
static op_status texture_build(op_node *node, op_tex_cache *cache, double cmax, op_texture *t,
                               op_error *err)
{
    memset(t, 0, sizeof *t);
    node->used = 1;
    double uo, vo, us, vs;
    GET_OR_FAIL(op_node_float(node, "uoffset", 0.0, &uo, err));
    GET_OR_FAIL(op_node_float(node, "voffset", 0.0, &vo, err));
    GET_OR_FAIL(op_node_float(node, "uscale", 1.0, &us, err));
    GET_OR_FAIL(op_node_float(node, "vscale", 1.0, &vs, err));
    if (!(isfinite(uo) && isfinite(vo) && isfinite(us) && isfinite(vs)))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <texture type=\"%s\">: uoffset, voffset, "
                            "uscale and vscale must be finite", node->file, node->line,
                            node->type);
    if (op_node_has(node, "toUV")) { /* Mitsuba 3's form of the same placement */
        op_matrix4 m;
        GET_OR_FAIL(op_node_transform(node, "toUV", &m, err));
        if (op_node_has(node, "uoffset") || op_node_has(node, "voffset") ||
            op_node_has(node, "uscale") || op_node_has(node, "vscale"))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <texture type=\"%s\">: give to_uv or "
                                "uoffset/voffset/uscale/vscale, not both", node->file, node->line,
                                node->type);
        if (m.m[0][1] != 0.0 || m.m[1][0] != 0.0)
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <texture type=\"%s\">: to_uv may "
                                "scale and translate u and v, not rotate or shear them (not yet "
                                "supported)", node->file, node->line, node->type);
        us = m.m[0][0];
        vs = m.m[1][1];
        uo = m.m[0][3];
        vo = m.m[1][3];
    }
    t->uoffset = (float)uo;
    t->voffset = (float)vo;
    t->uscale = (float)us;
    t->vscale = (float)vs;
    if (strcmp(node->type, "bitmap") == 0)
        return build_bitmap(node, cache, t, err);
    if (strcmp(node->type, "checkerboard") == 0) {
        double c0[3] = {0.4, 0.4, 0.4}, c1[3] = {0.2, 0.2, 0.2};
        GET_OR_FAIL(op_node_color(node, "color0", c0, c0, err));
        GET_OR_FAIL(op_node_color(node, "color1", c1, c1, err));
        for (int k = 0; k < 3; k++)
            if (!(c0[k] >= 0.0 && c0[k] <= cmax && c1[k] >= 0.0 && c1[k] <= cmax))
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <texture type=\"checkerboard\">: "
                                    "color0 and color1 must be in [0, %g]", node->file, node->line,
                                    cmax);
        t->color0 = v3_from_d(c0);
        t->color1 = v3_from_d(c1);
        t->type = OP_TEX_CHECKERBOARD;
        return OP_OK;
    }
    if (strcmp(node->type, "rawconstant") == 0 && node->dialect == OP_DIALECT_MITSUBA_3) {
        double c[3] = {1, 1, 1};
        const op_prop *p = op_node_prop(node, "value");
        if (p && (p->kind == OP_PROP_VECTOR || p->kind == OP_PROP_POINT))
            GET_OR_FAIL(op_node_vec3(node, "value", c, c, err));
        else
            GET_OR_FAIL(op_node_color(node, "value", c, c, err));
        t->color0 = v3_from_d(c);
        t->type = OP_TEX_CONSTANT;
        return OP_OK;
    }
    char names[128];
    return op_error_set(err, OP_ERR_INPUT, "%s:%d: <texture type=\"%s\">: unknown texture type "
                        "(%s)", node->file, node->line, node->type,
                        op_names_join(texture_types, names, sizeof names));
}

op_status op_texture_build(op_node *node, op_tex_cache *cache, op_texture *t, op_error *err)
{
    return texture_build(node, cache, 1.0, t, err);
}

op_status op_texture_build_unbounded(op_node *node, op_tex_cache *cache, op_texture *t,
                                     op_error *err)
{
    return texture_build(node, cache, 1e30, t, err);
}

op_status op_texture_build_value(op_node *node, op_tex_cache *cache, double vmax, op_texture *t,
                                 op_error *err)
{
    GET_OR_FAIL(texture_build(node, cache, vmax, t, err));
    t->value_lum = node->dialect == OP_DIALECT_MITSUBA_3;
    if (t->type == OP_TEX_CHECKERBOARD && t->value_lum) {
        op_v3 c0 = t->color0;
        t->color0 = t->color1;
        t->color1 = c0;
    }
    return OP_OK;
}

/* Brings a coordinate into a small range where the wrap mode gives the same texels: [0, 1) for
 * repeat, [0, 2) for mirror, [-1, 2] otherwise (beyond which nothing changes). */
static float reduce(float x, op_tex_wrap w)
{
    if (w == OP_WRAP_REPEAT)
        return x - floorf(x);
    if (w == OP_WRAP_MIRROR)
        return x - 2.0f * floorf(0.5f * x);
    return fminf(fmaxf(x, -1.0f), 2.0f);
}

/* Texel index i of a row or column of n under wrap w; -1 when outside for zero/one. */
static int wrap_index(int i, int n, op_tex_wrap w)
{
    switch (w) {
    case OP_WRAP_REPEAT:
        i %= n;
        return i < 0 ? i + n : i;
    case OP_WRAP_MIRROR:
        i %= 2 * n;
        if (i < 0)
            i += 2 * n;
        return i >= n ? 2 * n - 1 - i : i;
    case OP_WRAP_CLAMP:
        return i < 0 ? 0 : i >= n ? n - 1 : i;
    default:
        return i < 0 || i >= n ? -1 : i;
    }
}

static op_v3 texel(const op_texture *t, int x, int y)
{
    const op_image *img = t->img;
    int i = wrap_index(x, img->width, t->wrap_u), j = wrap_index(y, img->height, t->wrap_v);
    if (i < 0 || j < 0) /* zero/one outside: the wrap of the axis that left the image */
        return v3s((i < 0 ? t->wrap_u : t->wrap_v) == OP_WRAP_ONE ? 1.0f : 0.0f);
    const float *p = img->pixels + 3 * ((size_t)j * (size_t)img->width + (size_t)i);
    return v3(p[0], p[1], p[2]);
}

op_v3 op_texture_eval(const op_texture *t, float u, float v)
{
    float su = u * t->uscale + t->uoffset, sv = v * t->vscale + t->voffset;
    if (!isfinite(su) || !isfinite(sv))
        return v3s(0.0f);
    if (t->type == OP_TEX_CHECKERBOARD) {
        /* Mitsuba's: cells of 1/2, the cell index truncated toward zero */
        int x = (int)(fminf(fmaxf(su, -1e9f), 1e9f) * 2.0f) & 1;
        int y = (int)(fminf(fmaxf(sv, -1e9f), 1e9f) * 2.0f) & 1;
        return x == y ? t->color0 : t->color1;
    }
    if (t->type == OP_TEX_CONSTANT)
        return t->color0;
    if (t->type != OP_TEX_BITMAP)
        return v3s(0.0f);
    su = reduce(su, t->wrap_u);
    sv = reduce(sv, t->wrap_v);
    float fx = su * (float)t->img->width, fy = sv * (float)t->img->height;
    if (t->nearest)
        return texel(t, (int)floorf(fx), (int)floorf(fy));
    fx -= 0.5f;
    fy -= 0.5f;
    float x0 = floorf(fx), y0 = floorf(fy);
    float dx = fx - x0, dy = fy - y0;
    int ix = (int)x0, iy = (int)y0;
    op_v3 a = v3_add(v3_scale(texel(t, ix, iy), 1.0f - dx), v3_scale(texel(t, ix + 1, iy), dx));
    op_v3 b = v3_add(v3_scale(texel(t, ix, iy + 1), 1.0f - dx),
                     v3_scale(texel(t, ix + 1, iy + 1), dx));
    return v3_add(v3_scale(a, 1.0f - dy), v3_scale(b, dy));
}

/* Luminance of linear sRGB (the Y row of its XYZ matrix, as Mitsuba's luminance). */
static float lum(op_v3 c)
{
    return 0.212671f * c.x + 0.715160f * c.y + 0.072169f * c.z;
}

float op_texture_eval_value(const op_texture *t, float u, float v)
{
    op_v3 c = op_texture_eval(t, u, v);
    if (c.x == c.y && c.y == c.z)
        return c.x;
    return t->value_lum ? lum(c) : (c.x + c.y + c.z) / 3.0f;
}

void op_texture_lum_grad(const op_texture *t, float u, float v, float *du, float *dv)
{
    *du = *dv = 0.0f;
    float su = u * t->uscale + t->uoffset, sv = v * t->vscale + t->voffset;
    if (t->type != OP_TEX_BITMAP || t->nearest || !isfinite(su) || !isfinite(sv))
        return;
    float w = (float)t->img->width, h = (float)t->img->height;
    float fx = reduce(su, t->wrap_u) * w - 0.5f, fy = reduce(sv, t->wrap_v) * h - 0.5f;
    float x0 = floorf(fx), y0 = floorf(fy);
    float dx = fx - x0, dy = fy - y0;
    int ix = (int)x0, iy = (int)y0;
    float f00 = lum(texel(t, ix, iy)), f10 = lum(texel(t, ix + 1, iy));
    float f01 = lum(texel(t, ix, iy + 1)), f11 = lum(texel(t, ix + 1, iy + 1));
    /* d/dx and d/dy of the bilinear blend, in texels; x = su w - 1/2, su = u uscale + ... */
    float gx = (1.0f - dy) * (f10 - f00) + dy * (f11 - f01);
    float gy = (1.0f - dx) * (f01 - f00) + dx * (f11 - f10);
    *du = gx * w * t->uscale;
    *dv = gy * h * t->vscale;
}

void op_texture_stats(const op_texture *t, op_v3 *max, op_v3 *mean)
{
    if (t->type == OP_TEX_CHECKERBOARD) {
        *max = v3(fmaxf(t->color0.x, t->color1.x), fmaxf(t->color0.y, t->color1.y),
                  fmaxf(t->color0.z, t->color1.z));
        *mean = v3_scale(v3_add(t->color0, t->color1), 0.5f);
        return;
    }
    if (t->type != OP_TEX_BITMAP) {
        *max = *mean = t->color0;
        return;
    }
    size_t n = (size_t)t->img->width * (size_t)t->img->height;
    double hi[3] = {0, 0, 0}, sum[3] = {0, 0, 0};
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            double x = t->img->pixels[3 * i + (size_t)k];
            hi[k] = x > hi[k] ? x : hi[k];
            sum[k] += x;
        }
    *max = v3((float)hi[0], (float)hi[1], (float)hi[2]);
    *mean = n ? v3((float)(sum[0] / (double)n), (float)(sum[1] / (double)n),
                   (float)(sum[2] / (double)n))
              : v3s(0.0f);
}

op_node *op_texture_child(const op_node *n, const char *name)
{
    for (int i = 0; i < n->nchildren; i++) {
        const char *cn = op_node_child_name(n, i);
        if (strcmp(n->children[i]->tag, "texture") == 0 && cn && strcmp(cn, name) == 0)
            return n->children[i];
    }
    return NULL;
}
