/* sim: the worker pool behind the CPU backend's parallel loops. */
#include "sim_pool.h"

#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

typedef struct worker_arg {
    sim_pool *pool;
    int tid;
} worker_arg;

static void *worker_main(void *arg)
{
    worker_arg wa = *(worker_arg *)arg;
    free(arg);
    sim_pool *p = wa.pool;
    uint64_t seen = 0;
    pthread_mutex_lock(&p->mu);
    for (;;) {
        while (!p->quit && p->generation == seen) pthread_cond_wait(&p->wake, &p->mu);
        if (p->quit) break;
        seen = p->generation;
        sim_pool_fn fn = p->fn;
        void *ctx = p->ctx;
        pthread_mutex_unlock(&p->mu);
        fn(ctx, wa.tid, p->nthreads);
        pthread_mutex_lock(&p->mu);
        if (--p->pending == 0) pthread_cond_signal(&p->done);
    }
    pthread_mutex_unlock(&p->mu);
    return NULL;
}

core_status sim_pool_init(sim_pool *p, int nthreads, core_err *err)
{
    memset(p, 0, sizeof *p);
    if (nthreads <= 0) {
        long n = sysconf(_SC_NPROCESSORS_ONLN);
        nthreads = n > 0 ? (int)n : 1;
    }
    if (nthreads > 256) return core_fail(err, CORE_EINVAL, "threads: %d is more than 256", nthreads);
    p->nthreads = nthreads;
    pthread_mutex_init(&p->mu, NULL);
    pthread_cond_init(&p->wake, NULL);
    pthread_cond_init(&p->done, NULL);
    if (nthreads == 1) return CORE_OK;
    p->threads = calloc((size_t)nthreads - 1, sizeof *p->threads);
    if (!p->threads) {
        sim_pool_destroy(p);
        return core_fail(err, CORE_ENOMEM, "out of memory for %d threads", nthreads);
    }
    for (int i = 1; i < nthreads; i++) {
        worker_arg *wa = malloc(sizeof *wa);
        if (wa) {
            wa->pool = p;
            wa->tid = i;
        }
        if (!wa || pthread_create(&p->threads[i - 1], NULL, worker_main, wa) != 0) {
            free(wa);
            p->nthreads = i; /* join the ones that started */
            sim_pool_destroy(p);
            return core_fail(err, CORE_EBACKEND, "could not start worker thread %d", i);
        }
    }
    return CORE_OK;
}

void sim_pool_run(sim_pool *p, sim_pool_fn fn, void *ctx)
{
    if (p->nthreads <= 1) {
        fn(ctx, 0, 1);
        return;
    }
    pthread_mutex_lock(&p->mu);
    p->fn = fn;
    p->ctx = ctx;
    p->pending = p->nthreads - 1;
    p->generation++;
    pthread_cond_broadcast(&p->wake);
    pthread_mutex_unlock(&p->mu);
    fn(ctx, 0, p->nthreads);
    pthread_mutex_lock(&p->mu);
    while (p->pending > 0) pthread_cond_wait(&p->done, &p->mu);
    pthread_mutex_unlock(&p->mu);
}

typedef struct task_run {
    sim_pool_task_fn fn;
    void *ctx;
    size_t ntasks;
    atomic_size_t next;
} task_run;

static void task_worker(void *vctx, int tid, int nt)
{
    (void)nt;
    task_run *r = vctx;
    for (size_t t; (t = atomic_fetch_add_explicit(&r->next, 1, memory_order_relaxed)) < r->ntasks;)
        r->fn(r->ctx, t, r->ntasks, tid);
}

void sim_pool_run_tasks(sim_pool *p, sim_pool_task_fn fn, void *ctx, size_t ntasks)
{
    task_run r = { fn, ctx, ntasks, 0 };
    sim_pool_run(p, task_worker, &r);
}

typedef struct parts_run {
    sim_pool_fn fn;
    void *ctx;
} parts_run;

static void part_task(void *vctx, size_t task, size_t ntasks, int worker)
{
    (void)worker;
    const parts_run *r = vctx;
    r->fn(r->ctx, (int)task, (int)ntasks);
}

void sim_pool_run_parts(sim_pool *p, sim_pool_fn fn, void *ctx, int nparts)
{
    parts_run r = { fn, ctx };
    sim_pool_run_tasks(p, part_task, &r, nparts > 0 ? (size_t)nparts : 1);
}

void sim_pool_destroy(sim_pool *p)
{
    if (p->nthreads == 0) return;
    if (p->threads) {
        pthread_mutex_lock(&p->mu);
        p->quit = true;
        pthread_cond_broadcast(&p->wake);
        pthread_mutex_unlock(&p->mu);
        for (int i = 1; i < p->nthreads; i++) pthread_join(p->threads[i - 1], NULL);
        free(p->threads);
    }
    pthread_mutex_destroy(&p->mu);
    pthread_cond_destroy(&p->wake);
    pthread_cond_destroy(&p->done);
    memset(p, 0, sizeof *p);
}
