/* cache_file.h - the subsurface pre-pass cache file (--sss-cache, docs/subsurface-rendering.md):
 * the irradiance and exitance values a pre-pass computed (an op_sss_store), saved under a key
 * that hashes everything they depend on, so that another view of the same scene (the camera
 * moved, another crop tile, the next animation frame) computes only what the store lacks.
 *
 * File (little-endian): a 64-byte header - magic "OPLNSSSC", u32 format version, u32 shapes,
 * key[16], u64 body bytes, u64 body hash, u64 hash of header bytes 0..47, 8 bytes 0 - then per
 * translucent shape: u32 points n, u32 ne, u32 nm, and when n > 0 n flag bytes (OP_SSS_HAS_E |
 * OP_SSS_HAS_M), then ne irradiance and nm exitance values (3 float32 each) of the flagged
 * points in point order. Hashes are XXH3-64 (libxxhash). */
#ifndef OP_SSS_CACHE_FILE_H
#define OP_SSS_CACHE_FILE_H

#include "scene/render_scene.h"
#include "scene/scene_desc.h"
#include "sss/prepass.h"

/* The file format's version, raised whenever the layout or what the pre-pass computes for the
 * same key changes: a file of another version is recomputed and replaced. */
#define OP_SSS_CACHE_VERSION 8u /* 2: E behind a surface <bsdf> is what crosses it; 3: the dipole's
                                  hierarchical sum and finer points; 4: measured materials' points
                                  at their pixel centres; 5: the dipole's points in Morton order;
                                  6: measured materials' windowed layouts (no maxPoints coarsening
                                  where the view needs fewer) and the scatter's finer cells;
                                  7: windowed layouts of the dipole (in levels) and of stretched
                                  maps; 8: the measured scatter's normalization summed in
                                  partial sums, svd materials' e^x in single precision */

enum { OP_SSS_KEY_BYTES = 16 };

/* The hash of a parsed scene description without what the pre-pass does not depend on: the
 * <sensor> (camera, film, sampler) and the file names (their contents go into op_sss_key).
 * op_scene_load keeps it in the scene for translucent scenes. */
void op_sss_desc_hash(const op_node *root, unsigned char out[OP_SSS_KEY_BYTES]);

/* The key of scene's pre-pass with this seed: the format version and renderer version, the
 * description hash, the built geometry of every shape, the texture and environment images, the
 * content of every material file, each translucent shape's point count and cap, the scene
 * bounds and the seed. Reads the material files (OP_ERR_INPUT/IO naming one that fails). */
op_status op_sss_key(const op_scene *scene, uint64_t seed, unsigned char key[OP_SSS_KEY_BYTES],
                     op_error *err);

/* What op_sss_store_load found. */
typedef enum op_sss_file_state {
    OP_SSS_FILE_VALID,   /* a cache of this key: its contents are in the store */
    OP_SSS_FILE_MISSING, /* no file: the store is empty */
    OP_SSS_FILE_STALE    /* a cache of another key or format version: the store is empty */
} op_sss_file_state;

/* Reads the cache at path into store (nshapes empty entries, filled from the file when it is a
 * valid cache of key). A file that is not an opaline pre-pass cache, or a corrupt or truncated
 * one, or not a regular file, is OP_ERR_INPUT / OP_ERR_FORMAT naming path (such a file must not
 * be overwritten); *state says what was found otherwise, and the log says it too. */
op_status op_sss_store_load(const char *path, const unsigned char key[OP_SSS_KEY_BYTES],
                            int nshapes, op_sss_store *store, op_sss_file_state *state,
                            op_error *err);

/* Writes store under key to path through op_output: the file appears whole or not at all, so
 * concurrent writers each leave a complete file (the last rename wins). */
op_status op_sss_store_save(const char *path, const unsigned char key[OP_SSS_KEY_BYTES],
                            const op_sss_store *store, op_error *err);

void op_sss_store_free(op_sss_store *store);

#endif
