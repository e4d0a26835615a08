/* tile_merge.c - the tile list and its merge (see tile_merge.h). */
#include "tile_merge.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { MAX_LIST_BYTES = 16 << 20, MAX_REPORTED = 8 };

typedef struct tile {
    int x, y, w, h, line;
    char *file;     /* resolved against the list's folder (owned) */
    size_t listed;  /* where the name as the list gives it starts in file */
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

/* The next whitespace-separated whole number of *s in 0..INT_MAX into *v, *s moved past it. */
static int next_int(char **s, int *v)
{
    while (**s == ' ' || **s == '\t')
        (*s)++;
    if (**s < '0' || **s > '9')
        return 0;
    char *end;
    errno = 0;
    long long x = strtoll(*s, &end, 10);
    if (errno || x > INT_MAX || (*end != ' ' && *end != '\t'))
        return 0;
    *v = (int)x;
    *s = end;
    return 1;
}

/* A tile's file and where it is listed, for finding a file listed twice. */
typedef struct listed {
    char *key; /* the file's real path when it exists, else its name as resolved */
    int line;
} listed;

static int by_key_then_line(const void *a, const void *b)
{
    const listed *x = a, *y = b;
    int c = strcmp(x->key, y->key);
    return c ? c : (x->line > y->line) - (x->line < y->line);
}

/* OP_ERR_INPUT when two of the n tiles name one file (the same name, or the same existing
 * file), naming the earliest line that repeats one and the line it repeats. */
static op_status check_repeats(const char *path, const tile *t, int n, op_error *err)
{
    listed *l = calloc((size_t)n, sizeof *l);
    op_status st = l ? OP_OK : op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    for (int i = 0; i < n && !st; i++) {
        l[i].line = t[i].line;
        l[i].key = realpath(t[i].file, NULL);
        if (!l[i].key)
            l[i].key = strdup(t[i].file);
        if (!l[i].key)
            st = op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    }
    if (!st) {
        qsort(l, (size_t)n, sizeof *l, by_key_then_line);
        int first = -1, again = -1; /* lines: a file's first listing, the earliest repeat */
        for (int i = 1; i < n; i++)
            if (strcmp(l[i].key, l[i - 1].key) == 0 && (again < 0 || l[i].line < again) &&
                (i < 2 || strcmp(l[i - 1].key, l[i - 2].key) != 0)) {
                first = l[i - 1].line;
                again = l[i].line;
            }
        for (int i = 0; again >= 0 && i < n; i++)
            if (t[i].line == again)
                st = op_error_set(err, OP_ERR_INPUT, "%s:%d: %s is listed twice (line %d too)",
                                  path, again, t[i].file + t[i].listed, first);
    }
    for (int i = 0; l && i < n; i++)
        free(l[i].key);
    free(l);
    return st;
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
        int x, y, w, h;
        char *rest = s;
        while (*rest == ' ' || *rest == '\t' || *rest == '\r')
            rest++;
        if (*rest) {
            if (!next_int(&rest, &x) || !next_int(&rest, &y) || !next_int(&rest, &w) ||
                !next_int(&rest, &h) || w == 0 || h == 0) {
                st = op_error_set(err, OP_ERR_INPUT, "%s:%d: need X Y W H FILE (whole numbers "
                                  "in 0..%d, W and H at least 1)", path, line + 1, INT_MAX);
                break;
            }
            while (*rest == ' ' || *rest == '\t')
                rest++;
            char *file = rest;
            size_t fl = strlen(file);
            while (fl && (file[fl - 1] == ' ' || file[fl - 1] == '\t' || file[fl - 1] == '\r'))
                file[--fl] = '\0';
            if (!fl) {
                st = op_error_set(err, OP_ERR_INPUT, "%s:%d: need X Y W H FILE", path, line + 1);
                break;
            }
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
            t[count] = (tile){x, y, w, h, line + 1, resolve(path, file), 0};
            if (t[count].file)
                t[count].listed = strlen(t[count].file) - fl;
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
    if (st == OP_OK)
        st = check_repeats(path, t, count, err);
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

/* OP_ERR_INPUT naming file unless its OP_TILE_ATTR is scene_tag with t's crop. */
static op_status check_tag(const tile *t, const char *scene_tag, op_error *err)
{
    char want[192], got[192];
    snprintf(want, sizeof want, "%s crop=%d,%d,%d,%d", scene_tag, t->x, t->y, t->w, t->h);
    op_status st = op_image_exr_attr(t->file, OP_TILE_ATTR, got, sizeof got, err);
    if (st == OP_OK && !got[0])
        st = op_error_set(err, OP_ERR_INPUT, "%s: not a tile of opaline-render --raw-exr (no %s "
                          "attribute)", t->file, OP_TILE_ATTR);
    else if (st == OP_OK && strcmp(got, want) != 0)
        st = op_error_set(err, OP_ERR_INPUT, "%s: a tile of another render (%s, not %s)",
                          t->file, got, want);
    return st;
}

op_status op_tiles_merge(const char *list_path, int width, int height, const char *scene_tag,
                         op_image *img, op_error *err)
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
        } else if (ts == OP_OK && scene_tag && (ts = check_tag(&t[i], scene_tag, &terr))) {
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
