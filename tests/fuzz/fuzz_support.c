/* fuzz_support.c - scratch files and contract checks for the fuzz targets (see fuzz_support.h). */
#include "fuzz_support.h"

#include "opaline.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static char base[4096];    /* this process's scratch name, without suffix */
static char current[4200]; /* the scratch file that exists now, or "" */
static char folder[4200];  /* the scratch folder, once made, or "" */
static char folder_files[16][256]; /* the names written in it */
static int nfolder_files;
static char folder_path[4500];

static void remove_scratch(void)
{
    if (current[0])
        unlink(current);
    for (int i = 0; i < nfolder_files; i++) {
        int n = snprintf(folder_path, sizeof folder_path, "%s/%s", folder, folder_files[i]);
        if (n > 0 && n < (int)sizeof folder_path)
            unlink(folder_path);
    }
    if (folder[0])
        rmdir(folder);
}

static void start(void)
{
    if (base[0])
        return;
    const char *dir = getenv("TMPDIR");
    if (!dir || !*dir)
        dir = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
    snprintf(base, sizeof base, "%s/opaline-fuzz-%ld", dir, (long)getpid());
    atexit(remove_scratch);
    op_log_set_level(OP_LOG_ERROR); /* warnings about hostile input would flood the log */
}

static void write_file(const char *path, const uint8_t *data, size_t size)
{
    FILE *f = fopen(path, "wb");
    if (!f || (size && fwrite(data, 1, size, f) != size) || fclose(f) != 0) {
        perror(path);
        abort();
    }
}

const char *op_fuzz_file(const uint8_t *data, size_t size, const char *suffix)
{
    start();
    char path[sizeof current];
    snprintf(path, sizeof path, "%s%s", base, suffix);
    if (current[0] && strcmp(path, current) != 0)
        unlink(current);
    memcpy(current, path, sizeof current);
    write_file(current, data, size);
    return current;
}

const char *op_fuzz_folder_file(const char *name, const uint8_t *data, size_t size)
{
    start();
    if (!folder[0]) {
        snprintf(folder, sizeof folder, "%s.d", base);
        if (mkdir(folder, 0700) != 0 && errno != EEXIST) {
            perror(folder);
            abort();
        }
    }
    int known = 0;
    for (int i = 0; i < nfolder_files && !known; i++)
        known = strcmp(folder_files[i], name) == 0;
    if (!known) {
        if (nfolder_files == 16 || strlen(name) >= sizeof folder_files[0] || strchr(name, '/'))
            abort();
        snprintf(folder_files[nfolder_files++], sizeof folder_files[0], "%s", name);
    }
    snprintf(folder_path, sizeof folder_path, "%s/%s", folder, name);
    write_file(folder_path, data, size);
    return folder_path;
}

void op_fuzz_require(int cond, const char *msg)
{
    if (!cond) {
        fprintf(stderr, "fuzz: contract broken: %s\n", msg);
        abort();
    }
}
