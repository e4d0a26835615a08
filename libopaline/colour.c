/* colour.c - view transforms (opaline_image.h), through the OpenColorIO module loaded on first
 * use (colour_ocio.cpp). */
#include "opaline.h"
#include "opaline_image.h"
#include "colour_internal.h"
#include "module_internal.h"

#include <pthread.h>
#include <stdlib.h>
#include <string.h>

static pthread_once_t ocio_once = PTHREAD_ONCE_INIT;
static op_colour_ocio_apply_fn ocio_apply;
static char ocio_failure[1100];

static void ocio_load(void)
{
    void *entry = op_module_entry(OP_COLOUR_OCIO_MODULE, OPALINE_OCIO_MODULE_BUILT,
                                  OP_COLOUR_OCIO_ENTRY, ocio_failure, sizeof ocio_failure);
    if (entry)
        memcpy(&ocio_apply, &entry, sizeof entry); /* POSIX: a function's address */
}

/* vt through the module, on the n RGBA pixels of rgba (NULL: a check). */
static op_status run(const op_view_transform *vt, float *rgba, size_t n, op_error *err)
{
    static const op_colour_host host = {op_error_set};
    if (!vt->config || !vt->config[0] || !vt->view || !vt->view[0])
        return op_error_set(err, OP_ERR_INPUT, "view transform: no OpenColorIO config or view "
                            "named");
    if (!(vt->gamma > 0.0) || !(vt->exposure > -64.0 && vt->exposure < 64.0))
        return op_error_set(err, OP_ERR_INPUT, "view transform: gamma %g must be > 0 and "
                            "exposure %g in (-64, 64)", vt->gamma, vt->exposure);
    pthread_once(&ocio_once, ocio_load);
    if (!ocio_apply)
        return op_error_set(err, OP_ERR_INPUT, "view transform \"%s\": opaline's OpenColorIO "
                            "module is missing (%s)", vt->view, ocio_failure);
    return ocio_apply(&host, vt, rgba, n, err);
}

op_status op_view_transform_check(const op_view_transform *vt, op_error *err)
{
    return run(vt, NULL, 0, err);
}

op_status op_view_transform_apply(const op_view_transform *vt, op_image *img, op_error *err)
{
    if (img->channels == 4)
        return run(vt, img->pixels, (size_t)img->width * (size_t)img->height, err);
    if (img->channels != 3)
        return op_error_set(err, OP_ERR_INPUT, "view transform: an image of %d channels is not "
                            "colour", img->channels);
    size_t n = (size_t)img->width * (size_t)img->height;
    float *rgba = malloc(n * 4 * sizeof *rgba);
    if (!rgba)
        return op_error_set(err, OP_ERR_NOMEM, "view transform: out of memory");
    for (size_t i = 0; i < n; i++) {
        memcpy(rgba + 4 * i, img->pixels + 3 * i, 3 * sizeof *rgba);
        rgba[4 * i + 3] = 1.0f;
    }
    op_status st = run(vt, rgba, n, err);
    for (size_t i = 0; !st && i < n; i++)
        memcpy(img->pixels + 3 * i, rgba + 4 * i, 3 * sizeof *rgba);
    free(rgba);
    return st;
}
