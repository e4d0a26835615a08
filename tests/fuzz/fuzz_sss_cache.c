/* fuzz_sss_cache.c - the subsurface pre-pass cache reader (op_sss_store_load) on arbitrary
 * bytes. An input starting with the cache's magic is read as a whole file, under the key its
 * header holds (so a real cache's body is parsed, and a damaged one must be refused, never
 * crash). Any other input is a body: its first byte gives the shape count (0..3) and a valid
 * header with matching checksums is put around the rest, so that the body parser itself is
 * fuzzed. A cache that loads must hold only known flags, and must save and load back equal. */
#include "fuzz_support.h"

#include "sss/cache_file.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <xxhash.h>

static void put_u64(unsigned char *p, uint64_t v)
{
    for (int i = 0; i < 8; i++)
        p[i] = (unsigned char)(v >> (8 * i));
}

static void require_equal(const op_sss_store *a, const op_sss_store *b)
{
    op_fuzz_require(a->nshapes == b->nshapes, "shape count changed by a save and load");
    for (int s = 0; s < a->nshapes; s++) {
        const op_sss_saved *x = &a->shapes[s], *y = &b->shapes[s];
        op_fuzz_require(x->n == y->n, "point count changed by a save and load");
        if (x->n == 0)
            continue;
        op_fuzz_require(memcmp(x->has, y->has, (size_t)x->n) == 0, "flags changed");
        for (int i = 0; i < x->n; i++) {
            op_fuzz_require(!(x->has[i] & ~(OP_SSS_HAS_E | OP_SSS_HAS_M)), "unknown flag");
            if (x->has[i] & OP_SSS_HAS_E)
                op_fuzz_require(memcmp(x->e + 3 * i, y->e + 3 * i, 12) == 0, "E changed");
            if (x->has[i] & OP_SSS_HAS_M)
                op_fuzz_require(memcmp(x->m + 3 * i, y->m + 3 * i, 12) == 0, "M changed");
        }
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    unsigned char key[OP_SSS_KEY_BYTES] = {0};
    int nshapes;
    const char *path;
    if (size >= 8 && memcmp(data, "OPLNSSSC", 8) == 0) {
        if (size >= 32)
            memcpy(key, data + 16, sizeof key);
        nshapes = size >= 16 ? (int)(data[12] | data[13] << 8) : 1;
        if (nshapes > 64)
            nshapes = 64;
        path = op_fuzz_file(data, size, ".sssc");
    } else {
        nshapes = size ? data[0] % 4 : 0;
        const uint8_t *body = size ? data + 1 : data;
        size_t n = size ? size - 1 : 0;
        unsigned char *f = calloc(64 + n + 1, 1);
        op_fuzz_require(f != NULL, "out of memory");
        memcpy(f, "OPLNSSSC", 8);
        f[8] = (unsigned char)OP_SSS_CACHE_VERSION;
        f[12] = (unsigned char)nshapes;
        memcpy(f + 16, key, sizeof key);
        put_u64(f + 32, n);
        if (n)
            memcpy(f + 64, body, n);
        put_u64(f + 40, XXH3_64bits(f + 64, n));
        put_u64(f + 48, XXH3_64bits(f, 48));
        path = op_fuzz_file(f, 64 + n, ".sssc");
        free(f);
    }
    op_sss_store a, b;
    op_sss_file_state state;
    op_error err;
    op_log_set_level(OP_LOG_ERROR);
    if (op_sss_store_load(path, key, nshapes, &a, &state, &err) != OP_OK)
        return 0;
    if (state == OP_SSS_FILE_VALID) {
        char out[4200];
        snprintf(out, sizeof out, "%s.out", path);
        op_fuzz_require(op_sss_store_save(out, key, &a, &err) == OP_OK, "a loaded cache did not save");
        op_fuzz_require(op_sss_store_load(out, key, nshapes, &b, &state, &err) == OP_OK &&
                        state == OP_SSS_FILE_VALID, "a saved cache did not load");
        require_equal(&a, &b);
        op_sss_store_free(&b);
        remove(out);
    }
    op_sss_store_free(&a);
    return 0;
}
