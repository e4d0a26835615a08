/* opaline-bench-rsvd: times opaline's truncated SVD (op_rsvd, the svd method's factorization)
 * on a matrix given as raw float32, the way a peer library is timed: the same matrix, several
 * runs in one process, the median. bench/methods_bench uses it to put opaline's SVD side by side
 * with scikit-learn's randomized_svd on exactly the bytes it hands to scikit-learn.
 *
 * usage: opaline-bench-rsvd MATRIX ROWS COLS RANK [--repeats N] [--factors OUT]
 * MATRIX holds ROWS x COLS row-major little-endian float32 values (numpy's tofile). Prints one
 * JSON object: the seconds of each run and their median. OUT (written atomically) receives
 * the last run's U S (ROWS x RANK) then V (COLS x RANK), row-major float32. */
#include "opaline.h"
#include "rsvd.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int usage(void)
{
    fprintf(stderr, "usage: opaline-bench-rsvd MATRIX ROWS COLS RANK [--repeats N] "
                    "[--factors OUT]\n");
    return 2;
}

/* Parses a positive integer argument no larger than max; 0 if it is not one. */
static long long positive(const char *s, long long max)
{
    char *end;
    errno = 0;
    long long v = strtoll(s, &end, 10);
    return errno || *end || end == s || v < 1 || v > max ? 0 : v;
}

static int compare_doubles(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Reads exactly rows x cols floats from path; NULL with a message otherwise. */
static float *read_matrix(const char *path, long long rows, long long cols)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        op_log(OP_LOG_ERROR, "%s: %s", path, strerror(errno));
        return NULL;
    }
    size_t count = (size_t)rows * (size_t)cols;
    float *a = malloc(count * sizeof *a);
    size_t got = a ? fread(a, sizeof *a, count, f) : 0;
    int extra = a && got == count && fgetc(f) != EOF;
    fclose(f);
    if (!a || got != count || extra) {
        op_log(OP_LOG_ERROR,
               "%s: %s (expected %lld x %lld float32 values, "
               "%zu bytes)",
               path,
               !a      ? "out of memory"
               : extra ? "too long"
                       : "too short",
               rows, cols, count * sizeof *a);
        free(a);
        return NULL;
    }
    for (size_t i = 0; i < count; i++)
        if (!isfinite(a[i])) {
            op_log(OP_LOG_ERROR,
                   "%s: value %zu (row %zu, column %zu) is not "
                   "finite",
                   path, i, i / (size_t)cols, i % (size_t)cols);
            free(a);
            return NULL;
        }
    return a;
}

int main(int argc, char **argv)
{
    if (argc < 5)
        return usage();
    long long rows = positive(argv[2], INT32_MAX), cols = positive(argv[3], INT32_MAX);
    long long rank = positive(argv[4], INT32_MAX);
    long long repeats = 5;
    const char *factors = NULL;
    for (int i = 5; i < argc; i++) {
        if (!strcmp(argv[i], "--repeats") && i + 1 < argc)
            repeats = positive(argv[++i], 1000);
        else if (!strcmp(argv[i], "--factors") && i + 1 < argc)
            factors = argv[++i];
        else
            return usage();
    }
    if (!rows || !cols || !rank || !repeats) {
        op_log(OP_LOG_ERROR, "ROWS, COLS, RANK and --repeats must be positive "
                             "integers");
        return 2;
    }
    if (rank > (rows < cols ? rows : cols)) {
        op_log(OP_LOG_ERROR, "rank %lld exceeds min(%lld, %lld)", rank, rows, cols);
        return 2;
    }
    float *a = read_matrix(argv[1], rows, cols);
    float *us = malloc((size_t)rows * (size_t)rank * sizeof *us);
    float *v = malloc((size_t)cols * (size_t)rank * sizeof *v);
    double *seconds = malloc((size_t)repeats * sizeof *seconds);
    int rc = 0;
    if (!a || !us || !v || !seconds) {
        if (a)
            op_log(OP_LOG_ERROR, "out of memory");
        rc = 2;
        goto done;
    }
    op_rsvd_options opt = op_rsvd_defaults();
    for (long long r = 0; r < repeats; r++) {
        op_error err = {0};
        double t0 = op_monotonic_seconds();
        if (op_rsvd(a, rows, cols, (int)rank, &opt, us, v, NULL, NULL, &err) != OP_OK) {
            op_log(OP_LOG_ERROR, "%s: %s", argv[1], err.message);
            rc = 1;
            goto done;
        }
        seconds[r] = op_monotonic_seconds() - t0;
    }
    if (factors) {
        op_error err = {0};
        op_output *out;
        if (op_output_open(factors, &out, &err) != OP_OK) {
            op_log(OP_LOG_ERROR, "%s", err.message);
            rc = 1;
            goto done;
        }
        op_output_write(out, us, (size_t)rows * (size_t)rank * sizeof *us);
        op_output_write(out, v, (size_t)cols * (size_t)rank * sizeof *v);
        if (op_output_commit(out, &err) != OP_OK) {
            op_log(OP_LOG_ERROR, "%s", err.message);
            rc = 1;
            goto done;
        }
    }
    printf("{\"rows\": %lld, \"cols\": %lld, \"rank\": %lld, \"seconds\": [", rows, cols, rank);
    for (long long r = 0; r < repeats; r++)
        printf("%s%.6f", r ? ", " : "", seconds[r]);
    qsort(seconds, (size_t)repeats, sizeof *seconds, compare_doubles);
    double median = repeats % 2 ? seconds[repeats / 2]
                                : 0.5 * (seconds[repeats / 2 - 1] + seconds[repeats / 2]);
    printf("], \"median_seconds\": %.6f}", median);
done:
    free(a);
    free(us);
    free(v);
    free(seconds);
    return rc;
}
