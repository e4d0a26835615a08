/* image_oiio.cpp - the module opaline-oiio.so: the image formats read through OpenImageIO
 * (JPEG, TIFF, Radiance HDR, BMP, PNM, TGA, and OpenEXR files of a compression the OpenEXR C
 * library that image.c uses cannot decode), the channels a renderer uses, as
 * op_image floats (op_image_oiio_read_fn in image_internal.h). It calls libopaline only
 * through the op_image_host it is given. Only API that OpenImageIO 2.4 to 3.x share is used.
 * No exception leaves this file. */
#include "image_internal.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <memory>
#include <new>
#include <string>
#include <strings.h>
#include <type_traits>
#include <vector>

namespace
{

/* Error messages OpenImageIO holds for in (NULL: none) and for the thread, taken (so that none
 * is left pending, which some versions print at exit), joined, "unknown error" when empty. */
std::string take_errors(const OIIO::ImageInput *in)
{
    std::string msg = in ? in->geterror() : std::string();
    std::string global = OIIO::geterror();
    if (!global.empty())
        msg += (msg.empty() ? "" : "; ") + global;
    while (!msg.empty() && (msg.back() == '\n' || msg.back() == ' '))
        msg.pop_back();
    for (char &ch : msg)
        if (ch == '\n')
            ch = ' ';
    return msg.empty() ? "unknown error" : msg;
}

/* Which channels of spec make the image: idx[k] for the op_image channel k of *c (1, 3 or 4;
 * grey with alpha becomes RGBA with the grey repeated), by position and the alpha channel. */
bool pick_channels(const OIIO::ImageSpec &spec, int idx[4], int *c)
{
    int n = spec.nchannels, a = spec.alpha_channel;
    bool named_a = n >= 4 && spec.channelnames.size() > 3 && spec.channelnames[3] == "A";
    if (n == 1 || n == 2) {
        idx[0] = idx[1] = idx[2] = 0, idx[3] = n == 2 ? 1 : -1;
        *c = n == 2 ? 4 : 1;
    } else if (n >= 3) {
        idx[0] = 0, idx[1] = 1, idx[2] = 2, idx[3] = a >= 3 ? a : (named_a ? 3 : -1);
        *c = idx[3] >= 0 ? 4 : 3;
    } else {
        return false;
    }
    return true;
}

bool is_integer(OIIO::TypeDesc t)
{
    return t.basetype != OIIO::TypeDesc::FLOAT && t.basetype != OIIO::TypeDesc::HALF &&
           t.basetype != OIIO::TypeDesc::DOUBLE;
}

/* The transfer curve of integer pixels: 0 sRGB, 1 linear, else a gamma exponent. */
float transfer_gamma(const OIIO::ImageSpec &spec)
{
    std::string cs(spec.get_string_attribute("oiio:ColorSpace"));
    if (cs.size() >= 3 && strncasecmp(cs.c_str(), "lin", 3) == 0)
        return 1.0f;
    float g = spec.get_float_attribute("oiio:Gamma", 0.0f);
    if (!(g > 0.0f) || !std::isfinite(g) || std::fabs(g - 2.2f) <= 0.05f)
        return 0.0f; /* none declared, or sRGB's, as libpng counts it */
    return std::fabs(g - 1.0f) <= 0.01f ? 1.0f : g;
}

struct reader {
    const op_image_host *host;
    const char *path, *kind;
    op_error *err;

    op_status fail(op_status st, const char *what, const OIIO::ImageInput *in)
    {
        return host->error_set(err, st, "%s: %s %s: %s", path, what, kind, take_errors(in).c_str());
    }

    op_status read(const char *format, int decode, uint64_t max_pixels, int header_only,
                   op_image *img, int *encoded);
};

op_status reader::read(const char *format, int decode, uint64_t max_pixels, int header_only,
                       op_image *img, int *encoded)
{
    auto in = OIIO::ImageInput::create(format);
    if (!in)
        return fail(OP_ERR_INTERNAL, "OpenImageIO has no reader for", nullptr);
    in->threads(1); /* the renderer's threads are its own */
    OIIO::ImageSpec config, first;
    config.attribute("oiio:UnassociatedAlpha", 1); /* alpha as stored, never premultiplied */
    if (!in->open(path, first, config))
        return fail(OP_ERR_FORMAT, "not a readable", in.get());
    const int sub = 0; /* the first image (TIFF page) */
    int idx[4] = {-1, -1, -1, -1}, c = 0;
    if (!pick_channels(in->spec(), idx, &c)) {
        take_errors(in.get());
        return host->error_set(err, OP_ERR_FORMAT, "%s: %s image has no channels", path, kind);
    }
    OIIO::ImageSpec spec = in->spec();
    if (spec.deep || spec.depth > 1) {
        take_errors(in.get());
        return host->error_set(err, OP_ERR_FORMAT, "%s: %s %s images are not supported", path,
                               spec.deep ? "deep" : "volume", kind);
    }
    if (spec.width <= 0 || spec.height <= 0 || spec.width > OP_IMAGE_MAX_SIDE ||
        spec.height > OP_IMAGE_MAX_SIDE) {
        take_errors(in.get());
        return host->error_set(err, OP_ERR_FORMAT, "%s: %s size %dx%d is not supported", path, kind,
                               spec.width, spec.height);
    }
    op_status st = host->check_pixels(path, kind, (uint64_t)spec.width, (uint64_t)spec.height,
                                      max_pixels, err);
    if (st != OP_OK) {
        take_errors(in.get());
        return st;
    }
    bool integer = true;
    for (int k = 0; k < c; k++)
        integer = integer && is_integer(spec.channelformat(idx[k]));
    *encoded = integer;
    if (header_only) {
        take_errors(in.get());
        *img = op_image{spec.width, spec.height, c, nullptr};
        return OP_OK;
    }
    if ((st = host->alloc(img, spec.width, spec.height, c, err)) != OP_OK) {
        take_errors(in.get());
        return st;
    }

    /* Integer colour is decoded to linear light, or (decode unset) re-encoded as sRGB when
     * the file declares another curve; alpha and float pixels stay as stored. */
    float gamma = transfer_gamma(spec);
    auto colour = [&](float v) {
        if (!integer || (gamma == 0.0f && !decode))
            return v;
        float lin = gamma == 0.0f ? host->srgb_decode(v) : gamma == 1.0f ? v : std::pow(v, gamma);
        return decode ? lin : host->srgb_encode(lin);
    };
    /* 8- and 16-bit pixels are read as such into scratch (a quarter or half of the image's
     * floats), over the channel range covering the wanted ones, or channel by channel when that
     * range is wide; others straight into the image as floats, channel by channel unless the
     * wanted ones are in order. */
    int bits = 32;
    if (integer) {
        bits = 8;
        for (int k = 0; k < c; k++)
            bits = std::max(bits, (int)spec.channelformat(idx[k]).size() * 8);
    }
    size_t n = (size_t)spec.width * (size_t)spec.height;
    if (bits > 16) {
        bool in_order = true;
        for (int k = 1; k < c; k++)
            in_order = in_order && idx[k] == idx[0] + k;
        OIIO::stride_t xs = (OIIO::stride_t)(c * sizeof(float)), ys = xs * spec.width;
        for (int k = 0; k < (in_order ? 1 : c); k++) {
            bool ok = k > 0 && idx[k] == idx[k - 1];
            if (ok) /* grey repeated */
                for (size_t i = 0; i < n; i++)
                    img->pixels[i * (size_t)c + (size_t)k] =
                        img->pixels[i * (size_t)c + (size_t)k - 1];
            else
                ok = in->read_image(sub, 0, idx[k], in_order ? idx[k] + c : idx[k] + 1,
                                    OIIO::TypeDesc::FLOAT, img->pixels + k, xs, ys);
            if (!ok) {
                host->free(img);
                return fail(OP_ERR_FORMAT, "corrupt", in.get());
            }
        }
        if (integer)
            for (size_t i = 0; i < n * (size_t)c; i++)
                if (!(c == 4 && i % 4 == 3))
                    img->pixels[i] = colour(img->pixels[i]);
    } else {
        int lo = idx[0], hi = idx[0];
        for (int k = 1; k < c; k++)
            lo = std::min(lo, idx[k]), hi = std::max(hi, idx[k]);
        int span = hi - lo + 1 <= 4 ? hi - lo + 1 : 1;
        bool bytes = bits == 8;
        OIIO::TypeDesc type = bytes ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::UINT16;
        std::vector<unsigned char> buf8(bytes ? n * (size_t)span : 0);
        std::vector<uint16_t> buf16(bytes ? 0 : n * (size_t)span);
        void *buf = bytes ? (void *)buf8.data() : (void *)buf16.data();
        float table[2][256]; /* bytes: [0] colour, [1] alpha */
        for (int i = 0; i < 256; i++)
            table[0][i] = colour((float)i / 255.0f), table[1][i] = (float)i / 255.0f;
        for (int pass = 0; pass < (span == 1 ? c : 1); pass++) {
            int first_ch = span == 1 ? idx[pass] : lo;
            if (span == 1 && pass > 0 && idx[pass] == idx[pass - 1]) {
                for (size_t i = 0; i < n; i++)
                    img->pixels[i * (size_t)c + (size_t)pass] =
                        img->pixels[i * (size_t)c + (size_t)pass - 1];
                continue;
            }
            if (!in->read_image(sub, 0, first_ch, first_ch + span, type, buf)) {
                host->free(img);
                return fail(OP_ERR_FORMAT, "corrupt", in.get());
            }
            for (int k = 0; k < c; k++) {
                if (span == 1 && k != pass)
                    continue;
                size_t off = (size_t)(idx[k] - first_ch);
                bool alpha = k == 3;
                for (size_t i = 0; i < n; i++) {
                    size_t at = i * (size_t)span + off;
                    float v;
                    if (bytes) {
                        v = table[alpha][buf8[at]];
                    } else {
                        v = (float)buf16[at] / 65535.0f;
                        v = alpha ? v : colour(v);
                    }
                    img->pixels[i * (size_t)c + (size_t)k] = v;
                }
            }
        }
    }
    /* A decoder's warnings (a JPEG cut short and filled with grey) fail the image too. */
    if (in->has_error()) {
        host->free(img);
        return fail(OP_ERR_FORMAT, "corrupt", in.get());
    }
    take_errors(in.get());
    return OP_OK;
}

} // namespace

/* The module's one exported symbol, OP_IMAGE_OIIO_ENTRY. */
extern "C" __attribute__((visibility("default"))) op_status
op_image_oiio_read(const op_image_host *host, const char *path, const char *format,
                   const char *kind, int decode, uint64_t max_pixels, int header_only,
                   op_image *img, int *encoded, op_error *err);

op_status op_image_oiio_read(const op_image_host *host, const char *path, const char *format,
                             const char *kind, int decode, uint64_t max_pixels, int header_only,
                             op_image *img, int *encoded, op_error *err)
{
    static_assert(std::is_same<decltype(&op_image_oiio_read), op_image_oiio_read_fn>::value,
                  "the entry point is what image.c calls");
    std::memset(img, 0, sizeof *img);
    *encoded = 0;
    /* no thread pool of OpenImageIO's own: the renderer's threads are its own, and a pool's
     * idle threads outlive the read (LeakSanitizer's exit-time scan crashed on them) */
    static std::once_flag once;
    std::call_once(once, [] { OIIO::attribute("threads", 1); });
    reader r{host, path, kind, err};
    try {
        return r.read(format, decode, max_pixels, header_only, img, encoded);
    } catch (const std::bad_alloc &) {
        host->free(img);
        return host->error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    } catch (const std::exception &e) {
        host->free(img);
        return host->error_set(err, OP_ERR_FORMAT, "%s: unreadable %s image: %s", path, kind,
                               e.what());
    } catch (...) {
        host->free(img);
        return host->error_set(err, OP_ERR_FORMAT, "%s: unreadable %s image", path, kind);
    }
}
