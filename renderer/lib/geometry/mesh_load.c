/* mesh_load.c - a mesh file of any format, the loader chosen by the file name's extension
 * (see mesh.h). Apart from mesh.c so that the loaders, which use mesh.c, are not also used by it. */
#include "geometry/mesh.h"

#include <ctype.h>
#include <string.h>

op_status op_mesh_load(const char *path, op_mesh *out, op_error *err)
{
    memset(out, 0, sizeof *out);
    const char *dot = strrchr(path, '.');
    char ext[16] = {0};
    if (dot && strlen(dot + 1) < sizeof ext)
        for (size_t i = 0; dot[1 + i]; i++)
            ext[i] = (char)tolower((unsigned char)dot[1 + i]);
    if (strcmp(ext, "obj") == 0)
        return op_mesh_load_obj(path, out, err);
    if (strcmp(ext, "ply") == 0)
        return op_mesh_load_ply(path, out, err);
    if (strcmp(ext, "serialized") == 0)
        return op_mesh_load_serialized(path, 0, out, err);
    return op_error_set(err, OP_ERR_INPUT, "%s: unknown mesh format (expected .obj, .ply or "
                        ".serialized)", path);
}
