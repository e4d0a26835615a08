/* module_internal.h - finding libopaline's loadable C++ modules (opaline-oiio.so,
 * opaline-ocio.so); private to this folder. */
#ifndef OPALINE_MODULE_INTERNAL_H
#define OPALINE_MODULE_INTERNAL_H

#include <stddef.h>

/* The address of the function entry of the module file, loaded from <program's folder>/../lib/
 * opaline/ (the installed layout, and the build tree's bin/), else from built (where this build
 * put it); NULL with why in failure (n bytes) when neither loads. */
void *op_module_entry(const char *file, const char *built, const char *entry, char *failure,
                      size_t n);

#endif
