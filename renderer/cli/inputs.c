/* inputs.c - the files a scene reads and the content key over them (see inputs.h). */
#include "inputs.h"

#include <stdlib.h>
#include <string.h>
#include <xxhash.h>

static void record(void *user, const char *path)
{
    op_inputs *in = user;
    char *full = realpath(path, NULL);
    if (!full)
        full = strdup(path);
    if (!full) {
        in->nomem = 1;
        return;
    }
    for (int i = 0; i < in->n; i++)
        if (strcmp(in->paths[i], full) == 0) {
            free(full);
            return;
        }
    if (in->n == in->cap) {
        int nc = in->cap ? 2 * in->cap : 16;
        char **g = realloc(in->paths, (size_t)nc * sizeof *g);
        if (!g) {
            free(full);
            in->nomem = 1;
            return;
        }
        in->paths = g;
        in->cap = nc;
    }
    in->paths[in->n++] = full;
}

op_status op_inputs_collect(op_inputs *in, op_error *err)
{
    memset(in, 0, sizeof *in);
    op_file_inputs_each(record, in);
    if (in->nomem)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory listing the scene's files");
    return OP_OK;
}

void op_inputs_free(op_inputs *in)
{
    for (int i = 0; i < in->n; i++)
        free(in->paths[i]);
    free(in->paths);
    memset(in, 0, sizeof *in);
}

op_status op_inputs_print(const op_inputs *in, FILE *f, op_error *err)
{
    for (int i = 0; i < in->n; i++)
        if (strchr(in->paths[i], '\n'))
            return op_error_set(err, OP_ERR_INPUT, "%s: a file name with a line break cannot be "
                                "listed", in->paths[i]);
    for (int i = 0; i < in->n; i++)
        fprintf(f, "%s\n", in->paths[i]);
    if (fflush(f) != 0 || ferror(f))
        return op_error_set(err, OP_ERR_IO, "stdout: cannot write the list of input files");
    return OP_OK;
}

/* A string with its length, so that concatenations cannot collide (as sss/cache_file.c's key). */
static void h_str(XXH3_state_t *h, const char *s)
{
    uint64_t n = strlen(s);
    XXH3_64bits_update(h, &n, sizeof n);
    XXH3_64bits_update(h, s, (size_t)n);
}

static void h_u64(XXH3_state_t *h, uint64_t v)
{
    XXH3_64bits_update(h, &v, sizeof v);
}

op_status op_inputs_key(const op_inputs *in, const op_scene_info *info,
                        const op_scene_define *defines, int ndefines, const op_scene_limits *limits,
                        int spp, uint64_t *key, op_error *err)
{
    XXH3_state_t *h = XXH3_createState();
    if (!h)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    XXH3_64bits_reset(h);
    h_str(h, "opaline image key 1");
    h_str(h, op_version());
    h_u64(h, (uint64_t)in->n);
    op_status st = OP_OK;
    for (int i = 0; i < in->n && st == OP_OK; i++) {
        op_file_view v;
        st = op_file_map(in->paths[i], &v, err);
        if (st == OP_OK) {
            h_u64(h, (uint64_t)v.size);
            h_u64(h, XXH3_64bits(v.data, v.size));
            op_file_unmap(&v);
        }
    }
    h_u64(h, (uint64_t)ndefines);
    for (int i = 0; i < ndefines; i++) {
        h_str(h, defines[i].name);
        h_str(h, defines[i].value);
    }
    uint64_t coordinate;
    memcpy(&coordinate, &limits->coordinate, sizeof coordinate);
    h_u64(h, coordinate);
    h_u64(h, (uint64_t)limits->image_pixels);
    h_u64(h, (uint64_t)limits->kernel);
    h_u64(h, (uint64_t)limits->sss_points);
    h_u64(h, (uint64_t)limits->sss_max_points);
    h_u64(h, (uint64_t)(spp > 0 ? spp : info->spp));
    h_u64(h, (uint64_t)info->full_width);
    h_u64(h, (uint64_t)info->full_height);
    *key = XXH3_64bits_digest(h);
    XXH3_freeState(h);
    return st;
}
