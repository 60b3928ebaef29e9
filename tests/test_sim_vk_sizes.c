/* tests: every size the solver benchmark uses allocates and steps on the Vulkan backend. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "groom/groom.h"
#include "sim/sim.h"
#include "support/sim_check.h"
#include "support/vkpin.h"

/* The cases of tests/bench/bench_solver.c: the paper's Table 2 sizes and Table 1 scenes. */
static const uint32_t cases[][2] = {
    { 1024, 8 }, { 1024, 32 }, { 4096, 32 }, { 4096, 64 }, { 16384, 64 },
    { 15000, 23 }, { 500, 16 }, { 3358, 10 }, { 2902, 12 }, { 496, 12 },
};

static void test_benchmark_sizes(void **state)
{
    (void)state;
    sim_params p;
    sim_params_default(&p);
    p.substeps = 1; /* as the benchmark steps them */
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        core_err err;
        core_groom g;
        simcheck_groom(&g, GROOM_STRAIGHT, cases[c][0], cases[c][1], 0);
        sim s;
        sim_desc d = { .backend = SIM_BACKEND_VULKAN };
        if (sim_create(&s, &d, &g, &p, &err) != CORE_OK) fail_msg("%ux%u: %s", g.nstrands, g.nverts, err.msg);
        sim_set_motion(&s, (core_xform){ { 0.01f, 0.0f, 0.0f }, { 0.0f, 0.0f, 0.0f, 1.0f } });
        if (sim_step(&s, &err) != CORE_OK) fail_msg("%ux%u step: %s", g.nstrands, g.nverts, err.msg);
        size_t n = (size_t)g.nstrands * g.nverts;
        float *x = malloc(3 * n * sizeof(float));
        assert_non_null(x);
        assert_int_equal(sim_read_positions(&s, x, &err), CORE_OK);
        double moved = 0.0;
        for (size_t i = 0; i < 3 * n; i++) {
            assert_true(isfinite(x[i]));
            moved += fabs(x[i] - g.pos[i]);
        }
        sim_stats st;
        sim_get_stats(&s, &st);
        printf("%5u x %-3u: one step with SPH + shape + collisions, %.1f ms on the device\n", g.nstrands, g.nverts,
               st.last_step_ms);
        assert_int_equal(st.steps, 1);
        assert_true(moved > 0.0);
        free(x);
        sim_destroy(&s);
        core_groom_free(&g);
    }
}

int main(void)
{
    vkpin_driver_libraries();
    const struct CMUnitTest tests[] = { cmocka_unit_test(test_benchmark_sizes) };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
