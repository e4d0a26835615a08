/* progress.c - the one progress reporter: a bar with ETA on a terminal, plain lines
 * elsewhere, or a caller's callback (the Blender add-on and tests use that); and the one
 * monotonic clock read (op_monotonic_seconds), which it times with. */
#include "opaline.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

struct op_progress {
    char label[64];
    uint64_t total;
    _Atomic uint64_t done;
    op_progress_fn fn;
    void *user;
    int tty;
    double start, last_report;
    pthread_mutex_t lock; /* serializes reports; advance() takes it only when a report is due */
};

double op_monotonic_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void format_duration(char *buf, size_t n, double s)
{
    if (s < 0 || s > 1e7)
        snprintf(buf, n, "--:--");
    else if (s >= 3600)
        snprintf(buf, n, "%d:%02d:%02d", (int)s / 3600, ((int)s / 60) % 60, (int)s % 60);
    else
        snprintf(buf, n, "%02d:%02d", (int)s / 60, (int)s % 60);
}

static void report(op_progress *p, double t, int final)
{
    uint64_t done = atomic_load(&p->done);
    double frac = p->total ? (double)done / (double)p->total : 1.0;
    if (frac > 1.0)
        frac = 1.0;
    double elapsed = t - p->start;
    double eta = frac > 0 ? elapsed * (1.0 - frac) / frac : -1.0;
    if (p->fn) {
        p->fn(p->user, p->label, frac, eta);
        return;
    }
    if (op_log_get_level() < OP_LOG_INFO)
        return;
    char eta_s[32], el_s[32];
    format_duration(eta_s, sizeof eta_s, eta);
    format_duration(el_s, sizeof el_s, elapsed);
    const char *eta_label = "eta ";
    if (final) { /* ended: complete, or stopped short (cancelled or failed) */
        eta_label = done < p->total ? "" : "eta ";
        snprintf(eta_s, sizeof eta_s, "%s", done < p->total ? "stopped" : "00:00");
    }
    if (p->tty) {
        char bar[31];
        int filled = (int)(frac * 30.0);
        for (int i = 0; i < 30; i++)
            bar[i] = i < filled ? '#' : '.';
        bar[30] = '\0';
        fprintf(stderr, "\r%-20s [%s] %5.1f%%  elapsed %s  %s%s%s", p->label, bar, 100.0 * frac,
                el_s, eta_label, eta_s, final ? "\n" : "");
    } else {
        fprintf(stderr, "opaline: %s: %5.1f%% (elapsed %s, %s%s)\n", p->label, 100.0 * frac, el_s,
                eta_label, eta_s);
    }
    fflush(stderr);
}

op_progress *op_progress_begin(const char *label, uint64_t total, op_progress_fn fn, void *user)
{
    op_progress *p = calloc(1, sizeof *p);
    if (!p)
        return NULL;
    snprintf(p->label, sizeof p->label, "%s", label ? label : "");
    p->total = total;
    atomic_init(&p->done, 0);
    p->fn = fn;
    p->user = user;
    p->tty = isatty(STDERR_FILENO);
    p->start = p->last_report = op_monotonic_seconds();
    pthread_mutex_init(&p->lock, NULL);
    return p;
}

void op_progress_advance(op_progress *p, uint64_t n)
{
    if (!p)
        return;
    atomic_fetch_add(&p->done, n);
    double t = op_monotonic_seconds();
    double interval = p->fn || p->tty ? 0.25 : 5.0;
    /* Racy read of last_report is fine: it only decides whether to try the lock. */
    if (t - p->last_report < interval)
        return;
    if (pthread_mutex_trylock(&p->lock) != 0)
        return;
    if (t - p->last_report >= interval) {
        p->last_report = t;
        report(p, t, 0);
    }
    pthread_mutex_unlock(&p->lock);
}

/* Ends the report begun by op_progress_begin: whoever began p ends it, exactly once, on every
 * path (a second end is a use after free, like a second free). */
void op_progress_end(op_progress *p)
{
    if (!p)
        return;
    pthread_mutex_lock(&p->lock);
    report(p, op_monotonic_seconds(), 1);
    pthread_mutex_unlock(&p->lock);
    pthread_mutex_destroy(&p->lock);
    free(p);
}
