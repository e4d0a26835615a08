/* test_parallel.c - op_parallel_for, the one thread pool: every task index is run exactly once
 * for any thread count and task count (0 and 1 included), thread indices stay in range,
 * results depend on the task only (denormals flushed in every worker, the caller's mode
 * restored), and cancellation stops handing out tasks and reports OP_ERR_CANCELLED. */
#include <float.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "test_support.h"

typedef struct visits {
    int ntasks, nthreads;
    atomic_int *count;   /* ntasks counters */
    atomic_int bad;      /* a task or thread index out of range */
    float *out;          /* ntasks results */
    atomic_int *cancel;  /* set when task == cancel_at */
    int cancel_at;
} visits;

/* A result that depends on the task only, through a denormal intermediate: the same bits on
 * every thread only when every worker flushes denormals the same way. */
static float task_value(int task)
{
    volatile float tiny = FLT_MIN;
    volatile float d = tiny * 0.25f * (float)(1 + task % 3); /* denormal unless flushed */
    return d * 4.0f + (float)task;
}

static void visit(void *user, int task, int thread)
{
    visits *v = user;
    if (task < 0 || task >= v->ntasks || thread < 0 || thread >= v->nthreads) {
        atomic_fetch_add(&v->bad, 1);
        return;
    }
    atomic_fetch_add(&v->count[task], 1);
    v->out[task] = task_value(task);
    if (v->cancel && task == v->cancel_at)
        atomic_store(v->cancel, 1);
}

static void visits_init(visits *v, int ntasks, int nthreads)
{
    memset(v, 0, sizeof *v);
    v->ntasks = ntasks;
    /* the threads used: op_parallel_threads' count, at most one per task, at least one */
    int n = op_parallel_threads(nthreads);
    v->nthreads = n > ntasks ? (ntasks > 0 ? ntasks : 1) : n;
    v->count = calloc((size_t)ntasks + 1, sizeof *v->count);
    v->out = calloc((size_t)ntasks + 1, sizeof *v->out);
    assert_true(v->count && v->out);
    for (int i = 0; i < ntasks; i++)
        atomic_init(&v->count[i], 0);
    atomic_init(&v->bad, 0);
}

static void visits_free(visits *v)
{
    free(v->count);
    free(v->out);
}

static void every_index_once(void **state)
{
    (void)state;
    static const int threads[] = {1, 2, 3, 8, 0, -1};
    static const int tasks[] = {0, 1, 2, 7, 64, 1000};
    float *ref = NULL;
    for (size_t k = 0; k < sizeof tasks / sizeof tasks[0]; k++) {
        int nt = tasks[k];
        free(ref);
        ref = NULL;
        for (size_t t = 0; t < sizeof threads / sizeof threads[0]; t++) {
            visits v;
            visits_init(&v, nt, threads[t]);
            op_error err = {0};
            op_status st = op_parallel_for(threads[t], nt, visit, &v, NULL, &err);
            OP_ASSERT_OK(st, err);
            assert_int_equal(atomic_load(&v.bad), 0);
            for (int i = 0; i < nt; i++)
                if (atomic_load(&v.count[i]) != 1)
                    fail_msg("%d threads, %d tasks: task %d ran %d times", threads[t], nt, i,
                             atomic_load(&v.count[i]));
            /* the same results, bit for bit, for every thread count */
            if (!ref) {
                ref = calloc((size_t)nt + 1, sizeof *ref);
                assert_non_null(ref);
                memcpy(ref, v.out, (size_t)nt * sizeof *ref);
            } else if (nt > 0) {
                assert_memory_equal(ref, v.out, (size_t)nt * sizeof *ref);
            }
            visits_free(&v);
        }
    }
    free(ref);
    /* the workers flush denormals; the caller's own mode is restored afterwards */
    visits v;
    visits_init(&v, 4, 2);
    op_error err = {0};
    OP_ASSERT_OK(op_parallel_for(2, 4, visit, &v, NULL, &err), err);
    for (int i = 0; i < 4; i++)
        assert_true(v.out[i] == (float)i);
    visits_free(&v);
    volatile float tiny = FLT_MIN;
    volatile float d = tiny * 0.25f;
    assert_true(d > 0.0f);
}

static void thread_counts(void **state)
{
    (void)state;
    assert_int_equal(op_parallel_threads(1), 1);
    assert_int_equal(op_parallel_threads(5), 5);
    assert_int_equal(op_parallel_threads(100000), 1024);
    assert_true(op_parallel_threads(0) >= 1 && op_parallel_threads(0) <= 1024);
    assert_int_equal(op_parallel_threads(-3), op_parallel_threads(0));
}

static void cancellation(void **state)
{
    (void)state;
    /* one thread: tasks run in index order, none after the one that cancels */
    atomic_int cancel;
    atomic_init(&cancel, 0);
    visits v;
    visits_init(&v, 100, 1);
    v.cancel = &cancel;
    v.cancel_at = 5;
    op_error err = {0};
    op_status st = op_parallel_for(1, 100, visit, &v, &cancel, &err);
    assert_int_equal(st, OP_ERR_CANCELLED);
    assert_non_null(strstr(err.message, "interrupted"));
    for (int i = 0; i < 100; i++)
        assert_int_equal(atomic_load(&v.count[i]), i <= 5 ? 1 : 0);
    visits_free(&v);

    /* several threads: each thread stops taking tasks; none runs twice, most never run */
    atomic_init(&cancel, 0);
    visits_init(&v, 100000, 4);
    v.cancel = &cancel;
    v.cancel_at = 10;
    st = op_parallel_for(4, 100000, visit, &v, &cancel, &err);
    assert_int_equal(st, OP_ERR_CANCELLED);
    int ran = 0;
    for (int i = 0; i < 100000; i++) {
        assert_true(atomic_load(&v.count[i]) <= 1);
        ran += atomic_load(&v.count[i]);
    }
    assert_int_equal(atomic_load(&v.bad), 0);
    assert_true(ran >= 11 && ran < 100000);
    visits_free(&v);

    /* cancelled before the start: nothing runs */
    atomic_init(&cancel, 1);
    visits_init(&v, 10, 3);
    st = op_parallel_for(3, 10, visit, &v, &cancel, NULL);
    assert_int_equal(st, OP_ERR_CANCELLED);
    for (int i = 0; i < 10; i++)
        assert_int_equal(atomic_load(&v.count[i]), 0);
    visits_free(&v);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(every_index_once),
        cmocka_unit_test(thread_counts),
        cmocka_unit_test(cancellation),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
