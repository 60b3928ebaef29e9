/* tests: abandoning a step in progress (sim_set_cancel): the CPU backend goes back to the state
 * before the step, bit for bit, so a change applied after the abandoned step and the step taken
 * again give the same hair as the change applied before it. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdlib.h>
#include <string.h>

#include "groom/groom.h"
#include "sim/sim.h"
#include "support/sim_check.h"

#define NS 256
#define NV 16
#define STEPS 48

/* Says true at its `at`-th call (1-based), false otherwise; counts the calls. */
typedef struct poll_ctx {
    int calls, at;
} poll_ctx;

static bool poll_at(void *vctx)
{
    poll_ctx *p = vctx;
    return ++p->calls == p->at;
}

typedef struct twin {
    core_groom g;
    sim s;
    float *x, *v;
} twin;

static void make(twin *t, const sim_params *p)
{
    core_err err;
    simcheck_groom(&t->g, GROOM_WAVY, NS, NV, 11);
    sim_desc d = { .backend = SIM_BACKEND_CPU, .threads = 2 };
    if (sim_create(&t->s, &d, &t->g, p, &err) != CORE_OK) fail_msg("sim_create: %s", err.msg);
    t->x = malloc(sizeof(float) * 3 * NS * NV);
    t->v = malloc(sizeof(float) * 3 * NS * NV);
    assert_non_null(t->x);
    assert_non_null(t->v);
}

static void drop(twin *t)
{
    sim_destroy(&t->s);
    core_groom_free(&t->g);
    free(t->x);
    free(t->v);
}

/* The change made at step i (the same for both sims): gravity, SPH settings that rebuild the
 * neighbour lists, substeps and stiffness, in turn. */
static void change(sim_params *p, int i)
{
    switch (i % 4) {
    case 0: p->gravity = p->gravity > 5.0f ? 2.0f : 9.81f; break;
    case 1: p->sph_radius = p->sph_radius > 0.004f ? 0.003f : 0.005f; break;
    case 2: p->substeps = p->substeps == 4 ? 6 : 4; break;
    case 3: p->local_stiffness = p->local_stiffness > 5e5f ? 2e5f : 1e6f; break;
    }
}

/* Every step of one sim is abandoned once at a different stage (the step's first poll, in or
 * after the SPH pass, after substep k) and taken again after the change; the other applies the same
 * changes before its steps. Positions and velocities agree bit for bit throughout. */
static void test_abandoned_steps_leave_no_trace(void **state)
{
    (void)state;
    sim_params p;
    sim_params_default(&p);
    p.sph_radius = 0.003f;
    twin ref, cut;
    make(&ref, &p);
    make(&cut, &p);
    poll_ctx pc = { 0, 0 };
    assert_true(sim_set_cancel(&cut.s, poll_at, &pc));
    core_err err;
    int abandoned = 0;
    sim_params pr = p, pcut = p;
    for (int i = 0; i < STEPS; i++) {
        const core_xform head = simcheck_head_motion(i / 60.0, 4.0);
        sim_set_motion(&ref.s, head);
        sim_set_motion(&cut.s, head);
        const bool changed = i % 3 == 1;
        if (changed) {
            change(&pr, i);
            assert_int_equal(sim_set_params(&ref.s, &pr, &err), CORE_OK);
        }
        assert_int_equal(sim_step(&ref.s, &err), CORE_OK);

        pc.calls = 0;
        /* a step polls at its start, in its SPH pass (every second step at 30 Hz: after the
         * neighbour lists, after the densities, after the forces) and after each substep but the
         * last: at least `substeps` times */
        pc.at = 1 + i % pcut.substeps;
        core_status st = sim_step(&cut.s, &err);
        assert_int_equal(st, CORE_ECANCELED);
        abandoned++;
        if (changed) {
            change(&pcut, i);
            assert_int_equal(sim_set_params(&cut.s, &pcut, &err), CORE_OK);
        }
        pc.at = 0;
        assert_int_equal(sim_step(&cut.s, &err), CORE_OK);
        assert_int_equal(sim_read_state(&ref.s, ref.x, ref.v, &err), CORE_OK);
        assert_int_equal(sim_read_state(&cut.s, cut.x, cut.v, &err), CORE_OK);
        if (memcmp(ref.x, cut.x, sizeof(float) * 3 * NS * NV) || memcmp(ref.v, cut.v, sizeof(float) * 3 * NS * NV))
            fail_msg("step %d: the state after an abandoned step differs from the one never abandoned", i);
    }
    assert_int_equal(abandoned, STEPS);
    sim_stats sr, sc;
    sim_get_stats(&ref.s, &sr);
    sim_get_stats(&cut.s, &sc);
    assert_int_equal(sr.steps, sc.steps);
    assert_true(sr.sim_time == sc.sim_time);
    drop(&ref);
    drop(&cut);
}

/* Without a poll (NULL), steps are never abandoned; a backend that cannot abandon says so. */
static void test_poll_off(void **state)
{
    (void)state;
    sim_params p;
    sim_params_default(&p);
    twin t;
    make(&t, &p);
    poll_ctx pc = { 0, 1 };
    core_err err;
    assert_true(sim_set_cancel(&t.s, poll_at, &pc));
    assert_int_equal(sim_step(&t.s, &err), CORE_ECANCELED);
    assert_non_null(strstr(err.msg, "abandoned"));
    assert_true(sim_set_cancel(&t.s, NULL, NULL));
    pc.calls = 0;
    assert_int_equal(sim_step(&t.s, &err), CORE_OK);
    assert_int_equal(pc.calls, 0);
    sim_stats st;
    sim_get_stats(&t.s, &st);
    assert_int_equal(st.steps, 1);
    drop(&t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_abandoned_steps_leave_no_trace),
        cmocka_unit_test(test_poll_off),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
