/* Tests for server/scen without a daemon: scripts are read into steps (bad ones named by step and
 * field), the hello and announcements into what the checks need, and the frame invariants catch
 * each kind of fault with its frame, strand, vertex and value. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include <cjson/cJSON.h>

#include "scen/scen.h"

/* 2 strands x 3 vertices: strand 0 rest segment 3 cm from (0, 0.1, 0), strand 1 1 cm from
 * (0.05, 0.1, 0); a sphere at the origin, a capsule below it, an ellipsoid off to +x. */
static const char HELLO[] =
    "{\"type\":\"hello\",\"groom\":{\"source\":\"t\",\"strands\":2,\"verts\":3,\"rest_lengths\":[0.03,0.01],"
    "\"roots\":[0,0.1,0,0.05,0.1,0]},"
    "\"colliders\":[{\"kind\":\"sphere\",\"center\":[0,0,0],\"radius\":0.05},"
    "{\"kind\":\"capsule\",\"a\":[0,-0.06,0],\"b\":[0,-0.2,0],\"radius\":0.03},"
    "{\"kind\":\"ellipsoid\",\"center\":[0.3,0,0],\"radii\":[0.02,0.04,0.08],\"rotation\":[0,0,0,1]}],"
    "\"head\":{\"position\":[0,0,0],\"orientation\":[0,0,0,1]},"
    "\"params\":{\"schema\":[],\"values\":{\"dt\":0.02,\"gravity\":9.81,\"collisions\":true}},"
    "\"animation\":{\"preset\":\"none\",\"speed\":1},"
    "\"state\":{\"paused\":false,\"sim_time\":1,\"steps\":50,\"animation\":{\"preset\":\"none\",\"speed\":1}}}";

/* The rest pose under a head at height dy: both strands straight up from their roots. */
static void rest_frame(float xyz[18], float dy)
{
    const float root[2][3] = { { 0, 0.1f, 0 }, { 0.05f, 0.1f, 0 } }, seg[2] = { 0.03f, 0.01f };
    for (int s = 0; s < 2; s++)
        for (int v = 0; v < 3; v++) {
            xyz[(s * 3 + v) * 3 + 0] = root[s][0];
            xyz[(s * 3 + v) * 3 + 1] = root[s][1] + dy + seg[s] * (float)v;
            xyz[(s * 3 + v) * 3 + 2] = root[s][2];
        }
}

static codec_frame_info frame_info(uint64_t seq, double sim_time)
{
    codec_frame_info f;
    memset(&f, 0, sizeof f);
    f.seq = seq;
    f.sim.sim_time = sim_time;
    f.max_error_m = 1e-5f;
    f.nstrands_total = f.nstrands_sent = 2;
    f.nverts = 3;
    f.stride = 1;
    return f;
}

static void load(scen_world *w)
{
    core_err err;
    if (scen_world_hello(w, HELLO, strlen(HELLO), &err) != CORE_OK) fail_msg("hello: %s", err.msg);
}

static void test_world_reads_hello(void **state)
{
    (void)state;
    scen_world w;
    load(&w);
    assert_int_equal(w.strands, 2);
    assert_int_equal(w.verts, 3);
    assert_true(w.rest_lengths[0] == 0.03f && w.rest_lengths[1] == 0.01f);
    assert_int_equal(w.ncolliders, 3);
    assert_int_equal(w.colliders[1].kind, SCEN_CAPSULE);
    assert_non_null(scen_world_value(&w, "hello", "groom.roots.3"));
    assert_null(scen_world_value(&w, "hello", "groom.roots.9"));
    assert_null(scen_world_value(&w, "params", "nope"));
    /* announcements update params and state; a groom message replaces the groom */
    scen_world_text(&w, "{\"type\":\"params\",\"values\":{\"gravity\":0,\"wind_x\":1},\"by\":2}");
    scen_world_text(&w, "{\"type\":\"state\",\"paused\":true,\"sim_time\":2,\"steps\":100,\"animation\":{\"preset\":\"none\",\"speed\":1}}");
    scen_world_text(&w, "{\"type\":\"groom\",\"groom\":{\"strands\":1,\"verts\":4,\"rest_lengths\":[0.5],\"roots\":[1,2,3]},\"colliders\":[]}");
    assert_int_equal(w.strands, 1);
    assert_int_equal(w.verts, 4);
    assert_int_equal(w.ncolliders, 0);
    assert_true(w.rest_lengths[0] == 0.5f);
    const cJSON *gv = scen_world_value(&w, "groom", "groom.verts");
    assert_true(gv && cJSON_IsNumber(gv) && gv->valuedouble == 4);
    gv = scen_world_value(&w, "params", "wind_x");
    assert_true(gv && cJSON_IsNumber(gv) && gv->valuedouble == 1);
    gv = scen_world_value(&w, "state", "paused");
    assert_true(gv && cJSON_IsTrue(gv));
    codec_frame_info f = frame_info(1, 1.0);
    assert_true(scen_world_frame_step(&w, &f) == 50.0); /* 1 s at dt 0.02 */
    scen_world_free(&w);
    /* a hello without rest lengths is refused, naming the field */
    const char *bad = "{\"type\":\"hello\",\"groom\":{\"strands\":2,\"verts\":3,\"roots\":[0,0,0,0,0,0]},"
                      "\"head\":{\"position\":[0,0,0],\"orientation\":[0,0,0,1]}}";
    core_err err;
    assert_int_equal(scen_world_hello(&w, bad, strlen(bad), &err), CORE_EFORMAT);
    assert_non_null(strstr(err.msg, "rest_lengths"));
    /* a collider with a zero radius, and more colliders than the client takes */
    const char *flat = "{\"type\":\"hello\",\"groom\":{\"strands\":1,\"verts\":2,\"rest_lengths\":[1],\"roots\":[0,0,0]},"
                       "\"colliders\":[{\"kind\":\"ellipsoid\",\"center\":[0,0,0],\"radii\":[1,0,1]}],"
                       "\"head\":{\"position\":[0,0,0],\"orientation\":[0,0,0,1]}}";
    assert_int_equal(scen_world_hello(&w, flat, strlen(flat), &err), CORE_EFORMAT);
    assert_non_null(strstr(err.msg, "colliders[0]"));
    char many[8192];
    int n = snprintf(many, sizeof many, "{\"type\":\"hello\",\"groom\":{\"strands\":1,\"verts\":2,\"rest_lengths\":[1],"
                                        "\"roots\":[0,0,0]},\"head\":{\"position\":[0,0,0],\"orientation\":[0,0,0,1]},"
                                        "\"colliders\":[");
    for (int i = 0; i <= SCEN_MAX_COLLIDERS; i++)
        n += snprintf(many + n, sizeof many - (size_t)n, "%s{\"kind\":\"sphere\",\"center\":[0,0,0],\"radius\":1}", i ? "," : "");
    snprintf(many + n, sizeof many - (size_t)n, "]}");
    assert_int_equal(scen_world_hello(&w, many, strlen(many), &err), CORE_EFORMAT);
    assert_non_null(strstr(err.msg, "colliders: more than 32"));
}

static void test_check_passes_rest_pose(void **state)
{
    (void)state;
    scen_world w;
    load(&w);
    scen_check c;
    scen_check_begin(&c, NULL);
    float xyz[18];
    rest_frame(xyz, 0);
    for (uint64_t i = 0; i < 10; i++) {
        codec_frame_info f = frame_info(100 + i, 1.0 + 0.02 * (double)i);
        scen_check_frame(&c, &w, &f, xyz, 1000000000ull + i * 16000000ull);
    }
    assert_true(scen_check_end(&c, stderr, "  "));
    assert_int_equal(c.frames, 10);
    assert_int_equal(c.roots_unchecked, 0);
    double fps;
    assert_true(scen_check_fps_ok(&c, &fps));
    assert_true(fabs(fps - 62.5) < 1e-6);
    scen_world_free(&w);
}

/* Runs one frame through a fresh check with desc d; returns the check. */
static scen_check one_frame(scen_world *w, const scen_check_desc *d, const float *xyz, uint64_t seq)
{
    scen_check c;
    scen_check_begin(&c, d);
    codec_frame_info f = frame_info(seq, 1.0);
    scen_check_frame(&c, w, &f, xyz, 1000);
    return c;
}

static void expect_failure(const scen_check *c, scen_inv inv, uint64_t seq, uint32_t strand, uint32_t vertex)
{
    const scen_check_worst *x = &c->worst[inv];
    if (x->frames_failed != 1 || x->seq != seq || x->strand != strand || x->vertex != vertex)
        fail_msg("invariant %d: %lu frames failed, worst seq %llu strand %u vertex %u (%s)", (int)inv, x->frames_failed,
                 (unsigned long long)x->seq, x->strand, x->vertex, x->what);
    char buf[1024] = "";
    FILE *fp = fmemopen(buf, sizeof buf, "w");
    assert_false(scen_check_end(c, fp, ""));
    fclose(fp);
    char want[96];
    snprintf(want, sizeof want, "frame seq %llu, strand %u, vertex %u", (unsigned long long)seq, strand, vertex);
    if (!strstr(buf, want)) fail_msg("the report does not name %s:\n%s", want, buf);
}

static void test_check_catches_faults(void **state)
{
    (void)state;
    scen_world w;
    load(&w);
    float xyz[18];
    /* a non-finite coordinate */
    rest_frame(xyz, 0);
    xyz[(1 * 3 + 1) * 3 + 2] = NAN;
    scen_check c = one_frame(&w, NULL, xyz, 7);
    expect_failure(&c, SCEN_INV_FINITE, 7, 1, 1);
    /* strand 1's last segment 20% long (the default bound is 2%) */
    rest_frame(xyz, 0);
    xyz[(1 * 3 + 2) * 3 + 1] += 0.002f;
    c = one_frame(&w, NULL, xyz, 8);
    expect_failure(&c, SCEN_INV_STRETCH, 8, 1, 2);
    assert_true(fabs(c.worst[SCEN_INV_STRETCH].value - 0.2) < 1e-3);
    assert_int_equal(c.worst[SCEN_INV_DEPTH].frames_failed, 0);
    /* 1% is within the default bound, not within 0.5% */
    rest_frame(xyz, 0);
    xyz[(1 * 3 + 2) * 3 + 1] += 0.0001f;
    c = one_frame(&w, NULL, xyz, 9);
    assert_true(scen_check_end(&c, NULL, ""));
    c = one_frame(&w, &(scen_check_desc){ .max_stretch = 0.005 }, xyz, 9);
    expect_failure(&c, SCEN_INV_STRETCH, 9, 1, 2);
    /* strand 0 hanging down into the sphere: its tip 1 cm deep */
    rest_frame(xyz, 0);
    xyz[(0 * 3 + 1) * 3 + 1] = 0.07f;
    xyz[(0 * 3 + 2) * 3 + 1] = 0.04f;
    c = one_frame(&w, NULL, xyz, 10);
    expect_failure(&c, SCEN_INV_DEPTH, 10, 0, 2);
    assert_true(fabs(c.worst[SCEN_INV_DEPTH].value - 0.01) < 1e-6);
    assert_non_null(strstr(c.worst[SCEN_INV_DEPTH].what, "sphere 0"));
    assert_int_equal(c.worst[SCEN_INV_STRETCH].frames_failed, 0);
    /* with collisions off the depth is not checked */
    scen_world_text(&w, "{\"type\":\"params\",\"values\":{\"collisions\":false},\"by\":1}");
    c = one_frame(&w, NULL, xyz, 10);
    assert_true(scen_check_end(&c, NULL, ""));
    scen_world_text(&w, "{\"type\":\"params\",\"values\":{\"collisions\":true},\"by\":1}");
    /* a vertex in the capsule and one in the ellipsoid (its depth a lower bound: (1 - 0.875) x 2 cm);
     * stretch and roots off (a bound below zero) */
    scen_check_desc only_depth = { .max_stretch = -1, .root_tolerance = -1 };
    rest_frame(xyz, 0);
    xyz[(1 * 3 + 2) * 3 + 0] = 0.3f;
    xyz[(1 * 3 + 2) * 3 + 1] = 0.0f;
    xyz[(1 * 3 + 2) * 3 + 2] = 0.07f;
    c = one_frame(&w, &only_depth, xyz, 11);
    expect_failure(&c, SCEN_INV_DEPTH, 11, 1, 2);
    assert_true(fabs(c.worst[SCEN_INV_DEPTH].value - 0.0025) < 1e-6);
    assert_non_null(strstr(c.worst[SCEN_INV_DEPTH].what, "ellipsoid 2"));
    rest_frame(xyz, 0);
    xyz[(0 * 3 + 1) * 3 + 1] = -0.1f;
    xyz[(0 * 3 + 1) * 3 + 0] = 0.02f;
    c = one_frame(&w, &only_depth, xyz, 12);
    expect_failure(&c, SCEN_INV_DEPTH, 12, 0, 1);
    assert_true(fabs(c.worst[SCEN_INV_DEPTH].value - 0.01) < 1e-6);
    assert_non_null(strstr(c.worst[SCEN_INV_DEPTH].what, "capsule 1"));
    /* a root 5 mm off its place on the head */
    rest_frame(xyz, 0);
    xyz[(1 * 3 + 0) * 3 + 0] += 0.005f;
    c = one_frame(&w, &(scen_check_desc){ .max_stretch = -1 }, xyz, 13);
    expect_failure(&c, SCEN_INV_ROOT, 13, 1, 0);
    assert_true(fabs(c.worst[SCEN_INV_ROOT].value - 0.005) < 1e-6);
    scen_world_free(&w);
}

/* The head pose: a motion this client sent moves the expected roots (frames still in flight may
 * show the old pose until one shows the new); a running preset leaves the roots unchecked; after
 * it stops they are checked again once the 0.4 s blend is over. */
static void test_check_follows_head(void **state)
{
    (void)state;
    scen_world w;
    load(&w);
    float old_pose[18], new_pose[18];
    rest_frame(old_pose, 0);
    rest_frame(new_pose, 0.1f);
    scen_check c;
    scen_check_begin(&c, NULL);
    codec_frame_info f = frame_info(1, 1.0);
    scen_check_frame(&c, &w, &f, new_pose, 1000);
    assert_int_equal(c.worst[SCEN_INV_ROOT].frames_failed, 1);
    scen_world_sent(&w, "{\"type\":\"motion\",\"position\":[0,0.1,0],\"orientation\":[0,0,0,2]}");
    scen_check_begin(&c, NULL);
    scen_check_frame(&c, &w, &f, old_pose, 1000); /* in flight: still right */
    scen_check_frame(&c, &w, &f, new_pose, 2000);
    assert_true(scen_check_end(&c, stderr, ""));
    scen_check_frame(&c, &w, &f, old_pose, 3000); /* the new pose was seen: the old one is wrong now */
    assert_int_equal(c.worst[SCEN_INV_ROOT].frames_failed, 1);
    /* a preset: unknown head */
    scen_world_text(&w, "{\"type\":\"state\",\"paused\":false,\"sim_time\":2,\"steps\":100,\"animation\":{\"preset\":\"nod\",\"speed\":1}}");
    scen_check_begin(&c, NULL);
    f.sim.sim_time = 2.1;
    scen_check_frame(&c, &w, &f, old_pose, 1000);
    assert_int_equal(c.roots_unchecked, 1);
    assert_true(scen_check_end(&c, NULL, ""));
    /* stopped at sim time 3: blending until 3.4 (+ two steps), then the motion pose again */
    scen_world_text(&w, "{\"type\":\"state\",\"paused\":false,\"sim_time\":3,\"steps\":150,\"animation\":{\"preset\":\"none\",\"speed\":1}}");
    f.sim.sim_time = 3.2;
    scen_check_frame(&c, &w, &f, old_pose, 2000);
    assert_int_equal(c.roots_unchecked, 2);
    f.sim.sim_time = 3.5;
    scen_check_frame(&c, &w, &f, new_pose, 3000);
    assert_int_equal(c.roots_unchecked, 2);
    assert_true(scen_check_end(&c, NULL, ""));
    scen_check_frame(&c, &w, &f, old_pose, 4000);
    assert_int_equal(c.worst[SCEN_INV_ROOT].frames_failed, 1);
    scen_world_free(&w);
}

static void test_check_rate_and_gaps(void **state)
{
    (void)state;
    scen_world w;
    load(&w);
    float xyz[18];
    rest_frame(xyz, 0);
    scen_check c;
    scen_check_begin(&c, &(scen_check_desc){ .min_fps = 30, .max_gap_ms = 100 });
    codec_frame_info f = frame_info(1, 1.0);
    scen_check_frame(&c, &w, &f, xyz, 0);
    f.seq = 2;
    scen_check_frame(&c, &w, &f, xyz, 50000000ull);
    f.seq = 3;
    scen_check_frame(&c, &w, &f, xyz, 300000000ull); /* 250 ms gap; 2 frames in 0.3 s */
    char buf[1024] = "";
    FILE *fp = fmemopen(buf, sizeof buf, "w");
    assert_false(scen_check_end(&c, fp, ""));
    fclose(fp);
    if (!strstr(buf, "gap: 250.0 ms before frame seq 3") || !strstr(buf, "frame rate: 6.67 frames/s"))
        fail_msg("report:\n%s", buf);
    scen_world_free(&w);
}

/* Parses text, expecting a failure whose message holds needle. */
static void bad_script(const char *text, const char *needle)
{
    scen_script s;
    core_err err;
    if (scen_script_parse(&s, text, strlen(text), &err) == CORE_OK) fail_msg("accepted: %s", text);
    if (!strstr(err.msg, needle)) fail_msg("%s\n  said: %s\n  want: %s", text, err.msg, needle);
}

static void test_script_reads_steps(void **state)
{
    (void)state;
    const char *text =
        "{\"name\":\"all kinds\",\"timeout_ms\":500,\"steps\":["
        "{\"send\":{\"type\":\"set_params\",\"id\":1,\"values\":{\"gravity\":0}},\"at_ms\":10,\"comment\":\"c\"},"
        "{\"reply\":1,\"type\":\"ok\"},"
        "{\"send\":\"{not json\",\"at_step\":120},"
        "{\"reply\":null,\"error\":\"bad_json\",\"field\":\"\",\"timeout_ms\":20},"
        "{\"frames\":5},{\"until_sim_time\":1.5},{\"until_step\":90},{\"sleep_ms\":25},"
        "{\"expect\":\"params\",\"path\":\"gravity\",\"equals\":0,\"tolerance\":1e-6,\"within_ms\":100},"
        "{\"expect\":\"state\",\"path\":\"steps\",\"min\":1},"
        "{\"check\":{\"frames\":30,\"max_stretch\":0.05,\"max_depth\":-1,\"min_fps\":10}},"
        "{\"reply\":\"s\"}]}";
    scen_script s;
    core_err err;
    if (scen_script_parse(&s, text, strlen(text), &err) != CORE_OK) fail_msg("%s", err.msg);
    assert_string_equal(s.name, "all kinds");
    assert_int_equal(s.nsteps, 12);
    assert_int_equal(s.steps[0].kind, SCEN_SEND);
    assert_string_equal(s.steps[0].text, "{\"type\":\"set_params\",\"id\":1,\"values\":{\"gravity\":0}}");
    assert_true(s.steps[0].at_ms == 10 && s.steps[0].at_step < 0 && s.steps[0].timeout_ms == 500);
    assert_true(s.steps[1].kind == SCEN_REPLY && s.steps[1].id_kind == 1 && s.steps[1].id_num == 1);
    assert_string_equal(s.steps[1].reply_type, "ok");
    assert_string_equal(s.steps[2].text, "{not json");
    assert_true(s.steps[2].at_step == 120);
    assert_true(s.steps[3].id_kind == 0 && s.steps[3].field_given && s.steps[3].timeout_ms == 20);
    assert_string_equal(s.steps[3].error, "bad_json");
    assert_true(s.steps[4].kind == SCEN_FRAMES && s.steps[4].count == 5);
    assert_true(s.steps[5].kind == SCEN_UNTIL_SIM_TIME && s.steps[5].count == 1.5);
    assert_true(s.steps[6].kind == SCEN_UNTIL_STEP && s.steps[7].kind == SCEN_SLEEP && s.steps[7].count == 25);
    assert_true(s.steps[8].kind == SCEN_EXPECT && s.steps[8].timeout_ms == 100 && s.steps[8].tolerance == 1e-6);
    assert_string_equal(s.steps[8].equals, "0");
    assert_true(s.steps[9].min == 1 && isnan(s.steps[9].max) && !s.steps[9].equals);
    assert_true(s.steps[10].kind == SCEN_CHECK && s.steps[10].count == 30 && s.steps[10].check.max_depth == -1);
    assert_true(s.steps[10].check.min_fps == 10 && s.steps[10].check.max_stretch == 0.05);
    assert_true(s.steps[11].id_kind == 2);
    assert_string_equal(s.steps[11].id_str, "s");
    scen_script_free(&s);
}

static void test_script_errors_name_step_and_field(void **state)
{
    (void)state;
    bad_script("{\"steps\":[{\"frames\":1},", "not valid JSON (line 1");
    bad_script("[]", "must be a JSON object");
    bad_script("{\"steps\":[]}", "field \"steps\": must be a non-empty array");
    bad_script("{\"steps\":[{\"frames\":1}],\"extra\":1}", "script: field \"extra\"");
    bad_script("{\"steps\":[{\"frames\":1},{\"jump\":3}]}", "step 1: unknown step kind (fields: jump)");
    bad_script("{\"steps\":[{\"frames\":1,\"reply\":2}]}", "step 0: names two kinds");
    bad_script("{\"steps\":[{\"frames\":\"3\"}]}", "step 0 (frames): field \"frames\": must be a number");
    bad_script("{\"steps\":[{\"frames\":1.5}]}", "step 0 (frames): field \"frames\": must be a whole number");
    bad_script("{\"steps\":[{\"frames\":1},{\"reply\":1,\"timeout_ms\":\"x\"}]}",
               "step 1 (reply): field \"timeout_ms\": must be a number");
    bad_script("{\"steps\":[{\"reply\":1,\"timeout_ms\":1e999}]}", "step 0 (reply): field \"timeout_ms\": must be finite");
    bad_script("{\"steps\":[{\"sleep_ms\":-1e999}]}", "step 0 (sleep_ms): field \"sleep_ms\": must be a finite number");
    bad_script("{\"steps\":[{\"expect\":\"params\",\"path\":\"g\",\"equals\":[1e999]}]}",
               "step 0 (expect): field \"equals\": must be finite");
    bad_script("{\"steps\":[{\"reply\":1,\"colour\":2}]}", "step 0 (reply): field \"colour\": unknown field");
    bad_script("{\"steps\":[{\"reply\":[1]}]}", "step 0 (reply): field \"reply\": must be the request id");
    bad_script("{\"steps\":[{\"reply\":1,\"field\":\"x\"}]}", "field \"field\": goes with \"error\"");
    bad_script("{\"steps\":[{\"send\":3}]}", "step 0 (send): field \"send\": must be a message object");
    bad_script("{\"steps\":[{\"send\":{},\"at_ms\":1,\"at_step\":2}]}", "give at most one of");
    bad_script("{\"steps\":[{\"expect\":\"hellos\",\"path\":\"a\",\"equals\":1}]}", "field \"expect\": must be");
    bad_script("{\"steps\":[{\"expect\":\"hello\",\"equals\":1}]}", "field \"path\": is required");
    bad_script("{\"steps\":[{\"expect\":\"hello\",\"path\":\"a\"}]}", "give equals, min or max");
    bad_script("{\"steps\":[{\"check\":{\"frames\":10,\"max_strech\":1}}]}", "field \"check.max_strech\": unknown");
    bad_script("{\"steps\":[{\"check\":{}}]}", "needs \"frames\" or \"seconds\"");
    bad_script("{\"steps\":[{\"check\":{\"frames\":10,\"min_fps\":-1}}]}", "field \"min_fps\": -1 is outside");
    bad_script("{\"steps\":[7]}", "step 0: must be an object");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_world_reads_hello),
        cmocka_unit_test(test_check_passes_rest_pose),
        cmocka_unit_test(test_check_catches_faults),
        cmocka_unit_test(test_check_follows_head),
        cmocka_unit_test(test_check_rate_and_gaps),
        cmocka_unit_test(test_script_reads_steps),
        cmocka_unit_test(test_script_errors_name_step_and_field),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
