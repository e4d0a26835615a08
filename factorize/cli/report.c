/* report.c - see report.h. */
#include "report.h"

#include <math.h>
#include <string.h>
#include <sys/resource.h>

void op_report_stage(op_factor_report *r, const char *name, double seconds)
{
    if (r->nstages >= OP_REPORT_MAX_STAGES)
        return;
    snprintf(r->stage_name[r->nstages], sizeof r->stage_name[0], "%s", name);
    r->stage_seconds[r->nstages++] = seconds;
}

uint64_t op_peak_memory_bytes(void)
{
    /* VmHWM is this process image's own peak: getrusage's ru_maxrss would carry the peak of the
     * process that exec'ed opaline over (a Python driver's, a shell's). */
    FILE *f = fopen("/proc/self/status", "r");
    if (f) {
        char line[256];
        unsigned long long kib;
        while (fgets(line, sizeof line, f))
            if (sscanf(line, "VmHWM: %llu kB", &kib) == 1) {
                fclose(f);
                return (uint64_t)kib * 1024u;
            }
        fclose(f);
    }
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru) != 0)
        return 0;
    return (uint64_t)ru.ru_maxrss * 1024u; /* Linux reports kilobytes */
}

/* In 8 lanes, summed in a fixed order: the loop vectorizes (the sums of one row in a different
 * order than one by one, so the figures may differ from a sequential sum in the last digits). */
enum { ACCUM_LANES = 8 };

/* A lane of the sums over ref and approx (one value). The maxima are kept as the bits of
 * non-negative doubles, which order as the values do: integer selects vectorize where floating
 * compares (which may trap) do not. */
static inline void accum_lane(double *se, double *sr, int64_t *me, int64_t *mr, float ref,
                              float approx)
{
    uint32_t bits;
    memcpy(&bits, &ref, sizeof bits);
    double r = (double)ref, e;
    int64_t rb, eb;
    memcpy(&rb, &r, sizeof rb);
    rb &= -(int64_t)((bits & 0x7f800000u) != 0x7f800000u); /* non-finite counts as 0 */
    memcpy(&r, &rb, sizeof r);
    e = fabs(r - (double)approx);
    *se += e * e;
    *sr += r * r;
    memcpy(&eb, &e, sizeof eb);
    rb &= INT64_MAX; /* |r| */
    *me = eb > *me ? eb : *me;
    *mr = rb > *mr ? rb : *mr;
}

OP_VECTOR_CLONES
void op_error_accum_add(op_error_accum *acc, const float *ref, const float *approx, int n)
{
    double se[ACCUM_LANES], sr[ACCUM_LANES];
    int64_t me[ACCUM_LANES], mr[ACCUM_LANES];
    for (int k = 0; k < ACCUM_LANES; k++) {
        se[k] = sr[k] = 0.0;
        me[k] = mr[k] = 0;
    }
    int j0 = 0;
    for (; j0 + ACCUM_LANES <= n; j0 += ACCUM_LANES)
        for (int k = 0; k < ACCUM_LANES; k++)
            accum_lane(&se[k], &sr[k], &me[k], &mr[k], ref[j0 + k], approx[j0 + k]);
    for (int k = 0; j0 + k < n; k++)
        accum_lane(&se[k], &sr[k], &me[k], &mr[k], ref[j0 + k], approx[j0 + k]);
    for (int k = 0; k < ACCUM_LANES; k++) {
        double e, r;
        memcpy(&e, &me[k], sizeof e);
        memcpy(&r, &mr[k], sizeof r);
        acc->sum_sq_err += se[k];
        acc->sum_sq_ref += sr[k];
        acc->max_err = e > acc->max_err ? e : acc->max_err;
        acc->max_ref = r > acc->max_ref ? r : acc->max_ref;
    }
    acc->count += (uint64_t)n;
}

void op_error_accum_merge(op_error_accum *acc, const op_error_accum *part)
{
    acc->sum_sq_err += part->sum_sq_err;
    acc->sum_sq_ref += part->sum_sq_ref;
    acc->max_err = part->max_err > acc->max_err ? part->max_err : acc->max_err;
    acc->max_ref = part->max_ref > acc->max_ref ? part->max_ref : acc->max_ref;
    acc->count += part->count;
}

void op_error_accum_finish(const op_error_accum *acc, op_factor_report *r)
{
    r->rmse = acc->count ? sqrt(acc->sum_sq_err / (double)acc->count) : 0.0;
    r->relative_rmse = acc->sum_sq_ref > 0 ? sqrt(acc->sum_sq_err / acc->sum_sq_ref) : 0.0;
    r->psnr = r->rmse > 0 ? 20.0 * log10(acc->max_ref / r->rmse) : INFINITY;
    r->max_error = acc->max_err;
}

void op_report_print(const op_factor_report *r, FILE *f)
{
    fprintf(f, "material:          %s (%s", r->name, r->method);
    if (r->terms)
        fprintf(f, ", T=%d", r->terms);
    if (r->degree)
        fprintf(f, ", P=%d", r->degree);
    if (!strcmp(r->method, "svd"))
        fprintf(f, ", A=%g, B=%g", r->log_a, r->log_b);
    fprintf(f, ", %s)\n", r->shifted ? "shifted" : "unshifted");
    fprintf(f, "dataset:           %s (%d x %d pixels, kernel %d, %d channel(s), crc %08x)\n",
            r->input, r->width, r->height, r->kernel, r->channels, (unsigned)r->dataset_crc);
    fprintf(f, "output:            %s\n", r->output);
    fprintf(f, "RMSE:              %.6g (relative %.4g%%)\n", r->rmse, 100.0 * r->relative_rmse);
    if (isfinite(r->psnr))
        fprintf(f, "PSNR:              %.2f dB\n", r->psnr);
    else
        fprintf(f, "PSNR:              exact\n");
    fprintf(f, "max error:         %.6g\n", r->max_error);
    fprintf(f, "size:              %llu bytes (dataset %llu bytes, ratio %.1f : 1)\n",
            (unsigned long long)r->size_bytes, (unsigned long long)r->original_bytes,
            r->compression_ratio);
    if (r->nonfinite_replaced || r->negative_values)
        fprintf(f, "input values:      %llu non-finite replaced by 0, %llu negative treated as 0\n",
                (unsigned long long)r->nonfinite_replaced, (unsigned long long)r->negative_values);
    fprintf(f, "time:             ");
    for (int i = 0; i < r->nstages; i++)
        fprintf(f, " %s %.3f s,", r->stage_name[i], r->stage_seconds[i]);
    fprintf(f, " total %.3f s\n", r->total_seconds);
    if (r->has_fit)
        fprintf(f, "colour fit:        condition <= %.3g, coefficients <= %.3g, float32 storage "
                   "error %.2g (relative)\n", r->fit_condition, r->fit_coef_max,
                r->fit_storage_error);
    fprintf(f, "peak memory:       %.1f MiB\n", (double)r->peak_memory_bytes / 1048576.0);
    fprintf(f, "evaluation:        %.1f ns per Rd value (%.1f ns at random rows), albedo map "
               "%.4f s\n", r->eval_ns, r->eval_random_ns, r->albedo_map_seconds);
}

/* A JSON string literal of s (control characters escaped). */
static void json_string(FILE *f, const char *s)
{
    fputc('"', f);
    for (const unsigned char *p = (const unsigned char *)s; *p; p++) {
        if (*p == '"' || *p == '\\')
            fprintf(f, "\\%c", *p);
        else if (*p < 0x20)
            fprintf(f, "\\u%04x", *p);
        else
            fputc(*p, f);
    }
    fputc('"', f);
}

static void json_number(FILE *f, double v)
{
    if (isfinite(v))
        fprintf(f, "%.9g", v);
    else
        fputs("null", f);
}

/* One member after the first: `,\n  "key": ` then the value. */
static void json_field_string(FILE *f, const char *key, const char *v)
{
    fprintf(f, ",\n  \"%s\": ", key);
    json_string(f, v);
}

static void json_field_number(FILE *f, const char *key, double v)
{
    fprintf(f, ",\n  \"%s\": ", key);
    json_number(f, v);
}

op_status op_report_write_json(const op_factor_report *r, const char *path, op_output **pending,
                               op_error *err)
{
    op_output *out;
    *pending = NULL;
    op_status st = op_output_open(path, &out, err);
    if (st != OP_OK)
        return st;
    FILE *f = op_output_stream(out);
    fputs("{\n  \"name\": ", f);
    json_string(f, r->name);
    json_field_string(f, "method", r->method);
    json_field_string(f, "input", r->input);
    json_field_string(f, "output", r->output);
    fprintf(f, ",\n  \"width\": %d,\n  \"height\": %d,\n  \"kernel\": %d,\n  \"channels\": %d,\n"
               "  \"terms\": %d,\n  \"degree\": %d,\n  \"shifted\": %s",
            r->width, r->height, r->kernel, r->channels, r->terms, r->degree,
            r->shifted ? "true" : "false");
    json_field_number(f, "log_a", r->log_a);
    json_field_number(f, "log_b", r->log_b);
    fprintf(f, ",\n  \"dataset_crc\": \"%08x\"", (unsigned)r->dataset_crc);
    json_field_number(f, "rmse", r->rmse);
    json_field_number(f, "relative_rmse", r->relative_rmse);
    json_field_number(f, "psnr", r->psnr);
    json_field_number(f, "max_error", r->max_error);
    fprintf(f, ",\n  \"size_bytes\": %llu,\n  \"original_bytes\": %llu",
            (unsigned long long)r->size_bytes, (unsigned long long)r->original_bytes);
    json_field_number(f, "compression_ratio", r->compression_ratio);
    fprintf(f, ",\n  \"nonfinite_replaced\": %llu,\n  \"negative_values\": %llu,\n"
               "  \"stage_seconds\": {",
            (unsigned long long)r->nonfinite_replaced, (unsigned long long)r->negative_values);
    for (int i = 0; i < r->nstages; i++) {
        fprintf(f, "%s\"%s\": ", i ? ", " : "", r->stage_name[i]);
        json_number(f, r->stage_seconds[i]);
    }
    fputs("}", f);
    json_field_number(f, "total_seconds", r->total_seconds);
    fprintf(f, ",\n  \"peak_memory_bytes\": %llu", (unsigned long long)r->peak_memory_bytes);
    json_field_number(f, "eval_ns", r->eval_ns);
    json_field_number(f, "eval_random_ns", r->eval_random_ns);
    json_field_number(f, "albedo_map_seconds", r->albedo_map_seconds);
    if (r->has_fit) {
        json_field_number(f, "fit_condition", r->fit_condition);
        json_field_number(f, "fit_coef_max", r->fit_coef_max);
        json_field_number(f, "fit_storage_error", r->fit_storage_error);
    }
    json_field_string(f, "tool_version", op_version());
    fputs("\n}\n", f);
    const char *unused;
    if ((st = op_output_pending(out, &unused, err)) != OP_OK)
        op_output_abort(out);
    else
        *pending = out;
    return st;
}
