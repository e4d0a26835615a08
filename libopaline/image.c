/* image.c - linear float images and their files. Written: PNG (libpng, 8-bit sRGB), OpenEXR
 * (the OpenEXRCore C API), portable float maps and Radiance RGBE, each through op_output, so a
 * failed write leaves nothing behind. Read: the format chosen by content; PNG (libpng), OpenEXR
 * (its C API) and portable float maps here, every other format through OpenImageIO, in a
 * module loaded on first use (image_oiio.cpp). */
#include "opaline.h"
#include "opaline_image.h"
#include "image_internal.h"
#include "module_internal.h"

#include <errno.h>
#include <math.h>
#include <png.h>
#include <setjmp.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include <openexr.h>

static int valid_channels(int c)
{
    return c == 1 || c == 3 || c == 4;
}

op_status op_image_alloc(op_image *img, int width, int height, int channels, op_error *err)
{
    memset(img, 0, sizeof *img);
    if (width <= 0 || height <= 0 || width > OP_IMAGE_MAX_SIDE || height > OP_IMAGE_MAX_SIDE ||
        (size_t)width * (size_t)height > OP_IMAGE_MAX_PIXELS || !valid_channels(channels))
        return op_error_set(err, OP_ERR_INPUT, "image size %dx%d with %d channels is not supported",
                            width, height, channels);
    size_t n = (size_t)width * (size_t)height * (size_t)channels;
    img->pixels = calloc(n, sizeof(float));
    if (!img->pixels)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for a %dx%d image", width, height);
    img->width = width;
    img->height = height;
    img->channels = channels;
    return OP_OK;
}

void op_image_free(op_image *img)
{
    if (!img)
        return;
    free(img->pixels);
    memset(img, 0, sizeof *img);
}

static op_status check_image(const char *path, const op_image *img, op_error *err)
{
    if (!img || !img->pixels || img->width <= 0 || img->height <= 0 ||
        img->width > OP_IMAGE_MAX_SIDE || img->height > OP_IMAGE_MAX_SIDE ||
        !valid_channels(img->channels))
        return op_error_set(err, OP_ERR_INTERNAL, "%s: invalid image passed for writing", path);
    return OP_OK;
}

/* ---------------------------------------------------------------- sRGB */

static float srgb_encode(float v)
{
    if (!(v > 0.0f)) /* also NaN */
        return 0.0f;
    if (v >= 1.0f)
        return 1.0f;
    return v <= 0.0031308f ? 12.92f * v : 1.055f * powf(v, 1.0f / 2.4f) - 0.055f;
}

static float srgb_decode(float v)
{
    return v <= 0.04045f ? v / 12.92f : powf((v + 0.055f) / 1.055f, 2.4f);
}

static unsigned char to_byte(float v)
{
    if (!(v > 0.0f))
        return 0;
    if (v >= 1.0f)
        return 255;
    return (unsigned char)(v * 255.0f + 0.5f);
}

/* ---------------------------------------------------------------- PNG */

op_status op_image_write_png(const char *path, const op_image *img, float exposure_stops,
                             op_error *err)
{
    op_status st = check_image(path, img, err);
    if (st != OP_OK)
        return st;
    size_t n = (size_t)img->width * (size_t)img->height;
    int c = img->channels;
    unsigned char *buf = malloc(n * (size_t)c);
    if (!buf)
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    float scale = exp2f(exposure_stops);
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < c; k++) {
            float v = img->pixels[i * (size_t)c + (size_t)k];
            /* Alpha is coverage, not light: neither exposed nor gamma-encoded. */
            buf[i * (size_t)c + (size_t)k] = (c == 4 && k == 3) ? to_byte(v)
                                                                : to_byte(srgb_encode(v * scale));
        }

    op_output *out;
    if ((st = op_output_open(path, &out, err)) != OP_OK) {
        free(buf);
        return st;
    }
    png_image pi;
    memset(&pi, 0, sizeof pi);
    pi.version = PNG_IMAGE_VERSION;
    pi.width = (png_uint_32)img->width;
    pi.height = (png_uint_32)img->height;
    pi.format = c == 1 ? PNG_FORMAT_GRAY : c == 3 ? PNG_FORMAT_RGB : PNG_FORMAT_RGBA;
    int ok = png_image_write_to_stdio(&pi, op_output_stream(out), 0, buf, 0, NULL);
    free(buf);
    if (!ok) {
        op_error_set(err, OP_ERR_IO, "%s: cannot write PNG: %s", path, pi.message);
        png_image_free(&pi);
        op_output_abort(out);
        return OP_ERR_IO;
    }
    png_image_free(&pi);
    return op_output_commit(out, err);
}

/* Refuses an image whose header says it has more than max_pixels pixels, before any of it is
 * decoded: a small compressed file can describe gigabytes of pixels. */
static op_status check_pixels(const char *path, const char *kind, uint64_t w, uint64_t h,
                              uint64_t max_pixels, op_error *err)
{
    if (w * h <= max_pixels)
        return OP_OK;
    return op_error_set(err, OP_ERR_INPUT, "%s: %s image of %llu x %llu = %llu pixels is over the "
                        "limit of %llu pixels (image-pixels)", path, kind, (unsigned long long)w,
                        (unsigned long long)h, (unsigned long long)(w * h),
                        (unsigned long long)max_pixels);
}

static int host_little_endian(void)
{
    const uint16_t one = 1;
    unsigned char b;
    memcpy(&b, &one, 1);
    return b == 1;
}

/* libpng's row API reports errors here: kept, and the read abandoned (a longjmp). */
typedef struct png_failure {
    jmp_buf jump;
    char message[160];
} png_failure;

static void png_fail(png_structp png, png_const_charp msg)
{
    png_failure *f = png_get_error_ptr(png);
    snprintf(f->message, sizeof f->message, "%s", msg);
    longjmp(f->jump, 1);
}

static void png_warning_ignored(png_structp png, png_const_charp msg) {}

/* The transfer curve of a PNG's colour: 0 sRGB (an sRGB chunk, or no gAMA, or one within 0.05
 * of 2.2, as libpng counts sRGB), 1 linear, else the gamma exponent. */
static double png_transfer(png_structp png, png_infop info)
{
    int intent;
    double file_gamma;
    if (png_get_sRGB(png, info, &intent) || !png_get_gAMA(png, info, &file_gamma) ||
        !(file_gamma > 0.0))
        return 0.0;
    double g = 1.0 / file_gamma;
    return fabs(g - 1.0) <= 0.01 ? 1.0 : fabs(g - 2.2) <= 0.05 ? 0.0 : g;
}

/* A 16-bit PNG from f (at its start) into img (allocated with its size and channels), through
 * libpng's row API: the simplified API gives 16 bits only as premultiplied linear light through
 * a 2.2 power law. Colour is sRGB-encoded (or as gAMA says): decoded when decode is set, else
 * returned sRGB-encoded (code / 65535 for sRGB files); alpha as stored. */
static op_status read_png16(const char *path, FILE *f, int decode, op_image *img,
                            op_error *err)
{
    size_t w = (size_t)img->width, h = (size_t)img->height, c = (size_t)img->channels;
    png_failure fail = {.message = ""};
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &fail, png_fail,
                                             png_warning_ignored);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    uint16_t *buf = malloc(w * h * c * sizeof *buf);
    png_bytep *rows = malloc(h * sizeof *rows);
    if (!info || !buf || !rows) {
        png_destroy_read_struct(&png, &info, NULL);
        free(buf);
        free(rows);
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    }
    for (size_t y = 0; y < h; y++)
        rows[y] = (png_bytep)(buf + y * w * c);
    if (setjmp(fail.jump)) {
        png_destroy_read_struct(&png, &info, NULL);
        free(buf);
        free(rows);
        return op_error_set(err, OP_ERR_FORMAT, "%s: corrupt PNG: %s", path, fail.message);
    }
    png_init_io(png, f);
    png_read_info(png, info);
    png_set_expand(png); /* palette, tRNS to alpha */
    if (c >= 3)
        png_set_gray_to_rgb(png);
    if (host_little_endian())
        png_set_swap(png);
    png_set_interlace_handling(png);
    png_read_update_info(png, info);
    if (png_get_image_width(png, info) != w || png_get_image_height(png, info) != h ||
        png_get_bit_depth(png, info) != 16 || png_get_channels(png, info) != c)
        png_error(png, "layout differs from the header read first");
    double gamma = png_transfer(png, info);
    png_read_image(png, rows);
    png_read_end(png, NULL);
    png_destroy_read_struct(&png, &info, NULL);
    for (size_t i = 0; i < w * h * c; i++) {
        float v = (float)buf[i] / 65535.0f;
        if (!(c == 4 && i % 4 == 3)) {
            float lin = gamma == 0.0 ? srgb_decode(v) : gamma == 1.0 ? v : powf(v, (float)gamma);
            v = decode ? lin : gamma == 0.0 ? v : srgb_encode(lin);
        }
        img->pixels[i] = v;
    }
    free(buf);
    free(rows);
    return OP_OK;
}

/* Reads a PNG from f (path names it in messages) through libpng's simplified API (which never
 * prints), as 8-bit sRGB, decoded to linear light when decode is set (else byte / 255); alpha
 * stays as stored. Grey+alpha becomes RGBA. 16-bit files are read by read_png16. */
static op_status read_png(const char *path, FILE *f, int decode, uint64_t max_pixels,
                          int header_only, op_image *img, op_error *err)
{
    png_image pi;
    memset(&pi, 0, sizeof pi);
    pi.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_stdio(&pi, f)) {
        op_error_set(err, OP_ERR_FORMAT, "%s: not a readable PNG: %s", path, pi.message);
        png_image_free(&pi);
        return OP_ERR_FORMAT;
    }
    int has_alpha = (pi.format & PNG_FORMAT_FLAG_ALPHA) != 0;
    int colour = (pi.format & PNG_FORMAT_FLAG_COLOR) != 0;
    int c = has_alpha ? 4 : colour ? 3 : 1;
    int sixteen = (pi.format & PNG_FORMAT_FLAG_LINEAR) != 0; /* what 16-bit files report */
    pi.format = c == 1 ? PNG_FORMAT_GRAY : c == 3 ? PNG_FORMAT_RGB : PNG_FORMAT_RGBA;
    if (pi.width == 0 || pi.height == 0 || pi.width > OP_IMAGE_MAX_SIDE ||
        pi.height > OP_IMAGE_MAX_SIDE) {
        op_error_set(err, OP_ERR_FORMAT, "%s: PNG size %ux%u is not supported", path,
                     (unsigned)pi.width, (unsigned)pi.height);
        png_image_free(&pi);
        return OP_ERR_FORMAT;
    }
    op_status st = check_pixels(path, "PNG", pi.width, pi.height, max_pixels, err);
    if (st == OP_OK && header_only)
        *img = (op_image){(int)pi.width, (int)pi.height, c, NULL};
    else if (st == OP_OK)
        st = op_image_alloc(img, (int)pi.width, (int)pi.height, c, err);
    if (st != OP_OK || header_only) {
        png_image_free(&pi);
        return st;
    }
    if (sixteen) {
        png_image_free(&pi);
        rewind(f);
        if ((st = read_png16(path, f, decode, img, err)) != OP_OK)
            op_image_free(img);
        return st;
    }
    size_t n = (size_t)pi.width * pi.height * (size_t)c;
    unsigned char *buf = malloc(n);
    if (!buf) {
        png_image_free(&pi);
        op_image_free(img);
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    }
    if (!png_image_finish_read(&pi, NULL, buf, 0, NULL)) {
        op_error_set(err, OP_ERR_FORMAT, "%s: corrupt PNG: %s", path, pi.message);
        png_image_free(&pi);
        free(buf);
        op_image_free(img);
        return OP_ERR_FORMAT;
    }
    float table[256];
    for (int i = 0; i < 256; i++)
        table[i] = decode ? srgb_decode((float)i / 255.0f) : (float)i / 255.0f;
    for (size_t i = 0; i < n; i++)
        img->pixels[i] = (c == 4 && i % 4 == 3) ? (float)buf[i] / 255.0f : table[buf[i]];
    free(buf);
    png_image_free(&pi);
    return OP_OK;
}

/* ---------------------------------------------------------------- OpenEXR */

/* What the EXR stream callbacks share: the output (writing) or descriptor (reading), and the
 * library's last error message. One per call, so concurrent calls share nothing. */
typedef struct exr_io {
    op_output *out;
    int fd;
    int64_t size;
    int io_errno;
    char message[256];
} exr_io;

static void exr_error_cb(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    void *ud = NULL;
    if (exr_get_user_data(ctxt, &ud) == EXR_ERR_SUCCESS && ud) {
        exr_io *io = ud;
        snprintf(io->message, sizeof io->message, "%s", msg ? msg : exr_get_error_code_as_string(code));
    }
}

static int64_t exr_write_cb(exr_const_context_t ctxt, void *user, const void *buffer, uint64_t sz,
                            uint64_t offset, exr_stream_error_func_ptr_t error_cb)
{
    exr_io *io = user;
    FILE *f = op_output_stream(io->out);
    /* OpenEXR writes from this thread only (we encode chunk by chunk), so seeking is safe. */
    if (offset > (uint64_t)INT64_MAX || fseeko(f, (off_t)offset, SEEK_SET) != 0 ||
        fwrite(buffer, 1, sz, f) != sz) {
        io->io_errno = errno ? errno : EIO;
        error_cb(ctxt, EXR_ERR_WRITE_IO, "write failed: %s", strerror(io->io_errno));
        return -1;
    }
    return (int64_t)sz;
}

static int64_t exr_read_cb(exr_const_context_t ctxt, void *user, void *buffer, uint64_t sz,
                           uint64_t offset, exr_stream_error_func_ptr_t error_cb)
{
    exr_io *io = user;
    uint64_t done = 0;
    while (done < sz) {
        ssize_t r = pread(io->fd, (char *)buffer + done, sz - done, (off_t)(offset + done));
        if (r < 0) {
            if (errno == EINTR)
                continue;
            error_cb(ctxt, EXR_ERR_READ_IO, "read failed: %s", strerror(errno));
            return -1;
        }
        if (r == 0)
            break;
        done += (uint64_t)r;
    }
    return (int64_t)done;
}

static int64_t exr_size_cb(exr_const_context_t ctxt, void *user)
{
    return ((exr_io *)user)->size;
}

static const char *exr_msg(const exr_io *io, exr_result_t rv)
{
    return io->message[0] ? io->message : exr_get_default_error_message(rv);
}

/* Starts reading the OpenEXR file open as fd (size bytes) through io. */
static exr_result_t exr_open_read(const char *path, int fd, int64_t size, exr_io *io,
                                  exr_context_t *ctx)
{
    memset(io, 0, sizeof *io);
    io->fd = fd;
    io->size = size;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_error_cb;
    init.user_data = io;
    init.read_fn = exr_read_cb;
    init.size_fn = exr_size_cb;
    init.flags = EXR_CONTEXT_FLAG_DISABLE_CHUNK_RECONSTRUCTION;
    return exr_start_read(ctx, path, &init);
}

op_status op_image_write_exr(const char *path, const op_image *img, int half_float, op_error *err)
{
    return op_image_write_exr_attr(path, img, half_float, NULL, NULL, err);
}

op_status op_image_write_exr_attr(const char *path, const op_image *img, int half_float,
                                  const char *attr_name, const char *attr_value, op_error *err)
{
    op_status st = check_image(path, img, err);
    if (st != OP_OK)
        return st;
    exr_io io;
    memset(&io, 0, sizeof io);
    io.fd = -1;
    if ((st = op_output_open(path, &io.out, err)) != OP_OK)
        return st;

    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_error_cb;
    init.user_data = &io;
    init.write_fn = exr_write_cb;
    exr_context_t ctx = NULL;
    exr_encode_pipeline_t enc;
    int enc_started = 0;
    exr_result_t rv = exr_start_write(&ctx, path, EXR_WRITE_FILE_DIRECTLY, &init);
    int part = 0;
    static const char *names[4][4] = {{"Y"}, {0}, {"R", "G", "B"}, {"R", "G", "B", "A"}};
    int c = img->channels;
    exr_pixel_type_t ptype = half_float ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT;
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_add_part(ctx, "rgba", EXR_STORAGE_SCANLINE, &part);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_initialize_required_attr_simple(ctx, part, img->width, img->height,
                                                 EXR_COMPRESSION_ZIP);
    if (rv == EXR_ERR_SUCCESS && attr_name)
        rv = exr_attr_set_string(ctx, part, attr_name, attr_value);
    for (int k = 0; k < c && rv == EXR_ERR_SUCCESS; k++)
        rv = exr_add_channel(ctx, part, names[c - 1][k], ptype,
                             k == 3 ? EXR_PERCEPTUALLY_LINEAR : EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_write_header(ctx);
    int32_t lines = 1;
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_scanlines_per_chunk(ctx, part, &lines);
    size_t row_bytes = (size_t)img->width * (size_t)c * sizeof(float);
    for (int y = 0; rv == EXR_ERR_SUCCESS && y < img->height; y += lines) {
        exr_chunk_info_t ci;
        rv = exr_write_scanline_chunk_info(ctx, part, y, &ci);
        if (rv != EXR_ERR_SUCCESS)
            break;
        if (!enc_started) {
            rv = exr_encoding_initialize(ctx, part, &ci, &enc);
            enc_started = rv == EXR_ERR_SUCCESS;
        } else {
            rv = exr_encoding_update(ctx, part, &ci, &enc);
        }
        if (rv != EXR_ERR_SUCCESS)
            break;
        for (int ch = 0; ch < enc.channel_count; ch++) {
            exr_coding_channel_info_t *cc = &enc.channels[ch];
            int k = 0;
            while (k < c && strcmp(cc->channel_name, names[c - 1][k]) != 0)
                k++;
            if (k == c) {
                rv = EXR_ERR_INVALID_ARGUMENT;
                break;
            }
            cc->user_bytes_per_element = 4;
            cc->user_data_type = EXR_PIXEL_FLOAT;
            cc->user_pixel_stride = (int32_t)((size_t)c * sizeof(float));
            cc->user_line_stride = (int32_t)row_bytes;
            cc->encode_from_ptr =
                (const uint8_t *)(img->pixels + ((size_t)y * (size_t)img->width) * (size_t)c +
                                  (size_t)k);
        }
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_encoding_choose_default_routines(ctx, part, &enc);
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_encoding_run(ctx, part, &enc);
    }
    if (enc_started)
        exr_encoding_destroy(ctx, &enc);
    exr_result_t frv = ctx ? exr_finish(&ctx) : EXR_ERR_SUCCESS;
    if (rv == EXR_ERR_SUCCESS)
        rv = frv;
    if (rv != EXR_ERR_SUCCESS) {
        op_status code = io.io_errno ? OP_ERR_IO : OP_ERR_INTERNAL;
        op_error_set(err, code, "%s: cannot write OpenEXR: %s", path, exr_msg(&io, rv));
        op_output_abort(io.out);
        return code;
    }
    return op_output_commit(io.out, err);
}

/* Whether the linked OpenEXR C library decodes compression comp: DWAA and DWAB only since
 * OpenEXR 3.1.8 (before, its C core reports them not implemented; Debian 12 has 3.1.5). */
static int exr_core_decodes(exr_compression_t comp)
{
    if (comp != EXR_COMPRESSION_DWAA && comp != EXR_COMPRESSION_DWAB)
        return 1;
    int maj = 0, min = 0, patch = 0;
    const char *extra = NULL;
    exr_get_library_version(&maj, &min, &patch, &extra);
    return maj > 3 || (maj == 3 && (min > 1 || (min == 1 && patch >= 8)));
}

/* Reads a flat (not deep) scanline or tiled OpenEXR file, any pixel type converted to float:
 * the channels R, G, B and A (or Y, else R, and A) of the layer named (layer.R ..., or R ... of
 * the part named layer; NULL or "" the default layer), from the first part that has them. Its
 * own reader, on OpenEXR's C API: OpenImageIO 2.4's (OpenEXR's C++ library) takes 2 GB and 5 s
 * to refuse a 200-byte header declaring a huge data window. A file whose pixels that library
 * cannot decode (exr_core_decodes), its header read and its size checked, is left to the
 * caller: *compression gets the compression's name, nothing else is set; else it gets NULL. */
static op_status read_exr(const char *path, const char *layer, int fd, int64_t size,
                          uint64_t max_pixels, int header_only, op_image *img,
                          const char **compression, op_error *err)
{
    *compression = NULL;
    exr_io io;
    exr_context_t ctx = NULL;
    op_status st = OP_OK;
    exr_result_t rv = exr_open_read(path, fd, size, &io, &ctx);
    if (rv != EXR_ERR_SUCCESS) {
        if (ctx)
            exr_finish(&ctx);
        return op_error_set(err, OP_ERR_FORMAT, "%s: not a readable OpenEXR file: %s", path,
                            exr_msg(&io, rv));
    }
    /* The part and the channel names: the first part with the layer's R, G, B or Y. */
    static const char *slot_names[5] = {"R", "G", "B", "A", "Y"};
    char names[5][300];
    int part = -1, nparts = 0, has[5] = {0};
    const exr_attr_chlist_t *chl = NULL;
    if ((rv = exr_get_count(ctx, &nparts)) != EXR_ERR_SUCCESS) {
        st = op_error_set(err, OP_ERR_FORMAT, "%s: bad OpenEXR header: %s", path, exr_msg(&io, rv));
        goto done;
    }
    for (int p = 0; p < nparts && part < 0; p++) {
        const char *part_name = NULL;
        int whole = layer && *layer && exr_get_name(ctx, p, &part_name) == EXR_ERR_SUCCESS &&
                    part_name && strcmp(part_name, layer) == 0;
        const char *prefix = layer && *layer && !whole ? layer : "";
        for (int s = 0; s < 5; s++)
            snprintf(names[s], sizeof names[s], "%s%s%s", prefix, *prefix ? "." : "",
                     slot_names[s]);
        if ((rv = exr_get_channels(ctx, p, &chl)) != EXR_ERR_SUCCESS) {
            st = op_error_set(err, OP_ERR_FORMAT, "%s: bad OpenEXR header: %s", path,
                              exr_msg(&io, rv));
            goto done;
        }
        memset(has, 0, sizeof has);
        for (int i = 0; i < chl->num_channels; i++)
            for (int s = 0; s < 5; s++)
                if (strcmp(chl->entries[i].name.str, names[s]) == 0) {
                    if (chl->entries[i].x_sampling != 1 || chl->entries[i].y_sampling != 1) {
                        st = op_error_set(err, OP_ERR_FORMAT,
                                          "%s: subsampled OpenEXR channel %s is not supported",
                                          path, names[s]);
                        goto done;
                    }
                    has[s] = 1;
                }
        if ((has[0] && has[1] && has[2]) || has[4] || has[0])
            part = p;
    }
    if (part < 0) {
        if (layer && *layer)
            st = op_error_set(err, OP_ERR_INPUT, "%s: OpenEXR image has no layer \"%s\" with R, "
                              "G, B or Y channels", path, layer);
        else
            st = op_error_set(err, OP_ERR_FORMAT, "%s: OpenEXR file has no R, G, B or Y channels",
                              path);
        goto done;
    }
    exr_storage_t storage;
    exr_attr_box2i_t dw;
    if ((rv = exr_get_storage(ctx, part, &storage)) != EXR_ERR_SUCCESS ||
        (rv = exr_get_data_window(ctx, part, &dw)) != EXR_ERR_SUCCESS) {
        st = op_error_set(err, OP_ERR_FORMAT, "%s: bad OpenEXR header: %s", path, exr_msg(&io, rv));
        goto done;
    }
    if (storage != EXR_STORAGE_SCANLINE && storage != EXR_STORAGE_TILED) {
        st = op_error_set(err, OP_ERR_FORMAT, "%s: deep OpenEXR images are not supported", path);
        goto done;
    }
    int64_t w = (int64_t)dw.max.x - dw.min.x + 1, h = (int64_t)dw.max.y - dw.min.y + 1;
    if (w <= 0 || h <= 0 || w > OP_IMAGE_MAX_SIDE || h > OP_IMAGE_MAX_SIDE) {
        st = op_error_set(err, OP_ERR_FORMAT, "%s: OpenEXR data window %lldx%lld is not supported",
                          path, (long long)w, (long long)h);
        goto done;
    }
    if ((st = check_pixels(path, "OpenEXR", (uint64_t)w, (uint64_t)h, max_pixels, err)) != OP_OK)
        goto done;
    exr_compression_t comp = EXR_COMPRESSION_NONE;
    if ((rv = exr_get_compression(ctx, part, &comp)) != EXR_ERR_SUCCESS) {
        st = op_error_set(err, OP_ERR_FORMAT, "%s: bad OpenEXR header: %s", path, exr_msg(&io, rv));
        goto done;
    }
    if (!header_only && !exr_core_decodes(comp)) {
        *compression = comp == EXR_COMPRESSION_DWAA ? "DWAA" : "DWAB";
        goto done;
    }
    /* Slots: R G B A, or Y (else R) for grey; grey with alpha is read as RGBA. */
    int c, slot_of[5] = {-1, -1, -1, -1, -1};
    if (has[0] && has[1] && has[2]) {
        c = has[3] ? 4 : 3;
        for (int s = 0; s < c; s++)
            slot_of[s] = s;
    } else {
        c = has[3] ? 4 : 1;
        slot_of[has[4] ? 4 : 0] = 0;
        if (c == 4)
            slot_of[3] = 3;
    }
    int grey_alpha = c == 4 && !(has[0] && has[1] && has[2]);
    if (header_only) {
        *img = (op_image){(int)w, (int)h, c, NULL};
        goto done;
    }
    if ((st = op_image_alloc(img, (int)w, (int)h, c, err)) != OP_OK)
        goto done;

    /* The chunks: scanline blocks, or the level-0 tiles. */
    int32_t lines = 1, nchunks = 0, tiles_x = 1;
    uint32_t tw = 0, th = 0;
    if (storage == EXR_STORAGE_SCANLINE) {
        rv = exr_get_scanlines_per_chunk(ctx, part, &lines);
        nchunks = (int32_t)((h + lines - 1) / (lines > 0 ? lines : 1));
    } else {
        exr_tile_level_mode_t lm;
        exr_tile_round_mode_t rm;
        rv = exr_get_tile_descriptor(ctx, part, &tw, &th, &lm, &rm);
        if (rv == EXR_ERR_SUCCESS && (tw == 0 || th == 0))
            rv = EXR_ERR_INVALID_ATTR;
        if (rv == EXR_ERR_SUCCESS) {
            tiles_x = (int32_t)((w + tw - 1) / tw);
            nchunks = tiles_x * (int32_t)((h + th - 1) / th);
        }
    }
    if (rv != EXR_ERR_SUCCESS || lines <= 0) {
        st = op_error_set(err, OP_ERR_FORMAT, "%s: bad OpenEXR layout: %s", path, exr_msg(&io, rv));
        op_image_free(img);
        goto done;
    }
    /* Each chunk is decoded into planar scratch, then interleaved here: the library's fast
     * interleaved half-to-float paths have mixed up RGBA channel order in some releases. */
    size_t chunk_px = storage == EXR_STORAGE_SCANLINE ? (size_t)lines * (size_t)w
                                                      : (size_t)tw * (size_t)th;
    float *scratch = malloc(chunk_px * (size_t)(c + 1) * sizeof(float));
    if (!scratch) {
        op_image_free(img);
        st = op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
        goto done;
    }
    exr_decode_pipeline_t dec;
    int dec_started = 0;
    size_t row_floats = (size_t)w * (size_t)c;
    for (int32_t i = 0; i < nchunks && rv == EXR_ERR_SUCCESS; i++) {
        exr_chunk_info_t ci;
        if (storage == EXR_STORAGE_SCANLINE)
            rv = exr_read_scanline_chunk_info(ctx, part, dw.min.y + i * lines, &ci);
        else
            rv = exr_read_tile_chunk_info(ctx, part, i % tiles_x, i / tiles_x, 0, 0, &ci);
        if (rv != EXR_ERR_SUCCESS)
            break;
        int64_t x0 = storage == EXR_STORAGE_SCANLINE ? 0 : (int64_t)(i % tiles_x) * tw;
        int64_t y0 = storage == EXR_STORAGE_SCANLINE ? (int64_t)ci.start_y - dw.min.y
                                                     : (int64_t)(i / tiles_x) * th;
        if (y0 < 0 || x0 < 0 || ci.width <= 0 || ci.height <= 0 || y0 + ci.height > h ||
            x0 + ci.width > w || (size_t)ci.width * (size_t)ci.height > chunk_px) {
            rv = EXR_ERR_CORRUPT_CHUNK;
            break;
        }
        if (!dec_started) {
            rv = exr_decoding_initialize(ctx, part, &ci, &dec);
            dec_started = rv == EXR_ERR_SUCCESS;
        } else {
            rv = exr_decoding_update(ctx, part, &ci, &dec);
        }
        if (rv != EXR_ERR_SUCCESS)
            break;
        size_t plane = (size_t)ci.width * (size_t)ci.height;
        /* Every channel gets a destination: channels not read go to the plane after the
         * last slot (OpenEXR 3.1's specialized unpackers write through null pointers). */
        for (int ch = 0; ch < dec.channel_count; ch++) {
            exr_coding_channel_info_t *cc = &dec.channels[ch];
            int slot = c;
            for (int s = 0; s < 5; s++)
                if (slot_of[s] >= 0 && strcmp(cc->channel_name, names[s]) == 0)
                    slot = slot_of[s];
            cc->user_bytes_per_element = 4;
            cc->user_data_type = EXR_PIXEL_FLOAT;
            cc->user_pixel_stride = (int32_t)sizeof(float);
            cc->user_line_stride = (int32_t)((size_t)ci.width * sizeof(float));
            cc->decode_to_ptr = (uint8_t *)(scratch + (size_t)slot * plane);
        }
        rv = exr_decoding_choose_default_routines(ctx, part, &dec);
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_decoding_run(ctx, part, &dec);
        for (int32_t yy = 0; rv == EXR_ERR_SUCCESS && yy < ci.height; yy++)
            for (int32_t xx = 0; xx < ci.width; xx++)
                for (int k = 0; k < c; k++)
                    img->pixels[(size_t)(y0 + yy) * row_floats + (size_t)(x0 + xx) * (size_t)c +
                                (size_t)k] =
                        scratch[(size_t)(grey_alpha && (k == 1 || k == 2) ? 0 : k) * plane +
                                (size_t)yy * (size_t)ci.width + (size_t)xx];
    }
    free(scratch);
    if (dec_started)
        exr_decoding_destroy(ctx, &dec);
    if (rv != EXR_ERR_SUCCESS) {
        st = op_error_set(err, OP_ERR_FORMAT, "%s: corrupt OpenEXR pixel data: %s", path,
                          exr_msg(&io, rv));
        op_image_free(img);
    }
done:
    exr_finish(&ctx);
    return st;
}

/* ---------------------------------------------------------------- Radiance RGBE */

/* One linear RGB value in Greg Ward's shared-exponent encoding (negative and non-finite
 * channels count as 0; values beyond the format's range become its largest). */
static void rgbe_encode(const float rgb[3], unsigned char out[4])
{
    float c[3];
    for (int k = 0; k < 3; k++)
        c[k] = isfinite(rgb[k]) && rgb[k] > 0.0f ? rgb[k] : 0.0f;
    float v = fmaxf(c[0], fmaxf(c[1], c[2]));
    if (v < 1e-32f) {
        out[0] = out[1] = out[2] = out[3] = 0;
        return;
    }
    int e;
    float m = frexpf(v, &e); /* v = m 2^e, m in [0.5, 1) */
    if (e > 127) {
        out[0] = out[1] = out[2] = 255;
        out[3] = 255;
        return;
    }
    float scale = m * 256.0f / v;
    for (int k = 0; k < 3; k++) {
        float b = c[k] * scale;
        out[k] = (unsigned char)(b >= 255.0f ? 255 : (int)b);
    }
    out[3] = (unsigned char)(e + 128);
}

/* Flat (uncompressed) scanlines, which every RGBE reader accepts, rows from the top. */
op_status op_image_write_hdr(const char *path, const op_image *img, op_error *err)
{
    op_status st = check_image(path, img, err);
    if (st != OP_OK)
        return st;
    op_output *out;
    if ((st = op_output_open(path, &out, err)) != OP_OK)
        return st;
    char header[128];
    int hn = snprintf(header, sizeof header, "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n",
                      img->height, img->width);
    op_output_write(out, header, (size_t)hn);
    unsigned char *row = malloc((size_t)img->width * 4);
    if (!row) {
        op_output_abort(out);
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    }
    int ch = img->channels;
    for (int y = 0; y < img->height; y++) {
        for (int x = 0; x < img->width; x++) {
            const float *p = img->pixels + ((size_t)y * img->width + x) * (size_t)ch;
            float rgb[3] = {p[0], ch >= 3 ? p[1] : p[0], ch >= 3 ? p[2] : p[0]};
            rgbe_encode(rgb, row + 4 * (size_t)x);
        }
        op_output_write(out, row, (size_t)img->width * 4);
    }
    free(row);
    return op_output_commit(out, err);
}

/* ---------------------------------------------------------------- PFM */

static void swap4(void *p)
{
    unsigned char *b = p, t;
    t = b[0], b[0] = b[3], b[3] = t;
    t = b[1], b[1] = b[2], b[2] = t;
}

/* Grey images are written as "Pf", colour as "PF"; alpha is dropped (PFM has no alpha).
 * Rows go bottom to top, as the format requires. */
op_status op_image_write_pfm(const char *path, const op_image *img, op_error *err)
{
    op_status st = check_image(path, img, err);
    if (st != OP_OK)
        return st;
    op_output *out;
    if ((st = op_output_open(path, &out, err)) != OP_OK)
        return st;
    int oc = img->channels == 1 ? 1 : 3;
    char header[64];
    int hn = snprintf(header, sizeof header, "%s\n%d %d\n-1.0\n", oc == 1 ? "Pf" : "PF",
                      img->width, img->height);
    op_output_write(out, header, (size_t)hn);
    float *row = malloc((size_t)img->width * (size_t)oc * sizeof(float));
    if (!row) {
        op_output_abort(out);
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    }
    int swap = !host_little_endian();
    for (int y = img->height - 1; y >= 0; y--) {
        const float *src = img->pixels + (size_t)y * (size_t)img->width * (size_t)img->channels;
        for (int x = 0; x < img->width; x++)
            for (int k = 0; k < oc; k++) {
                float *d = &row[(size_t)x * (size_t)oc + (size_t)k];
                *d = src[(size_t)x * (size_t)img->channels + (size_t)k];
                if (swap)
                    swap4(d);
            }
        op_output_write(out, row, (size_t)img->width * (size_t)oc * sizeof(float));
    }
    free(row);
    return op_output_commit(out, err);
}

int op_matrix_variable_valid(const char *name)
{
    size_t n = strlen(name);
    if (n == 0 || n > 63 || !((name[0] >= 'a' && name[0] <= 'z') || (name[0] >= 'A' && name[0] <= 'Z')))
        return 0;
    for (size_t i = 1; i < n; i++) {
        char c = name[i];
        if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
              c == '_'))
            return 0;
    }
    return 1;
}

/* v with `digits` significant digits as format spells numbers, into buf (64 bytes). */
static void matrix_number(float v, op_matrix_format format, int digits, char *buf)
{
    int mma = format == OP_MATRIX_MATHEMATICA;
    if (isnan(v)) {
        snprintf(buf, 64, "%s", mma ? "Indeterminate" : "NaN");
        return;
    }
    if (isinf(v)) {
        snprintf(buf, 64, "%s%s", v < 0 ? "-" : "", mma ? "Infinity" : "Inf");
        return;
    }
    char num[48];
    snprintf(num, sizeof num, "%.*g", digits, (double)v);
    char *e = mma ? strchr(num, 'e') : NULL;
    if (e)
        snprintf(buf, 64, "%.*s*^%s", (int)(e - num), num, e + 1);
    else
        snprintf(buf, 64, "%s", num);
}

op_status op_image_write_matrix(const char *path, const op_image *img, op_matrix_format format,
                                int digits, const char *variable, op_error *err)
{
    op_status st = check_image(path, img, err);
    if (st != OP_OK)
        return st;
    if (digits < 1 || digits > 17 || !op_matrix_variable_valid(variable))
        return op_error_set(err, OP_ERR_INPUT, "%s: a matrix needs 1 to 17 digits and a variable "
                            "name of letters, digits and _ after a letter", path);
    op_output *out;
    if ((st = op_output_open(path, &out, err)) != OP_OK)
        return st;
    int mma = format == OP_MATRIX_MATHEMATICA, nch = img->channels;
    char text[128];
    for (int ch = 0; ch < nch; ch++) {
        int n;
        if (!mma)
            n = ch == 0 ? snprintf(text, sizeof text, "%s = [", variable)
                        : snprintf(text, sizeof text, "\n%s(:, :, %d) = [", variable, ch + 1);
        else if (ch == 0)
            n = snprintf(text, sizeof text, "%s = %s", variable, nch == 1 ? "{{" : "Transpose[{{{");
        else
            n = 0;
        op_output_write(out, text, (size_t)n);
        for (int y = 0; y < img->height; y++)
            for (int x = 0; x < img->width; x++) {
                char num[64];
                matrix_number(img->pixels[((size_t)y * img->width + x) * nch + ch], format,
                              digits, num);
                const char *sep;
                if (x + 1 < img->width)
                    sep = ", ";
                else if (!mma)
                    sep = y + 1 < img->height ? ";\n\t" : "];\n";
                else if (y + 1 < img->height)
                    sep = "},\n\t{";
                else if (ch + 1 < nch)
                    sep = "}},\n\n\t{{";
                else
                    sep = nch == 1 ? "}};\n" : "}}}, {3,1,2}];\n";
                n = snprintf(text, sizeof text, "%s%s", num, sep);
                op_output_write(out, text, (size_t)n);
            }
    }
    return op_output_commit(out, err);
}

op_status op_image_write_npy(const char *path, const op_image *img, op_error *err)
{
    op_status st = check_image(path, img, err);
    if (st != OP_OK)
        return st;
    op_output *out;
    if ((st = op_output_open(path, &out, err)) != OP_OK)
        return st;
    long long shape[3] = {img->height, img->width, img->channels};
    unsigned char header[OP_NPY_HEADER_SIZE];
    op_output_write(out, header, op_npy_write_header(header, img->channels == 1 ? 2 : 3, shape));
    size_t n = (size_t)img->width * (size_t)img->channels;
    float *row = malloc(n * sizeof(float));
    if (!row) {
        op_output_abort(out);
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    }
    int swap = !host_little_endian();
    for (int y = 0; y < img->height; y++) {
        memcpy(row, img->pixels + (size_t)y * n, n * sizeof(float));
        for (size_t i = 0; swap && i < n; i++)
            swap4(&row[i]);
        op_output_write(out, row, n * sizeof(float));
    }
    free(row);
    return op_output_commit(out, err);
}

/* Parses one whitespace-delimited token of a PFM header from buf[*pos..n). */
static int pfm_token(const unsigned char *buf, size_t n, size_t *pos, char *tok, size_t cap)
{
    size_t p = *pos, k = 0;
    while (p < n && (buf[p] == ' ' || buf[p] == '\t' || buf[p] == '\n' || buf[p] == '\r'))
        p++;
    while (p < n && !(buf[p] == ' ' || buf[p] == '\t' || buf[p] == '\n' || buf[p] == '\r')) {
        if (k + 1 >= cap)
            return 0;
        tok[k++] = (char)buf[p++];
    }
    tok[k] = '\0';
    if (p >= n || k == 0)
        return 0;
    *pos = p + 1; /* exactly one whitespace character ends the token */
    return 1;
}

static op_status read_pfm(const char *path, int fd, int64_t size, uint64_t max_pixels,
                          int header_only, op_image *img, op_error *err)
{
    unsigned char head[128];
    ssize_t got = pread(fd, head, sizeof head, 0);
    if (got < 0)
        return op_error_set(err, OP_ERR_IO, "%s: cannot read: %s", path, strerror(errno));
    size_t pos = 0;
    char t0[8], t1[16], t2[16], t3[32];
    if (!pfm_token(head, (size_t)got, &pos, t0, sizeof t0) ||
        !pfm_token(head, (size_t)got, &pos, t1, sizeof t1) ||
        !pfm_token(head, (size_t)got, &pos, t2, sizeof t2) ||
        !pfm_token(head, (size_t)got, &pos, t3, sizeof t3))
        return op_error_set(err, OP_ERR_FORMAT, "%s: bad PFM header", path);
    int c = strcmp(t0, "PF") == 0 ? 3 : strcmp(t0, "Pf") == 0 ? 1 : 0;
    char *e1, *e2, *e3;
    long w = strtol(t1, &e1, 10), h = strtol(t2, &e2, 10);
    double scale = strtod(t3, &e3);
    if (!c || *e1 || *e2 || *e3 || w <= 0 || h <= 0 || w > OP_IMAGE_MAX_SIDE ||
        h > OP_IMAGE_MAX_SIDE || scale == 0.0 || !isfinite(scale))
        return op_error_set(err, OP_ERR_FORMAT, "%s: bad PFM header", path);
    op_status lim = check_pixels(path, "PFM", (uint64_t)w, (uint64_t)h, max_pixels, err);
    if (lim != OP_OK)
        return lim;
    size_t count = (size_t)w * (size_t)h * (size_t)c;
    if ((uint64_t)size < pos + count * sizeof(float))
        return op_error_set(err, OP_ERR_FORMAT, "%s: truncated PFM (%lld bytes, need %zu)", path,
                            (long long)size, pos + count * sizeof(float));
    if (header_only) {
        *img = (op_image){(int)w, (int)h, c, NULL};
        return OP_OK;
    }
    op_status st = op_image_alloc(img, (int)w, (int)h, c, err);
    if (st != OP_OK)
        return st;
    int swap = (scale < 0) != host_little_endian();
    size_t row = (size_t)w * (size_t)c;
    for (long y = 0; y < h; y++) {
        float *dst = img->pixels + (size_t)(h - 1 - y) * row;
        size_t want = row * sizeof(float), done = 0;
        off_t off = (off_t)(pos + (size_t)y * want);
        while (done < want) {
            ssize_t r = pread(fd, (char *)dst + done, want - done, off + (off_t)done);
            if (r <= 0) {
                op_image_free(img);
                return op_error_set(err, r < 0 ? OP_ERR_IO : OP_ERR_FORMAT,
                                    "%s: cannot read PFM row %ld", path, y);
            }
            done += (size_t)r;
        }
        if (swap)
            for (size_t i = 0; i < row; i++)
                swap4(&dst[i]);
    }
    return OP_OK;
}

/* ---------------------------------------------------------------- reading */

op_status op_image_exr_attr(const char *path, const char *name, char *out, size_t n,
                            op_error *err)
{
    out[0] = '\0';
    int fd;
    uint64_t size;
    op_status st = op_file_open(path, &fd, &size, err);
    if (st != OP_OK)
        return st;
    exr_io io;
    exr_context_t ctx = NULL;
    exr_result_t rv = exr_open_read(path, fd, (int64_t)size, &io, &ctx);
    if (rv != EXR_ERR_SUCCESS) {
        st = op_error_set(err, OP_ERR_FORMAT, "%s: not a readable OpenEXR file: %s", path,
                          exr_msg(&io, rv));
    } else {
        int32_t len = 0;
        const char *v = NULL;
        if (exr_attr_get_string(ctx, 0, name, &len, &v) == EXR_ERR_SUCCESS && v && len > 0)
            snprintf(out, n, "%.*s", (int)len, v);
    }
    if (ctx)
        exr_finish(&ctx);
    close(fd);
    return st;
}

/* The format of an image file from its first bytes (n of them), or from its name's extension
 * for TGA, which has no signature: the OpenImageIO reader's name and the format's name for
 * messages; NULL for PNG, OpenEXR and PFM (read here) or an unknown file. */
static const char *oiio_format(const char *path, const unsigned char *m, size_t n,
                               const char **kind)
{
    static const struct {
        const char *magic;
        size_t len;
        const char *format, *kind;
    } signatures[] = {
        {"\xff\xd8\xff", 3, "jpeg", "JPEG"},
        {"II*\0", 4, "tiff", "TIFF"},
        {"MM\0*", 4, "tiff", "TIFF"},
        {"II+\0", 4, "tiff", "TIFF"}, /* BigTIFF */
        {"MM\0+", 4, "tiff", "TIFF"},
        {"#?", 2, "hdr", "Radiance HDR"},
        {"BM", 2, "bmp", "BMP"},
    };
    for (size_t i = 0; i < sizeof signatures / sizeof signatures[0]; i++)
        if (n >= signatures[i].len && memcmp(m, signatures[i].magic, signatures[i].len) == 0) {
            *kind = signatures[i].kind;
            return signatures[i].format;
        }
    if (n >= 3 && m[0] == 'P' && m[1] >= '1' && m[1] <= '6' &&
        (m[2] == '\n' || m[2] == ' ' || m[2] == '\r' || m[2] == '\t')) {
        *kind = "PNM";
        return "pnm";
    }
    const char *dot = strrchr(path, '.');
    if (dot && (strcasecmp(dot, ".tga") == 0 || strcasecmp(dot, ".targa") == 0)) {
        *kind = "TGA";
        return "targa";
    }
    return NULL;
}

/* The OpenImageIO module's entry point, loaded once (op_module_entry). */
static pthread_once_t oiio_once = PTHREAD_ONCE_INIT;
static op_image_oiio_read_fn oiio_read;
static char oiio_failure[1100];

static void oiio_load(void)
{
    void *entry = op_module_entry(OP_IMAGE_OIIO_MODULE, OPALINE_OIIO_MODULE_BUILT,
                                  OP_IMAGE_OIIO_ENTRY, oiio_failure, sizeof oiio_failure);
    if (entry)
        memcpy(&oiio_read, &entry, sizeof entry); /* POSIX: a function's address */
}

/* Reads path through the OpenImageIO module: op_image_oiio_read_fn (image_internal.h). */
static op_status read_oiio(const char *path, const char *format, const char *kind, int decode,
                           uint64_t max_pixels, int header_only, op_image *img, int *encoded,
                           op_error *err)
{
    static const op_image_host host = {op_error_set, op_image_alloc, op_image_free, srgb_decode,
                                       srgb_encode,  check_pixels};
    pthread_once(&oiio_once, oiio_load);
    if (!oiio_read)
        return op_error_set(err, OP_ERR_IO, "%s: cannot read %s images: opaline's image module "
                            "is missing (%s)", path, kind, oiio_failure);
    return oiio_read(&host, path, format, kind, decode, max_pixels, header_only, img, encoded,
                     err);
}

/* Reads any supported file (the layer named, for OpenEXR); integer ones are sRGB-decoded when
 * decode is set. With header_only, only img's size and channels are set (pixels NULL), from
 * the header, nothing decoded. */
static op_status read_any(const char *path, const char *layer, int decode, uint64_t max_pixels,
                          int header_only, op_image *img, int *encoded, op_error *err)
{
    memset(img, 0, sizeof *img);
    *encoded = 0;
    int fd;
    uint64_t size;
    op_status st = op_file_open(path, &fd, &size, err);
    if (st != OP_OK)
        return st;
    unsigned char magic[8] = {0};
    ssize_t got = pread(fd, magic, sizeof magic, 0);
    if (got < 0) {
        int e = errno;
        close(fd);
        return op_error_set(err, OP_ERR_IO, "%s: cannot read: %s", path, strerror(e));
    }
    static const unsigned char png_magic[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    static const unsigned char exr_magic[4] = {0x76, 0x2f, 0x31, 0x01};
    if (got >= 4 && memcmp(magic, exr_magic, 4) == 0) {
        const char *compression;
        st = read_exr(path, layer, fd, (int64_t)size, max_pixels, header_only, img, &compression,
                      err);
        close(fd);
        if (st != OP_OK || !compression)
            return st;
        /* OpenImageIO's OpenEXR reader (OpenEXR's C++ library) decodes every compression;
         * it reads the default layer */
        char kind[64];
        snprintf(kind, sizeof kind, "%s-compressed OpenEXR", compression);
        if (layer && *layer)
            return op_error_set(err, OP_ERR_INPUT, "%s: the layer \"%s\" of a %s file cannot be "
                                "read with this OpenEXR library (3.1.8 or later reads it)", path,
                                layer, kind);
        return read_oiio(path, "openexr", kind, decode, max_pixels, 0, img, encoded, err);
    }
    if (layer && *layer) {
        close(fd);
        return op_error_set(err, OP_ERR_INPUT, "%s: only OpenEXR images have layers (\"%s\")",
                            path, layer);
    }
    const char *kind = NULL, *format = oiio_format(path, magic, (size_t)got, &kind);
    if (format) {
        close(fd); /* OpenImageIO opens the file itself */
        return read_oiio(path, format, kind, decode, max_pixels, header_only, img, encoded, err);
    }
    if (got >= 8 && memcmp(magic, png_magic, 8) == 0) {
        FILE *f = fdopen(fd, "rb"); /* at offset 0: pread does not move it */
        if (!f) {
            close(fd);
            return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
        }
        st = read_png(path, f, decode, max_pixels, header_only, img, err);
        *encoded = 1;
        fclose(f);
        return st;
    }
    if (got >= 3 && magic[0] == 'P' && (magic[1] == 'F' || magic[1] == 'f') &&
        (magic[2] == '\n' || magic[2] == ' ' || magic[2] == '\r'))
        st = read_pfm(path, fd, (int64_t)size, max_pixels, header_only, img, err);
    else
        st = op_error_set(err, OP_ERR_FORMAT, "%s: not an OpenEXR, PNG or PFM image, nor JPEG, "
                          "TIFF, Radiance HDR, BMP, PNM or TGA (named .tga)", path);
    close(fd);
    return st;
}

op_status op_image_read(const char *path, op_image *img, op_error *err)
{
    int encoded;
    return read_any(path, NULL, 1, OP_IMAGE_DEFAULT_MAX_PIXELS, 0, img, &encoded, err);
}

op_status op_image_read_stored(const char *path, op_image *img, int *encoded, op_error *err)
{
    return read_any(path, NULL, 0, OP_IMAGE_DEFAULT_MAX_PIXELS, 0, img, encoded, err);
}

op_status op_image_read_limited(const char *path, int decode, uint64_t max_pixels, op_image *img,
                                int *encoded, op_error *err)
{
    return op_image_read_layer(path, NULL, decode, max_pixels, img, encoded, err);
}

op_status op_image_read_layer(const char *path, const char *layer, int decode,
                              uint64_t max_pixels, op_image *img, int *encoded, op_error *err)
{
    int ignored;
    return read_any(path, layer, decode, max_pixels, 0, img, encoded ? encoded : &ignored, err);
}

op_status op_image_read_size(const char *path, int *width, int *height, int *channels,
                             op_error *err)
{
    op_image img;
    int encoded;
    op_status st = read_any(path, NULL, 1, UINT64_MAX, 1, &img, &encoded, err);
    *width = st ? 0 : img.width;
    *height = st ? 0 : img.height;
    *channels = st ? 0 : img.channels;
    return st;
}
