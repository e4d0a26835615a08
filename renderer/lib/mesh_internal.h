/* mesh_internal.h - what the mesh loaders share: a read-only view of a whole file. */
#ifndef OP_MESH_INTERNAL_H
#define OP_MESH_INTERNAL_H

#include <stddef.h>

#include "mesh.h"

typedef struct op_mapped_file {
    const char *data; /* size bytes, not NUL-terminated; NULL when size is 0 */
    size_t size;
} op_mapped_file;

/* Maps path read-only (OP_ERR_IO naming the path when it cannot be opened or read). */
op_status op_map_file(const char *path, op_mapped_file *f, op_error *err);
void op_unmap_file(op_mapped_file *f);

/* Largest vertex or triangle count a loader accepts (indices stay within int32). */
#define OP_MESH_MAX_COUNT 0x7fffffffu

#endif
