/* parallel.h - the renderer's one thread pool pattern: run ntasks independent tasks on
 * nthreads POSIX threads (tasks taken in index order from a shared counter), with denormals
 * flushed to zero in the workers. Results must depend on the task index only, never on which
 * thread ran it, so the output is the same for any thread count. */
#ifndef OP_PARALLEL_H
#define OP_PARALLEL_H

#include <stdatomic.h>

#include "opaline.h"

/* fn(user, task, thread) for every task in [0, ntasks); thread is in [0, nthreads). Stops
 * handing out tasks once *cancel (if not NULL) becomes non-zero and then returns
 * OP_ERR_CANCELLED. nthreads <= 0 means all cores. */
op_status op_parallel_for(int nthreads, int ntasks, void (*fn)(void *user, int task, int thread),
                          void *user, atomic_int *cancel, op_error *err);
/* The number of threads op_parallel_for uses for nthreads (<= 0: online cores). */
int op_parallel_threads(int nthreads);

#endif
