/* sim: a small fixed-size pthread pool that runs one data-parallel job at a time. */
#ifndef SIM_SIM_POOL_H
#define SIM_SIM_POOL_H

#include <pthread.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "../core/core.h"

/* A job: called once per worker with tid in [0, nthreads). */
typedef void (*sim_pool_fn)(void *ctx, int tid, int nthreads);

typedef struct sim_pool {
    int nthreads;          /* workers including the calling thread */
    pthread_t *threads;    /* nthreads - 1 helper threads */
    pthread_mutex_t mu;
    pthread_cond_t wake, done;
    uint64_t generation;
    int pending;
    bool quit;
    sim_pool_fn fn;
    void *ctx;
} sim_pool;

/* Starts nthreads - 1 helper threads (nthreads <= 0: the number of online cores).
 * The pool is owned and driven by one thread (the sim thread). */
core_status sim_pool_init(sim_pool *p, int nthreads, core_err *err);

/* Runs fn on every worker (the caller is worker 0) and returns when all are done. */
void sim_pool_run(sim_pool *p, sim_pool_fn fn, void *ctx);

/* A task of a task job: called once for each task in [0, ntasks), on whichever worker takes it. */
typedef void (*sim_pool_task_fn)(void *ctx, size_t task, size_t ntasks, int worker);

/* Runs fn for every task, the workers (the caller is worker 0) each taking the next task not yet
 * taken, and returns when all are done: a worker slowed by another process leaves its share to
 * the others. What a task computes must not depend on the worker that runs it (per-worker
 * scratch and counters are fine). Called by the pool's owner thread. */
void sim_pool_run_tasks(sim_pool *p, sim_pool_task_fn fn, void *ctx, size_t ntasks);

/* sim_pool_run_tasks for a job written for sim_pool_run: fn(ctx, part, nparts) for every part in
 * [0, nparts), each on whichever worker takes it (so fn must use its index only to pick its
 * share of the work, never for per-worker scratch). */
void sim_pool_run_parts(sim_pool *p, sim_pool_fn fn, void *ctx, int nparts);

/* Joins the helper threads; safe on a zeroed pool. */
void sim_pool_destroy(sim_pool *p);

/* The [begin, end) share of n items for worker tid of nt, in blocks of align items so that
 * vector loops see the same element groups for any thread count. Pure. */
static inline void sim_pool_range(size_t n, int tid, int nt, size_t align, size_t *begin, size_t *end)
{
    size_t blocks = (n + align - 1) / align;
    size_t b = blocks * (size_t)tid / (size_t)nt, e = blocks * (size_t)(tid + 1) / (size_t)nt;
    *begin = b * align < n ? b * align : n;
    *end = e * align < n ? e * align : n;
}

#endif
