/* Tests for the app's pure pieces: the command mailbox (order, coalescing, bound), the preset
 * head animations and the blend between them, and the frame streams (rate decimation, sharing, the full-table fallback,
 * the publish schedule). The pipeline itself is exercised end to end by tests/it/. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "app/app_anim.h"
#include "app/app_mailbox.h"
#include "app/app_parser.h"
#include "app/app_peers.h"
#include "app/app_stream.h"

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
    c = msg_cmd(1, PROTO_MOTION, 4.0f); /* one with an id replaces the tail, and stays for its reply */
    c.msg.id.kind = PROTO_ID_NUMBER;
    assert_int_equal(app_mailbox_post(&m, &c), CORE_OK);
    c = msg_cmd(1, PROTO_MOTION, 5.0f);
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
    assert_true(out.msg.u.motion.position.x == 4.0f && out.msg.id.kind == PROTO_ID_NUMBER);
    assert_true(app_mailbox_take(&m, &out));
    assert_true(out.msg.u.motion.position.x == 5.0f);
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

static float angle_between(core_quat a, core_quat b)
{
    float d = fabsf(a.x * b.x + a.y * b.y + a.z * b.z + a.w * b.w);
    return 2.0f * acosf(fminf(d, 1.0f));
}

static void test_blend_pure(void **state)
{
    (void)state;
    core_xform a = { { 0.1f, 0.2f, 0.3f }, core_q_axis_angle(core_v3(0, 1, 0), 0.5f) };
    core_xform b = { { -0.1f, 0.0f, 0.3f }, core_q_axis_angle(core_v3(1, 0, 0), -0.4f) };
    core_xform x = app_anim_blend(a, b, 0.0);
    assert_memory_equal(&x, &a, sizeof a);
    x = app_anim_blend(a, b, 1.0);
    assert_memory_equal(&x, &b, sizeof b);
    x = app_anim_blend(a, b, 0.5);
    assert_true(dist(x.pos, core_v3(0.0f, 0.1f, 0.3f)) < 1e-6f);
    assert_true(fabsf(angle_between(x.rot, a.rot) - angle_between(x.rot, b.rot)) < 1e-3f);
    /* the shorter arc: -q is the same rotation */
    core_xform nb = { b.pos, { -b.rot.x, -b.rot.y, -b.rot.z, -b.rot.w } };
    core_xform y = app_anim_blend(a, nb, 0.5);
    assert_true(fabsf(x.rot.x * y.rot.x + x.rot.y * y.rot.y + x.rot.z * y.rot.z + x.rot.w * y.rot.w) > 1.0f - 1e-6f);
    assert_true(app_anim_blend_weight(-1.0) == 0.0 && app_anim_blend_weight(0.0) == 0.0);
    assert_true(app_anim_blend_weight(APP_ANIM_BLEND_S) == 1.0 && app_anim_blend_weight(10.0) == 1.0);
    assert_true(fabs(app_anim_blend_weight(0.5 * APP_ANIM_BLEND_S) - 0.5) < 1e-12);
    for (double t = 0.0; t < APP_ANIM_BLEND_S; t += 0.001) /* increasing, zero slope at the ends */
        assert_true(app_anim_blend_weight(t + 0.001) >= app_anim_blend_weight(t));
    assert_true(app_anim_blend_weight(0.001) < 1e-4 && 1.0 - app_anim_blend_weight(APP_ANIM_BLEND_S - 0.001) < 1e-4);
}

/* Runs s for `steps` steps of dt as the sim thread does (advance, then the pose), checking that
 * the crown never moves 3 cm in a step (test_presets' smoothness bound); returns the last pose. */
static core_xform run_steps(app_anim *s, int steps, double dt, core_xform prev)
{
    const core_vec3 crown = { 0.05f, 0.1f, 0.08f };
    for (int i = 0; i < steps; i++) {
        app_anim_advance(s, dt);
        core_xform x = app_anim_pose(s);
        if (!(dist(core_xform_point(x, crown), core_xform_point(prev, crown)) < 0.03f))
            fail_msg("%s: the crown moves %g m in a step", app_preset_names[s->preset],
                     dist(core_xform_point(x, crown), core_xform_point(prev, crown)));
        prev = x;
    }
    return prev;
}

/* A change of preset at step boundary: the head moves < 2 mm and < 0.02 rad over the step that
 * follows it (where snapping to the new preset, as before, moves it by centimetres or tenths of
 * a radian), and once APP_ANIM_BLEND_S has passed it is exactly the new preset's pose. */
static void check_switch(app_anim *s, app_preset to, double dt, bool by_motion)
{
    core_xform before = app_anim_pose(s);
    core_xform snapped = app_anim_head(to, dt * s->speed, s->base); /* the old code's next pose */
    if (by_motion) assert_true(app_anim_motion(s, s->base));
    else app_anim_start(s, to, s->speed);
    core_xform now = app_anim_pose(s);
    assert_memory_equal(&now, &before, sizeof now); /* continuous at the change itself */
    app_anim_advance(s, dt);
    core_xform after = app_anim_pose(s);
    float dp = dist(after.pos, before.pos), da = angle_between(after.rot, before.rot);
    float old_dp = dist(snapped.pos, before.pos), old_da = angle_between(snapped.rot, before.rot);
    printf("-> %s: step after the change moves %.3f mm, %.4f rad (snapping: %.1f mm, %.3f rad)\n",
           app_preset_names[to], 1e3 * dp, da, 1e3 * old_dp, old_da);
    assert_true(dp < 0.002f && da < 0.02f);
    assert_false(old_dp < 0.002f && old_da < 0.02f); /* the check catches the old snap */
    int blend_steps = (int)ceil(APP_ANIM_BLEND_S / dt);
    after = run_steps(s, blend_steps, dt, after);
    core_xform want = app_anim_head(to, s->time, s->base);
    assert_memory_equal(&after, &want, sizeof want);
}

static void test_preset_switch_blends(void **state)
{
    (void)state;
    const double dt = 1.0 / 60.0;
    app_anim s;
    app_anim_init(&s);
    core_xform base = { { 0.1f, 1.6f, -0.2f }, core_q_norm((core_quat){ 0.0f, 0.3f, 0.0f, 0.95f }) };
    assert_false(app_anim_motion(&s, base)); /* no preset: the head follows the client at once */
    core_xform x = app_anim_pose(&s);
    assert_memory_equal(&x, &base, sizeof base);

    app_anim_start(&s, APP_PRESET_SHAKE, 1.0);
    x = run_steps(&s, 25, dt, x);        /* t = 0.4167 s: shake at its 0.6 rad extreme */
    check_switch(&s, APP_PRESET_HEADBANG, dt, false);
    app_anim_start(&s, APP_PRESET_NOD, 1.0);
    x = run_steps(&s, 30, dt, app_anim_pose(&s)); /* t = 0.5 s: nod at its 0.3 rad extreme */
    check_switch(&s, APP_PRESET_NONE, dt, false);
    check_switch(&s, APP_PRESET_CIRCLE, dt, false);
    /* a motion while a preset runs stops it, blending too */
    app_anim_start(&s, APP_PRESET_NOD, 1.0);
    x = run_steps(&s, 30, dt, app_anim_pose(&s));
    check_switch(&s, APP_PRESET_NONE, dt, true);
    /* a change in the middle of a blend starts from the blended pose */
    app_anim_start(&s, APP_PRESET_SHAKE, 2.0);
    x = run_steps(&s, 13, dt, app_anim_pose(&s));
    app_anim_start(&s, APP_PRESET_HEADBANG, 2.0);
    x = run_steps(&s, 6, dt, x);
    check_switch(&s, APP_PRESET_SWAY, dt, false);
}

static void test_stream_decimation(void **state)
{
    (void)state;
    assert_int_equal(app_stream_decimation(60, 0), 1);
    assert_int_equal(app_stream_decimation(60, 60), 1);
    assert_int_equal(app_stream_decimation(60, 240), 1);
    assert_int_equal(app_stream_decimation(60, 59.9), 1);
    assert_int_equal(app_stream_decimation(60, 30), 2);
    assert_int_equal(app_stream_decimation(60, 25), 2);
    assert_int_equal(app_stream_decimation(60, 20), 3);
    assert_int_equal(app_stream_decimation(60, 60.0 / 7.0), 7);
    assert_int_equal(app_stream_decimation(30, 10), 3);
    assert_int_equal(app_stream_decimation(60, 1e-9), APP_MAX_DECIMATION);
    for (double r = 0.5; r <= 240; r += 0.25) {
        uint32_t k = app_stream_decimation(60, r);
        /* the stream is at least as fast as asked, and one more step would be slower */
        if (r < 60) assert_true(60.0 / k >= r * (1 - 1e-9) && 60.0 / (k + 1) < r);
    }
}

/* Streams for a small groom at the default publishing rate (no net). */
static void tiny_streams(app_streams *ss)
{
    app_streams_init(ss, NULL, 60, 1e-4, 30, 16, 4);
}

static void test_streams_share_and_fall_back(void **state)
{
    (void)state;
    app_streams a;
    tiny_streams(&a);
    int full = app_stream_acquire(&a, PROTO_SOURCE_STRANDS, 1, 1e-4, 0), half = app_stream_acquire(&a, PROTO_SOURCE_STRANDS, 1, 1e-4, 30);
    assert_true(full >= 0 && half >= 0 && full != half);
    assert_int_equal(app_stream_acquire(&a, PROTO_SOURCE_STRANDS, 1, 1e-4, 25), half); /* 25 Hz: the 30 Hz stream */
    assert_int_equal(a.s[half].subscribers, 2);
    assert_int_equal(a.s[half].decimation, 2);
    assert_true(a.s[half].ready);
    /* fill every other slot with other settings */
    for (int i = 2; i < NET_MAX_STREAMS; i++) assert_true(app_stream_acquire(&a, PROTO_SOURCE_STRANDS, 1 + i, 1e-4, 0) >= 0);
    assert_int_equal(app_stream_acquire(&a, PROTO_SOURCE_STRANDS, 99, 1e-4, 0), -1);
    /* full table: 10 Hz shares the nearest faster stream of the same stride and error (30 Hz) */
    assert_int_equal(app_stream_acquire(&a, PROTO_SOURCE_STRANDS, 1, 1e-4, 10), half);
    assert_int_equal(a.s[half].subscribers, 3);
    /* a faster rate than any stream of those settings has no fallback */
    assert_int_equal(app_stream_acquire(&a, PROTO_SOURCE_STRANDS, 1, 2e-4, 0), -1);
    /* with the default stream gone, its slot is kept for it: other settings are refused */
    app_stream_release(&a, full);
    assert_false(a.s[full].used);
    assert_int_equal(app_stream_acquire(&a, PROTO_SOURCE_STRANDS, 99, 1e-4, 0), -1);
    assert_int_equal(app_stream_acquire(&a, PROTO_SOURCE_STRANDS, 1, 1e-4, 45), full); /* 45 Hz: every round, the default stream */
    assert_int_equal(app_stream_acquire(&a, PROTO_SOURCE_STRANDS, 1, 1e-4, 0), full);
    assert_int_equal(a.s[full].subscribers, 2);
    app_stream_release(&a, full);
    app_stream_release(&a, full);
    app_stream_release(&a, half);
    app_stream_release(&a, half);
    app_stream_release(&a, half);
    assert_false(a.s[half].used);
    app_streams_free(&a);
}

static void test_streams_due_schedule(void **state)
{
    (void)state;
    app_streams a;
    tiny_streams(&a);
    int full = app_stream_acquire(&a, PROTO_SOURCE_STRANDS, 1, 1e-4, 0), third = app_stream_acquire(&a, PROTO_SOURCE_STRANDS, 1, 1e-4, 20);
    int idle = app_stream_acquire(&a, PROTO_SOURCE_STRANDS, 2, 1e-4, 0);
    app_stream_release(&a, idle);
    assert_int_equal(a.s[third].decimation, 3);
    int nfull = 0, nthird = 0;
    for (int round = 0; round < 12; round++) {
        assert_true(app_streams_due(&a, true, false));
        nfull += a.s[full].due;
        nthird += a.s[third].due;
        assert_false(a.s[idle].due); /* released: never encoded */
        /* a new stream takes the next round, then every third */
        assert_int_equal(a.s[third].due, round % 3 == 0);
    }
    assert_int_equal(nfull, 12);
    assert_int_equal(nthird, 4);
    /* a frame outside the schedule goes to every stream and leaves the countdowns alone */
    assert_true(app_streams_due(&a, false, true));
    assert_true(a.s[full].due && a.s[third].due);
    assert_true(app_streams_due(&a, true, false));
    assert_true(a.s[third].due);
    assert_false(app_streams_due(&a, false, false));
    app_stream_release(&a, full);
    app_stream_release(&a, third);
    assert_false(app_streams_due(&a, true, true)); /* no subscribers: nothing to encode */
    app_streams_free(&a);
}

/* The per-client message budget: a full bucket at open, APP_RATE_BURST messages at once, then
 * refilled at APP_RATE_PER_S; unknown and closed clients are not limited; the table keeps every
 * other client's bucket through growth and deletions. */
static void test_rate_budget(void **state)
{
    (void)state;
    app_peers r = { 0 };
    const unsigned long long t0 = 1000000000ull;
    assert_true(app_peers_take(&r, 7, t0)); /* empty table: nobody is limited */
    for (uint32_t c = 1; c <= 300; c++) assert_int_equal(app_peers_open(&r, c, true, t0), CORE_OK);
    int burst = 0;
    while (app_peers_take(&r, 5, t0)) burst++;
    assert_int_equal(burst, (int)APP_RATE_BURST);
    /* a quarter second later: a quarter of the sustained rate is back */
    int later = 0;
    while (app_peers_take(&r, 5, t0 + 250000000ull)) later++;
    assert_int_equal(later, (int)(APP_RATE_PER_S / 4));
    /* the others still have full buckets, also after half of them leave */
    for (uint32_t c = 1; c <= 300; c += 2) app_peers_close(&r, c);
    assert_int_equal(r.n, 150);
    for (uint32_t c = 2; c <= 300; c += 2) {
        int n = 0;
        while (n <= (int)APP_RATE_BURST && app_peers_take(&r, c, t0)) n++;
        if (n != (int)APP_RATE_BURST) fail_msg("client %u had %d messages, not %d", c, n, (int)APP_RATE_BURST);
    }
    assert_true(app_peers_take(&r, 3, t0)); /* closed: no longer limited */
    assert_true(app_peers_take(&r, 1000, t0)); /* never opened */
    app_peers_free(&r);
}

/* The rate_limited reply (a daemon's and an edge's): the request's id echoed, whatever else the
 * message holds (even one that would not parse further), none when it has none. */
static void test_rate_limited_reply(void **state)
{
    (void)state;
    proto_parser p;
    core_err err;
    assert_int_equal(app_parser_init(&p, &err), CORE_OK);
    static const char with_id[] = "{\"type\":\"set_params\",\"id\":\"f-1\",\"values\":{\"no_such\":1}}";
    char *t = app_peers_limited(&p, with_id, strlen(with_id));
    assert_non_null(t);
    assert_non_null(strstr(t, "\"code\":\"rate_limited\""));
    assert_non_null(strstr(t, "\"id\":\"f-1\""));
    proto_free(t);
    t = app_peers_limited(&p, "{not json", 9);
    assert_non_null(strstr(t, "\"code\":\"rate_limited\""));
    assert_null(strstr(t, "\"id\""));
    proto_free(t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mailbox_order_and_coalescing),
        cmocka_unit_test(test_mailbox_bound_and_wait),
        cmocka_unit_test(test_presets),
        cmocka_unit_test(test_blend_pure),
        cmocka_unit_test(test_preset_switch_blends),
        cmocka_unit_test(test_stream_decimation),
        cmocka_unit_test(test_rate_budget),
        cmocka_unit_test(test_rate_limited_reply),
        cmocka_unit_test(test_streams_share_and_fall_back),
        cmocka_unit_test(test_streams_due_schedule),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
