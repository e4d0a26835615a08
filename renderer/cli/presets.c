/* presets.c - --find-material and --preset-folders (presets.h). */
#include "presets.h"

#include <errno.h>
#include <string.h>
#include <sys/stat.h>

#include "opaline_render.h"

typedef struct printer {
    FILE *f;
    const char *prefix; /* "searched " or "" */
    int bad_name;       /* a folder holding a line break: not printed */
} printer;

static int print_folder(void *user, const char *folder)
{
    printer *p = user;
    if (strpbrk(folder, "\n\r"))
        p->bad_name = 1;
    else
        fprintf(p->f, "%s%s\n", p->prefix, folder);
    return 0;
}

/* The exit code once the lines are printed (code, unless f failed). */
static int flushed(FILE *f, int code)
{
    errno = 0;
    if (fflush(f) != 0 || ferror(f)) {
        op_log(OP_LOG_ERROR, "stdout: cannot write: %s", errno ? strerror(errno) : "write error");
        return 1;
    }
    return code;
}

int op_print_material(FILE *f, const char *name, const char *scene_dir)
{
    printer p = {f, "searched ", 0};
    char path[4096];
    op_error err = {0};
    op_status st = op_find_material(name, scene_dir, print_folder, &p, path, sizeof path, &err);
    struct stat sb;
    int code = 0, missing = st == OP_OK && stat(path, &sb) != 0;
    if (st == OP_OK && (missing || !S_ISREG(sb.st_mode))) {
        op_log(OP_LOG_ERROR, "material file %s: %s", path,
               missing ? strerror(errno) : "not a regular file");
        code = OP_EXIT_NOT_FOUND;
    } else if (st == OP_ERR_INPUT) {
        op_log(OP_LOG_ERROR, "%s", err.message);
        code = OP_EXIT_NOT_FOUND;
    } else if (st) {
        op_log(OP_LOG_ERROR, "%s", err.message);
        code = op_exit_code(st);
    } else if (strpbrk(path, "\n\r")) {
        p.bad_name = 1;
    } else {
        fprintf(f, "found %s\n", path);
    }
    if (p.bad_name) {
        op_log(OP_LOG_ERROR, "a folder or file name holds a line break: not printed");
        code = 2;
    }
    return flushed(f, code);
}

int op_print_preset_folders(FILE *f, const char *scene_dir)
{
    printer p = {f, "", 0};
    op_error err = {0};
    op_status st = op_preset_folders(scene_dir, print_folder, &p, &err);
    if (st) {
        op_log(OP_LOG_ERROR, "%s", err.message);
        return flushed(f, op_exit_code(st));
    }
    if (p.bad_name) {
        op_log(OP_LOG_ERROR, "a folder name holds a line break: not printed");
        return flushed(f, 2);
    }
    return flushed(f, 0);
}
