/* op_output.c - crash-safe output: write to a temporary file beside the destination, rename
 * into place on commit. */
#include "opaline.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

struct op_output {
    FILE *f;
    char *path;
    char *tmp_path;
    int failed_errno;
};

op_status op_output_open(const char *path, op_output **out, op_error *err)
{
    *out = NULL;
    op_output *o = calloc(1, sizeof *o);
    size_t n = strlen(path);
    if (!o || !(o->path = malloc(n + 1)) || !(o->tmp_path = malloc(n + 16))) {
        if (o)
            free(o->path);
        free(o);
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    }
    memcpy(o->path, path, n + 1);
    snprintf(o->tmp_path, n + 16, "%s.tmp-XXXXXX", path);
    int fd = mkstemp(o->tmp_path);
    if (fd >= 0) {
        /* mkstemp creates mode 0600; give the file the permissions open() would have. */
        mode_t mask = umask(0);
        umask(mask);
        fchmod(fd, 0666 & ~mask);
    }
    if (fd < 0 || !(o->f = fdopen(fd, "wb"))) {
        int e = errno;
        if (fd >= 0) {
            close(fd);
            unlink(o->tmp_path);
        }
        free(o->tmp_path);
        free(o->path);
        free(o);
        return op_error_set(err, OP_ERR_IO, "%s: cannot create: %s", path, strerror(e));
    }
    *out = o;
    return OP_OK;
}

FILE *op_output_stream(op_output *out)
{
    return out->f;
}

void op_output_write(op_output *out, const void *data, size_t n)
{
    if (n && !out->failed_errno && fwrite(data, 1, n, out->f) != n)
        out->failed_errno = errno ? errno : EIO;
}

static void output_free(op_output *o)
{
    free(o->tmp_path);
    free(o->path);
    free(o);
}

op_status op_output_commit(op_output *out, op_error *err)
{
    int e = out->failed_errno;
    if (!e && (fflush(out->f) != 0 || fsync(fileno(out->f)) != 0 || ferror(out->f)))
        e = errno ? errno : EIO;
    if (fclose(out->f) != 0 && !e)
        e = errno ? errno : EIO;
    if (!e && rename(out->tmp_path, out->path) != 0)
        e = errno;
    if (e) {
        unlink(out->tmp_path);
        op_error_set(err, OP_ERR_IO, "%s: cannot write: %s", out->path, strerror(e));
        output_free(out);
        return OP_ERR_IO;
    }
    output_free(out);
    return OP_OK;
}

void op_output_abort(op_output *out)
{
    if (!out)
        return;
    fclose(out->f);
    unlink(out->tmp_path);
    output_free(out);
}
