/* image_samples.cpp - test images written through OpenImageIO: see image_samples.h. */
#include "image_samples.h"

#include <OpenImageIO/imageio.h>

#include <cstdio>
#include <string>

extern "C" int op_test_write_image(const char *path, int w, int h, int channels, const char *type,
                                   const float *pixels, const char *const *names)
{
    auto out = OIIO::ImageOutput::create(path);
    if (!out) {
        std::fprintf(stderr, "%s: %s\n", path, OIIO::geterror().c_str());
        return -1;
    }
    OIIO::ImageSpec spec(w, h, channels, OIIO::TypeDesc(type));
    if (names)
        for (int k = 0; k < channels; k++)
            spec.channelnames[(size_t)k] = names[k];
    spec.alpha_channel = channels == 2 ? 1 : channels == 4 ? 3 : -1;
    spec.attribute("oiio:UnassociatedAlpha", 1); /* alpha written as given */
    spec.attribute("Compression", "none");       /* TGA, TIFF: what the fuzzer mutates best */
    spec.attribute("oiio:BitsPerSample", (int)spec.format.size() * 8); /* PNM: 16 bits too */
    bool ok =
        out->open(path, spec) && out->write_image(OIIO::TypeDesc::FLOAT, pixels) && out->close();
    if (!ok) {
        std::fprintf(stderr, "%s: %s\n", path, out->geterror().c_str());
        return -1;
    }
    return 0;
}
