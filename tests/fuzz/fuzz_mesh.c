/* fuzz_mesh.c - the OBJ and PLY loaders (PLY when the input starts with "ply", else OBJ) on
 * arbitrary bytes; a mesh they accept has finite data, every index in range, and survives the
 * scene builder's normal computation. */
#include "fuzz_support.h"

#include "geometry/mesh.h"

#include <math.h>
#include <string.h>

static void require_finite(const float *v, size_t n)
{
    for (size_t i = 0; v && i < n; i++)
        op_fuzz_require(isfinite(v[i]), "mesh holds a NaN or infinite value");
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    int ply = size >= 3 && memcmp(data, "ply", 3) == 0;
    op_mesh m;
    op_error err;
    if (op_mesh_load(op_fuzz_file(data, size, ply ? ".ply" : ".obj"), &m, &err) != OP_OK)
        return 0;
    require_finite(m.positions, 3 * (size_t)m.nverts);
    require_finite(m.normals, 3 * (size_t)m.nverts);
    require_finite(m.uvs, 2 * (size_t)m.nverts);
    for (size_t i = 0; i < 3 * (size_t)m.ntris; i++)
        op_fuzz_require(m.indices[i] < m.nverts, "triangle index out of range");
    op_mesh_drop_normals(&m);
    if (op_mesh_compute_normals(&m, &err) == OP_OK)
        require_finite(m.normals, 3 * (size_t)m.nverts);
    op_mesh_free(&m);
    return 0;
}
