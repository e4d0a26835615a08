/* tile_merge.c - the tile list and its merge (see tile_merge.h). */
#include "tile_merge.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { MAX_LIST_BYTES = 16 << 20, MAX_REPORTED = 8 };

typedef struct tile {
    int x, y, w, h, line;
    char *file; /* resolved against the list's folder; points into the list buffer or owned */
} tile;

/* file relative to the folder of list (unless absolute), in a new string. */
static char *resolve(const char *list, const char *file)
{
    const char *slash = strrchr(list, '/');
    size_t dn = file[0] == '/' || !slash ? 0 : (size_t)(slash - list) + 1;
    size_t fn = strlen(file);
    char *p = malloc(dn + fn + 1);
    if (p) {
        memcpy(p, list, dn);
        memcpy(p + dn, file, fn + 1);
    }
    return p;
}

static void free_tiles(tile *t, int n)
{
    for (int i = 0; i < n; i++)
        free(t[i].file);
    free(t);
}

/* Parses the list into *out (n tiles). Bad lines are OP_ERR_INPUT naming list:line. */
static op_status parse_list(const char *path, tile **out, int *n, op_error *err)
{
    char *data;
    size_t size;
    op_status st = op_file_read(path, MAX_LIST_BYTES, &data, &size, err);
    if (st)
        return st;
    tile *t = NULL;
    int cap = 0, count = 0, line = 0;
    for (char *s = data; st == OP_OK && s && *s; line++) {
        char *nl = strchr(s, '\n');
        if (nl)
            *nl = '\0';
        char *hash = strchr(s, '#');
        if (hash)
            *hash = '\0';
        int x, y, w, h, used = 0;
        char *rest = s;
        while (*rest == ' ' || *rest == '\t' || *rest == '\r')
            rest++;
        if (*rest) {
            if (sscanf(rest, "%d %d %d %d %n", &x, &y, &w, &h, &used) != 4 || used == 0 ||
                x < 0 || y < 0 || w <= 0 || h <= 0 || !rest[used]) {
                st = op_error_set(err, OP_ERR_INPUT, "%s:%d: need X Y W H FILE", path, line + 1);
                break;
            }
            char *file = rest + used;
            size_t fl = strlen(file);
            while (fl && (file[fl - 1] == ' ' || file[fl - 1] == '\t' || file[fl - 1] == '\r'))
                file[--fl] = '\0';
            if (count == cap) {
                int nc = cap ? 2 * cap : 16;
                tile *g = realloc(t, (size_t)nc * sizeof *t);
                if (!g) {
                    st = op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
                    break;
                }
                t = g;
                cap = nc;
            }
            t[count] = (tile){x, y, w, h, line + 1, resolve(path, file)};
            if (!t[count].file) {
                st = op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
                break;
            }
            count++;
        }
        s = nl ? nl + 1 : NULL;
    }
    free(data);
    if (st == OP_OK && count == 0)
        st = op_error_set(err, OP_ERR_INPUT, "%s: no tiles listed", path);
    if (st) {
        free_tiles(t, count);
        return st;
    }
    *out = t;
    *n = count;
    return OP_OK;
}

/* Every pixel covered by exactly one tile, every tile inside the image. */
static op_status check_layout(const char *path, const tile *t, int n, int width, int height,
                              op_error *err)
{
    for (int i = 0; i < n; i++)
        if ((long long)t[i].x + t[i].w > width || (long long)t[i].y + t[i].h > height)
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: tile %d,%d %dx%d leaves the %dx%d "
                                "image", path, t[i].line, t[i].x, t[i].y, t[i].w, t[i].h, width,
                                height);
    unsigned char *cover = calloc((size_t)width * (size_t)height, 1);
    if (!cover)
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    op_status st = OP_OK;
    for (int i = 0; i < n && !st; i++)
        for (int y = t[i].y; y < t[i].y + t[i].h && !st; y++)
            for (int x = t[i].x; x < t[i].x + t[i].w; x++)
                if (cover[(size_t)y * width + x]++) {
                    st = op_error_set(err, OP_ERR_INPUT, "%s:%d: tile %d,%d %dx%d overlaps "
                                      "another at pixel %d,%d", path, t[i].line, t[i].x, t[i].y,
                                      t[i].w, t[i].h, x, y);
                    break;
                }
    for (size_t p = 0; !st && p < (size_t)width * (size_t)height; p++)
        if (!cover[p])
            st = op_error_set(err, OP_ERR_INPUT, "%s: no tile covers pixel %d,%d of the %dx%d "
                              "image", path, (int)(p % (size_t)width), (int)(p / (size_t)width),
                              width, height);
    free(cover);
    return st;
}

op_status op_tiles_merge(const char *list_path, int width, int height, op_image *img,
                         op_error *err)
{
    memset(img, 0, sizeof *img);
    tile *t;
    int n;
    op_status st = parse_list(list_path, &t, &n, err);
    if (st)
        return st;
    if ((st = check_layout(list_path, t, n, width, height, err)) != OP_OK ||
        (st = op_image_alloc(img, width, height, 4, err)) != OP_OK) {
        free_tiles(t, n);
        return st;
    }
    int bad = 0;
    char report[700] = "";
    size_t used = 0;
    for (int i = 0; i < n; i++) {
        op_image tileimg;
        op_error terr = {0};
        op_status ts = op_image_read(t[i].file, &tileimg, &terr);
        if (ts == OP_OK && (tileimg.width != t[i].w || tileimg.height != t[i].h ||
                            tileimg.channels != 4)) {
            ts = op_error_set(&terr, OP_ERR_INPUT, "%s: %dx%d with %d channels, not the "
                              "%dx%d RGBA tile listed", t[i].file, tileimg.width,
                              tileimg.height, tileimg.channels, t[i].w, t[i].h);
            op_image_free(&tileimg);
        }
        if (ts) {
            if (ts == OP_ERR_NOMEM || ts == OP_ERR_CANCELLED) {
                op_error_set(err, ts, "%s", terr.message);
                free_tiles(t, n);
                op_image_free(img);
                return ts;
            }
            if (bad < MAX_REPORTED) {
                int k = snprintf(report + used, sizeof report - used, "; line %d, tile %d,%d "
                                 "%dx%d: %s", t[i].line, t[i].x, t[i].y, t[i].w, t[i].h,
                                 terr.message);
                if (k > 0)
                    used += (size_t)k < sizeof report - used ? (size_t)k
                                                             : sizeof report - used - 1;
            }
            bad++;
            continue;
        }
        for (int y = 0; y < t[i].h; y++)
            memcpy(img->pixels + ((size_t)(t[i].y + y) * width + t[i].x) * 4,
                   tileimg.pixels + (size_t)y * t[i].w * 4, (size_t)t[i].w * 4 * sizeof(float));
        op_image_free(&tileimg);
    }
    free_tiles(t, n);
    if (bad) {
        op_image_free(img);
        return op_error_set(err, OP_ERR_INPUT, "%s: %d of %d tiles missing or invalid, nothing "
                            "merged%s%s", list_path, bad, n, report,
                            bad > MAX_REPORTED ? "; ..." : "");
    }
    return OP_OK;
}
