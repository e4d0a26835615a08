/* fuzz_support.c - scratch files and contract checks for the fuzz targets (see fuzz_support.h). */
#include "fuzz_support.h"

#include "opaline.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static char base[4096];    /* this process's scratch name, without suffix */
static char current[4200]; /* the scratch file that exists now, or "" */

static void remove_scratch(void)
{
    if (current[0])
        unlink(current);
}

const char *op_fuzz_file(const uint8_t *data, size_t size, const char *suffix)
{
    if (!base[0]) {
        const char *dir = getenv("TMPDIR");
        if (!dir || !*dir)
            dir = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
        snprintf(base, sizeof base, "%s/opaline-fuzz-%ld", dir, (long)getpid());
        atexit(remove_scratch);
        op_log_set_level(OP_LOG_ERROR); /* warnings about hostile input would flood the log */
    }
    char path[sizeof current];
    snprintf(path, sizeof path, "%s%s", base, suffix);
    if (current[0] && strcmp(path, current) != 0)
        unlink(current);
    memcpy(current, path, sizeof current);
    FILE *f = fopen(current, "wb");
    if (!f || (size && fwrite(data, 1, size, f) != size) || fclose(f) != 0) {
        perror(current);
        abort();
    }
    return current;
}

void op_fuzz_require(int cond, const char *msg)
{
    if (!cond) {
        fprintf(stderr, "fuzz: contract broken: %s\n", msg);
        abort();
    }
}
