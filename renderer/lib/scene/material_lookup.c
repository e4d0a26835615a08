/* material_lookup.c - the one preset search order: op_preset_folders and op_find_material of
 * opaline_render.h, which the scene's <subsurface> and the command line both use. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include "opaline_render.h"
#include "scene/scene_path.h"

/* The build tree's presets folder (the build sets it), searched last so that an uninstalled
 * build/bin/opaline-render finds the presets the build made; an installed renderer (its
 * installed presets folder exists) never searches or names it. */
#ifndef OPALINE_DEFAULT_PRESETS_DIR
#define OPALINE_DEFAULT_PRESETS_DIR "presets"
#endif
/* The installed presets folder, relative to the prefix of the running program (bin/..). */
#define OPALINE_INSTALLED_PRESETS_SUBDIR "share/opaline/presets"

static int file_exists(const char *p)
{
    struct stat st;
    return stat(p, &st) == 0 && S_ISREG(st.st_mode);
}

static int dir_exists(const char *p)
{
    struct stat st;
    return stat(p, &st) == 0 && S_ISDIR(st.st_mode);
}

/* Writes PREFIX/share/opaline/presets into out, PREFIX being the folder above the one of the
 * running program (/proc/self/exe, links resolved): an installed tree finds its own presets
 * wherever it was installed or moved to. Writes "" when the program's path is unknown. */
static void installed_presets_dir(char *out, size_t n)
{
    char exe[4096];
    out[0] = '\0';
    ssize_t len = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (len <= 0 || (size_t)len >= sizeof exe - 1)
        return;
    exe[len] = '\0';
    for (int up = 0; up < 2; up++) { /* drop the program's name, then its bin folder */
        char *slash = strrchr(exe, '/');
        if (!slash)
            return;
        *slash = '\0';
    }
    int w = snprintf(out, n, "%s/%s", exe, OPALINE_INSTALLED_PRESETS_SUBDIR);
    if (w < 0 || (size_t)w >= n) /* too long to name: not searched */
        out[0] = '\0';
}

op_status op_preset_folders(const char *scene_dir, op_folder_fn each, void *user,
                            op_error *err)
{
    if (scene_dir && each(user, scene_dir[0] ? scene_dir : "."))
        return OP_OK;
    const char *env = getenv("OPALINE_PRESETS_PATH");
    if (env && env[0]) {
        char *copy = strdup(env);
        if (!copy)
            return op_error_set(err, OP_ERR_NOMEM, "out of memory");
        char *save = NULL;
        for (char *d = strtok_r(copy, ":", &save); d; d = strtok_r(NULL, ":", &save))
            if (each(user, d)) {
                free(copy);
                return OP_OK;
            }
        free(copy);
    }
    char installed[4096];
    installed_presets_dir(installed, sizeof installed);
    if (installed[0] && each(user, installed))
        return OP_OK;
    if (!installed[0] || !dir_exists(installed))
        each(user, OPALINE_DEFAULT_PRESETS_DIR);
    return OP_OK;
}

typedef struct preset_search {
    const char *name;
    char *out;
    size_t n;
    char searched[4096]; /* the folders searched, comma-separated */
    int found;
    op_folder_fn each;   /* also told of every folder searched, or NULL */
    void *user;
} preset_search;

/* Whether folder/name.opm is a regular file (its path is left in out either way; said at
 * debug level when found). */
static int preset_in(void *user, const char *folder)
{
    preset_search *ps = user;
    snprintf(ps->out, ps->n, "%s/%s.opm", folder, ps->name);
    size_t sl = strlen(ps->searched);
    snprintf(ps->searched + sl, sizeof ps->searched - sl, "%s%s", sl ? ", " : "", folder);
    if (ps->each)
        ps->each(ps->user, folder);
    if (!file_exists(ps->out))
        return 0;
    op_log(OP_LOG_DEBUG, "material preset \"%s\" is %s", ps->name, ps->out);
    ps->found = 1;
    return 1;
}

op_status op_find_material(const char *name, const char *scene_dir, op_folder_fn each,
                           void *user, char *out, size_t n, op_error *err)
{
    size_t len = strlen(name);
    int is_path = strchr(name, '/') != NULL || (len > 4 && strcasecmp(name + len - 4, ".opm") == 0);
    if (is_path) { /* opening it says what is wrong with it, if anything */
        op_path_join(out, n, scene_dir, name);
        return OP_OK;
    }
    preset_search ps = {name, out, n, "", 0, each, user};
    op_status st = op_preset_folders(scene_dir ? scene_dir : "", preset_in, &ps, err);
    if (st || ps.found)
        return st;
    return op_error_set(err, OP_ERR_INPUT, "material preset \"%s\" not found (searched %s; set "
                        "OPALINE_PRESETS_PATH or give an .opm path)", name, ps.searched);
}
