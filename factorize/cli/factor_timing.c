/* factor_timing.c - how fast a new material evaluates (factor_timing.h). */
#include "factor_timing.h"
#include "opaline.h"
#include "opaline_material.h"

#include <stdlib.h>

/* The median of n values (sorts them). */
static double median(double *v, int n)
{
    for (int i = 1; i < n; i++)
        for (int j = i; j > 0 && v[j] < v[j - 1]; j--) {
            double t = v[j];
            v[j] = v[j - 1];
            v[j - 1] = t;
        }
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

op_status op_factor_time_eval(const op_material *m, op_factor_report *rep, op_error *err)
{
    enum { N = 1 << 16 }; /* 2 x 3 passes of 65536 calls: about 0.02 s of the command */
    const op_material_info *in = op_material_get_info(m);
    int h = in->kernel / 2;
    int32_t *args = malloc((size_t)N * 5 * sizeof *args);
    float *albedo = malloc((size_t)in->width * (size_t)in->height * (size_t)in->channels *
                           sizeof *albedo);
    if (!args || !albedo) {
        free(args);
        free(albedo);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    }
    uint64_t x = 0x2545f4914f6cdd1dull;
    for (int i = 0; i < N * 5; i++) {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        uint32_t r = (uint32_t)(x >> 32);
        int k = i % 5;
        args[i] = k == 0   ? (int32_t)(r % (uint32_t)in->channels)
                  : k == 1 ? (int32_t)(r % (uint32_t)in->width)
                  : k == 2 ? (int32_t)(r % (uint32_t)in->height)
                           : (int32_t)(r % (uint32_t)in->kernel) - h;
    }
    /* Coherent: 64 offsets per incident pixel, as a renderer gathers a kernel; random: every
     * argument independent, so nearly every call misses the caches. Each is the median of
     * REPEATS passes (the machines are shared and noisy). */
    enum { REPEATS = 3 };
    double coherent_ns[REPEATS], random_ns[REPEATS], sum = 0;
    for (int k = 0; k < REPEATS; k++) {
        double t = op_monotonic_seconds();
        for (int i = 0; i < N; i++) {
            const int32_t *a = args + 5 * (i & ~63), *d = args + 5 * i;
            sum += op_material_eval(m, a[0], a[1], a[2], d[3], d[4]);
        }
        coherent_ns[k] = (op_monotonic_seconds() - t) * 1e9 / N;
        t = op_monotonic_seconds();
        for (int i = 0; i < N; i++) {
            const int32_t *a = args + 5 * i;
            sum += op_material_eval(m, a[0], a[1], a[2], a[3], a[4]);
        }
        random_ns[k] = (op_monotonic_seconds() - t) * 1e9 / N;
    }
    rep->eval_ns = median(coherent_ns, REPEATS);
    rep->eval_random_ns = median(random_ns, REPEATS);
    double t = op_monotonic_seconds();
    op_status st = op_material_albedo_map(m, albedo, err);
    rep->albedo_map_seconds = op_monotonic_seconds() - t;
    op_log(OP_LOG_DEBUG, "evaluation checksum %g", sum);
    free(args);
    free(albedo);
    return st;
}
