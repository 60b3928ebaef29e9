/* Tests for app_groom_load_named (app/app_groom.c): every name of app_groom_styles loads, the
 * procedural ones as strand grooms, the hairmesh:<style> ones traced through a hair mesh (the
 * guides rounded up to whole strands per face); unknown names are refused naming the style. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <stdio.h>
#include <string.h>

#include "app/app_groom.h"

static void test_every_style_loads(void **state)
{
    (void)state;
    int hairmeshes = 0;
    for (int i = 0; i < APP_NSTYLES; i++) {
        const char *name = app_groom_styles[i];
        app_groom g;
        core_err err;
        if (app_groom_load_named(name, 50, 6, 0, &g, &err) != CORE_OK) fail_msg("%s: %s", name, err.msg);
        const bool hm = strncmp(name, "hairmesh:", 9) == 0;
        char want[64];
        snprintf(want, sizeof want, "%s%s", hm ? "" : "procedural:", name);
        assert_string_equal(g.source, want);
        assert_int_equal(g.g.nverts, 6);
        if (hm) {
            hairmeshes++;
            assert_non_null(g.g.hairmesh);
            assert_non_null(g.hairmesh_bin);
            assert_int_equal(g.g.hairmesh->nguides, g.g.nstrands);
            assert_true(g.g.nstrands >= 50 && g.g.nstrands % g.g.hairmesh->nfaces == 0);
        } else {
            assert_null(g.g.hairmesh);
            assert_int_equal(g.g.nstrands, 50);
        }
        app_groom_free(&g);
    }
    assert_int_equal(hairmeshes, 3);
}

static void test_unknown_style_refused(void **state)
{
    (void)state;
    const char *bad[] = { "braided", "hairmesh:braided", "hairmesh:", "" };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        app_groom g;
        core_err err;
        assert_int_not_equal(app_groom_load_named(bad[i], 16, 4, 0, &g, &err), CORE_OK);
        assert_non_null(strstr(err.msg, "style"));
        assert_null(g.g.pos);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_style_loads),
        cmocka_unit_test(test_unknown_style_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
