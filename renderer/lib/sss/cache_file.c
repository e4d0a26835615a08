/* cache_file.c - the pre-pass cache's key and file (see cache_file.h). */
#include "sss/cache_file.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <xxhash.h>

#include "bsdf/texture.h"

static const char MAGIC[8] = {'O', 'P', 'L', 'N', 'S', 'S', 'S', 'C'};
enum { HEADER_BYTES = 64 };

/* ------------------------------------------------------------ the key */

static void h_bytes(XXH3_state_t *h, const void *p, size_t n)
{
    if (n)
        XXH3_128bits_update(h, p, n);
}

static void h_u64(XXH3_state_t *h, uint64_t v)
{
    unsigned char b[8];
    for (int i = 0; i < 8; i++)
        b[i] = (unsigned char)(v >> (8 * i));
    h_bytes(h, b, 8);
}

/* A string with its length, so that concatenations cannot collide. */
static void h_str(XXH3_state_t *h, const char *s)
{
    size_t n = s ? strlen(s) : 0;
    h_u64(h, s ? n : UINT64_MAX);
    h_bytes(h, s, n);
}

static void h_floats(XXH3_state_t *h, const float *v, size_t n)
{
    h_u64(h, v ? n : UINT64_MAX);
    for (size_t i = 0; v && i < n; i++) {
        uint32_t b;
        memcpy(&b, &v[i], 4);
        h_u64(h, b);
    }
}

static void h_double(XXH3_state_t *h, double v)
{
    uint64_t b;
    memcpy(&b, &v, 8);
    h_u64(h, b);
}

static void h_key(XXH3_state_t *h, unsigned char out[OP_SSS_KEY_BYTES])
{
    XXH128_canonical_t c;
    XXH128_canonicalFromHash(&c, XXH3_128bits_digest(h));
    memcpy(out, c.digest, OP_SSS_KEY_BYTES);
}

static void hash_node(XXH3_state_t *h, const op_node *n)
{
    h_str(h, n->tag);
    h_str(h, n->type);
    h_str(h, n->name);
    h_u64(h, (uint64_t)n->nprops);
    for (int i = 0; i < n->nprops; i++) {
        const op_prop *p = &n->props[i];
        h_str(h, p->name);
        h_u64(h, (uint64_t)p->kind);
        switch (p->kind) {
        case OP_PROP_FLOAT:
            h_double(h, p->value.f);
            break;
        case OP_PROP_INTEGER:
            h_u64(h, (uint64_t)p->value.i);
            break;
        case OP_PROP_BOOLEAN:
            h_u64(h, (uint64_t)p->value.b);
            break;
        case OP_PROP_STRING:
            /* a file's name says nothing its content (hashed by op_sss_key) does not */
            h_str(h, strcmp(p->name, "filename") == 0 ? "" : p->value.s);
            break;
        case OP_PROP_POINT:
        case OP_PROP_VECTOR:
        case OP_PROP_COLOR:
            for (int k = 0; k < 3; k++)
                h_double(h, p->value.v[k]);
            break;
        case OP_PROP_TRANSFORM:
            for (int r = 0; r < 4; r++)
                for (int c = 0; c < 4; c++)
                    h_double(h, p->value.xf.m[r][c]);
            break;
        }
    }
    int kept = 0;
    for (int i = 0; i < n->nchildren; i++)
        kept += strcmp(n->children[i]->tag, "sensor") != 0;
    h_u64(h, (uint64_t)kept);
    for (int i = 0; i < n->nchildren; i++) {
        if (strcmp(n->children[i]->tag, "sensor") == 0)
            continue; /* camera, film, sampler: the pre-pass's results do not depend on them */
        h_str(h, n->child_names ? n->child_names[i] : NULL);
        hash_node(h, n->children[i]);
    }
}

void op_sss_desc_hash(const op_node *root, unsigned char out[OP_SSS_KEY_BYTES])
{
    XXH3_state_t *h = XXH3_createState();
    if (!h) { /* no memory for 600 bytes: a key that matches nothing real */
        memset(out, 0xff, OP_SSS_KEY_BYTES);
        return;
    }
    XXH3_128bits_reset(h);
    hash_node(h, root);
    h_key(h, out);
    XXH3_freeState(h);
}

static void hash_mesh(XXH3_state_t *h, const op_trimesh *m)
{
    h_u64(h, (uint64_t)m->nverts);
    h_u64(h, (uint64_t)m->ntris);
    h_floats(h, m->pos, 3 * (size_t)m->nverts);
    h_floats(h, m->nrm, 3 * (size_t)m->nverts);
    h_floats(h, m->uv, 2 * (size_t)m->nverts);
    h_bytes(h, m->idx, 3 * (size_t)m->ntris * sizeof *m->idx);
}

static void hash_image(XXH3_state_t *h, const op_image *img)
{
    h_u64(h, (uint64_t)img->width);
    h_u64(h, (uint64_t)img->height);
    h_u64(h, (uint64_t)img->channels);
    h_floats(h, img->pixels, (size_t)img->width * img->height * img->channels);
}

op_status op_sss_key(const op_scene *s, uint64_t seed, unsigned char key[OP_SSS_KEY_BYTES],
                     op_error *err)
{
    XXH3_state_t *h = XXH3_createState();
    if (!h)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    XXH3_128bits_reset(h);
    h_str(h, "opaline subsurface pre-pass");
    h_u64(h, OP_SSS_CACHE_VERSION);
    h_str(h, op_version());
    h_bytes(h, s->desc_hash, OP_SSS_KEY_BYTES);
    h_u64(h, (uint64_t)s->nprotos);
    for (int i = 0; i < s->nprotos; i++)
        hash_mesh(h, &s->protos[i]);
    h_u64(h, (uint64_t)s->nshapes);
    for (int i = 0; i < s->nshapes; i++) {
        const op_shape_rec *sh = &s->shapes[i];
        h_u64(h, (uint64_t)sh->instanced);
        if (sh->instanced) /* its prototype (hashed above) and placement */
            h_floats(h, sh->place.m, 12);
        else
            hash_mesh(h, &sh->mesh);
        h_u64(h, (uint64_t)sh->bsdf);
        h_u64(h, (uint64_t)sh->emitter);
        h_u64(h, (uint64_t)sh->sss);
    }
    int ntex = op_tex_cache_count(s->textures);
    h_u64(h, (uint64_t)ntex);
    for (int i = 0; i < ntex; i++)
        hash_image(h, op_tex_cache_image(s->textures, i));
    for (int i = 0; i < s->nemitters; i++)
        if (s->emitters[i].type == OP_EM_ENVMAP)
            hash_image(h, &s->emitters[i].env);
    h_u64(h, (uint64_t)s->nsss);
    for (int i = 0; i < s->nsss; i++) {
        const op_sss_desc *d = &s->sss[i];
        h_u64(h, (uint64_t)s->sss_plan[i].points);
        h_u64(h, (uint64_t)d->max_points);
        h_u64(h, (uint64_t)d->irr_samples);
        h_double(h, d->density);
        h_double(h, d->scale);
    }
    /* every material file, whole: its content is what the kernel rows come from */
    op_status st = OP_OK;
    h_u64(h, (uint64_t)s->nmaterials);
    for (int i = 0; i < s->nmaterials && st == OP_OK; i++) {
        op_file_view v;
        st = op_file_map(s->material_paths[i], &v, err);
        if (st == OP_OK) {
            h_u64(h, XXH3_64bits(v.data, v.size));
            op_file_unmap(&v);
        }
    }
    h_floats(h, &s->bmin.x, 1);
    h_floats(h, &s->bmin.y, 1);
    h_floats(h, &s->bmin.z, 1);
    h_floats(h, &s->bmax.x, 1);
    h_floats(h, &s->bmax.y, 1);
    h_floats(h, &s->bmax.z, 1);
    h_u64(h, seed);
    h_key(h, key);
    XXH3_freeState(h);
    return st;
}

/* ------------------------------------------------------------ the file */

static void put_f32(unsigned char *p, float f)
{
    uint32_t b;
    memcpy(&b, &f, 4);
    op_put_le32(p, b);
}

static float get_f32(const unsigned char *p)
{
    uint32_t b = op_get_le32(p);
    float f;
    memcpy(&f, &b, 4);
    return f;
}

void op_sss_store_free(op_sss_store *store)
{
    for (int i = 0; store->shapes && i < store->nshapes; i++) {
        free(store->shapes[i].has);
        free(store->shapes[i].e);
        free(store->shapes[i].m);
    }
    free(store->shapes);
    memset(store, 0, sizeof *store);
}

/* Fills store's entries from a body whose hash matched. */
static op_status parse_body(const char *path, const unsigned char *b, uint64_t n,
                            op_sss_store *store, op_error *err)
{
    uint64_t at = 0;
    for (int s = 0; s < store->nshapes; s++) {
        if (n - at < 12)
            return op_error_set(err, OP_ERR_FORMAT, "%s: corrupt pre-pass cache (shape %d cut "
                                "short)", path, s);
        uint32_t np = op_get_le32(b + at), ne = op_get_le32(b + at + 4), nm = op_get_le32(b + at + 8);
        at += 12;
        if (np > INT32_MAX || ne > np || nm > np || n - at < np + 12 * ((uint64_t)ne + nm))
            return op_error_set(err, OP_ERR_FORMAT, "%s: corrupt pre-pass cache (shape %d: %u "
                                "points, %u irradiance and %u exitance values in %llu bytes)",
                                path, s, np, ne, nm, (unsigned long long)(n - at));
        if (np == 0)
            continue;
        op_sss_saved *sv = &store->shapes[s];
        sv->has = malloc(np);
        sv->e = calloc(3 * (size_t)np, sizeof *sv->e);
        sv->m = calloc(3 * (size_t)np, sizeof *sv->m);
        sv->n = (int)np;
        if (!sv->has || !sv->e || !sv->m)
            return op_error_set(err, OP_ERR_NOMEM, "out of memory for the pre-pass cache");
        memcpy(sv->has, b + at, np);
        at += np;
        uint32_t ce = 0, cm = 0;
        for (uint32_t i = 0; i < np; i++) {
            if (sv->has[i] & ~(OP_SSS_HAS_E | OP_SSS_HAS_M))
                return op_error_set(err, OP_ERR_FORMAT, "%s: corrupt pre-pass cache (shape %d, "
                                    "point %u: flags %u)", path, s, i, sv->has[i]);
            ce += (sv->has[i] & OP_SSS_HAS_E) != 0;
            cm += (sv->has[i] & OP_SSS_HAS_M) != 0;
        }
        if (ce != ne || cm != nm)
            return op_error_set(err, OP_ERR_FORMAT, "%s: corrupt pre-pass cache (shape %d: %u "
                                "and %u flagged values, the counts say %u and %u)", path, s,
                                ce, cm, ne, nm);
        const unsigned char *pe = b + at, *pm = b + at + 12 * (uint64_t)ne;
        for (uint32_t i = 0; i < np; i++)
            for (int c = 0; c < 3; c++) {
                if (sv->has[i] & OP_SSS_HAS_E) {
                    sv->e[3 * (size_t)i + c] = get_f32(pe);
                    pe += 4;
                }
                if (sv->has[i] & OP_SSS_HAS_M) {
                    sv->m[3 * (size_t)i + c] = get_f32(pm);
                    pm += 4;
                }
            }
        at += 12 * ((uint64_t)ne + nm);
    }
    if (at != n)
        return op_error_set(err, OP_ERR_FORMAT, "%s: corrupt pre-pass cache (%llu bytes after "
                            "the last shape)", path, (unsigned long long)(n - at));
    return OP_OK;
}

static op_status not_ours(const char *path, const char *why, op_error *err)
{
    return op_error_set(err, OP_ERR_INPUT, "%s: %s; refusing to use or overwrite it (give "
                        "another --sss-cache file, or remove it)", path, why);
}

op_status op_sss_store_load(const char *path, const unsigned char key[OP_SSS_KEY_BYTES],
                            int nshapes, op_sss_store *store, op_sss_file_state *state,
                            op_error *err)
{
    memset(store, 0, sizeof *store);
    store->nshapes = nshapes;
    store->shapes = calloc((size_t)(nshapes > 0 ? nshapes : 1), sizeof *store->shapes);
    if (!store->shapes)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    *state = OP_SSS_FILE_STALE;
    struct stat sb;
    if (stat(path, &sb) != 0 && (errno == ENOENT || errno == ENOTDIR)) {
        *state = OP_SSS_FILE_MISSING;
        op_log(OP_LOG_INFO, "pre-pass cache %s: none yet: computing", path);
        return OP_OK;
    }
    char *data = NULL;
    size_t n = 0;
    op_status st = op_file_read(path, SIZE_MAX - 1, &data, &n, err);
    if (st) { /* a directory, FIFO, device, unreadable file: never ours to replace */
        op_sss_store_free(store);
        return op_error_prefix(err, "--sss-cache: ");
    }
    const unsigned char *b = (const unsigned char *)data;
    if (n < sizeof MAGIC || memcmp(b, MAGIC, sizeof MAGIC) != 0) {
        st = not_ours(path, "not an opaline pre-pass cache (no OPLNSSSC header)", err);
    } else if (n < 12) {
        st = not_ours(path, "a truncated pre-pass cache", err);
    } else if (op_get_le32(b + 8) != OP_SSS_CACHE_VERSION) {
        op_log(OP_LOG_INFO, "pre-pass cache %s: format version %u, this renderer writes %u: "
               "recomputing", path, op_get_le32(b + 8), OP_SSS_CACHE_VERSION);
    } else if (n < HEADER_BYTES) {
        st = not_ours(path, "a truncated pre-pass cache (shorter than its header)", err);
    } else if (op_get_le64(b + 48) != XXH3_64bits(b, 48)) {
        st = not_ours(path, "a corrupt pre-pass cache (its header's checksum does not match)",
                      err);
    } else if (op_get_le64(b + 32) != n - HEADER_BYTES) {
        st = not_ours(path, "a truncated or extended pre-pass cache (its size does not match its "
                      "header)", err);
    } else if (op_get_le64(b + 40) != XXH3_64bits(b + HEADER_BYTES, n - HEADER_BYTES)) {
        st = not_ours(path, "a corrupt pre-pass cache (its checksum does not match)", err);
    } else if (memcmp(b + 16, key, OP_SSS_KEY_BYTES) != 0 || op_get_le32(b + 12) != (uint32_t)nshapes) {
        op_log(OP_LOG_INFO, "pre-pass cache %s: key differs (the scene, its files, the seed or "
               "the limits changed): recomputing", path);
    } else {
        st = parse_body(path, b + HEADER_BYTES, n - HEADER_BYTES, store, err);
        if (st == OP_OK)
            *state = OP_SSS_FILE_VALID;
        else if (st == OP_ERR_FORMAT)
            op_error_prefix(err, "--sss-cache: ");
    }
    free(data);
    if (st)
        op_sss_store_free(store);
    return st;
}

op_status op_sss_store_save(const char *path, const unsigned char key[OP_SSS_KEY_BYTES],
                            const op_sss_store *store, op_error *err)
{
    uint64_t body = 0;
    for (int s = 0; s < store->nshapes; s++) {
        const op_sss_saved *sv = &store->shapes[s];
        body += 12 + (uint64_t)sv->n;
        for (int i = 0; i < sv->n; i++)
            body += 12 * (uint64_t)(((sv->has[i] & OP_SSS_HAS_E) != 0) +
                                    ((sv->has[i] & OP_SSS_HAS_M) != 0));
    }
    unsigned char *buf = malloc(HEADER_BYTES + (size_t)body);
    if (!buf)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for the pre-pass cache");
    unsigned char *p = buf + HEADER_BYTES;
    for (int s = 0; s < store->nshapes; s++) {
        const op_sss_saved *sv = &store->shapes[s];
        uint32_t ne = 0, nm = 0;
        for (int i = 0; i < sv->n; i++) {
            ne += (sv->has[i] & OP_SSS_HAS_E) != 0;
            nm += (sv->has[i] & OP_SSS_HAS_M) != 0;
        }
        op_put_le32(p, (uint32_t)sv->n);
        op_put_le32(p + 4, ne);
        op_put_le32(p + 8, nm);
        p += 12;
        if (sv->n > 0)
            memcpy(p, sv->has, (size_t)sv->n);
        p += sv->n;
        unsigned char *pe = p, *pm = p + 12 * (size_t)ne;
        for (int i = 0; i < sv->n; i++)
            for (int c = 0; c < 3; c++) {
                if (sv->has[i] & OP_SSS_HAS_E) {
                    put_f32(pe, sv->e[3 * (size_t)i + c]);
                    pe += 4;
                }
                if (sv->has[i] & OP_SSS_HAS_M) {
                    put_f32(pm, sv->m[3 * (size_t)i + c]);
                    pm += 4;
                }
            }
        p += 12 * ((size_t)ne + nm);
    }
    memset(buf, 0, HEADER_BYTES);
    memcpy(buf, MAGIC, sizeof MAGIC);
    op_put_le32(buf + 8, OP_SSS_CACHE_VERSION);
    op_put_le32(buf + 12, (uint32_t)store->nshapes);
    memcpy(buf + 16, key, OP_SSS_KEY_BYTES);
    op_put_le64(buf + 32, body);
    op_put_le64(buf + 40, XXH3_64bits(buf + HEADER_BYTES, (size_t)body));
    op_put_le64(buf + 48, XXH3_64bits(buf, 48));
    op_output *out;
    op_status st = op_output_open_update(path, &out, err); /* it was read as an input */
    if (st == OP_OK) {
        op_output_write(out, buf, HEADER_BYTES + (size_t)body);
        st = op_output_commit(out, err);
    }
    free(buf);
    if (st)
        return op_error_prefix(err, "--sss-cache: ");
    return OP_OK;
}
