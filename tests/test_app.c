/* Tests for the app's pure pieces: the command mailbox (order, coalescing, bound) and the
 * preset head animations. The pipeline itself is exercised end to end by tests/it_net.c. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <string.h>

#include "app_internal.h"

static app_cmd msg_cmd(uint32_t client, proto_type t, float x)
{
    app_cmd c;
    memset(&c, 0, sizeof c);
    c.kind = APP_CMD_MSG;
    c.client = client;
    c.msg.type = t;
    c.msg.u.motion.position.x = x;
    return c;
}

static void test_mailbox_order_and_coalescing(void **state)
{
    (void)state;
    app_mailbox m;
    core_err err;
    assert_int_equal(app_mailbox_init(&m, &err), CORE_OK);
    app_cmd open = { .kind = APP_CMD_OPEN, .client = 1 };
    assert_int_equal(app_mailbox_post(&m, &open), CORE_OK);
    app_cmd c = msg_cmd(1, PROTO_MOTION, 1.0f);
    assert_int_equal(app_mailbox_post(&m, &c), CORE_OK);
    c = msg_cmd(2, PROTO_MOTION, 2.0f); /* replaces the motion still at the tail */
    assert_int_equal(app_mailbox_post(&m, &c), CORE_OK);
    c = msg_cmd(1, PROTO_RESET, 0.0f);
    assert_int_equal(app_mailbox_post(&m, &c), CORE_OK);
    c = msg_cmd(1, PROTO_MOTION, 3.0f); /* after a reset: a new entry, order kept */
    assert_int_equal(app_mailbox_post(&m, &c), CORE_OK);
    app_cmd out;
    assert_true(app_mailbox_take(&m, &out));
    assert_int_equal(out.kind, APP_CMD_OPEN);
    assert_true(app_mailbox_take(&m, &out));
    assert_int_equal(out.msg.type, PROTO_MOTION);
    assert_int_equal(out.client, 2);
    assert_true(out.msg.u.motion.position.x == 2.0f);
    assert_true(app_mailbox_take(&m, &out));
    assert_int_equal(out.msg.type, PROTO_RESET);
    assert_true(app_mailbox_take(&m, &out));
    assert_true(out.msg.u.motion.position.x == 3.0f);
    assert_false(app_mailbox_take(&m, &out));
    app_mailbox_free(&m);
}

static void test_mailbox_bound_and_wait(void **state)
{
    (void)state;
    app_mailbox m;
    core_err err;
    assert_int_equal(app_mailbox_init(&m, &err), CORE_OK);
    app_cmd c = msg_cmd(1, PROTO_GET_PARAMS, 0.0f);
    for (int i = 0; i < APP_MAILBOX; i++) assert_int_equal(app_mailbox_post(&m, &c), CORE_OK);
    assert_int_equal(app_mailbox_post(&m, &c), CORE_ENOMEM);
    app_cmd out;
    assert_true(app_mailbox_take(&m, &out));
    assert_int_equal(app_mailbox_post(&m, &c), CORE_OK);
    /* a wait returns at once when commands are queued, and at the deadline otherwise */
    unsigned long long t0 = core_now_ns();
    app_mailbox_wait(&m, t0 + 2000000000ull);
    assert_true(core_now_ns() - t0 < 1000000000ull);
    while (app_mailbox_take(&m, &out)) {}
    t0 = core_now_ns();
    app_mailbox_wait(&m, t0 + 30000000ull);
    assert_true(core_now_ns() - t0 >= 25000000ull);
    app_mailbox_wake(&m);
    t0 = core_now_ns();
    app_mailbox_wait(&m, t0 + 2000000000ull);
    assert_true(core_now_ns() - t0 < 1000000000ull);
    app_mailbox_free(&m);
}

static float dist(core_vec3 a, core_vec3 b) { return core_v3_len(core_v3_sub(a, b)); }

static void test_presets(void **state)
{
    (void)state;
    core_xform base = { { 0.1f, 0.2f, 0.3f }, core_q_norm((core_quat){ 0.0f, 0.3f, 0.0f, 0.95f }) };
    core_xform none = app_anim_head(APP_PRESET_NONE, 1.7, base);
    assert_memory_equal(&none, &base, sizeof base);
    const core_vec3 neck = { 0.0f, -0.12f, 0.0f }, crown = { 0.05f, 0.1f, 0.08f }; /* off every axis */
    for (int p = APP_PRESET_NOD; p < APP_PRESET_COUNT; p++) {
        float moved = 0.0f;
        core_xform prev = app_anim_head((app_preset)p, 0.0, base);
        for (int i = 1; i <= 240; i++) {
            double t = i / 60.0;
            core_xform x = app_anim_head((app_preset)p, t, base);
            /* rotations pivot at the neck; the circle only translates (at most 12 cm) */
            if (p != APP_PRESET_CIRCLE) assert_true(dist(core_xform_point(x, neck), core_xform_point(base, neck)) < 1e-5f);
            else assert_true(dist(x.pos, base.pos) <= 0.1201f);
            /* smooth: a frame moves the crown by less than 3 cm */
            assert_true(dist(core_xform_point(x, crown), core_xform_point(prev, crown)) < 0.03f);
            moved = fmaxf(moved, dist(core_xform_point(x, crown), core_xform_point(base, crown)));
            prev = x;
        }
        if (!(moved > 0.02f)) fail_msg("preset %s moves the crown only %g m", app_preset_names[p], moved);
    }
    assert_string_equal(app_preset_names[APP_PRESET_NONE], "none");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mailbox_order_and_coalescing),
        cmocka_unit_test(test_mailbox_bound_and_wait),
        cmocka_unit_test(test_presets),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
