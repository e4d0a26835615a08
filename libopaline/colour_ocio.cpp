/* colour_ocio.cpp - the module opaline-ocio.so: view transforms through OpenColorIO's processor
 * (op_colour_ocio_apply_fn in colour_internal.h), built as Blender builds its display processor
 * for a render it saves. It calls libopaline only through the op_colour_host it is given. Only
 * API that OpenColorIO 2.1 to 2.4 share is used. No exception leaves this file. */
#include "colour_internal.h"

#include <OpenColorIO/OpenColorIO.h>

#include <cmath>
#include <cstring>
#include <mutex>
#include <new>
#include <string>
#include <type_traits>

namespace OCIO = OCIO_NAMESPACE;

namespace
{

bool named(const char *s)
{
    return s && s[0] && std::strcmp(s, "None") != 0;
}

/* The names a config has, quoted and joined, for a message. */
template <typename Count, typename Name> std::string names(Count count, Name name)
{
    std::string all;
    for (int i = 0; i < count(); i++)
        all += std::string(all.empty() ? "\"" : ", \"") + name(i) + "\"";
    return all.empty() ? "none" : all;
}

/* vt's processor from config: 2^exposure in the scene-linear role, the look (from the
 * scene-linear role to its result space, the view's own looks then bypassed), the display's
 * view, then the exponent 1 / gamma. NULL with err set when config lacks a name. */
OCIO::ConstProcessorRcPtr processor(const op_colour_host *host,
                                    const OCIO::ConstConfigRcPtr &config,
                                    const op_view_transform *vt, op_error *err)
{
    const char *display = named(vt->display) ? vt->display : config->getDefaultDisplay();
    bool known = false;
    for (int i = 0; i < config->getNumDisplays() && !known; i++)
        known = std::strcmp(config->getDisplay(i), display) == 0;
    if (!known) {
        host->error_set(err, OP_ERR_INPUT, "%s: no display \"%s\" (it has %s)", vt->config,
                        display, names([&] { return config->getNumDisplays(); },
                                       [&](int i) { return config->getDisplay(i); }).c_str());
        return nullptr;
    }
    known = false;
    for (int i = 0; i < config->getNumViews(display) && !known; i++)
        known = std::strcmp(config->getView(display, i), vt->view) == 0;
    if (!known) {
        host->error_set(err, OP_ERR_INPUT, "%s: display \"%s\" has no view \"%s\" (it has %s)",
                        vt->config, display, vt->view,
                        names([&] { return config->getNumViews(display); },
                              [&](int i) { return config->getView(display, i); }).c_str());
        return nullptr;
    }
    if (named(vt->look) && !config->getLook(vt->look)) {
        host->error_set(err, OP_ERR_INPUT, "%s: no look \"%s\" (it has %s)", vt->config, vt->look,
                        names([&] { return config->getNumLooks(); },
                              [&](int i) { return config->getLookNameByIndex(i); }).c_str());
        return nullptr;
    }

    OCIO::GroupTransformRcPtr group = OCIO::GroupTransform::Create();
    std::string input = OCIO::ROLE_SCENE_LINEAR;
    if (vt->exposure != 0.0) {
        double s = std::exp2(vt->exposure);
        const double m44[16] = {s, 0, 0, 0, 0, s, 0, 0, 0, 0, s, 0, 0, 0, 0, 1};
        OCIO::MatrixTransformRcPtr scale = OCIO::MatrixTransform::Create();
        scale->setMatrix(m44);
        group->appendTransform(scale);
    }
    bool look = false;
    if (named(vt->look)) {
        const char *result = OCIO::LookTransform::GetLooksResultColorSpace(
            config, config->getCurrentContext(), vt->look);
        if (result && result[0]) { /* an empty look has none, and is skipped */
            OCIO::LookTransformRcPtr lt = OCIO::LookTransform::Create();
            lt->setSrc(input.c_str());
            lt->setDst(result);
            lt->setLooks(vt->look);
            group->appendTransform(lt);
            input = result;
            look = true;
        }
    }
    OCIO::DisplayViewTransformRcPtr dv = OCIO::DisplayViewTransform::Create();
    dv->setSrc(input.c_str());
    dv->setLooksBypass(look);
    dv->setDisplay(display);
    dv->setView(vt->view);
    group->appendTransform(dv);
    if (vt->gamma != 1.0) {
        double e = 1.0 / vt->gamma;
        const double value[4] = {e, e, e, 1.0};
        OCIO::ExponentTransformRcPtr et = OCIO::ExponentTransform::Create();
        et->setValue(value);
        group->appendTransform(et);
    }
    return config->getProcessor(group);
}

op_status apply(const op_colour_host *host, const op_view_transform *vt, float *rgba, size_t n,
                op_error *err)
{
    OCIO::ConstConfigRcPtr config = OCIO::Config::CreateFromFile(vt->config);
    OCIO::ConstProcessorRcPtr proc = processor(host, config, vt, err);
    if (!proc)
        return OP_ERR_INPUT;
    OCIO::ConstCPUProcessorRcPtr cpu = proc->getDefaultCPUProcessor();
    if (!rgba)
        return OP_OK;
    /* premultiplied colour is divided by alpha in (0, 1) before, multiplied after */
    for (size_t i = 0; i < n; i++) {
        float *p = rgba + 4 * i, a = p[3];
        if (a > 0.0f && a < 1.0f)
            p[0] /= a, p[1] /= a, p[2] /= a;
    }
    const size_t row = (size_t)1 << 20; /* PackedImageDesc's sizes are long: rows of pixels */
    for (size_t at = 0; at < n; at += row) {
        long count = (long)(n - at < row ? n - at : row);
        OCIO::PackedImageDesc desc(rgba + 4 * at, count, 1, 4);
        cpu->apply(desc);
    }
    for (size_t i = 0; i < n; i++) {
        float *p = rgba + 4 * i, a = p[3];
        if (a > 0.0f && a < 1.0f)
            p[0] *= a, p[1] *= a, p[2] *= a;
    }
    return OP_OK;
}

} // namespace

/* The module's one exported symbol, OP_COLOUR_OCIO_ENTRY. */
extern "C" __attribute__((visibility("default"))) op_status
op_colour_ocio_apply(const op_colour_host *host, const op_view_transform *vt, float *rgba,
                     size_t n, op_error *err);

op_status op_colour_ocio_apply(const op_colour_host *host, const op_view_transform *vt,
                               float *rgba, size_t n, op_error *err)
{
    static_assert(std::is_same<decltype(&op_colour_ocio_apply), op_colour_ocio_apply_fn>::value,
                  "the entry point is what colour.c calls");
    /* OpenColorIO's messages would go to stderr beside opaline's log: errors come back as
     * exceptions, which are reported */
    static std::once_flag once;
    std::call_once(once, [] { OCIO::SetLoggingLevel(OCIO::LOGGING_LEVEL_NONE); });
    try {
        return apply(host, vt, rgba, n, err);
    } catch (const std::bad_alloc &) {
        return host->error_set(err, OP_ERR_NOMEM, "view transform: out of memory");
    } catch (const std::exception &e) {
        return host->error_set(err, OP_ERR_INPUT, "%s: OpenColorIO: %s", vt->config, e.what());
    } catch (...) {
        return host->error_set(err, OP_ERR_INPUT, "%s: OpenColorIO failed", vt->config);
    }
}
