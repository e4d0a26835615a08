/* parallel.c - a parallel for over POSIX threads (see opaline.h). */
#include "opaline.h"

#include <pthread.h>
#include <stdlib.h>
#include <unistd.h>
#if defined(__SSE__) || defined(__x86_64__)
#include <pmmintrin.h>
#include <xmmintrin.h>
#endif

typedef struct pool {
    void (*fn)(void *user, int task, int thread);
    void *user;
    int ntasks;
    atomic_int next;
    atomic_int *cancel;
} pool;

typedef struct worker {
    pool *p;
    int thread;
} worker;

static void *worker_main(void *arg)
{
    worker *w = arg;
#if defined(__SSE__) || defined(__x86_64__)
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
#endif
    for (;;) {
        if (w->p->cancel && atomic_load(w->p->cancel))
            break;
        int t = atomic_fetch_add(&w->p->next, 1);
        if (t >= w->p->ntasks)
            break;
        w->p->fn(w->p->user, t, w->thread);
    }
    return NULL;
}

int op_parallel_threads(int nthreads)
{
    if (nthreads > 0)
        return nthreads > 1024 ? 1024 : nthreads;
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n < 1 ? 1 : (n > 1024 ? 1024 : (int)n);
}

op_status op_parallel_for(int nthreads, int ntasks, void (*fn)(void *user, int task, int thread),
                          void *user, atomic_int *cancel, op_error *err)
{
    int n = op_parallel_threads(nthreads);
    if (n > ntasks)
        n = ntasks > 0 ? ntasks : 1;
    pool p = {fn, user, ntasks, 0, cancel};
    atomic_init(&p.next, 0);
    worker *ws = calloc((size_t)n, sizeof *ws);
    pthread_t *th = calloc((size_t)n, sizeof *th);
    if (!ws || !th) {
        free(ws);
        free(th);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for %d threads", n);
    }
    int started = 0;
    for (int i = 0; i < n; i++) {
        ws[i].p = &p;
        ws[i].thread = i;
        /* Thread 0 runs on the caller's thread after the others start. */
        if (i > 0) {
            if (pthread_create(&th[i], NULL, worker_main, &ws[i]) != 0)
                break;
            started++;
        }
    }
#if defined(__SSE__) || defined(__x86_64__)
    unsigned int csr = _mm_getcsr();
#endif
    worker_main(&ws[0]);
#if defined(__SSE__) || defined(__x86_64__)
    _mm_setcsr(csr);
#endif
    for (int i = 1; i <= started; i++)
        pthread_join(th[i], NULL);
    free(ws);
    free(th);
    if (cancel && atomic_load(cancel))
        return op_error_set(err, OP_ERR_CANCELLED, "interrupted");
    return OP_OK;
}
