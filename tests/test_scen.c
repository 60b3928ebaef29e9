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
#include <stdlib.h>
#include <string.h>

#include <cjson/cJSON.h>

#include "proto/proto.h"
#include "scen/scen.h"

/* The groom data a fake server serves (scen_fetch_fn): groom data binaries by version. */
typedef struct fake_server {
    unsigned char bin[2][16 + 16 * 2];
    size_t len[2];
    char etag[2][17];
    int serve;        /* which version GET /groom.bin answers */
    int fetches;
    const char *fail; /* a fetch failure's message, or NULL */
} fake_server;

static void put_u32(unsigned char *p, uint32_t v)
{
    for (int i = 0; i < 4; i++) p[i] = (unsigned char)(v >> (8 * i));
}

static void put_f32(unsigned char *p, float f)
{
    uint32_t bits;
    memcpy(&bits, &f, 4);
    put_u32(p, bits);
}

/* Version k of the groom data: strands x verts with the given rest lengths and roots. */
static void make_bin(fake_server *f, int k, uint32_t strands, uint32_t verts, const float *rest, const float *roots)
{
    unsigned char *b = f->bin[k];
    memcpy(b, "SCGR", 4);
    put_u32(b + 4, 1);
    put_u32(b + 8, strands);
    put_u32(b + 12, verts);
    for (uint32_t s = 0; s < strands; s++) put_f32(b + 16 + 4 * s, rest[s]);
    for (uint32_t i = 0; i < 3 * strands; i++) put_f32(b + 16 + 4 * strands + 4 * i, roots[i]);
    f->len[k] = 16 + 16 * (size_t)strands;
    proto_bin_etag(b, f->len[k], f->etag[k]);
}

static core_status fake_fetch(void *user, const char *url, size_t max_bytes, uint8_t **body, size_t *len, core_err *err)
{
    fake_server *f = user;
    f->fetches++;
    if (strcmp(url, "/groom.bin") != 0) return core_fail(err, CORE_EIO, "groom data: GET %s answered 404", url);
    if (f->fail) return core_fail(err, CORE_EIO, "%s", f->fail);
    size_t n = f->len[f->serve] < max_bytes ? f->len[f->serve] : max_bytes;
    *body = malloc(n);
    memcpy(*body, f->bin[f->serve], n);
    *len = n;
    return CORE_OK;
}

/* 2 strands x 3 vertices: strand 0 rest segment 3 cm from (0, 0.1, 0), strand 1 1 cm from
 * (0.05, 0.1, 0); a sphere at the origin, a capsule below it, an ellipsoid off to +x. */
static void fake_init(fake_server *f)
{
    memset(f, 0, sizeof *f);
    const float rest[2] = { 0.03f, 0.01f }, roots[6] = { 0, 0.1f, 0, 0.05f, 0.1f, 0 };
    make_bin(f, 0, 2, 3, rest, roots);
    const float rest1[1] = { 0.5f }, roots1[3] = { 1, 2, 3 };
    make_bin(f, 1, 1, 4, rest1, roots1);
}

/* The hello, its groom naming version k of f's data (bytes: its size plus extra). */
static void hello_text(char *out, size_t cap, const fake_server *f, int k, const char *url, long extra)
{
    snprintf(out, cap,
             "{\"type\":\"hello\",\"groom\":{\"source\":\"t\",\"strands\":2,\"verts\":3,\"url\":\"%s\",\"etag\":\"%s\","
             "\"bytes\":%ld},"
             "\"colliders\":[{\"kind\":\"sphere\",\"center\":[0,0,0],\"radius\":0.05},"
             "{\"kind\":\"capsule\",\"a\":[0,-0.06,0],\"b\":[0,-0.2,0],\"radius\":0.03},"
             "{\"kind\":\"ellipsoid\",\"center\":[0.3,0,0],\"radii\":[0.02,0.04,0.08],\"rotation\":[0,0,0,1]}],"
             "\"head\":{\"position\":[0,0,0],\"orientation\":[0,0,0,1]},"
             "\"params\":{\"schema\":[],\"values\":{\"dt\":0.02,\"gravity\":9.81,\"collisions\":true}},"
             "\"animation\":{\"preset\":\"none\",\"speed\":1},"
             "\"state\":{\"paused\":false,\"sim_time\":1,\"steps\":50,\"animation\":{\"preset\":\"none\",\"speed\":1}}}",
             url, f->etag[k], (long)f->len[k] + extra);
}

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

/* A frame of the 2 x 3 groom under the identity head. */
static codec_frame_info frame_info(uint64_t seq, double sim_time)
{
    codec_frame_info f;
    memset(&f, 0, sizeof f);
    f.seq = seq;
    f.sim.sim_time = sim_time;
    f.sim.sim_step = (uint64_t)(sim_time / 0.02 + 0.5);
    f.sim.head_rot[3] = 1;
    f.max_error_m = 1e-5f;
    f.nstrands_total = f.nstrands_sent = 2;
    f.nverts = 3;
    f.stride = 1;
    return f;
}

static void load(scen_world *w, fake_server *f)
{
    fake_init(f);
    char hello[2048];
    hello_text(hello, sizeof hello, f, 0, "/groom.bin", 0);
    core_err err;
    if (scen_world_hello(w, hello, strlen(hello), fake_fetch, f, &err) != CORE_OK) fail_msg("hello: %s", err.msg);
}

static void test_world_reads_hello(void **state)
{
    (void)state;
    scen_world w;
    fake_server srv;
    load(&w, &srv);
    assert_int_equal(srv.fetches, 1);
    assert_int_equal(w.strands, 2);
    assert_int_equal(w.verts, 3);
    assert_true(w.rest_lengths[0] == 0.03f && w.rest_lengths[1] == 0.01f);
    assert_true(w.roots[3] == 0.05f && w.roots[4] == 0.1f);
    assert_string_equal(w.data_etag, srv.etag[0]);
    assert_int_equal(w.ncolliders, 3);
    assert_int_equal(w.colliders[1].kind, SCEN_CAPSULE);
    assert_non_null(scen_world_value(&w, "hello", "groom.etag"));
    assert_null(scen_world_value(&w, "hello", "colliders.9"));
    assert_null(scen_world_value(&w, "params", "nope"));
    /* announcements update params and state; a groom message replaces the groom, fetching its data */
    core_err err;
    assert_int_equal(scen_world_text(&w, "{\"type\":\"params\",\"values\":{\"gravity\":0,\"wind_x\":1},\"by\":2}", &err),
                     CORE_OK);
    assert_int_equal(scen_world_text(&w, "{\"type\":\"state\",\"paused\":true,\"sim_time\":2,\"steps\":100,"
                                         "\"animation\":{\"preset\":\"none\",\"speed\":1}}", &err),
                     CORE_OK);
    char msg[512];
    snprintf(msg, sizeof msg,
             "{\"type\":\"groom\",\"groom\":{\"strands\":1,\"verts\":4,\"url\":\"/groom.bin\",\"etag\":\"%s\",\"bytes\":%zu},"
             "\"colliders\":[]}",
             srv.etag[1], srv.len[1]);
    srv.serve = 1;
    if (scen_world_text(&w, msg, &err) != CORE_OK) fail_msg("groom: %s", err.msg);
    assert_int_equal(srv.fetches, 2);
    assert_int_equal(w.strands, 1);
    assert_int_equal(w.verts, 4);
    assert_int_equal(w.ncolliders, 0);
    assert_true(w.rest_lengths[0] == 0.5f && w.roots[2] == 3.0f);
    /* the same etag again (a collider change): the data held is kept, not fetched */
    assert_int_equal(scen_world_text(&w, msg, &err), CORE_OK);
    assert_int_equal(srv.fetches, 2);
    assert_true(w.rest_lengths[0] == 0.5f);
    const cJSON *gv = scen_world_value(&w, "groom", "groom.verts");
    assert_true(gv && cJSON_IsNumber(gv) && gv->valuedouble == 4);
    gv = scen_world_value(&w, "params", "wind_x");
    assert_true(gv && cJSON_IsNumber(gv) && gv->valuedouble == 1);
    gv = scen_world_value(&w, "state", "paused");
    assert_true(gv && cJSON_IsTrue(gv));
    scen_world_free(&w);
    /* a collider with a zero radius, and more colliders than the client takes */
    const char *flat = "{\"type\":\"hello\",\"groom\":{\"strands\":1,\"verts\":2},"
                       "\"colliders\":[{\"kind\":\"ellipsoid\",\"center\":[0,0,0],\"radii\":[1,0,1]}],"
                       "\"head\":{\"position\":[0,0,0],\"orientation\":[0,0,0,1]}}";
    assert_int_equal(scen_world_hello(&w, flat, strlen(flat), fake_fetch, &srv, &err), CORE_EFORMAT);
    assert_non_null(strstr(err.msg, "colliders[0]"));
    char many[8192];
    int n = snprintf(many, sizeof many, "{\"type\":\"hello\",\"groom\":{\"strands\":1,\"verts\":2},"
                                        "\"head\":{\"position\":[0,0,0],\"orientation\":[0,0,0,1]},\"colliders\":[");
    for (int i = 0; i <= SCEN_MAX_COLLIDERS; i++)
        n += snprintf(many + n, sizeof many - (size_t)n, "%s{\"kind\":\"sphere\",\"center\":[0,0,0],\"radius\":1}", i ? "," : "");
    snprintf(many + n, sizeof many - (size_t)n, "]}");
    assert_int_equal(scen_world_hello(&w, many, strlen(many), fake_fetch, &srv, &err), CORE_EFORMAT);
    assert_non_null(strstr(err.msg, "colliders: more than 32"));
}

/* Reads a hello (version k of srv's data at url, bytes off by extra), expecting a failure
 * whose message holds needle. */
static void bad_groom_data(fake_server *srv, int k, const char *url, long extra, const char *needle)
{
    char hello[2048];
    hello_text(hello, sizeof hello, srv, k, url, extra);
    scen_world w;
    core_err err;
    if (scen_world_hello(&w, hello, strlen(hello), fake_fetch, srv, &err) == CORE_OK) {
        scen_world_free(&w);
        fail_msg("accepted: %s", hello);
    }
    if (!strstr(err.msg, "groom data: ") || !strstr(err.msg, needle)) fail_msg("said: %s\nwant: %s", err.msg, needle);
}

/* The groom data: fetch failures, a size, count or format that does not match the groom are
 * refused, each saying so; data of a newer groom than announced is not taken (its frames are
 * not checked) until the groom message that names it. */
static void test_world_groom_data(void **state)
{
    (void)state;
    fake_server srv;
    fake_init(&srv);
    bad_groom_data(&srv, 0, "/missing.bin", 0, "GET /missing.bin answered 404");
    srv.fail = "groom data: GET http://127.0.0.1:1/groom.bin: cannot connect";
    bad_groom_data(&srv, 0, "/groom.bin", 0, "cannot connect");
    srv.fail = NULL;
    bad_groom_data(&srv, 0, "/groom.bin", 4, "sent 48 bytes, groom.bytes says 52");
    bad_groom_data(&srv, 0, "groom.bin", 0, "groom.url (a path)");
    srv.bin[0][4] = 2; /* version 2, etag recomputed: the reader's message is passed on */
    proto_bin_etag(srv.bin[0], srv.len[0], srv.etag[0]);
    bad_groom_data(&srv, 0, "/groom.bin", 0, "/groom.bin: groom data binary: version 2, expected 1");
    fake_init(&srv);
    put_u32(srv.bin[0] + 12, 5); /* 2 x 5 in the binary, 2 x 3 in the hello */
    proto_bin_etag(srv.bin[0], srv.len[0], srv.etag[0]);
    bad_groom_data(&srv, 0, "/groom.bin", 0, "holds 2 x 5, groom says 2 x 3");
    const char *no_etag = "{\"type\":\"hello\",\"groom\":{\"strands\":2,\"verts\":3,\"url\":\"/groom.bin\",\"bytes\":48},"
                          "\"head\":{\"position\":[0,0,0],\"orientation\":[0,0,0,1]}}";
    scen_world w;
    core_err err;
    assert_int_equal(scen_world_hello(&w, no_etag, strlen(no_etag), fake_fetch, &srv, &err), CORE_EFORMAT);
    assert_non_null(strstr(err.msg, "groom.etag"));
    /* the server already serves version 1 when the hello names version 0: no data yet */
    fake_init(&srv);
    srv.serve = 1;
    char hello[2048];
    hello_text(hello, sizeof hello, &srv, 0, "/groom.bin", 0);
    if (scen_world_hello(&w, hello, strlen(hello), fake_fetch, &srv, &err) != CORE_OK) fail_msg("%s", err.msg);
    assert_null(w.rest_lengths);
    scen_check c;
    scen_check_begin(&c, NULL);
    float xyz[18];
    rest_frame(xyz, 0.5f); /* nowhere near the roots: not checked */
    codec_frame_info f = frame_info(1, 1.0);
    scen_check_frame(&c, &w, &f, xyz, 1000);
    assert_int_equal(c.groom_unchecked, 1);
    assert_true(scen_check_end(&c, NULL, ""));
    /* a groom message whose data fails to fetch fails, saying so */
    srv.fail = "groom data: GET http://127.0.0.1:1/groom.bin answered 503";
    char msg[512];
    snprintf(msg, sizeof msg,
             "{\"type\":\"groom\",\"groom\":{\"strands\":1,\"verts\":4,\"url\":\"/groom.bin\",\"etag\":\"%s\",\"bytes\":%zu},"
             "\"colliders\":[]}",
             srv.etag[1], srv.len[1]);
    assert_int_equal(scen_world_text(&w, msg, &err), CORE_EIO);
    assert_non_null(strstr(err.msg, "groom data: GET http://127.0.0.1:1/groom.bin answered 503"));
    srv.fail = NULL;
    assert_int_equal(scen_world_text(&w, msg, &err), CORE_OK);
    assert_true(w.rest_lengths && w.rest_lengths[0] == 0.5f);
    scen_world_free(&w);
}

static void test_check_passes_rest_pose(void **state)
{
    (void)state;
    scen_world w;
    fake_server srv;
    load(&w, &srv);
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
    assert_int_equal(c.groom_unchecked, 0);
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
    fake_server srv;
    load(&w, &srv);
    float xyz[18];
    core_err err;
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
    assert_int_equal(scen_world_text(&w, "{\"type\":\"params\",\"values\":{\"collisions\":false},\"by\":1}", &err), CORE_OK);
    c = one_frame(&w, NULL, xyz, 10);
    assert_true(scen_check_end(&c, NULL, ""));
    assert_int_equal(scen_world_text(&w, "{\"type\":\"params\",\"values\":{\"collisions\":true},\"by\":1}", &err), CORE_OK);
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

/* The head pose is the frame's own: roots and collider depths are measured under the head
 * transform its header carries (a preset running or not). */
static void test_check_follows_head(void **state)
{
    (void)state;
    scen_world w;
    fake_server srv;
    load(&w, &srv);
    float at_rest[18], raised[18];
    rest_frame(at_rest, 0);
    rest_frame(raised, 0.1f);
    scen_check c;
    scen_check_begin(&c, NULL);
    codec_frame_info f = frame_info(1, 1.0);
    scen_check_frame(&c, &w, &f, raised, 1000); /* the header says the identity: roots 10 cm off */
    expect_failure(&c, SCEN_INV_ROOT, 1, 0, 0);
    assert_true(fabs(c.worst[SCEN_INV_ROOT].value - 0.1) < 1e-6);
    f.sim.head_pos[1] = 0.1f; /* the header says raised 10 cm */
    scen_check_begin(&c, NULL);
    scen_check_frame(&c, &w, &f, raised, 1000);
    assert_true(scen_check_end(&c, stderr, ""));
    scen_check_frame(&c, &w, &f, at_rest, 2000);
    assert_int_equal(c.worst[SCEN_INV_ROOT].frames_failed, 1);
    /* turned half a turn about y (a non-unit quaternion is normalized): x and z flip */
    float turned[18];
    rest_frame(turned, 0);
    for (int i = 0; i < 6; i++) {
        turned[3 * i] = -turned[3 * i];
        turned[3 * i + 2] = -turned[3 * i + 2];
    }
    f = frame_info(2, 1.0);
    f.sim.head_rot[1] = 2;
    f.sim.head_rot[3] = 0;
    scen_check_begin(&c, NULL);
    scen_check_frame(&c, &w, &f, turned, 1000);
    assert_true(scen_check_end(&c, stderr, ""));
    /* strand 0 hanging 1 cm into the sphere, seen in the head frame */
    turned[(0 * 3 + 1) * 3 + 1] = 0.07f;
    turned[(0 * 3 + 2) * 3 + 1] = 0.04f;
    scen_check_begin(&c, &(scen_check_desc){ .max_stretch = -1 });
    scen_check_frame(&c, &w, &f, turned, 1000);
    expect_failure(&c, SCEN_INV_DEPTH, 2, 0, 2);
    scen_world_free(&w);
}

static void test_check_rate_and_gaps(void **state)
{
    (void)state;
    scen_world w;
    fake_server srv;
    load(&w, &srv);
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

    const char *metrics = "{\"steps\":[{\"expect\":\"metrics\",\"path\":\"strandcast_steps_total\",\"min\":1}]}";
    if (scen_script_parse(&s, metrics, strlen(metrics), &err) != CORE_OK) fail_msg("%s", err.msg);
    assert_true(s.nsteps == 1 && s.steps[0].kind == SCEN_EXPECT && s.steps[0].min == 1);
    assert_string_equal(s.steps[0].what, "metrics");
    assert_string_equal(s.steps[0].path, "strandcast_steps_total");
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
    bad_script("{\"steps\":[{\"expect\":\"hellos\",\"path\":\"a\",\"equals\":1}]}",
               "field \"expect\": must be \"hello\", \"params\", \"state\", \"groom\", \"frame\" or \"metrics\"");
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
        cmocka_unit_test(test_world_groom_data),
        cmocka_unit_test(test_check_passes_rest_pose),
        cmocka_unit_test(test_check_catches_faults),
        cmocka_unit_test(test_check_follows_head),
        cmocka_unit_test(test_check_rate_and_gaps),
        cmocka_unit_test(test_script_reads_steps),
        cmocka_unit_test(test_script_errors_name_step_and_field),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
