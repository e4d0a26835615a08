/* scene_path.c - file names of a scene (see scene_path.h). */
#include "scene/scene_path.h"

#include <stdlib.h>
#include <string.h>

void op_path_join(char *out, size_t n, const char *dir, const char *name)
{
    size_t k = 0;
    const char *parts[3] = {NULL, NULL, name};
    if (name[0] != '/' && dir && dir[0]) {
        parts[0] = dir;
        parts[1] = "/";
    }
    for (int p = 0; p < 3; p++)
        for (const char *c = parts[p]; c && *c && k + 1 < n; c++)
            out[k++] = *c;
    out[k] = '\0';
}

char *op_path_beside(const char *file, const char *rel)
{
    const char *slash = file ? strrchr(file, '/') : NULL;
    if (rel[0] == '/' || !slash)
        return strdup(rel);
    size_t dl = (size_t)(slash - file) + 1, rl = strlen(rel);
    char *out = malloc(dl + rl + 1);
    if (!out)
        return NULL;
    memcpy(out, file, dl);
    memcpy(out + dl, rel, rl + 1);
    return out;
}
