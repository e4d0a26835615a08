/* module.c - finding libopaline's loadable modules (module_internal.h). */
#include "module_internal.h"

#include <dlfcn.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

void *op_module_entry(const char *file, const char *built, const char *entry, char *failure,
                      size_t n)
{
    char exe[4096], tried[2][4200];
    ssize_t len = readlink("/proc/self/exe", exe, sizeof exe - 1);
    exe[len > 0 ? len : 0] = '\0';
    char *slash = strrchr(exe, '/');
    if (slash)
        *slash = '\0';
    snprintf(tried[0], sizeof tried[0], "%s/../lib/opaline/%s", exe, file);
    snprintf(tried[1], sizeof tried[1], "%s", built);
    failure[0] = '\0';
    for (int i = 0; i < 2; i++) {
        if (access(tried[i], F_OK) != 0)
            continue;
        void *module = dlopen(tried[i], RTLD_NOW | RTLD_LOCAL);
        void *fn = module ? dlsym(module, entry) : NULL;
        if (fn)
            return fn;
        snprintf(failure, n, "%.1000s", dlerror());
    }
    if (!failure[0])
        snprintf(failure, n, "neither %.500s nor %.500s exists", tried[0], tried[1]);
    return NULL;
}
