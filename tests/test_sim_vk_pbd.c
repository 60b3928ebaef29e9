/* tests: the PBD solver on the Vulkan backend (lavapipe) against the C backend: positions under
 * head motion with colliders and a distance grid, the segment error falling with the
 * iterations, the run-time switch between the DFTL and the PBD solver, the NaN guard and the
 * backend choice. */
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
#include "sim/vk/sim_vk.h"
#include "support/quality.h"
#include "support/sim_check.h"
#include "support/vkpin.h"

static sim_params pbd_params(void)
{
    sim_params p;
    sim_params_default(&p);
    p.solver = SIM_SOLVER_PBD;
    return p;
}

static void open_sim(sim *s, sim_backend_kind kind, const core_groom *g, const sim_params *p)
{
    core_err err;
    sim_desc d = { .backend = kind, .threads = 2 };
    if (sim_create(s, &d, g, p, &err) != CORE_OK) fail_msg("sim_create: %s", err.msg);
    assert_int_equal(sim_backend(s), kind);
}

static void step_to(sim *s, core_xform h, float *x)
{
    core_err err;
    sim_set_motion(s, h);
    if (sim_step(s, &err) != CORE_OK) fail_msg("sim_step: %s", err.msg);
    if (sim_read_positions(s, x, &err) != CORE_OK) fail_msg("read: %s", err.msg);
}

static double max_distance(const float *a, const float *b, size_t n)
{
    double worst = 0.0;
    for (size_t i = 0; i < n; i++) worst = simcheck_worse(worst, simcheck_dist3(a + 3 * i, b + 3 * i));
    return worst;
}

static void assert_no_validation_errors(const sim *s)
{
    bool on;
    const uint32_t errors = sim_vk_validation_errors(s, &on);
    if (on) printf("validation layer on: %u error(s)\n", errors);
    assert_int_equal(errors, 0);
}

/* 30 steps of violent head motion with the head ellipsoid, the other colliders and a distance
 * grid that holds some of the authored vertices (their contact floors below zero, so the pushes
 * read each vertex's floor), every feature of the solver on (shape, friction, damping, drag, 4
 * substeps): the Vulkan
 * positions stay within 1e-5 of the strand length of the C backend's at every step (the same
 * arithmetic in the same order; what differs is the rounding of a few operations on the
 * device, which the motion amplifies; lavapipe gives the same bits). */
static void test_matches_cpu(void **state)
{
    (void)state;
    sim_params p = pbd_params();
    core_groom g;
    simcheck_groom(&g, GROOM_WAVY, 192, 16, 11);
    simcheck_sphere_sdf(&g);
    assert_true(g.ncolliders > 0);
    const size_t n = (size_t)g.nstrands * g.nverts;
    float *fl = malloc(n * sizeof(float));
    assert_non_null(fl);
    sim_groom_contact_floor(&g, fl);
    size_t below = 0;
    for (size_t i = 0; i < n; i++) below += i % g.nverts != 0 && fl[i] < 0.0f;
    free(fl);
    assert_true(below > 0);
    sim cpu, vk;
    open_sim(&cpu, SIM_BACKEND_CPU, &g, &p);
    open_sim(&vk, SIM_BACKEND_VULKAN, &g, &p);
    float *xc = malloc(12 * n), *xv = malloc(12 * n);
    assert_true(xc && xv);
    const double len = simcheck_mean_strand_length(&g);
    double worst = 0.0, first = 0.0, moved = 0.0, pen = 0.0;
    for (int i = 1; i <= 30; i++) {
        const core_xform h = simcheck_head_motion(i * (double)p.dt, 1.0);
        step_to(&cpu, h, xc);
        step_to(&vk, h, xv);
        const double d = max_distance(xc, xv, n);
        if (i == 1) first = d;
        worst = simcheck_worse(worst, d);
        pen = simcheck_worse(pen, quality_penetration_max(&g, h, xv));
    }
    moved = simcheck_mean_distance(xc, g.pos, n);
    sim_stats st, sc;
    sim_get_stats(&vk, &st);
    sim_get_stats(&cpu, &sc);
    printf("pbd, %zu particles, 30 steps: max |vulkan - cpu| after 1 step %.3g m, over all %.3g m = %.3g of the "
           "strand length; mean distance from rest %.3g m; deepest penetration on vulkan %.3g mm; %llu NaN resets; "
           "stretch left to the closing pass mean %.6g / %.6g, largest %.6g / %.6g (vulkan / cpu)\n",
           n, first, worst, worst / len, moved, pen * 1e3, (unsigned long long)st.nan_resets, st.pbd_stretch_mean,
           sc.pbd_stretch_mean, st.pbd_stretch_max, sc.pbd_stretch_max);
    assert_true(st.pbd_stretch_max > 0.0);
    assert_true(fabs(st.pbd_stretch_mean - sc.pbd_stretch_mean) <= 1e-6 * sc.pbd_stretch_mean);
    assert_true(fabs(st.pbd_stretch_max - sc.pbd_stretch_max) <= 1e-6 * sc.pbd_stretch_max);
    assert_true(moved > 0.01);
    assert_true(worst <= 1e-5 * len);
    assert_true(pen <= 0.0005);
    assert_int_equal(st.steps, 30);
    assert_int_equal(st.nan_resets, 0);
    assert_int_equal(st.nstages > 0 ? strcmp(st.stage_names[0], "pbd") : 0, 0);
    assert_no_validation_errors(&vk);
    sim_destroy(&cpu);
    sim_destroy(&vk);
    core_groom_free(&g);
    free(xc);
    free(xv);
}

/* As on the C backend (test_sim_pbd.c): with shape and collisions off, the closing pass leaves
 * every segment within 1e-4 of its length under violent motion, and the stretch the iterations
 * leave it (sim_stats.pbd_stretch_mean) falls from 1 to 4 to 16 iterations and at least halves
 * from 1 to 16 on Vulkan. */
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
        core_groom g;
        simcheck_groom(&g, GROOM_STRAIGHT, 64, 24, 3);
        sim s;
        open_sim(&s, SIM_BACKEND_VULKAN, &g, &p);
        float *x = malloc(12 * (size_t)g.nstrands * g.nverts);
        assert_non_null(x);
        double exact = 0.0;
        for (int k = 1; k <= 30; k++) {
            step_to(&s, simcheck_head_motion(k * (double)p.dt, 1.5), x);
            exact = simcheck_worse(exact, quality_segment_error_max(&g, x, 0.0));
        }
        sim_stats st;
        sim_get_stats(&s, &st);
        err[i] = st.pbd_stretch_mean;
        printf("vulkan, pbd_iterations %2d: stretch left to the closing pass mean %.3e, largest %.3e; after it %.3e\n",
               iterations[i], err[i], st.pbd_stretch_max, exact);
        assert_true(exact <= 1e-4);
        sim_destroy(&s);
        core_groom_free(&g);
        free(x);
    }
    assert_true(err[0] > 0.0);
    assert_true(err[1] < err[0]);
    assert_true(err[2] < err[1]);
    assert_true(err[2] < 0.5 * err[0]);
}

/* sim_change on the Vulkan backend: dftl -> pbd -> dftl mid-motion keeps every position and
 * velocity and the step counter, stays on Vulkan, and the switched solver steps on from there
 * (a step moves the hair by about what the other solver's step did, not from a reset). */
static void test_switch(void **state)
{
    (void)state;
    sim_params p;
    sim_params_default(&p);
    p.sph = false;
    core_groom g;
    simcheck_groom(&g, GROOM_WAVY, 64, 16, 5);
    sim s;
    open_sim(&s, SIM_BACKEND_VULKAN, &g, &p);
    const size_t n = (size_t)g.nstrands * g.nverts;
    float *x0 = malloc(12 * n), *v0 = malloc(12 * n), *x1 = malloc(12 * n), *v1 = malloc(12 * n);
    assert_true(x0 && v0 && x1 && v1);
    core_err err;
    const int32_t order[] = { SIM_SOLVER_PBD, SIM_SOLVER_DFTL };
    int k = 0;
    for (int round = 0; round < 2; round++) {
        for (int i = 0; i < 10; i++) step_to(&s, simcheck_head_motion(++k * (double)p.dt, 1.0), x1);
        assert_int_equal(sim_read_state(&s, x0, v0, &err), CORE_OK);
        p.solver = order[round];
        if (sim_change(&s, &g, &p, &err) != CORE_OK) fail_msg("sim_change: %s", err.msg);
        assert_int_equal(s.solver, order[round]);
        assert_int_equal(sim_backend(&s), SIM_BACKEND_VULKAN);
        sim_stats st;
        sim_get_stats(&s, &st);
        assert_int_equal(st.steps, k);
        assert_int_equal(sim_read_state(&s, x1, v1, &err), CORE_OK);
        assert_memory_equal(x0, x1, 12 * n);
        assert_memory_equal(v0, v1, 12 * n);
        step_to(&s, simcheck_head_motion(++k * (double)p.dt, 1.0), x1);
        const double step = simcheck_mean_distance(x0, x1, n), from_rest = simcheck_mean_distance(x1, g.pos, n);
        printf("on vulkan %s after the switch: a step moves %.3g m on average; %.3g m from the rest pose\n",
               sim_solver_name(p.solver), step, from_rest);
        for (size_t i = 0; i < 3 * n; i++) assert_true(isfinite(x1[i]));
        assert_true(step > 1e-5 && step < 0.05);
        assert_true(from_rest > 1e-3);
    }
    assert_no_validation_errors(&s);
    sim_destroy(&s);
    core_groom_free(&g);
    free(x0), free(v0), free(x1), free(v1);
}

/* The PBD solver on Vulkan holds only its own buffers: the SPH passes' (sorted copies, cells,
 * neighbour lists, accelerations) are placeholders, so it needs less GPU memory than DFTL with
 * SPH on the same groom although its scratch is 120 bytes a particle. */
static void test_pbd_memory(void **state)
{
    (void)state;
    core_groom g;
    simcheck_groom(&g, GROOM_WAVY, 1024, 32, 5);
    const size_t n = (size_t)g.nstrands * g.nverts;
    sim_params p;
    sim_params_default(&p);
    sim dftl, pbd;
    open_sim(&dftl, SIM_BACKEND_VULKAN, &g, &p);
    p = pbd_params();
    open_sim(&pbd, SIM_BACKEND_VULKAN, &g, &p);
    sim_stats sd, sp;
    sim_get_stats(&dftl, &sd);
    sim_get_stats(&pbd, &sp);
    printf("GPU buffers per particle: dftl %.1f bytes, pbd %.1f bytes\n", (double)sd.device_bytes / (double)n,
           (double)sp.device_bytes / (double)n);
    /* pbd: positions, velocities, rest 36, staging 24, scratch 120, floors 4, chain state and
     * the frame slots */
    assert_true(sp.device_bytes > 184 * n);
    assert_true(sp.device_bytes < 200 * n);
    assert_true(sp.device_bytes < sd.device_bytes);
    sim_destroy(&dftl);
    sim_destroy(&pbd);
    core_groom_free(&g);
}

/* A strand that overflows is put back at its rest pose and counted, as on the C backend. */
static void test_nan_guard(void **state)
{
    (void)state;
    sim_params p = pbd_params();
    p.substeps = 1;
    core_groom g;
    simcheck_groom(&g, GROOM_STRAIGHT, 32, 8, 11);
    sim s;
    open_sim(&s, SIM_BACKEND_VULKAN, &g, &p);
    const size_t n = 32 * 8;
    float *x = malloc(12 * n), *v = malloc(12 * n);
    assert_true(x && v);
    core_err err;
    assert_int_equal(sim_read_state(&s, x, v, &err), CORE_OK);
    for (int l = 1; l < 8; l++) x[3 * (5 * 8 + l)] = v[3 * (5 * 8 + l)] = 3.4e38f;
    assert_int_equal(sim_write_state(&s, x, v, &err), CORE_OK);
    step_to(&s, core_xform_identity(), x);
    for (size_t i = 0; i < 3 * n; i++) assert_true(isfinite(x[i]));
    assert_true(simcheck_dist3(x + 3 * (5 * 8 + 7), g.pos + 3 * (5 * 8 + 7)) < 1e-6);
    sim_stats st;
    sim_get_stats(&s, &st);
    assert_int_equal(st.nan_resets, 1);
    sim_reset(&s);
    sim_get_stats(&s, &st);
    assert_int_equal(st.nan_resets, 0);
    sim_destroy(&s);
    core_groom_free(&g);
    free(x);
    free(v);
}

/* pbd on backend vulkan is the Vulkan backend; auto follows the DFTL solver's rule (on this
 * machine, lavapipe or the C backend, whichever the trial steps found faster) and steps;
 * sim_vk_create takes the solver along and refuses hairmesh; a bad device index is refused. */
static void test_backend_choice(void **state)
{
    (void)state;
    sim_params p = pbd_params();
    core_groom g;
    simcheck_groom(&g, GROOM_STRAIGHT, 64, 8, 11);
    sim s;
    core_err err;
    sim_desc d = { .backend = SIM_BACKEND_VULKAN };
    assert_int_equal(sim_create(&s, &d, &g, &p, &err), CORE_OK);
    assert_string_equal(s.vt->name, "vulkan");
    sim_destroy(&s);
    d.backend = SIM_BACKEND_AUTO;
    assert_int_equal(sim_create(&s, &d, &g, &p, &err), CORE_OK);
    printf("auto picked for pbd: %s\n", s.vt->name);
    assert_int_equal(s.solver, SIM_SOLVER_PBD);
    sim_stats st;
    sim_get_stats(&s, &st);
    assert_int_equal(st.steps, 0);
    assert_int_equal(sim_step(&s, &err), CORE_OK);
    sim_destroy(&s);
    d.backend = SIM_BACKEND_VULKAN;
    assert_int_equal(sim_vk_create(&s, &d, NULL, &g, &p, &err), CORE_OK); /* the solver goes with it */
    assert_int_equal(s.solver, SIM_SOLVER_PBD);
    p.pbd_iterations = 2;
    assert_int_equal(sim_set_params(&s, &p, &err), CORE_OK);
    assert_int_equal(sim_step(&s, &err), CORE_OK);
    sim_destroy(&s);
    p.solver = SIM_SOLVER_HAIRMESH;
    assert_int_equal(sim_vk_create(&s, &d, NULL, &g, &p, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "no Vulkan backend"));
    assert_null(s.vt);
    p.solver = SIM_SOLVER_PBD;
    d.device = 99;
    assert_int_equal(sim_create(&s, &d, &g, &p, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "device 99"));
    core_groom_free(&g);
}

int main(void)
{
    vkpin_driver_libraries();
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_matches_cpu), cmocka_unit_test(test_stretch_falls_with_iterations),
        cmocka_unit_test(test_switch),      cmocka_unit_test(test_nan_guard),
        cmocka_unit_test(test_backend_choice),   cmocka_unit_test(test_pbd_memory),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
