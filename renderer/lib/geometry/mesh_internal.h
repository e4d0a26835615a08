/* mesh_internal.h - what the mesh loaders share. Each reads its file through op_file_map. */
#ifndef OP_MESH_INTERNAL_H
#define OP_MESH_INTERNAL_H

#include <stddef.h>

#include "geometry/mesh.h"

/* Largest vertex or triangle count a loader accepts (indices stay within int32). */
#define OP_MESH_MAX_COUNT 0x7fffffffu

#endif
