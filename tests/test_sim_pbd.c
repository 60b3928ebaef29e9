/* tests: the PBD guide-strand solver (C backend): the closing root-to-tip pass keeps every
 * segment's length and the stretch the iterations leave it falls as they rise, no vertex ends
 * inside a collider (nor inside Ratboy's body under the animation presets, deeper than it is
 * authored, with every segment within 1% there), a groom authored in contact with its mesh keeps
 * its authored pose and segment lengths there, hair held by the contacts alone comes to rest
 * after motion within the DFTL solver's bound (and with the closing pass's velocity correction
 * at its ends), stiffness and damping mean the same at any dt and substep count, the run-time
 * solver switch keeps the hair where it is, and its results do not depend on the thread count
 * nor on the strands solved beside each one. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "groom/groom.h"
#include "sim/sim.h"
#include "sim/sim_step.h"
#include "support/quality.h"
#include "support/sim_check.h"

static sim_params pbd_params(void)
{
    sim_params p;
    sim_params_default(&p);
    p.solver = SIM_SOLVER_PBD;
    return p;
}

/* The distance constraints converge: the closing root-to-tip pass makes every segment exact
 * (its largest error under violent motion with shape and collisions off, so nothing else holds
 * the lengths, stays below 1e-4), and the stretch the iterations leave it
 * (sim_stats.pbd_stretch_mean, over every segment and substep of the run) falls from 1 to 4 to
 * 16 pbd_iterations and at least halves from 1 to 16: 2.7%, 2.0%, 1.2% (largest 50%, 40%, 23%).
 * Each substep starts from exact lengths, so what is left is the substep's own stretch (the
 * root's motion and gravity), which Gauss-Seidel over even/odd pairs carries about one segment
 * down the strand per iteration: it falls more slowly than the 45%, 15%, 4% the iterations
 * alone left when the stretch piled up from substep to substep. It would not fall if the
 * iterations stopped working. */
static void test_stretch_falls_with_iterations(void **state)
{
    (void)state;
    const int iterations[] = { 1, 4, 16 };
    double err[3];
    for (int i = 0; i < 3; i++) {
        sim_params p = pbd_params();
        p.shape = false;
        p.collisions = false;
        p.pbd_iterations = iterations[i];
        simcheck_run r = { 0 };
        simcheck_groom(&r.groom, GROOM_STRAIGHT, 64, 24, 3);
        simcheck_run_open(&r, &p, 2);
        double exact = 0.0;
        for (int k = 1; k <= 60; k++) {
            simcheck_run_step(&r, simcheck_head_motion(k * (double)p.dt, 1.5));
            exact = simcheck_worse(exact, quality_segment_error_max(&r.groom, r.x, 0.0));
        }
        sim_stats st;
        sim_get_stats(&r.s, &st);
        err[i] = st.pbd_stretch_mean;
        printf("pbd_iterations %2d: stretch left to the closing pass mean %.3e, largest %.3e; after it %.3e\n",
               iterations[i], err[i], st.pbd_stretch_max, exact);
        assert_true(exact <= 1e-4);
        assert_true(st.pbd_stretch_max >= err[i]);
        simcheck_run_close(&r);
    }
    assert_true(err[0] > 0.0);
    assert_true(err[1] < err[0]);
    assert_true(err[2] < err[1]);
    assert_true(err[2] < 0.5 * err[0]);
}

/* No vertex ends a step inside a collider by more than 1% of its radius, through violent motion,
 * at 1 iteration and at the default. */
static void test_no_penetration(void **state)
{
    (void)state;
    const int iterations[] = { 1, 4 };
    for (int i = 0; i < 2; i++) {
        sim_params p = pbd_params();
        p.pbd_iterations = iterations[i];
        simcheck_run r = { 0 };
        simcheck_groom(&r.groom, GROOM_WAVY, 256, 24, 7);
        assert_true(r.groom.ncolliders >= 2);
        simcheck_run_open(&r, &p, 2);
        double worst = -1.0;
        for (int k = 1; k <= 300; k++) {
            const core_xform h = simcheck_head_motion(k * (double)p.dt, 1.5);
            simcheck_run_step(&r, h);
            worst = simcheck_worse(worst, simcheck_deepest_penetration(&r.groom, h, r.x));
        }
        printf("pbd_iterations %d: deepest penetration %.3g of the collider radius\n", iterations[i], worst);
        assert_true(worst <= 0.01);
        simcheck_run_close(&r);
    }
}

/* With shape off, hair that only the contacts hold comes to rest within 3 s of violent motion
 * (the DFTL solver's bound), held by contact friction. The defaults and pbd_iterations at 1 and
 * 32 are in tests/test_sim_rest.c (every parameter at its extremes). */
static void test_rest_shape_off(void **state)
{
    (void)state;
    sim_params p = pbd_params();
    p.shape = false;
    double settle;
    const double rest = simcheck_wavy_rest(&p, &settle);
    printf("pbd shape off: rest p99.9 %.2e mm/frame, settled after %.2f s\n", rest * 1e3, settle);
    assert_true(rest <= SIMCHECK_REST_P999);
}

/* dftl_correction is the closing pass's velocity correction: at its ends (0: none, 1: the whole
 * correction the next vertex got) the hair, shape on, comes to rest within 3 s of violent motion
 * (test_sim_rest takes the other parameters to their ends under pbd only where they are PBD's). */
static void test_rest_at_correction_ends(void **state)
{
    (void)state;
    const float ends[] = { 0.0f, 1.0f };
    for (int i = 0; i < 2; i++) {
        sim_params p = pbd_params();
        p.dftl_correction = ends[i];
        double settle;
        const double rest = simcheck_wavy_rest(&p, &settle);
        printf("pbd dftl_correction %g: rest p99.9 %.2e mm/frame, settled after %.2f s\n", (double)ends[i], rest * 1e3,
               settle);
        assert_true(rest <= SIMCHECK_REST_P999);
    }
}

/* Ratboy with its body's distance grid, PBD at the defaults: under every animation preset (1 s
 * each) every segment of 0.1 mm or more stays within 1% of its length and no vertex ends a step
 * more than 0.5 mm deeper inside than it is authored (1.04 mm at rest with collisions off).
 * Before the closing root-to-tip pass the even/odd distance constraints alone left 34-112% over
 * the presets on the shortest segments (0.1-0.5 mm); pushing each vertex out after the pass
 * without sliding it back to its length left 1-5.6%. Skipped without the assets. */
static void test_ratboy_contacts(void **state)
{
    (void)state;
    core_groom g;
    if (!simcheck_ratboy(&g, true)) skip();
    const sim_params p = pbd_params();
    int failures = 0;
    for (int a = 0; a < APP_PRESET_COUNT; a++) {
        double seg, pen;
        simcheck_preset_errors(&g, &p, (app_preset)a, 1.0, 1e-4, &seg, &pen);
        printf("ratboy pbd %-9s max segment error %.3f%%, deepest penetration %.3f mm\n", app_preset_names[a],
               100.0 * seg, 1e3 * pen);
        failures += !(pen <= 0.0005) + !(seg <= 0.01);
    }
    core_groom_free(&g);
    assert_int_equal(failures, 0);
}

/* The groom is authored in contact with the body: Ratboy at rest with its body's distance
 * grid, gravity off (so that only the contacts could move it), keeps every segment of 0.1 mm or
 * more within 1% of its length and no vertex more than 0.5 mm deeper than authored (94% on the
 * shortest first segments when every vertex was pushed out to the skin). Skipped without the
 * assets. */
static void test_ratboy_authored_contacts(void **state)
{
    (void)state;
    core_groom g;
    if (!simcheck_ratboy(&g, true)) skip();
    sim_params p = pbd_params();
    p.gravity = 0.0f;
    double seg, pen;
    simcheck_preset_errors(&g, &p, APP_PRESET_NONE, 1.0, 1e-4, &seg, &pen);
    printf("ratboy pbd at rest, gravity off: max segment error %.4f%%, deepest penetration beyond the authored "
           "depth %.3f mm\n", 100.0 * seg, 1e3 * pen);
    core_groom_free(&g);
    assert_true(seg <= 0.01);
    assert_true(pen <= 0.0005);
}

/* A groom authored partly inside its mesh's distance grid (a sphere 12 mm outside the head
 * ellipsoid the roots sit on): with nothing else acting (gravity and the analytic colliders
 * off) it stays in its authored pose, on the C backend; every vertex is pushed only to the
 * depth it is authored at (sim_groom_contact_floor). */
static void test_authored_inside_holds(void **state)
{
    (void)state;
    sim_params p = pbd_params();
    p.gravity = 0.0f;
    simcheck_run r = { 0 };
    simcheck_groom(&r.groom, GROOM_WAVY, 64, 16, 5);
    simcheck_sphere_sdf(&r.groom);
    r.groom.ncolliders = 0;
    const size_t n = (size_t)r.groom.nstrands * r.groom.nverts;
    float *fl = malloc(n * sizeof(float));
    assert_non_null(fl);
    sim_groom_contact_floor(&r.groom, fl);
    size_t inside = 0;
    float deepest = 0.0f;
    for (size_t i = 0; i < n; i++) {
        if (i % r.groom.nverts == 0) continue;
        inside += fl[i] < 0.0f;
        deepest = fminf(deepest, fl[i]);
    }
    free(fl);
    simcheck_run_open(&r, &p, 2);
    double moved = 0.0;
    for (int k = 1; k <= 30; k++) {
        simcheck_run_step(&r, core_xform_identity());
        for (size_t i = 0; i < n; i++) moved = simcheck_worse(moved, simcheck_dist3(r.x + 3 * i, r.groom.pos + 3 * i));
    }
    printf("%zu non-root vertices authored inside the grid (deepest %.2f mm): farthest from the authored pose "
           "%.3g mm\n", inside, -1e3 * deepest, 1e3 * moved);
    assert_true(inside > 0 && deepest < -0.005f);
    assert_true(moved <= 1e-6);
    simcheck_run_close(&r);
}


/* The stiffnesses are compliances (per unit of time): settled sag and decay time agree within
 * 10% at (1/60 s, 4 substeps), (1/60 s, 8) and (1/30 s, 8). */
static void test_dt_independence(void **state)
{
    (void)state;
    sim_params p = pbd_params();
    p.global_stiffness = 2000.0f;
    p.local_stiffness = 20000.0f;
    simcheck_dt_independence(&p, 0.10);
}

/* A cancel poll that never abandons a step and counts how often it is asked. */
static bool count_polls(void *ctx)
{
    (*(int *)ctx)++;
    return false;
}

/* Switching solvers at run time (sim_change) keeps every position and velocity, the head, the
 * counters and the cancel poll; the switched solver goes on from there (SPH off: see below);
 * hairmesh on a strand groom is refused and leaves the
 * running solver as it was. */
static void test_switch(void **state)
{
    (void)state;
    sim_params p;
    sim_params_default(&p);
    p.sph = false; /* DFTL's SPH spreads the hair that PBD (no hair-hair forces) lets lie closer */
    simcheck_run r = { 0 };
    simcheck_groom(&r.groom, GROOM_WAVY, 64, 16, 5);
    simcheck_run_open(&r, &p, 2);
    core_err err;
    const size_t n3 = 3 * r.n;
    float *x0 = malloc(n3 * 4), *v0 = malloc(n3 * 4), *x1 = malloc(n3 * 4), *v1 = malloc(n3 * 4);
    assert_true(x0 && v0 && x1 && v1);
    const int32_t order[] = { SIM_SOLVER_PBD, SIM_SOLVER_DFTL, SIM_SOLVER_PBD };
    for (int round = 0; round < 3; round++) {
        /* mid-motion: the state carries over exactly */
        for (int k = 1; k <= 20; k++) simcheck_run_step(&r, simcheck_head_motion(k * (double)p.dt, 1.0));
        assert_int_equal(sim_read_state(&r.s, x0, v0, &err), CORE_OK);
        sim_stats before, after;
        sim_get_stats(&r.s, &before);
        p.solver = order[round];
        if (sim_change(&r.s, &r.groom, &p, &err) != CORE_OK) fail_msg("sim_change: %s", err.msg);
        assert_int_equal(r.s.solver, order[round]);
        sim_get_stats(&r.s, &after); /* the counters go on */
        assert_true(after.steps == before.steps && after.sim_time == before.sim_time);
        assert_int_equal(sim_read_state(&r.s, x1, v1, &err), CORE_OK);
        assert_memory_equal(x0, x1, n3 * 4);
        assert_memory_equal(v0, v1, n3 * 4);
        /* the switched solver takes the hair on from there: it comes to rest, and a switch back
         * and forth at rest hardly moves it (the two solvers hold the same style, up to how far
         * each lets gravity pull it: 0.25 mm at the tips) */
        const double rest = simcheck_motion_then_rest(&r, p.dt, 0.5, 2.0, NULL);
        p.solver = order[round] == SIM_SOLVER_PBD ? SIM_SOLVER_DFTL : SIM_SOLVER_PBD;
        assert_int_equal(sim_change(&r.s, &r.groom, &p, &err), CORE_OK);
        const double moved = simcheck_run_step(&r, core_xform_identity());
        p.solver = order[round];
        assert_int_equal(sim_change(&r.s, &r.groom, &p, &err), CORE_OK);
        printf("on %s: rest p99.9 %.2e mm/frame; a step of the other solver from there moves p99.9 %.4f mm\n",
               sim_solver_name(p.solver), rest * 1e3, moved * 1e3);
        assert_true(rest <= SIMCHECK_REST_P999);
        assert_true(moved < 0.5e-3);
    }
    /* the cancel poll goes with the switch: PBD cannot abandon a step, DFTL asks it again */
    int polls = 0;
    assert_false(sim_set_cancel(&r.s, count_polls, &polls));
    p.solver = SIM_SOLVER_DFTL;
    assert_int_equal(sim_change(&r.s, &r.groom, &p, &err), CORE_OK);
    simcheck_run_step(&r, core_xform_identity());
    assert_true(polls > 0);
    p.solver = SIM_SOLVER_PBD;
    assert_int_equal(sim_change(&r.s, &r.groom, &p, &err), CORE_OK);
    p.solver = SIM_SOLVER_HAIRMESH;
    assert_int_equal(sim_change(&r.s, &r.groom, &p, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "hair-mesh groom"));
    assert_int_equal(r.s.solver, SIM_SOLVER_PBD);
    assert_int_equal(sim_set_params(&r.s, &p, &err), CORE_EINVAL);
    sim_params_default(&p);
    p.solver = SIM_SOLVER_HAIRMESH;
    sim s2;
    assert_int_equal(sim_create(&s2, NULL, &r.groom, &p, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "solver hairmesh needs a hair-mesh groom"));
    p.solver = 3;
    assert_int_equal(sim_params_validate(&p, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "solver"));
    free(x0), free(v0), free(x1), free(v1);
    simcheck_run_close(&r);
}

/* Strands are solved independently: 1 and 3 threads give the same bits. */
static void test_threads_agree(void **state)
{
    (void)state;
    sim_params p = pbd_params();
    simcheck_run a = { 0 }, b = { 0 };
    simcheck_groom(&a.groom, GROOM_CURLY, 200, 16, 9);
    simcheck_groom(&b.groom, GROOM_CURLY, 200, 16, 9);
    simcheck_run_open(&a, &p, 1);
    simcheck_run_open(&b, &p, 3);
    for (int k = 1; k <= 40; k++) {
        const core_xform h = simcheck_head_motion(k * (double)p.dt, 1.5);
        simcheck_run_step(&a, h);
        simcheck_run_step(&b, h);
    }
    assert_memory_equal(a.x, b.x, 12 * a.n);
    simcheck_run_close(&a);
    simcheck_run_close(&b);
}

/* Strands are solved 8 side by side (the vectorized groups): a strand's bits do not depend on
 * its neighbours in the group nor on its place in it. The last 34 strands of a 45-strand groom,
 * run alone (each three lanes earlier, the last group 6 lanes short), end where they did among
 * the 45, positions and velocities. */
static void test_lanes_independent(void **state)
{
    (void)state;
    core_err err;
    sim_params p = pbd_params();
    p.substeps = 2;
    simcheck_run a = { 0 }, b = { 0 };
    simcheck_groom(&a.groom, GROOM_CURLY, 45, 12, 5);
    const uint32_t skip = 8 + 3, nv = a.groom.nverts;
    b.groom = a.groom;
    b.groom.nstrands = a.groom.nstrands - skip;
    b.groom.mesh = NULL, b.groom.sdf = NULL, b.groom.hairmesh = NULL;
    b.groom.pos = malloc(12 * (size_t)b.groom.nstrands * nv);
    assert_non_null(b.groom.pos);
    memcpy(b.groom.pos, a.groom.pos + 3 * (size_t)skip * nv, 12 * (size_t)b.groom.nstrands * nv);
    simcheck_run_open(&a, &p, 1);
    simcheck_run_open(&b, &p, 2);
    for (int k = 1; k <= 30; k++) {
        const core_xform h = simcheck_head_motion(k * (double)p.dt, 1.5);
        simcheck_run_step(&a, h);
        simcheck_run_step(&b, h);
    }
    float *va = malloc(12 * a.n), *vb = malloc(12 * b.n);
    assert_true(va && vb);
    assert_int_equal(sim_read_state(&a.s, NULL, va, &err), CORE_OK);
    assert_int_equal(sim_read_state(&b.s, NULL, vb, &err), CORE_OK);
    assert_memory_equal(a.x + 3 * (size_t)skip * nv, b.x, 12 * b.n);
    assert_memory_equal(va + 3 * (size_t)skip * nv, vb, 12 * b.n);
    free(va), free(vb);
    simcheck_run_close(&a);
    simcheck_run_close(&b);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_stretch_falls_with_iterations),
        cmocka_unit_test(test_no_penetration),
        cmocka_unit_test(test_rest_shape_off),
        cmocka_unit_test(test_rest_at_correction_ends),
        cmocka_unit_test(test_ratboy_contacts),
        cmocka_unit_test(test_ratboy_authored_contacts),
        cmocka_unit_test(test_authored_inside_holds),
        cmocka_unit_test(test_dt_independence),
        cmocka_unit_test(test_switch),
        cmocka_unit_test(test_threads_agree),
        cmocka_unit_test(test_lanes_independent),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
