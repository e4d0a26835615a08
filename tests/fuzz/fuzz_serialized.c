/* fuzz_serialized.c - the Mitsuba serialized mesh reader on arbitrary bytes, for the first
 * two shape indices: a mesh it accepts has finite data and every index in range, and its
 * counts are those the header-only reader (the scene description's) gives. An input that
 * starts with "Z3" or "Z4" is a mesh's uncompressed stream instead: it is compressed behind a
 * header of that version, twice, with a dictionary, so that mutations reach the parsing of
 * the stream rather than stopping at zlib's checks. */
#include "fuzz_support.h"

#include "geometry/mesh.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

static void require_finite(const float *v, size_t n)
{
    for (size_t i = 0; v && i < n; i++)
        op_fuzz_require(isfinite(v[i]), "mesh holds a NaN or infinite value");
}

static void put_le(unsigned char *p, uint64_t v, int size)
{
    for (int i = 0; i < size; i++)
        p[i] = (unsigned char)(v >> (8 * i));
}

/* The file of two meshes whose stream is body, compressed; NULL when out of memory. */
static unsigned char *wrap(const uint8_t *body, size_t n, int version, size_t *size)
{
    uLongf zn = compressBound(n);
    size_t entry = version == 4 ? 8 : 4, mesh = 4 + zn;
    unsigned char *f = malloc(2 * mesh + 2 * entry + 4);
    if (!f || compress2(f + 4, &zn, body, n, 1) != Z_OK) {
        free(f);
        return NULL;
    }
    mesh = 4 + zn;
    put_le(f, 0x041C, 2);
    put_le(f + 2, (uint64_t)version, 2);
    memcpy(f + mesh, f, mesh);
    put_le(f + 2 * mesh, 0, (int)entry);
    put_le(f + 2 * mesh + entry, mesh, (int)entry);
    put_le(f + 2 * mesh + 2 * entry, 2, 4);
    *size = 2 * mesh + 2 * entry + 4;
    return f;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    unsigned char *wrapped = NULL;
    if (size >= 2 && data[0] == 'Z' && (data[1] == '3' || data[1] == '4')) {
        wrapped = wrap(data + 2, size - 2, data[1] - '0', &size);
        if (!wrapped)
            return 0;
        data = wrapped;
    }
    const char *path = op_fuzz_file(data, size, ".serialized");
    free(wrapped);
    for (uint32_t index = 0; index < 2; index++) {
        op_mesh m;
        op_error err;
        uint64_t nverts, ntris;
        int counted = op_mesh_serialized_counts(path, index, &nverts, &ntris, &err) == OP_OK;
        if (op_mesh_load_serialized(path, index, &m, &err) != OP_OK)
            continue;
        op_fuzz_require(counted && nverts == m.nverts && ntris == m.ntris,
                        "the header-only counts differ from the loaded mesh's");
        require_finite(m.positions, 3 * (size_t)m.nverts);
        require_finite(m.normals, 3 * (size_t)m.nverts);
        require_finite(m.uvs, 2 * (size_t)m.nverts);
        for (size_t i = 0; i < 3 * (size_t)m.ntris; i++)
            op_fuzz_require(m.indices[i] < m.nverts, "triangle index out of range");
        op_mesh_free(&m);
    }
    return 0;
}
