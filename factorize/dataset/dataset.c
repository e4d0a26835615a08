/* dataset.c - dataset specifications, the paper presets, energy checks and writing. */
#include "dataset.h"
#include "opaline_material.h"
#include "opaline_material_write.h"


#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* Each dataset's defaults. The layout parameters n, p1, p2, p3 mean, by layout:
 * veins: stripes, vein mm; inclusions: -, fraction, radius mm; layers: -, band mm, wave mm,
 * band period mm (the band count follows the sample's height); skin: -, pore pitch mm, pore
 * radius mm, vein mm (see dataset_layout.h). */
static const struct {
    const char *key, *name;
    op_dataset_kind kind;
    int w, h, k;
    double sx, sy;
    const char *a, *b;
    int n;
    double p1, p2, p3;
} presets[] = {
    {"chess4x4", "Chess4x4", OP_DS_CHESS4X4, 277, 277, 29, 12.6, 12.6, "Marble", "Skin1", 0, 0, 0,
     0},
    {"chess8x8", "Chess8x8", OP_DS_CHESS8X8, 222, 222, 39, 25.1, 25.1, "Skimmilk", "Potato", 0, 0,
     0, 0},
    {"marble-closeup", "MarbleCloseup", OP_DS_MARBLE_CLOSEUP, 128, 128, 39, 2.6, 2.6, "Marble",
     "Vein", 0, 0, 0, 0},
    {"veined-marble", "VeinedMarble", OP_DS_VEINED_MARBLE, 213, 211, 29, 13.0, 13.0, "Marble",
     "Vein", 0, 0, 0, 0},
    {"homogeneous", "Homogeneous", OP_DS_HOMOGENEOUS, 64, 64, 29, 5.0, 5.0, "Marble", "Marble", 0,
     0, 0, 0},
    {"carrara-marble", "CarraraMarble", OP_DS_CARRARA_MARBLE, 144, 144, 21, 7.2, 7.2, "Marble",
     "Vein", 4, 0.9, 0, 0},
    {"jade", "Jade", OP_DS_JADE, 128, 128, 21, 5.12, 5.12, "Jade", "Marble", 0, 0.15, 1.5, 0},
    {"layered-wax", "LayeredWax", OP_DS_LAYERED_WAX, 128, 128, 21, 6.4, 6.4, "Cream", "RedWax", 0,
     3.0, 2.0, 12.8},
    {"soap", "Soap", OP_DS_SOAP, 128, 128, 21, 5.12, 5.12, "PinkSoap", "Wholemilk", 2, 3.0, 0,
     0},
    {"skin", "Skin", OP_DS_SKIN, 128, 128, 25, 3.84, 3.84, "Skin2", "Skin1", 0, 3.0, 0.55,
     0.7},
};

#define N_PRESETS (sizeof presets / sizeof presets[0])

op_status op_dataset_spec_defaults(const char *name, op_dataset_spec *spec, op_error *err)
{
    for (size_t i = 0; i < N_PRESETS; i++) {
        if (strcasecmp(name, presets[i].key))
            continue;
        memset(spec, 0, sizeof *spec);
        spec->kind = presets[i].kind;
        snprintf(spec->name, sizeof spec->name, "%s", presets[i].name);
        spec->width = presets[i].w;
        spec->height = presets[i].h;
        spec->kernel = presets[i].k;
        spec->size_x_cm = presets[i].sx;
        spec->size_y_cm = presets[i].sy;
        spec->media[0] = op_medium_lookup(presets[i].a);
        spec->media[1] = op_medium_lookup(presets[i].b);
        spec->generator = OP_GEN_DIFFUSION;
        spec->photons = 1000;
        spec->seed = 1;
        spec->threads = 1;
        return OP_OK;
    }
    return op_error_set(err, OP_ERR_INPUT,
                        "unknown dataset '%s' (known: chess4x4, chess8x8, marble-closeup, "
                        "veined-marble, homogeneous, carrara-marble, jade, layered-wax, soap, "
                        "skin)", name);
}

op_status op_dataset_spec_check(const op_dataset_spec *s, op_error *err)
{
    if (s->width <= 0 || s->height <= 0)
        return op_error_set(err, OP_ERR_INPUT, "pixels %d x %d: both must be >= 1", s->width,
                            s->height);
    if ((uint64_t)s->width * (uint64_t)s->height > (1u << 26))
        return op_error_set(err, OP_ERR_INPUT, "pixels %d x %d: too many", s->width, s->height);
    if (s->kernel < 1 || s->kernel % 2 == 0 || s->kernel > 1023)
        return op_error_set(err, OP_ERR_INPUT, "kernel %d: must be odd, from 1 to 1023",
                            s->kernel);
    if (!(s->size_x_cm > 0) || !(s->size_y_cm > 0) || !isfinite(s->size_x_cm) ||
        !isfinite(s->size_y_cm))
        return op_error_set(err, OP_ERR_INPUT, "size %g x %g cm: both must be positive",
                            s->size_x_cm, s->size_y_cm);
    if (!s->media[0] || !s->media[1])
        return op_error_set(err, OP_ERR_INPUT, "dataset without media");
    if (s->eta != 0 && !(s->eta >= 1.0 && s->eta <= 3.0))
        return op_error_set(err, OP_ERR_INPUT, "eta %g: must be from 1 to 3 (or 0: each "
                            "medium's own)", s->eta);
    if (s->threads < 1 || s->threads > 1024)
        return op_error_set(err, OP_ERR_INPUT, "threads %d: must be 1 to 1024", s->threads);
    if (s->generator == OP_GEN_MONTECARLO && s->photons < 1)
        return op_error_set(err, OP_ERR_INPUT, "photons must be >= 1");
    return OP_OK;
}

op_status op_dataset_layout(const op_dataset_spec *s, op_layout *l, op_error *err)
{
    const op_medium *a = s->media[0], *b = s->media[1];
    size_t row = 0;
    while (row < N_PRESETS && presets[row].kind != s->kind)
        row++;
    if (row == N_PRESETS)
        return op_error_set(err, OP_ERR_INTERNAL, "unknown dataset kind %d", (int)s->kind);
    int n = presets[row].n;
    double p1 = presets[row].p1, p2 = presets[row].p2, p3 = presets[row].p3;
    int w = s->width, h = s->height;
    double sx = s->size_x_cm, sy = s->size_y_cm;
    switch (s->kind) {
    case OP_DS_CARRARA_MARBLE:
    case OP_DS_SOAP:
        return op_layout_veins(l, w, h, sx, sy, n, p1, s->seed, a, b, err);
    case OP_DS_JADE:
        return op_layout_inclusions(l, w, h, sx, sy, p1, p2, s->seed, a, b, err);
    case OP_DS_LAYERED_WAX: {
        double bands = round(10 * sy / p3);
        int count = bands < 1 ? 1 : bands > 4096 ? 4096 : (int)bands;
        return op_layout_layers(l, w, h, sx, sy, count, p1, p2, s->seed, a, b, err);
    }
    case OP_DS_SKIN:
        return op_layout_skin(l, w, h, sx, sy, p1, p2, p3, s->seed, a, b, err);
    case OP_DS_CHESS4X4:
        return op_layout_chessboard(l, s->width, s->height, s->size_x_cm, s->size_y_cm, 4, a, b,
                                    err);
    case OP_DS_CHESS8X8:
        return op_layout_chessboard(l, s->width, s->height, s->size_x_cm, s->size_y_cm, 8, a, b,
                                    err);
    case OP_DS_MARBLE_CLOSEUP: /* a close-up: a few veins, 0.5 mm wide */
        return op_layout_veins(l, s->width, s->height, s->size_x_cm, s->size_y_cm, 2, 0.5,
                               s->seed, a, b, err);
    case OP_DS_VEINED_MARBLE: /* densely veined: many thin veins, 0.8 mm wide */
        return op_layout_veins(l, s->width, s->height, s->size_x_cm, s->size_y_cm, 9, 0.8,
                               s->seed, a, b, err);
    case OP_DS_HOMOGENEOUS:
        return op_layout_homogeneous(l, s->width, s->height, s->size_x_cm, s->size_y_cm, a, err);
    }
    return op_error_set(err, OP_ERR_INTERNAL, "unknown dataset kind %d", (int)s->kind);
}

op_status op_dataset_alloc(op_dataset *d, int w, int h, int k, int with_se, op_error *err)
{
    return op_dataset_alloc_block(d, w, h, k, with_se, (uint64_t)w * (uint64_t)h, err);
}

op_status op_dataset_alloc_block(op_dataset *d, int w, int h, int k, int with_se, uint64_t rows,
                                 op_error *err)
{
    memset(d, 0, sizeof *d);
    d->width = w;
    d->height = h;
    d->kernel = k;
    d->nrows = rows;
    size_t n = (size_t)rows * (size_t)k * (size_t)k;
    for (int c = 0; c < 3; c++) {
        d->rd[c] = calloc(n, sizeof(float));
        if (with_se)
            d->se[c] = calloc(n, sizeof(float));
        if (!d->rd[c] || (with_se && !d->se[c])) {
            op_dataset_free(d);
            return op_error_set(err, OP_ERR_NOMEM,
                                "out of memory for %llu rows of a %d x %d x %d x %d dataset "
                                "(%.1f GB)", (unsigned long long)rows, w, h, k, k,
                                n * 4.0 * 3 * (with_se ? 2 : 1) / 1e9);
        }
    }
    return OP_OK;
}

void op_dataset_free(op_dataset *d)
{
    for (int c = 0; c < 3; c++) {
        free(d->rd[c]);
        free(d->se[c]);
        d->rd[c] = d->se[c] = NULL;
    }
}

op_status op_dataset_check(const op_dataset *d, op_error *err)
{
    static const char rgb[] = "RGB";
    int cols = d->kernel * d->kernel;
    uint64_t w = (uint64_t)d->width;
    for (int c = 0; c < 3; c++)
        for (uint64_t r = 0; r < d->nrows; r++) {
            const float *row = d->rd[c] + r * (uint64_t)cols;
            uint64_t p = d->row0 + r;
            double sum = 0;
            for (int j = 0; j < cols; j++) {
                if (!isfinite(row[j]) || row[j] < 0)
                    return op_error_set(err, OP_ERR_INPUT,
                                        "channel %c, pixel (%d, %d), offset (%d, %d): value %g is "
                                        "negative or not finite", rgb[c], (int)(p % w),
                                        (int)(p / w), j % d->kernel - d->kernel / 2,
                                        j / d->kernel - d->kernel / 2, (double)row[j]);
                sum += row[j];
            }
            if (sum > 1.0 + 1e-6)
                return op_error_set(err, OP_ERR_INPUT,
                                    "channel %c, pixel (%d, %d): albedo (row sum) %.6g exceeds 1",
                                    rgb[c], (int)(p % w), (int)(p / w), sum);
        }
    return OP_OK;
}

/* Rd values as little-endian float32 bytes: on a big-endian host they would need swapping,
 * which opaline does not support (the container assumes little-endian throughout). */
uint32_t op_dataset_crc(const op_dataset *d)
{
    uint32_t crc = 0;
    size_t n = (size_t)d->nrows * (size_t)d->kernel * (size_t)d->kernel;
    for (int c = 0; c < 3; c++)
        crc = op_crc32(crc, d->rd[c], n * sizeof(float));
    return crc;
}

static const char *const se_tags[3] = {"SE.R", "SE.G", "SE.B"};

struct op_dataset_writer {
    op_material_writer *w;
    op_material_info info;
    int with_se;
    uint64_t rows;     /* rows written so far */
    uint32_t crc[3];   /* of each channel's Rd so far */
    char rd_tag[3][8]; /* OP_RAW_SECTION + channel, the raw method's own tags */
};

op_status op_dataset_writer_open(const char *path, const op_dataset *d, int with_se,
                                 op_dataset_writer **out, op_error *err)
{
    *out = NULL;
    op_dataset_writer *dw = calloc(1, sizeof *dw);
    if (!dw)
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    op_material_info *info = &dw->info;
    info->method = OP_METHOD_RAW;
    info->width = d->width;
    info->height = d->height;
    info->kernel = d->kernel;
    info->channels = 3;
    info->size_x_cm = d->size_x_cm;
    info->size_y_cm = d->size_y_cm;
    snprintf(info->name, sizeof info->name, "%s", d->name);
    snprintf(info->generator, sizeof info->generator, "%s", d->generator);
    dw->with_se = with_se;
    op_status st = op_material_writer_open(path, info, &dw->w, err);
    uint64_t bytes = op_dataset_rows(d) * (uint64_t)d->kernel * (uint64_t)d->kernel * 4;
    for (int c = 0; c < 3; c++)
        op_channel_tag(dw->rd_tag[c], sizeof dw->rd_tag[c], OP_RAW_SECTION, info, c);
    for (int c = 0; c < 3 && st == OP_OK; c++)
        st = op_material_writer_reserve(dw->w, dw->rd_tag[c], bytes, err);
    for (int c = 0; c < 3 && st == OP_OK && with_se; c++)
        st = op_material_writer_reserve(dw->w, se_tags[c], bytes, err);
    if (st != OP_OK) {
        op_dataset_writer_abort(dw);
        return st;
    }
    *out = dw;
    return OP_OK;
}

op_status op_dataset_writer_add(op_dataset_writer *dw, const op_dataset *b, op_error *err)
{
    if (b->row0 != dw->rows || b->kernel != dw->info.kernel || (dw->with_se && !b->se[0]))
        return op_error_set(err, OP_ERR_INTERNAL, "dataset block of rows %llu.. out of order",
                            (unsigned long long)b->row0);
    size_t n = (size_t)b->nrows * (size_t)b->kernel * (size_t)b->kernel * sizeof(float);
    op_status st = OP_OK;
    for (int c = 0; c < 3 && st == OP_OK; c++) {
        dw->crc[c] = op_crc32(dw->crc[c], b->rd[c], n);
        st = op_material_writer_fill(dw->w, dw->rd_tag[c], b->rd[c], n, err);
    }
    for (int c = 0; c < 3 && st == OP_OK && dw->with_se; c++)
        st = op_material_writer_fill(dw->w, se_tags[c], b->se[c], n, err);
    dw->rows += b->nrows;
    return st;
}

op_status op_dataset_writer_commit(op_dataset_writer *dw, op_error *err)
{
    uint64_t bytes = (uint64_t)dw->info.width * (uint64_t)dw->info.height *
                     (uint64_t)dw->info.kernel * (uint64_t)dw->info.kernel * 4;
    dw->info.dataset_crc = op_crc32_combine(op_crc32_combine(dw->crc[0], dw->crc[1], bytes),
                                            dw->crc[2], bytes);
    op_status st = op_material_writer_set_info(dw->w, &dw->info, err);
    if (st != OP_OK) {
        op_dataset_writer_abort(dw);
        return st;
    }
    st = op_material_writer_commit(dw->w, err); /* refuses missing rows */
    free(dw);
    return st;
}

void op_dataset_writer_abort(op_dataset_writer *dw)
{
    if (!dw)
        return;
    op_material_writer_abort(dw->w);
    free(dw);
}

op_status op_dataset_write(const op_dataset *d, const char *path, op_error *err)
{
    op_dataset_writer *w;
    op_status st = op_dataset_writer_open(path, d, d->se[0] != NULL, &w, err);
    if (st != OP_OK)
        return st;
    st = op_dataset_writer_add(w, d, err);
    if (st != OP_OK) {
        op_dataset_writer_abort(w);
        return st;
    }
    return op_dataset_writer_commit(w, err);
}
