/* outputs.c - the images a run writes (outputs.h). */
#include "outputs.h"

#include <libgen.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "tile_merge.h"

int op_write_images(const op_scene_description *desc, const op_image *img, const char *const *paths, int n,
                    const char *raw_tag, int code)
{
    op_error werr = {0};
    op_status ws = OP_OK;
    op_output_group_begin();
    for (int i = 0; i < n && !ws; i++) {
        const char *format = op_scene_description_image_format(desc, paths[i]);
        ws = raw_tag && format && !strcmp(format, ".exr")
                 ? op_image_write_exr_attr(paths[i], img, 0, OP_TILE_ATTR, raw_tag, &werr)
                 : op_scene_description_write_image(desc, img, paths[i], &werr);
    }
    if (ws)
        op_output_group_abort();
    else
        ws = op_output_group_commit(&werr);
    if (ws) {
        op_log(OP_LOG_ERROR, "%s%s", werr.message, n > 1 ? " (no output was replaced)" : "");
        return code ? code : op_exit_code(ws);
    }
    for (int i = 0; i < n; i++)
        op_log(OP_LOG_INFO, "wrote %s", paths[i]);
    return code;
}

/* path with ".partial" before its extension (out.exr -> out.partial.exr), so the format stays.
 * Returns 0 when it does not fit in n bytes. */
static int partial_name(const char *path, char *out, size_t n)
{
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    const char *dot = strrchr(base, '.');
    int len = dot && dot != base
                  ? snprintf(out, n, "%.*s.partial%s", (int)(dot - path), path, dot)
                  : snprintf(out, n, "%s.partial", path);
    return len >= 0 && (size_t)len < n;
}

int op_write_partial(const op_scene_description *desc, const op_image *img, const op_render_stats *rs,
                     const char *const *outputs, int n, int beside, const char *what,
                     const char *raw_tag, int code)
{
    char when[64];
    if (rs->tiles_done == 0)
        snprintf(when, sizeof when, "before any tile was finished");
    else
        snprintf(when, sizeof when, "after %d of %d tiles", rs->tiles_done, rs->tiles);
    if (n == 0)
        op_log(OP_LOG_WARN, "%s %s", what, when);
    for (int i = 0; i < n; i++) {
        char part[4096];
        if (!beside || rs->tiles_done == 0) {
            op_log(OP_LOG_WARN, "%s %s: %s not written", what, when, outputs[i]);
        } else if (!partial_name(outputs[i], part, sizeof part)) {
            op_log(OP_LOG_ERROR, "%s: the name is too long for its partial image", outputs[i]);
            if (code == 0)
                code = op_exit_code(OP_ERR_IO);
        } else {
            op_log(OP_LOG_WARN, "%s %s: %s not written, the finished tiles go to %s", what, when,
                   outputs[i], part);
            const char *p = part;
            code = op_write_images(desc, img, &p, 1, raw_tag, code);
        }
    }
    return code;
}

void op_default_output(const char *scene_path, const op_scene_info *info, char *out, size_t n)
{
    if (info->film_filename) {
        const char *f = info->film_filename;
        const char *dot = strrchr(f, '.');
        const char *slash = strrchr(f, '/');
        if (!dot || (slash && dot < slash))
            snprintf(out, n, "%s%s", f, info->film_extension);
        else
            snprintf(out, n, "%s", f);
        return;
    }
    char *tmp = strdup(scene_path);
    const char *base = tmp ? basename(tmp) : "render";
    char stem[1024];
    snprintf(stem, sizeof stem, "%s", base);
    char *dot = strrchr(stem, '.');
    if (dot && dot != stem)
        *dot = '\0';
    snprintf(out, n, "%s%s", stem, info->film_extension);
    free(tmp);
}
