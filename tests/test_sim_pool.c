/* Tests of the CPU backend's worker pool: every job part and task runs once, busy workers leave
 * their tasks to free ones. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdatomic.h>
#include <string.h>
#include <time.h>

#include "sim/sim_pool.h"

#define NTASKS 1000

typedef struct task_log {
    atomic_int runs[NTASKS];
    atomic_int by_worker[8];
    atomic_int bad_args;
    int nthreads;
    int slow_worker; /* this worker sleeps in each task it takes; -1 = none */
} task_log;

static void record(void *vctx, size_t task, size_t ntasks, int worker)
{
    task_log *l = vctx;
    if (ntasks != NTASKS || task >= NTASKS || worker < 0 || worker >= l->nthreads) {
        atomic_fetch_add(&l->bad_args, 1);
        return;
    }
    atomic_fetch_add(&l->runs[task], 1);
    atomic_fetch_add(&l->by_worker[worker], 1);
    if (worker == l->slow_worker) {
        struct timespec ts = { 0, 20 * 1000 * 1000 };
        nanosleep(&ts, NULL);
    }
}

static void run_logged(int nthreads, int slow_worker, task_log *l)
{
    sim_pool p;
    core_err err;
    memset(l, 0, sizeof *l);
    l->nthreads = nthreads;
    l->slow_worker = slow_worker;
    assert_int_equal(sim_pool_init(&p, nthreads, &err), CORE_OK);
    sim_pool_run_tasks(&p, record, l, NTASKS);
    sim_pool_destroy(&p);
    assert_int_equal(atomic_load(&l->bad_args), 0);
    for (int t = 0; t < NTASKS; t++) assert_int_equal(atomic_load(&l->runs[t]), 1);
}

/* Every task runs exactly once, for 1 to 5 workers. */
static void test_tasks_run_once(void **state)
{
    (void)state;
    static task_log l;
    for (int n = 1; n <= 5; n++) {
        run_logged(n, -1, &l);
        int total = 0;
        for (int w = 0; w < n; w++) total += atomic_load(&l.by_worker[w]);
        assert_int_equal(total, NTASKS);
    }
}

/* A worker that is held up (here: sleeping 20 ms per task) takes few tasks; the others take
 * the rest instead of waiting for a fixed share to be done. */
static void test_slow_worker_takes_fewer(void **state)
{
    (void)state;
    static task_log l;
    run_logged(3, 0, &l);
    assert_true(atomic_load(&l.by_worker[0]) < NTASKS / 10);
}

typedef struct part_log {
    atomic_int hits[10007];
    atomic_int bad;
} part_log;

static void cover(void *vctx, int part, int nparts)
{
    part_log *l = vctx;
    if (nparts != 64 || part < 0 || part >= nparts) {
        atomic_fetch_add(&l->bad, 1);
        return;
    }
    size_t b, e;
    sim_pool_range(10007, part, nparts, 64, &b, &e);
    for (size_t i = b; i < e; i++) atomic_fetch_add(&l->hits[i], 1);
}

/* sim_pool_run_parts calls a sim_pool_run job once per part: the parts' ranges cover every item once. */
static void test_parts_cover_range(void **state)
{
    (void)state;
    static part_log l;
    memset(&l, 0, sizeof l);
    sim_pool p;
    core_err err;
    assert_int_equal(sim_pool_init(&p, 2, &err), CORE_OK);
    sim_pool_run_parts(&p, cover, &l, 64);
    sim_pool_destroy(&p);
    assert_int_equal(atomic_load(&l.bad), 0);
    for (int i = 0; i < 10007; i++) assert_int_equal(atomic_load(&l.hits[i]), 1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tasks_run_once),
        cmocka_unit_test(test_slow_worker_takes_fewer),
        cmocka_unit_test(test_parts_cover_range),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
