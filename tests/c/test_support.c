/* test_support.c - see test_support.h. */
#include "test_support.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

const char *op_test_tmp_path(const char *suffix)
{
    static char buf[8][1024];
    static int counter;
    const char *tmp = getenv("OPALINE_TEST_TMP");
    if (!tmp || !*tmp)
        tmp = "/tmp";
    char *out = buf[counter % 8];
    snprintf(out, sizeof buf[0], "%s/t%ld-%d-%s", tmp, (long)getpid(), counter, suffix);
    counter++;
    return out;
}

const char *op_test_shared_path(const char *rel)
{
    static char buf[4][1024];
    static int counter;
    const char *dir = getenv("OPALINE_SHARED_DIR");
    char *out = buf[counter++ % 4];
    struct stat st;
    snprintf(out, sizeof buf[0], "%s/%s", dir ? dir : "../shared", rel);
    if (stat(out, &st) != 0) {
        fprintf(stderr, "skipping: %s is absent (shared test material is not beside the "
                        "checkout)\n", out);
        return NULL;
    }
    return out;
}

int op_test_count_prefix(const char *dir, const char *prefix)
{
    DIR *d = opendir(dir);
    assert_non_null(d);
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)))
        n += strncmp(e->d_name, prefix, strlen(prefix)) == 0;
    closedir(d);
    return n;
}
