/* Integration tests: the real strandcastd on a free loopback port, driven by real WebSocket clients.
 * usage: it_net STRANDCASTD [TEST-NAME-PATTERN] */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <cjson/cJSON.h>
#include <math.h>
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "codec/codec.h"
#include "proto/proto.h"
#include "support/daemon.h"
#include "support/rawws.h"
#include "wsc/wsc.h"

#define SUBPROTOCOL PROTO_SUBPROTOCOL
#define NSTRANDS 128
#define NVERTS 8
#define WAIT_MS 8000 /* generous: the ASan build is slow */

typedef struct config {
    const char *exe;
} config;

/* What one client has decoded from its binary frames. */
typedef struct view {
    codec_decoder dec;
    float *xyz;
    size_t cap;
    codec_frame_info info; /* of the last decoded frame */
    uint64_t ok, bad, keys;
    uint64_t last_seq, last_key_seq; /* of the last decoded frame and keyframe */
    uint64_t seq_gcd, key_gcd;       /* gcd of the seq steps between decoded frames / keyframes */
    bool first_was_key;
    char last_error[256];
} view;

typedef struct fixture {
    const config *cfg;
    char dir[64];
    char web[96], assets[96];
    daemon_proc d;
    wsc *w;
    view views[8];
    int nviews;
} fixture;

static uint64_t gcd(uint64_t a, uint64_t b)
{
    while (b) {
        uint64_t t = a % b;
        a = b;
        b = t;
    }
    return a;
}

static void on_frame(wsc_conn *c, const uint8_t *data, size_t len, void *user)
{
    (void)c;
    view *v = user;
    codec_frame_info info;
    core_err err;
    if (codec_peek_header(data, len, &info, &err) != CORE_OK) {
        v->bad++;
        snprintf(v->last_error, sizeof v->last_error, "%s", err.msg);
        return;
    }
    size_t need = 3 * (size_t)info.nstrands_sent * info.nverts;
    if (need > v->cap) {
        v->xyz = realloc(v->xyz, need * sizeof *v->xyz);
        v->cap = need;
    }
    if (codec_decode(&v->dec, data, len, v->xyz, v->cap, &info, &err) != CORE_OK) {
        v->bad++;
        snprintf(v->last_error, sizeof v->last_error, "%s", err.msg);
        return;
    }
    if (v->ok == 0) v->first_was_key = info.keyframe;
    else v->seq_gcd = gcd(v->seq_gcd, info.seq - v->last_seq);
    if (info.keyframe && v->keys) v->key_gcd = gcd(v->key_gcd, info.seq - v->last_key_seq);
    if (info.keyframe) v->last_key_seq = info.seq;
    v->last_seq = info.seq;
    v->ok++;
    v->keys += info.keyframe;
    v->info = info;
}

static void write_file(const char *path, const void *data, size_t len)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, len, f), len);
    fclose(f);
}

/* A valid Cem Yuksel .hair file: hairs strands of pts points (2 cm apart) hanging from a ring,
 * lifted by up m. */
static void write_hair(const char *path, uint32_t hairs, uint32_t pts, float up)
{
    size_t len = 128 + (size_t)hairs * pts * 12;
    unsigned char *buf = calloc(1, len);
    assert_non_null(buf);
    memcpy(buf, "HAIR", 4);
    uint32_t points = hairs * pts, flags = 2, segs = pts - 1;
    memcpy(buf + 4, &hairs, 4);
    memcpy(buf + 8, &points, 4);
    memcpy(buf + 12, &flags, 4);
    memcpy(buf + 16, &segs, 4);
    float *p = (float *)(buf + 128);
    for (uint32_t s = 0; s < hairs; s++)
        for (uint32_t k = 0; k < pts; k++) {
            float a = 6.2831853f * (float)s / (float)hairs;
            p[3 * (s * pts + k) + 0] = 0.07f * cosf(a);
            p[3 * (s * pts + k) + 1] = up + 0.05f - 0.02f * (float)k;
            p[3 * (s * pts + k) + 2] = 0.07f * sinf(a);
        }
    write_file(path, buf, len);
    free(buf);
}

/* Starts the daemon with the common flags plus extra (NULL-terminated, may be NULL). */
static int setup_with(void **state, const char *const *extra)
{
    fixture *fx = calloc(1, sizeof *fx);
    fx->cfg = *state;
    snprintf(fx->dir, sizeof fx->dir, "/tmp/strandcast-it-XXXXXX");
    assert_non_null(mkdtemp(fx->dir));
    snprintf(fx->web, sizeof fx->web, "%s/web", fx->dir);
    snprintf(fx->assets, sizeof fx->assets, "%s/assets", fx->dir);
    mkdir(fx->web, 0755);
    mkdir(fx->assets, 0755);
    static const char *const files[][2] = {
        { "index.html", "<!doctype html><title>t</title>" }, { "app.js", "export const a = 1;\n" },
        { "mod.mjs", "export default 2;\n" },                 { "x.wasm", "\0asm\1\0\0\0" },
        { "data.json", "{\"a\":1}" },                         { "style.css", "body{}" },
    };
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        char p[160];
        snprintf(p, sizeof p, "%s/%s", fx->web, files[i][0]);
        write_file(p, files[i][1], strcmp(files[i][0], "x.wasm") == 0 ? 8 : strlen(files[i][1]));
    }
    char hair[160];
    snprintf(hair, sizeof hair, "%s/tiny.hair", fx->assets);
    write_hair(hair, 16, 8, 0.0f);
    snprintf(hair, sizeof hair, "%s/far.hair", fx->assets);
    write_hair(hair, 16, 8, 2000.0f);
    char strands[16], verts[16];
    snprintf(strands, sizeof strands, "%d", NSTRANDS);
    snprintf(verts, sizeof verts, "%d", NVERTS);
    /* --backend cpu: the auto probe would load lavapipe, whose Mesa/LLVM allocations LeakSanitizer
     * reports from an unloaded module in the sanitizer tree (the Vulkan tests cover auto) */
    char *argv[32] = { (char *)fx->cfg->exe, "--port", "0", "--backend", "cpu", "--strands", strands, "--verts", verts,
                       "--threads", "1", "--web", fx->web, "--assets", fx->assets, "--client-buffer", "8192", NULL };
    int argc = 0;
    while (argv[argc]) argc++;
    for (; extra && *extra && argc < 31; extra++) argv[argc++] = (char *)*extra;
    argv[argc] = NULL;
    assert_int_equal(daemon_start(&fx->d, fx->cfg->exe, argv, 20000), 0);
    fx->w = wsc_new();
    assert_non_null(fx->w);
    *state = fx;
    return 0;
}

static int setup(void **state)
{
    return setup_with(state, NULL);
}

#define PING_INTERVAL_S 1
#define PING_TIMEOUT_S 3

static int setup_ping(void **state)
{
    static const char *const extra[] = { "--ping-interval", "1", "--ping-timeout", "3", NULL };
    return setup_with(state, extra);
}

static int setup_ipv6(void **state)
{
    static const char *const extra[] = { "--listen", "::1", NULL };
    return setup_with(state, extra);
}

static int teardown(void **state)
{
    fixture *fx = *state;
    wsc_free(fx->w);
    int rc = fx->d.pid ? daemon_stop(&fx->d, SIGTERM, 15000) : 0; /* 0: the test stopped it itself */
    for (int i = 0; i < fx->nviews; i++) {
        codec_decoder_free(&fx->views[i].dec);
        free(fx->views[i].xyz);
    }
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf %s", fx->dir);
    if (system(cmd) != 0) fprintf(stderr, "could not remove %s\n", fx->dir);
    free(fx);
    if (rc != 0) fprintf(stderr, "strandcastd exited with %d after SIGTERM (want 0)\n", rc);
    return rc == 0 ? 0 : -1;
}

/* Connects a client with a frame view; waits for it to open. */
static wsc_conn *connect_view(fixture *fx, view **out)
{
    assert_true(fx->nviews < 8);
    view *v = &fx->views[fx->nviews++];
    codec_decoder_init(&v->dec);
    wsc_conn *c = wsc_connect(fx->w, fx->d.port, SUBPROTOCOL, on_frame, v);
    assert_true(wsc_wait_open(fx->w, c, WAIT_MS));
    if (out) *out = v;
    return c;
}

static cJSON *expect_msg_within(fixture *fx, wsc_conn *c, const char *type, int ms)
{
    const char *t = wsc_next_of_type(fx->w, c, type, ms);
    if (!t) {
        size_t n;
        char *const *all = wsc_texts(c, &n);
        for (size_t i = 0; i < n; i++) fprintf(stderr, "  got: %.160s\n", all[i]);
        fail_msg("no \"%s\" message arrived", type);
    }
    cJSON *j = cJSON_Parse(t);
    assert_non_null(j);
    return j;
}

static cJSON *expect_msg(fixture *fx, wsc_conn *c, const char *type) { return expect_msg_within(fx, c, type, WAIT_MS); }

static const cJSON *get(const cJSON *o, const char *k)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, k);
    if (!v) fail_msg("missing key \"%s\"", k);
    return v;
}

static double num(const cJSON *o, const char *k)
{
    const cJSON *v = get(o, k);
    assert_true(cJSON_IsNumber(v));
    return v->valuedouble;
}

static const char *str(const cJSON *o, const char *k)
{
    const cJSON *v = get(o, k);
    assert_true(cJSON_IsString(v));
    return v->valuestring;
}

/* A wsc_until condition: a view's counter (frames, keyframes) has reached n. */
typedef struct reach_arg {
    const uint64_t *count;
    uint64_t n;
} reach_arg;

static bool counted(void *arg)
{
    reach_arg *c = arg;
    return *c->count >= c->n;
}

static void wait_frames(fixture *fx, view *v, uint64_t n)
{
    reach_arg f = { &v->ok, n };
    if (!wsc_until(fx->w, counted, &f, WAIT_MS)) fail_msg("only %llu frames decoded (want %llu; %llu bad: %s)",
                                                             (unsigned long long)v->ok, (unsigned long long)n,
                                                             (unsigned long long)v->bad, v->last_error);
}

typedef struct time_arg {
    view *v;
    double t;
} time_arg;

static bool at_time(void *arg)
{
    time_arg *a = arg;
    return a->v->ok && fabs(a->v->info.sim_time - a->t) < 1e-3;
}

static void wait_sim_time(fixture *fx, view *v, double t)
{
    time_arg a = { v, t };
    if (!wsc_until(fx->w, at_time, &a, WAIT_MS)) fail_msg("no frame at sim time %g (last %g)", t, v->info.sim_time);
}

/* Mean y of the last vertex of every decoded strand. */
static double mean_tip_y(const view *v)
{
    double s = 0;
    for (uint32_t i = 0; i < v->info.nstrands_sent; i++) s += v->xyz[3 * ((size_t)i * v->info.nverts + v->info.nverts - 1) + 1];
    return s / v->info.nstrands_sent;
}

/* The value of a metric line "name value" in a Prometheus text body (-1 when absent). */
static double metric(const char *body, const char *name)
{
    char pat[160];
    snprintf(pat, sizeof pat, "\n%s ", name);
    const char *p = strstr(body, pat);
    return p ? atof(p + strlen(pat)) : -1.0;
}

static void test_hello_and_frames(void **state)
{
    fixture *fx = *state;
    view *v;
    wsc_conn *c = connect_view(fx, &v);
    cJSON *h = expect_msg(fx, c, "hello");
    assert_string_equal(str(h, "server"), "strandcastd");
    assert_string_equal(str(h, "subprotocol"), SUBPROTOCOL);
    assert_true(num(h, "protocol") == PROTO_VERSION);
    assert_true(num(h, "client") >= 1);
    const cJSON *caps = get(h, "capabilities");
    bool has_params = false;
    for (const cJSON *e = caps->child; e; e = e->next) has_params |= strcmp(e->valuestring, "params") == 0;
    assert_true(has_params);
    const cJSON *schema = get(get(h, "params"), "schema");
    assert_true(cJSON_GetArraySize(schema) >= 10);
    bool has_gravity = false;
    for (const cJSON *e = schema->child; e; e = e->next) {
        str(e, "name");
        str(e, "type");
        num(e, "min");
        num(e, "max");
        get(e, "default");
        str(e, "unit");
        assert_true(strlen(str(e, "help")) > 0);
        if (strcmp(str(e, "name"), "gravity") == 0) has_gravity = num(e, "default") == 9.81;
    }
    assert_true(has_gravity);
    assert_true(num(get(get(h, "params"), "values"), "gravity") == 9.81);
    const cJSON *g = get(h, "groom");
    assert_true(num(g, "strands") == NSTRANDS && num(g, "verts") == NVERTS);
    assert_int_equal(cJSON_GetArraySize(get(g, "roots")), 3 * NSTRANDS);
    assert_int_equal(cJSON_GetArraySize(get(g, "rest_lengths")), NSTRANDS);
    assert_true(cJSON_GetArraySize(get(h, "colliders")) > 0);
    const cJSON *files = get(get(h, "grooms"), "files"); /* sorted */
    assert_int_equal(cJSON_GetArraySize(files), 2);
    assert_string_equal(cJSON_GetArrayItem(files, 0)->valuestring, "far.hair");
    assert_string_equal(cJSON_GetArrayItem(files, 1)->valuestring, "tiny.hair");
    assert_string_equal(str(get(h, "stream"), "codec"), "strand");

    wait_frames(fx, v, 10);
    assert_true(v->first_was_key);
    assert_int_equal(v->bad, 0);
    assert_int_equal(v->info.nstrands_total, NSTRANDS);
    assert_int_equal(v->info.nstrands_sent, NSTRANDS);
    assert_int_equal(v->info.nverts, NVERTS);
    for (size_t i = 0; i < 3 * NSTRANDS * NVERTS; i++) assert_true(isfinite(v->xyz[i]));
    /* roots sit where the hello says (head at rest) */
    const cJSON *roots = get(g, "roots");
    for (int s = 0; s < NSTRANDS; s += 37)
        for (int k = 0; k < 3; k++)
            assert_true(fabs(v->xyz[3 * (size_t)s * NVERTS + k] - cJSON_GetArrayItem(roots, 3 * s + k)->valuedouble) < 2e-4);
    cJSON_Delete(h);
}

/* Paused: reset, then step n times; returns once the frame after the last step arrived. */
static void reset_and_step(fixture *fx, wsc_conn *c, view *v, int n)
{
    wsc_send_text(c, "{\"type\":\"reset\",\"id\":\"r\"}");
    cJSON *ok = expect_msg(fx, c, "ok");
    assert_string_equal(str(ok, "request"), "reset");
    cJSON_Delete(ok);
    wait_sim_time(fx, v, 0.0);
    if (!n) return;
    char msg[64];
    snprintf(msg, sizeof msg, "{\"type\":\"step\",\"count\":%d}", n);
    wsc_send_text(c, msg);
    ok = expect_msg(fx, c, "ok");
    assert_string_equal(str(ok, "request"), "step");
    cJSON_Delete(ok);
    wait_sim_time(fx, v, n / 60.0);
}

static void test_params_broadcast_and_physics(void **state)
{
    fixture *fx = *state;
    view *v1, *v2;
    wsc_conn *c1 = connect_view(fx, &v1), *c2 = connect_view(fx, &v2);
    cJSON *h1 = expect_msg(fx, c1, "hello"), *h2 = expect_msg(fx, c2, "hello");
    double me = num(h1, "client");
    assert_true(num(h2, "client") != me);

    /* shape off: the default groom's stiff shape springs hold it against gravity */
    wsc_send_text(c1, "{\"type\":\"set_params\",\"id\":\"s0\",\"values\":{\"shape\":false}}");
    cJSON_Delete(expect_msg(fx, c1, "ok"));
    cJSON_Delete(expect_msg(fx, c2, "params"));
    cJSON_Delete(expect_msg(fx, c1, "params"));
    wsc_send_text(c1, "{\"type\":\"pause\",\"id\":1}");
    cJSON *ok = expect_msg(fx, c1, "ok");
    assert_true(num(ok, "id") == 1);
    assert_string_equal(str(ok, "request"), "pause");
    cJSON *st = expect_msg(fx, c2, "state");
    assert_true(cJSON_IsTrue(get(st, "paused")));

    /* with gravity: reset, 30 steps */
    reset_and_step(fx, c1, v1, 30);
    double tip_g = mean_tip_y(v1);

    /* gravity 0: acknowledged, broadcast to the other client with who changed it */
    wsc_send_text(c1, "{\"type\":\"set_params\",\"id\":\"g0\",\"values\":{\"gravity\":0}}");
    cJSON *ok2 = expect_msg(fx, c1, "ok");
    assert_string_equal(str(ok2, "id"), "g0");
    cJSON *p2 = expect_msg(fx, c2, "params");
    assert_true(num(get(p2, "values"), "gravity") == 0.0);
    assert_true(num(p2, "by") == me);
    assert_int_equal(cJSON_GetArraySize(get(p2, "values")), 1);
    cJSON *p1 = expect_msg(fx, c1, "params");
    assert_true(num(get(p1, "values"), "gravity") == 0.0);
    wsc_send_text(c2, "{\"type\":\"get_params\",\"id\":7}");
    cJSON *gp = expect_msg(fx, c2, "params");
    assert_true(num(gp, "id") == 7 && num(get(gp, "values"), "gravity") == 0.0 && cJSON_IsNull(get(gp, "by")));

    reset_and_step(fx, c1, v1, 0);
    double tip_rest = mean_tip_y(v1);
    reset_and_step(fx, c1, v1, 30);
    double tip_0 = mean_tip_y(v1);
    /* without gravity the tips stay near rest; with it they sag */
    if (!(tip_0 > tip_g + 0.002)) fail_msg("tips: gravity %.5f, none %.5f, rest %.5f", tip_g, tip_0, tip_rest);
    assert_true(fabs(tip_0 - tip_rest) < fabs(tip_g - tip_rest));
    assert_int_equal(v1->bad + v2->bad, 0);
    cJSON_Delete(h1);
    cJSON_Delete(h2);
    cJSON_Delete(ok);
    cJSON_Delete(st);
    cJSON_Delete(ok2);
    cJSON_Delete(p1);
    cJSON_Delete(p2);
    cJSON_Delete(gp);
}

typedef struct roots_arg {
    view *v;
    const cJSON *roots;
    double rot90;  /* 1 = expect a +90 degree turn about y */
    double off[3];
} roots_arg;

static bool roots_at(void *arg)
{
    roots_arg *a = arg;
    if (!a->v->ok) return false;
    for (int s = 0; s < NSTRANDS; s += 17) {
        double r[3];
        for (int k = 0; k < 3; k++) r[k] = cJSON_GetArrayItem(a->roots, 3 * s + k)->valuedouble;
        if (a->rot90 != 0) { /* (x, y, z) -> (z, y, -x) */
            double x = r[0];
            r[0] = r[2];
            r[2] = -x;
        }
        for (int k = 0; k < 3; k++)
            if (fabs(a->v->xyz[3 * (size_t)s * NVERTS + k] - (r[k] + a->off[k])) > 5e-4) return false;
    }
    return true;
}

static void test_motion_moves_roots(void **state)
{
    fixture *fx = *state;
    view *v;
    wsc_conn *c = connect_view(fx, &v);
    cJSON *h = expect_msg(fx, c, "hello");
    const cJSON *roots = get(get(h, "groom"), "roots");
    wait_frames(fx, v, 2);
    wsc_send_text(c, "{\"type\":\"motion\",\"t\":1,\"position\":[0.05,0.1,-0.02],\"orientation\":[0,0,0,1]}");
    roots_arg a = { v, roots, 0, { 0.05, 0.1, -0.02 } };
    if (!wsc_until(fx->w, roots_at, &a, WAIT_MS)) fail_msg("roots did not follow the head translation");
    /* a stale motion (older t) is ignored */
    wsc_send_text(c, "{\"type\":\"motion\",\"t\":0.5,\"position\":[0,0,0],\"orientation\":[0,0,0,1]}");
    wsc_send_text(c, "{\"type\":\"motion\",\"t\":2,\"position\":[0,0,0],\"orientation\":[0,0.70710678,0,0.70710678],\"id\":3}");
    cJSON *ok = expect_msg(fx, c, "ok");
    assert_true(num(ok, "id") == 3);
    roots_arg b = { v, roots, 1, { 0, 0, 0 } };
    if (!wsc_until(fx->w, roots_at, &b, WAIT_MS)) fail_msg("roots did not follow the head rotation");
    /* a stale motion with an id is answered; motions with ids are never coalesced away */
    wsc_send_text(c, "{\"type\":\"motion\",\"t\":1.5,\"position\":[0,0,0],\"orientation\":[0,0,0,1],\"id\":\"old\"}");
    cJSON *stale = expect_msg(fx, c, "error");
    assert_string_equal(str(stale, "code"), "bad_state");
    assert_string_equal(str(stale, "field"), "t");
    assert_string_equal(str(stale, "id"), "old");
    cJSON_Delete(stale);
    for (int i = 0; i < 6; i++) {
        char m[160];
        snprintf(m, sizeof m, "{\"type\":\"motion\",\"t\":%d,\"position\":[0,0,0],\"orientation\":[0,0.70710678,0,0.70710678],\"id\":%d}",
                 2 + i, 10 + i);
        wsc_send_text(c, m);
    }
    for (int i = 0; i < 6; i++) {
        cJSON *o = expect_msg(fx, c, "ok");
        assert_true(num(o, "id") == 10 + i);
        cJSON_Delete(o);
    }

    /* a preset moves the head over time and is announced */
    wsc_send_text(c, "{\"type\":\"animate\",\"preset\":\"shake\",\"speed\":2,\"id\":4}");
    cJSON *st = expect_msg(fx, c, "state");
    assert_string_equal(str(get(st, "animation"), "preset"), "shake");
    assert_true(num(get(st, "animation"), "speed") == 2);
    double x0 = v->xyz[0];
    double maxd = 0;
    for (int i = 0; i < 20; i++) {
        wsc_run(fx->w, 50);
        maxd = fmax(maxd, fabs(v->xyz[0] - x0));
    }
    assert_true(maxd > 0.005);
    /* motion stops the preset */
    wsc_send_text(c, "{\"type\":\"motion\",\"t\":20,\"position\":[0,0,0],\"orientation\":[0,0,0,1]}");
    cJSON *st2 = expect_msg(fx, c, "state");
    assert_string_equal(str(get(st2, "animation"), "preset"), "none");
    assert_int_equal(v->bad, 0);
    cJSON_Delete(h);
    cJSON_Delete(ok);
    cJSON_Delete(st);
    cJSON_Delete(st2);
}

static void test_bad_inputs_keep_stream(void **state)
{
    fixture *fx = *state;
    view *watch;
    wsc_conn *c1 = connect_view(fx, &watch);
    wsc_conn *c2 = connect_view(fx, NULL);
    cJSON *h = expect_msg(fx, c2, "hello");
    cJSON_Delete(h);
    wait_frames(fx, watch, 3);
    uint64_t before = watch->ok;
    static const struct {
        const char *msg, *code, *field;
    } cases[] = {
        { "not json", "bad_json", "" },
        { "[1,2,3]", "bad_json", "" },
        { "{\"type\":\"fly\",\"id\":5}", "unknown_type", "type" },
        { "{\"id\":6}", "bad_field", "type" },
        { "{\"type\":\"reset\",\"extra\":true,\"id\":\"e\"}", "bad_field", "extra" },
        { "{\"type\":\"set_params\",\"id\":\"x\",\"values\":{\"gravity\":\"high\"}}", "bad_field", "values.gravity" },
        { "{\"type\":\"set_params\",\"values\":{\"gravity\":-3}}", "out_of_range", "values.gravity" },
        { "{\"type\":\"set_params\",\"values\":{\"gravity\":1e999}}", "not_finite", "values.gravity" },
        { "{\"type\":\"set_params\",\"values\":{\"nope\":1}}", "unknown_param", "values.nope" },
        { "{\"type\":\"set_params\",\"values\":{\"shape\":1}}", "bad_field", "values.shape" },
        { "{\"type\":\"set_groom\",\"file\":\"../../etc/passwd\"}", "bad_field", "file" },
        { "{\"type\":\"set_groom\",\"file\":\"missing.tfx\"}", "not_found", "file" },
        { "{\"type\":\"step\",\"id\":9}", "bad_state", "" },
        { "{\"type\":\"subscribe\",\"stride\":0}", "out_of_range", "stride" },
        { "{\"type\":\"motion\",\"position\":[0,0],\"orientation\":[0,0,0,1]}", "bad_field", "position" },
        { "{\"type\":\"animate\",\"preset\":\"moonwalk\"}", "out_of_range", "preset" },
        { "{\"type\":\"reset\",\"id\":\"0123456789012345678901234567890123456789012345678901234567890123456789\"}",
          "too_large", "id" },
        { "{\"type\":\"reset\",\"x\":[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]}",
          "bad_field", "x" },
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        wsc_send_text(c2, cases[i].msg);
        cJSON *e = expect_msg(fx, c2, "error");
        if (strcmp(str(e, "code"), cases[i].code) != 0 || strcmp(str(e, "field"), cases[i].field) != 0)
            fail_msg("%s: got %s/%s (%s)", cases[i].msg, str(e, "code"), str(e, "field"), str(e, "message"));
        assert_true(strlen(str(e, "message")) > 0);
        if (strstr(cases[i].msg, "\"id\":5")) assert_true(num(e, "id") == 5);
        if (strstr(cases[i].msg, "\"id\":\"x\"")) assert_string_equal(str(e, "id"), "x");
        cJSON_Delete(e);
    }
    /* the offender's connection still works; a fragmented message is reassembled */
    static const char *const parts[] = { "{\"type\":\"get", "_params\",", "\"id\":77}" };
    for (int i = 0; i < 3; i++) wsc_send_frame(c2, parts[i], strlen(parts[i]), false, i > 0, i == 2);
    cJSON *p = expect_msg(fx, c2, "params");
    assert_true(num(p, "id") == 77);
    cJSON_Delete(p);

    /* protocol violations close with the right code (raw frames, exactly as written) */
    int fd = rawws_open(fx->d.port, SUBPROTOCOL);
    assert_true(fd >= 0);
    assert_int_equal(rawws_send(fd, 2, "\x01\x02", 2, true), 0);
    assert_int_equal(rawws_close_code(fd, WAIT_MS), 1003);
    rawws_free(fd);
    fd = rawws_open(fx->d.port, SUBPROTOCOL);
    size_t half = 40 * 1024;
    char *chunk = malloc(half);
    memset(chunk, ' ', half);
    chunk[0] = '{';
    assert_int_equal(rawws_send(fd, 1, chunk, half, false), 0);
    rawws_send(fd, 0, chunk + 1, half - 1, true);
    free(chunk);
    assert_int_equal(rawws_close_code(fd, WAIT_MS), 1009);
    rawws_free(fd);
    fd = rawws_open(fx->d.port, SUBPROTOCOL);
    assert_int_equal(rawws_send(fd, 1, "{\"type\":\"\xff\xfe\"}", 13, true), 0);
    assert_int_equal(rawws_close_code(fd, WAIT_MS), 1007);
    rawws_free(fd);
    /* a code point split across fragments is fine; a truncated one at the end is not */
    fd = rawws_open(fx->d.port, SUBPROTOCOL);
    static const char part1[] = "{\"type\":\"reset\",\"id\":\"\xe2\x82", part2[] = "\xac\"}", cut[] = "\"\xe2\x82";
    assert_int_equal(rawws_send(fd, 1, part1, sizeof part1 - 1, false), 0);
    assert_int_equal(rawws_send(fd, 0, part2, sizeof part2 - 1, true), 0);
    assert_int_equal(rawws_send(fd, 1, cut, sizeof cut - 1, true), 0);
    assert_int_equal(rawws_close_code(fd, WAIT_MS), 1007);
    rawws_free(fd);

    /* the watcher never stopped receiving decodable frames */
    wait_frames(fx, watch, before + 20);
    assert_int_equal(watch->bad, 0);
    assert_true(wsc_is_open(c1) && wsc_is_open(c2));
    http_reply r;
    assert_int_equal(http_get(fx->d.port, "/metrics", &r), 0);
    assert_true(metric(r.body, "strandcast_control_messages_total{result=\"rejected\"}") >= 18);
    assert_true(metric(r.body, "strandcast_protocol_closes_total") >= 3);
    http_reply_free(&r);
}

static void test_subprotocol_refused(void **state)
{
    fixture *fx = *state;
    static const char *const req =
        "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
        "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n%s\r\n";
    char buf[512];
    http_reply r;
    snprintf(buf, sizeof buf, req, "Sec-WebSocket-Protocol: strandcast.v1\r\n");
    assert_int_equal(http_exchange(fx->d.port, buf, &r, 3000), 0);
    assert_int_equal(r.status, 400);
    assert_non_null(strstr(r.body, "strandcast.v2"));
    assert_non_null(strstr(r.body, "strandcast.v1"));
    http_reply_free(&r);
    snprintf(buf, sizeof buf, req, "");
    assert_int_equal(http_exchange(fx->d.port, buf, &r, 3000), 0);
    assert_int_equal(r.status, 400);
    assert_non_null(strstr(r.body, "strandcast.v2"));
    http_reply_free(&r);
    /* the right name in a list is accepted */
    snprintf(buf, sizeof buf, req, "Sec-WebSocket-Protocol: chat, strandcast.v2\r\n");
    assert_int_equal(http_exchange(fx->d.port, buf, &r, 300), 0);
    assert_int_equal(r.status, 101);
    http_reply_free(&r);
    /* a real client asking for another subprotocol fails to connect */
    wsc_conn *c = wsc_connect(fx->w, fx->d.port, "other.v9", NULL, NULL);
    assert_false(wsc_wait_open(fx->w, c, WAIT_MS));
    assert_true(wsc_failed(c));
}

static void test_http_static_and_metrics(void **state)
{
    fixture *fx = *state;
    static const struct {
        const char *path, *type;
    } files[] = {
        { "/", "text/html" },           { "/index.html", "text/html" },   { "/app.js", "text/javascript" },
        { "/mod.mjs", "text/javascript" }, { "/x.wasm", "application/wasm" }, { "/data.json", "application/json" },
        { "/style.css", "text/css" },
    };
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        http_reply r;
        assert_int_equal(http_get(fx->d.port, files[i].path, &r), 0);
        if (r.status != 200 || strncmp(r.content_type, files[i].type, strlen(files[i].type)) != 0)
            fail_msg("%s: %d %s", files[i].path, r.status, r.content_type);
        http_reply_free(&r);
    }
    http_reply r;
    assert_int_equal(http_get(fx->d.port, "/x.wasm", &r), 0);
    assert_int_equal(r.body_len, 8);
    assert_memory_equal(r.body, "\0asm\1\0\0\0", 8);
    http_reply_free(&r);
    assert_int_equal(http_get(fx->d.port, "/missing.js", &r), 0);
    assert_int_equal(r.status, 404);
    http_reply_free(&r);
    assert_int_equal(http_get(fx->d.port, "/../assets/tiny.hair", &r), 0);
    assert_int_not_equal(r.status, 200);
    http_reply_free(&r);
    assert_int_equal(http_get(fx->d.port, "/%2e%2e/assets/tiny.hair", &r), 0);
    assert_int_not_equal(r.status, 200);
    http_reply_free(&r);

    wsc_conn *c = connect_view(fx, NULL);
    (void)c;
    wsc_run(fx->w, 1500);
    assert_int_equal(http_get(fx->d.port, "/metrics", &r), 0);
    assert_int_equal(r.status, 200);
    assert_string_equal(r.content_type, "text/plain; version=0.0.4; charset=utf-8");
    static const char *const names[] = {
        "strandcast_steps_per_second ", "strandcast_step_seconds ", "strandcast_clients 1\n",
        "strandcast_frames_sent_total ", "strandcast_frames_skipped_total ", "strandcast_bytes_sent_total ",
        "strandcast_encode_seconds ", "strandcast_control_messages_total{result=\"accepted\"} ",
        "strandcast_control_messages_total{result=\"rejected\"} ", "# TYPE strandcast_steps_total counter",
    };
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (!strstr(r.body, names[i])) fail_msg("/metrics lacks %s", names[i]);
    assert_true(metric(r.body, "strandcast_steps_per_second") > 1.0);
    assert_true(metric(r.body, "strandcast_frames_sent_total") > 10.0);
    assert_true(metric(r.body, "strandcast_bytes_sent_total") > 1000.0);
    http_reply_free(&r);

    /* three clients of one stream: each frame is encoded once and sent three times */
    wsc_conn *c2 = connect_view(fx, NULL), *c3 = connect_view(fx, NULL);
    wsc_run(fx->w, 500);
    assert_int_equal(http_get(fx->d.port, "/metrics", &r), 0);
    double enc0 = metric(r.body, "strandcast_frames_encoded_total"), sent0 = metric(r.body, "strandcast_frames_sent_total");
    double acc0 = metric(r.body, "strandcast_control_messages_total{result=\"accepted\"}");
    double run0 = metric(r.body, "strandcast_steps_total"), sim0 = metric(r.body, "strandcast_sim_steps");
    http_reply_free(&r);
    wsc_send_text(c2, "{\"type\":\"get_params\",\"id\":1}");
    cJSON_Delete(expect_msg(fx, c2, "params"));
    wsc_run(fx->w, 1500);
    assert_int_equal(http_get(fx->d.port, "/metrics", &r), 0);
    double enc = metric(r.body, "strandcast_frames_encoded_total") - enc0;
    double sent = metric(r.body, "strandcast_frames_sent_total") - sent0;
    if (!(enc > 10 && sent >= 2.7 * enc && sent <= 3.3 * enc))
        fail_msg("%g frames encoded, %g sent to 3 clients of one stream", enc, sent);
    assert_true(metric(r.body, "strandcast_control_messages_total{result=\"accepted\"}") == acc0 + 1);
    double run1 = metric(r.body, "strandcast_steps_total"), sim1 = metric(r.body, "strandcast_sim_steps");
    assert_true(run1 > run0 && sim1 > sim0);
    http_reply_free(&r);
    /* a reset restarts the simulation's count, not the daemon's */
    wsc_send_text(c3, "{\"type\":\"reset\"}");
    cJSON_Delete(expect_msg(fx, c3, "state"));
    wsc_run(fx->w, 300); /* the figures are taken after each step */
    assert_int_equal(http_get(fx->d.port, "/metrics", &r), 0);
    if (!(metric(r.body, "strandcast_steps_total") >= run1 && metric(r.body, "strandcast_sim_steps") < sim1))
        fail_msg("after reset: steps_total %g (was %g), sim_steps %g (was %g)", metric(r.body, "strandcast_steps_total"),
                 run1, metric(r.body, "strandcast_sim_steps"), sim1);
    http_reply_free(&r);
}

typedef struct count_arg {
    view *v;
    uint32_t strands, verts;
} count_arg;

static bool frame_shape(void *arg)
{
    count_arg *a = arg;
    return a->v->ok && a->v->info.nstrands_total == a->strands && a->v->info.nverts == a->verts;
}

static void test_pause_step_subscribe_groom(void **state)
{
    fixture *fx = *state;
    view *v, *v2;
    wsc_conn *c = connect_view(fx, &v), *c2 = connect_view(fx, &v2);
    cJSON *h = expect_msg(fx, c, "hello");
    cJSON_Delete(h);
    wsc_send_text(c, "{\"type\":\"pause\"}");
    cJSON *st = expect_msg(fx, c, "state");
    double steps0 = num(st, "steps");
    wsc_send_text(c, "{\"type\":\"step\",\"count\":3,\"id\":1}");
    cJSON *ok = expect_msg(fx, c, "ok");
    cJSON *st2 = expect_msg(fx, c, "state");
    assert_true(num(st2, "steps") == steps0 + 3);
    assert_true(cJSON_IsTrue(get(st2, "paused")));
    wsc_send_text(c, "{\"type\":\"resume\"}");
    cJSON *st3 = expect_msg(fx, c, "state");
    assert_true(cJSON_IsFalse(get(st3, "paused")));

    /* every 4th strand, coarser error, 20 frames/s */
    wsc_send_text(c, "{\"type\":\"subscribe\",\"stride\":4,\"max_error\":0.001,\"max_rate\":20,\"id\":\"s\"}");
    cJSON *sub = expect_msg(fx, c, "subscribed");
    assert_string_equal(str(sub, "id"), "s");
    assert_true(num(get(sub, "stream"), "strands") == NSTRANDS / 4);
    assert_true(num(get(sub, "stream"), "max_rate") == 20);
    wsc_run(fx->w, 300);
    uint64_t n0 = v->ok, m0 = v2->ok;
    wsc_run(fx->w, 2000);
    uint64_t got = v->ok - n0, other = v2->ok - m0;
    assert_int_equal(v->info.stride, 4);
    assert_int_equal(v->info.nstrands_sent, NSTRANDS / 4);
    assert_true(fabs(v->info.max_error_m - 0.001) < 1e-6);
    /* at most 20/s; and no fewer than 60% of what the server published, up to that rate (the
     * sanitizer build may simulate slower than real time) */
    double expect = fmin(40.0, (double)other);
    if ((double)got > 40.0 + 2.0 || (double)got < 0.6 * expect)
        fail_msg("%llu frames in 2 s at max_rate 20 (full-rate client: %llu)", (unsigned long long)got,
                 (unsigned long long)other);
    assert_int_equal(v2->info.nstrands_sent, NSTRANDS);

    /* a keyframe on request, while paused (so that no scheduled keyframe can stand in for it):
     * exactly one frame follows, and it is a keyframe */
    wsc_send_text(c, "{\"type\":\"pause\"}");
    cJSON_Delete(expect_msg(fx, c, "state"));
    wsc_run(fx->w, 300);
    uint64_t keys = v->keys, frames = v->ok;
    wsc_send_text(c, "{\"type\":\"keyframe\",\"id\":2}");
    cJSON *ok2 = expect_msg(fx, c, "ok");
    wsc_run(fx->w, 300);
    if (v->ok != frames + 1 || v->keys != keys + 1)
        fail_msg("after a keyframe request while paused: %llu frames, %llu keyframes (want 1, 1)",
                 (unsigned long long)(v->ok - frames), (unsigned long long)(v->keys - keys));
    wsc_send_text(c, "{\"type\":\"resume\"}");
    cJSON_Delete(expect_msg(fx, c, "state"));

    /* a procedural groom change reaches every client, then frames of the new shape */
    wsc_send_text(c, "{\"type\":\"set_groom\",\"style\":\"wavy\",\"strands\":128,\"verts\":12,\"id\":3}");
    cJSON *ok3 = expect_msg(fx, c, "ok");
    assert_true(num(ok3, "id") == 3);
    cJSON *g2 = expect_msg(fx, c2, "groom");
    assert_true(num(get(g2, "groom"), "strands") == 128 && num(get(g2, "groom"), "verts") == 12);
    assert_string_equal(str(get(g2, "groom"), "source"), "procedural:wavy");
    count_arg ca = { v2, 128, 12 };
    assert_true(wsc_until(fx->w, frame_shape, &ca, WAIT_MS));
    /* one groom change at a time: a second sent right behind a large one is refused */
    wsc_send_text(c, "{\"type\":\"set_groom\",\"style\":\"curly\",\"strands\":12000,\"verts\":32,\"id\":4}");
    wsc_send_text(c, "{\"type\":\"set_groom\",\"style\":\"straight\",\"id\":5}");
    cJSON *busy = expect_msg(fx, c, "error");
    assert_string_equal(str(busy, "code"), "busy");
    assert_true(num(busy, "id") == 5);
    cJSON *ok4 = expect_msg(fx, c, "ok");
    assert_true(num(ok4, "id") == 4);
    cJSON *g4 = expect_msg(fx, c2, "groom");
    assert_true(num(get(g4, "groom"), "strands") == 12000);
    /* a file from the asset folder */
    wsc_send_text(c, "{\"type\":\"set_groom\",\"file\":\"tiny.hair\",\"verts\":6}");
    cJSON *g3 = expect_msg(fx, c2, "groom");
    assert_string_equal(str(get(g3, "groom"), "source"), "file:tiny.hair");
    assert_true(num(get(g3, "groom"), "strands") == 16);
    count_arg cb = { v2, 16, 6 };
    assert_true(wsc_until(fx->w, frame_shape, &cb, WAIT_MS));
    assert_int_equal(v->bad + v2->bad, 0);
    cJSON *items[] = { st, ok, st2, st3, sub, ok2, ok3, g2, g3, busy, ok4, g4 };
    for (size_t i = 0; i < sizeof items / sizeof items[0]; i++) cJSON_Delete(items[i]);
}

/* ---- the collision mesh (Ratboy, from the shared assets; skipped when they are absent) ---- */

#define RATBOY_VERTS 12909u
#define RATBOY_TRIS 25814u
#define MESH_WAIT_MS 240000 /* the SDF of the Ratboy body takes seconds (minutes under ASan) */

/* The shared asset folder (STRANDCAST_ASSETS, else next to the source tree), or NULL when the
 * Ratboy files are not there. */
static const char *ratboy_assets(void)
{
    static char dir[1024];
    const char *env = getenv("STRANDCAST_ASSETS");
    snprintf(dir, sizeof dir, "%s", env ? env : STRANDCAST_SOURCE_DIR "/../shared/assets");
    char p[1100];
    snprintf(p, sizeof p, "%s/ratboy/Ratboy_body.tfxmesh", dir);
    if (access(p, R_OK) != 0) return NULL;
    snprintf(p, sizeof p, "%s/ratboy/Ratboy_mohawk.tfx", dir);
    return access(p, R_OK) == 0 ? dir : NULL;
}

/* The daemon with --groom Ratboy_mohawk.tfx --collider Ratboy_body.tfxmesh and an asset folder
 * holding links to both, a malformed mesh and a tiny .hair. Leaves *state NULL (the test then
 * skips) when the assets are absent. */
static int setup_ratboy(void **state)
{
    const char *src = ratboy_assets();
    if (!src) {
        *state = NULL;
        return 0;
    }
    fixture *fx = calloc(1, sizeof *fx);
    fx->cfg = *state;
    snprintf(fx->dir, sizeof fx->dir, "/tmp/strandcast-it-XXXXXX");
    assert_non_null(mkdtemp(fx->dir));
    snprintf(fx->assets, sizeof fx->assets, "%s/assets", fx->dir);
    mkdir(fx->assets, 0755);
    char p[1200], q[1200], groom[1200], mesh[1200];
    snprintf(p, sizeof p, "%s/ratboy", fx->assets);
    mkdir(p, 0755);
    static const char *const names[] = { "Ratboy_mohawk.tfx", "Ratboy_body.tfxmesh" };
    for (int i = 0; i < 2; i++) {
        snprintf(p, sizeof p, "%s/ratboy/%s", src, names[i]);
        snprintf(q, sizeof q, "%s/ratboy/%s", fx->assets, names[i]);
        assert_int_equal(symlink(p, q), 0);
    }
    snprintf(groom, sizeof groom, "%s/ratboy/Ratboy_mohawk.tfx", src);
    snprintf(mesh, sizeof mesh, "%s/ratboy/Ratboy_body.tfxmesh", src);
    snprintf(p, sizeof p, "%s/bad.obj", fx->assets); /* an open mesh: one triangle */
    write_file(p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", 32);
    snprintf(p, sizeof p, "%s/tiny.hair", fx->assets);
    write_hair(p, 16, 8, 0.0f);
    char *argv[] = { (char *)fx->cfg->exe, "--port", "0", "--backend", "cpu", "--threads", "1", "--verts", "8",
                     "--assets", fx->assets, "--groom", groom, "--collider", mesh, NULL };
    assert_int_equal(daemon_start(&fx->d, fx->cfg->exe, argv, MESH_WAIT_MS), 0);
    fx->w = wsc_new();
    assert_non_null(fx->w);
    *state = fx;
    return 0;
}

static int teardown_ratboy(void **state) { return *state ? teardown(state) : 0; }

/* GET path; checks the reply is the documented mesh binary of the hello's description. */
static void check_mesh_bin(fixture *fx, const cJSON *desc)
{
    http_reply r;
    assert_int_equal(http_get(fx->d.port, str(desc, "url"), &r), 0);
    if (r.status != 200) fail_msg("GET %s: %d\n%.300s", str(desc, "url"), r.status, r.raw);
    assert_string_equal(r.content_type, "application/octet-stream");
    assert_true(r.body_len == (size_t)num(desc, "bytes"));
    uint32_t nv, nt;
    core_err err;
    if (proto_mesh_bin_read((const unsigned char *)r.body, r.body_len, &nv, &nt, &err) != CORE_OK) fail_msg("%s", err.msg);
    assert_int_equal(nv, RATBOY_VERTS);
    assert_int_equal(nt, RATBOY_TRIS);
    /* positions inside the described bounds; the tag is the bytes' hash, also the ETag */
    const cJSON *b = get(desc, "bounds");
    for (uint32_t i = 0; i < 3 * nv; i++) {
        float f;
        memcpy(&f, r.body + PROTO_MESH_HEADER + 4 * i, 4);
        double lo = cJSON_GetArrayItem(b, (int)(i % 3))->valuedouble, hi = cJSON_GetArrayItem(b, (int)(i % 3) + 3)->valuedouble;
        if (!(f >= lo - 1e-6 && f <= hi + 1e-6)) fail_msg("vertex %u coordinate %g outside [%g, %g]", i / 3, (double)f, lo, hi);
    }
    char etag[17], hdr[32];
    proto_mesh_bin_etag((const unsigned char *)r.body, r.body_len, etag);
    assert_string_equal(etag, str(desc, "etag"));
    snprintf(hdr, sizeof hdr, "\"%s\"", etag);
    if (!strstr(r.raw, hdr)) fail_msg("no ETag %s in:\n%.300s", hdr, r.raw);
    http_reply_free(&r);
    /* revalidation: the same tag answers 304 without a body */
    char req[256];
    snprintf(req, sizeof req, "GET %s HTTP/1.1\r\nHost: 127.0.0.1\r\nIf-None-Match: %s\r\nConnection: close\r\n\r\n",
             str(desc, "url"), hdr);
    assert_int_equal(http_exchange(fx->d.port, req, &r, 5000), 0);
    assert_int_equal(r.status, 304);
    assert_int_equal(r.body_len, 0);
    http_reply_free(&r);
}

/* One set_groom that must be refused with code on field; the stream goes on. */
static void expect_groom_error(fixture *fx, wsc_conn *c, view *v, const char *msg, const char *code, const char *field)
{
    wsc_send_text(c, msg);
    cJSON *e = expect_msg(fx, c, "error");
    if (strcmp(str(e, "code"), code) != 0 || strcmp(str(e, "field"), field) != 0)
        fail_msg("%s: %s / %s (%s), want %s / %s", msg, str(e, "code"), str(e, "field"), str(e, "message"), code, field);
    cJSON_Delete(e);
    wait_frames(fx, v, v->ok + 3);
}

static void test_collider_mesh(void **state)
{
    fixture *fx = *state;
    if (!fx) skip();
    view *v;
    wsc_conn *c = connect_view(fx, &v);
    cJSON *h = expect_msg(fx, c, "hello");
    const cJSON *desc = get(h, "collider_mesh");
    assert_true(num(desc, "verts") == RATBOY_VERTS && num(desc, "triangles") == RATBOY_TRIS);
    assert_string_equal(str(desc, "source"), "Ratboy_body.tfxmesh");
    assert_string_equal(str(desc, "url"), "/collider.bin");
    const cJSON *sdf = get(desc, "sdf");
    assert_true(num(sdf, "cell") >= 0.002 - 1e-9);
    const cJSON *meshes = get(get(h, "grooms"), "colliders");
    assert_int_equal(cJSON_GetArraySize(meshes), 2); /* bad.obj and the body, sorted */
    assert_string_equal(cJSON_GetArrayItem(meshes, 1)->valuestring, "ratboy/Ratboy_body.tfxmesh");
    /* the fitted head ellipsoid stays: the mesh adds to the analytic colliders */
    assert_int_equal(cJSON_GetArraySize(get(h, "colliders")), 1);
    check_mesh_bin(fx, desc);
    wait_frames(fx, v, 3);

    /* refusals: the stream goes on after each */
    expect_groom_error(fx, c, v, "{\"type\":\"set_groom\",\"style\":\"wavy\",\"collider\":\"nope.obj\",\"id\":1}", "not_found", "collider");
    expect_groom_error(fx, c, v, "{\"type\":\"set_groom\",\"style\":\"wavy\",\"collider\":\"ratboy/Ratboy_mohawk.tfx\"}", "not_found", "collider");
    expect_groom_error(fx, c, v, "{\"type\":\"set_groom\",\"style\":\"wavy\",\"collider\":\"../ratboy/Ratboy_body.tfxmesh\"}", "bad_field", "collider");
    expect_groom_error(fx, c, v, "{\"type\":\"set_groom\",\"style\":\"wavy\",\"collider\":\"/etc/passwd\"}", "bad_field", "collider");
    expect_groom_error(fx, c, v, "{\"type\":\"set_groom\",\"style\":\"wavy\",\"collider\":\"bad.obj\\u0000x\"}", "bad_field", "collider");
    expect_groom_error(fx, c, v, "{\"type\":\"set_groom\",\"style\":\"wavy\",\"collider\":7}", "bad_field", "collider");
    expect_groom_error(fx, c, v, "{\"type\":\"set_groom\",\"file\":\"tiny.hair\",\"collider\":\"bad.obj\"}", "failed", "collider");

    /* none: the groom message says so and the binary is gone */
    wsc_send_text(c, "{\"type\":\"set_groom\",\"file\":\"tiny.hair\",\"collider\":null,\"id\":2}");
    cJSON *g = expect_msg(fx, c, "groom");
    assert_true(cJSON_IsNull(get(g, "collider_mesh")));
    cJSON_Delete(g);
    http_reply r;
    assert_int_equal(http_get(fx->d.port, "/collider.bin", &r), 0);
    assert_int_equal(r.status, 404);
    http_reply_free(&r);

    /* the body again, with a groom file: the loads run beside the simulation, whose frames go on */
    uint64_t before = v->ok;
    unsigned long long t0 = core_now_ns();
    wsc_send_text(c, "{\"type\":\"set_groom\",\"file\":\"ratboy/Ratboy_mohawk.tfx\",\"verts\":8,"
                     "\"collider\":\"ratboy/Ratboy_body.tfxmesh\",\"id\":3}");
    cJSON_Delete(expect_msg_within(fx, c, "ok", MESH_WAIT_MS));
    double secs = (double)(core_now_ns() - t0) / 1e9;
    uint64_t during = v->ok - before;
    fprintf(stderr, "set_groom with the Ratboy body: %.2f s, %llu frames meanwhile\n", secs, (unsigned long long)during);
    if (secs > 1.0 && during < 10) fail_msg("%llu frames in the %.1f s of the load: the simulation stalled", (unsigned long long)during, secs);
    g = expect_msg(fx, c, "groom");
    const cJSON *d2 = get(g, "collider_mesh");
    assert_string_equal(str(d2, "source"), "ratboy/Ratboy_body.tfxmesh");
    assert_string_equal(str(d2, "etag"), str(desc, "etag")); /* the same bytes */
    check_mesh_bin(fx, d2);
    /* absent = keep: a procedural groom keeps the body */
    wsc_send_text(c, "{\"type\":\"set_groom\",\"style\":\"straight\",\"strands\":64,\"verts\":4,\"id\":4}");
    cJSON_Delete(expect_msg_within(fx, c, "ok", MESH_WAIT_MS));
    cJSON *g2 = expect_msg(fx, c, "groom");
    assert_true(num(get(g2, "collider_mesh"), "triangles") == RATBOY_TRIS);
    count_arg ca = { v, 64, 4 };
    assert_true(wsc_until(fx->w, frame_shape, &ca, WAIT_MS));
    assert_int_equal(v->bad, 0);
    cJSON_Delete(g2);
    cJSON_Delete(g);
    cJSON_Delete(h);
}

static void test_slow_client_skips(void **state)
{
    fixture *fx = *state;
    view *fast, *slow;
    connect_view(fx, &fast);
    wsc_conn *s = connect_view(fx, &slow);
    wsc_small_rcvbuf(s, 4096);
    wait_frames(fx, slow, 2);
    /* the head moves, so that frames stay large (hair at rest sends nearly empty deltas) */
    wsc_send_text(s, "{\"type\":\"animate\",\"preset\":\"shake\",\"speed\":2}");
    cJSON_Delete(expect_msg(fx, s, "state"));
    /* the slow client stops reading for 2 s while the server keeps streaming */
    wsc_read_enable(s, false);
    uint64_t f0 = fast->ok;
    wsc_run(fx->w, 2000);
    assert_true(fast->ok - f0 >= 20);
    wsc_read_enable(s, true);
    uint64_t s0 = slow->ok;
    wait_frames(fx, slow, s0 + 30);
    assert_int_equal(slow->bad, 0);
    assert_true(wsc_is_open(s));
    http_reply r;
    assert_int_equal(http_get(fx->d.port, "/metrics", &r), 0);
    if (!(metric(r.body, "strandcast_frames_skipped_total") > 0)) fail_msg("no frame was skipped:\n%s", r.body);
    http_reply_free(&r);
}

/* Subscribes c with max_rate and checks the reply's frame rate. */
static void subscribe_rate(fixture *fx, wsc_conn *c, double max_rate, double frame_rate)
{
    char msg[96];
    snprintf(msg, sizeof msg, "{\"type\":\"subscribe\",\"max_rate\":%g}", max_rate);
    wsc_send_text(c, msg);
    cJSON *sub = expect_msg(fx, c, "subscribed");
    const cJSON *so = get(sub, "stream");
    if (num(so, "frame_rate") != frame_rate || num(so, "rate") != 60 || num(so, "max_rate") != max_rate)
        fail_msg("max_rate %g: frame_rate %g, rate %g (want %g, 60)", max_rate, num(so, "frame_rate"), num(so, "rate"),
                 frame_rate);
    cJSON_Delete(sub);
}

/* A client capped below the publishing rate gets a stream of its own rate: every k-th round's
 * frame, with keyframes every keyframe_interval of its own frames (not the full-rate stream's
 * frames thinned, which would send it every keyframe of the full stream). */
static void test_rate_streams(void **state)
{
    fixture *fx = *state;
    view *full, *half, *capped;
    wsc_conn *cf = connect_view(fx, &full), *ch = connect_view(fx, &half), *cc = connect_view(fx, &capped);
    wait_frames(fx, half, 1);
    wait_frames(fx, capped, 1);
    subscribe_rate(fx, ch, 30, 30);
    subscribe_rate(fx, cc, 25, 30); /* no divisor rate of 60 is 25: the 30 Hz stream, capped */
    /* frames from here on are of the new streams (each starts with its keyframe) */
    wsc_run(fx->w, 100);
    view *vs[] = { full, half, capped };
    for (int i = 0; i < 3; i++) {
        vs[i]->ok = vs[i]->keys = 0;
        vs[i]->seq_gcd = vs[i]->key_gcd = 0;
    }
    reach_arg k = { &half->keys, 4 };
    if (!wsc_until(fx->w, counted, &k, 3 * WAIT_MS)) fail_msg("%llu keyframes on the 30 Hz stream", (unsigned long long)half->keys);
    unsigned long long t0 = core_now_ns();
    uint64_t c0 = capped->ok;
    wsc_run(fx->w, 2000);
    double secs = (double)(core_now_ns() - t0) / 1e9;
    /* seq counts publishing rounds: the full stream takes each (keyframe every 30), the 30 Hz
     * streams every second one (keyframe every 30 of theirs = 60 rounds) */
    if (full->seq_gcd != 1 || full->key_gcd != 30)
        fail_msg("full stream: seq steps gcd %llu, keyframe steps gcd %llu (want 1, 30)",
                 (unsigned long long)full->seq_gcd, (unsigned long long)full->key_gcd);
    if (half->seq_gcd != 2 || half->key_gcd != 60)
        fail_msg("30 Hz stream: seq steps gcd %llu, keyframe steps gcd %llu (want 2, 60)",
                 (unsigned long long)half->seq_gcd, (unsigned long long)half->key_gcd);
    if (capped->seq_gcd % 2 != 0 || capped->key_gcd % 60 != 0)
        fail_msg("25 Hz cap: seq steps gcd %llu, keyframe steps gcd %llu (want multiples of 2, 60)",
                 (unsigned long long)capped->seq_gcd, (unsigned long long)capped->key_gcd);
    double rate = (double)(capped->ok - c0) / secs;
    if (rate > 25.0 * 1.1) fail_msg("%.1f frames/s at max_rate 25", rate);
    assert_int_equal(full->bad + half->bad + capped->bad, 0);
    assert_true(wsc_is_open(cf) && wsc_is_open(ch) && wsc_is_open(cc));
}

/* Stream slots: with 31 of the 32 taken by other strides and the default stream gone, the last
 * is kept for the default stream, so a newcomer still gets frames; a subscribe no slot can
 * serve is refused (busy) and the client keeps its stream; one with a faster stream of its
 * stride and error shares it. */
static void test_stream_slots(void **state)
{
    fixture *fx = *state;
    wsc_conn *others[31];
    for (int i = 0; i < 31; i++) {
        others[i] = wsc_connect(fx->w, fx->d.port, SUBPROTOCOL, NULL, NULL);
        assert_true(wsc_wait_open(fx->w, others[i], WAIT_MS));
        cJSON_Delete(expect_msg(fx, others[i], "hello"));
        char msg[64];
        snprintf(msg, sizeof msg, "{\"type\":\"subscribe\",\"stride\":%d}", i + 2);
        wsc_send_text(others[i], msg);
        cJSON *sub = expect_msg(fx, others[i], "subscribed");
        assert_true(num(get(sub, "stream"), "stride") == i + 2);
        cJSON_Delete(sub);
    }
    /* 31 streams, no default one: the free slot is not for stride 40 */
    wsc_send_text(others[0], "{\"type\":\"subscribe\",\"stride\":40,\"id\":1}");
    cJSON *busy = expect_msg(fx, others[0], "error");
    assert_string_equal(str(busy, "code"), "busy");
    assert_true(num(busy, "id") == 1);
    cJSON_Delete(busy);
    /* a newcomer starts on the default stream, in the kept slot */
    view *v;
    wsc_conn *c = connect_view(fx, &v);
    wait_frames(fx, v, 3);
    assert_int_equal(v->info.nstrands_sent, NSTRANDS);
    /* every slot taken now: refused, and the stream goes on */
    wsc_send_text(c, "{\"type\":\"subscribe\",\"stride\":40,\"id\":2}");
    busy = expect_msg(fx, c, "error");
    assert_string_equal(str(busy, "code"), "busy");
    cJSON_Delete(busy);
    uint64_t n = v->ok;
    wait_frames(fx, v, n + 3);
    assert_int_equal(v->info.nstrands_sent, NSTRANDS);
    /* 10 Hz of stride 2 has no slot of its own: it shares the 60 Hz stride-2 stream, capped */
    wsc_send_text(c, "{\"type\":\"subscribe\",\"stride\":2,\"max_rate\":10,\"id\":3}");
    cJSON *sub = expect_msg(fx, c, "subscribed");
    const cJSON *so = get(sub, "stream");
    assert_true(num(so, "stride") == 2 && num(so, "max_rate") == 10 && num(so, "frame_rate") == 60);
    cJSON_Delete(sub);
    n = v->ok;
    wait_frames(fx, v, n + 3);
    assert_int_equal(v->info.nstrands_sent, NSTRANDS / 2);
    assert_int_equal(v->bad, 0);
}

/* A groom 2 km up cannot be streamed at 0.01 mm (its lattice coordinates would pass 2^26): that
 * stream's clients are told why, and a 1 mm stream goes on. */
static void test_stream_failure_is_reported(void **state)
{
    fixture *fx = *state;
    view *v1, *v2;
    wsc_conn *c1 = connect_view(fx, &v1), *c2 = connect_view(fx, &v2);
    cJSON_Delete(expect_msg(fx, c1, "hello"));
    cJSON_Delete(expect_msg(fx, c2, "hello"));
    wsc_send_text(c1, "{\"type\":\"subscribe\",\"max_error\":1e-3}");
    cJSON_Delete(expect_msg(fx, c1, "subscribed"));
    wsc_send_text(c2, "{\"type\":\"subscribe\",\"max_error\":1e-5}");
    cJSON_Delete(expect_msg(fx, c2, "subscribed"));
    wsc_send_text(c1, "{\"type\":\"set_groom\",\"file\":\"far.hair\"}");
    cJSON_Delete(expect_msg(fx, c2, "groom"));
    cJSON *e = expect_msg(fx, c2, "error");
    assert_string_equal(str(e, "code"), "failed");
    assert_string_equal(str(e, "field"), "stream");
    assert_null(cJSON_GetObjectItemCaseSensitive(e, "id"));
    if (!strstr(str(e, "message"), "max_error")) fail_msg("message: %s", str(e, "message"));
    cJSON_Delete(e);
    count_arg far = { v1, 16, 8 };
    assert_true(wsc_until(fx->w, frame_shape, &far, WAIT_MS));
    uint64_t n = v1->ok;
    wait_frames(fx, v1, n + 5);
    assert_true(v1->info.nstrands_total == 16 && fabs(mean_tip_y(v1) - 1999.9) < 1.0);
    /* a client joining the failing stream (c2 still on it) is told at once */
    view *v3;
    wsc_conn *c3 = connect_view(fx, &v3);
    cJSON_Delete(expect_msg(fx, c3, "hello"));
    wsc_send_text(c3, "{\"type\":\"subscribe\",\"max_error\":1e-5,\"id\":7}");
    cJSON_Delete(expect_msg(fx, c3, "subscribed"));
    e = expect_msg(fx, c3, "error");
    assert_string_equal(str(e, "field"), "stream");
    cJSON_Delete(e);
    /* a coarser bound streams again; a groom the fine stream can carry brings its frames back */
    wsc_send_text(c2, "{\"type\":\"subscribe\",\"max_error\":1e-3}");
    cJSON_Delete(expect_msg(fx, c2, "subscribed"));
    assert_true(wsc_until(fx->w, frame_shape, &(count_arg){ v2, 16, 8 }, WAIT_MS));
    uint64_t before = v3->ok;
    wsc_send_text(c1, "{\"type\":\"set_groom\",\"file\":\"tiny.hair\"}");
    cJSON_Delete(expect_msg(fx, c3, "groom"));
    wait_frames(fx, v3, before + 3);
    assert_true(fabs(v3->info.max_error_m - 1e-5) < 1e-9 && fabs(mean_tip_y(v3)) < 1.0);
    assert_int_equal(v1->bad + v2->bad + v3->bad, 0);
}

/* --listen ::1: the daemon serves the IPv6 loopback only (the URL it prints is [::1]:port). */
static void test_listen_ipv6(void **state)
{
    fixture *fx = *state;
    view v = { 0 };
    codec_decoder_init(&v.dec);
    wsc_conn *c6 = wsc_connect_host(fx->w, "::1", fx->d.port, SUBPROTOCOL, on_frame, &v);
    assert_true(wsc_wait_open(fx->w, c6, WAIT_MS));
    cJSON_Delete(expect_msg(fx, c6, "hello"));
    wait_frames(fx, &v, 3);
    wsc_conn *c4 = wsc_connect(fx->w, fx->d.port, SUBPROTOCOL, NULL, NULL);
    assert_false(wsc_wait_open(fx->w, c4, 2000)); /* nothing on 127.0.0.1 */
    codec_decoder_free(&v.dec);
    free(v.xyz);
}

/* Without --listen and --port the daemon serves 127.0.0.1:7681 and prints that URL. */
static void test_default_address(void **state)
{
    const config *cfg = *state;
    daemon_proc d;
    char *argv[] = { (char *)cfg->exe, "--backend", "cpu", "--strands", "64", "--verts", "4", "--threads", "1", NULL };
    assert_int_equal(daemon_start(&d, cfg->exe, argv, 20000), 0);
    assert_int_equal(d.port, 7681); /* the documented default */
    http_reply r;
    assert_int_equal(http_get(d.port, "/metrics", &r), 0);
    assert_int_equal(r.status, 200);
    http_reply_free(&r);
    assert_int_equal(daemon_stop(&d, SIGTERM, 15000), 0);
}

/* SIGTERM or SIGINT: every client is closed with 1001 and the daemon exits 0. */
static void signal_closes_clients(fixture *fx, int sig)
{
    view *v;
    wsc_conn *a = connect_view(fx, &v), *b = connect_view(fx, NULL);
    wait_frames(fx, v, 5);
    kill(fx->d.pid, sig);
    assert_int_equal(wsc_wait_closed(fx->w, a, WAIT_MS), 1001);
    assert_int_equal(wsc_wait_closed(fx->w, b, WAIT_MS), 1001);
    assert_string_equal(wsc_close_reason(a), "server shutting down");
    /* exit status 0: a clean shutdown (the sanitizer build also fails on any leak) */
    assert_int_equal(daemon_stop(&fx->d, 0, 15000), 0);
}

static void test_sigterm_closes_clients(void **state) { signal_closes_clients(*state, SIGTERM); }

static void test_sigint_closes_clients(void **state) { signal_closes_clients(*state, SIGINT); }

static void test_reader_that_never_reads_is_closed(void **state)
{
    fixture *fx = *state;
    view *watch;
    connect_view(fx, &watch);
    wait_frames(fx, watch, 2);
    /* a client floods requests and never reads: its replies pile up in a bounded queue,
     * then the server gives up on it (1008) while everyone else keeps streaming */
    int fd = rawws_open(fx->d.port, SUBPROTOCOL);
    assert_true(fd >= 0);
    int small = 4096;
    setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
    static const char req[] = "{\"type\":\"get_params\"}";
    for (int i = 0; i < 3000; i++)
        if (rawws_send(fd, 1, req, sizeof req - 1, true) != 0) break;
    uint64_t before = watch->ok;
    wsc_run(fx->w, 1500);
    assert_int_equal(rawws_close_code(fd, WAIT_MS), 1008);
    rawws_free(fd);
    wait_frames(fx, watch, before + 10);
    assert_int_equal(watch->bad, 0);
}

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static double clients_now(fixture *fx)
{
    http_reply r;
    assert_int_equal(http_get(fx->d.port, "/metrics", &r), 0);
    double n = metric(r.body, "strandcast_clients");
    http_reply_free(&r);
    return n;
}

/* A raw WebSocket client on its own thread that reads every frame and sends a request every
 * 0.5 s but never answers a ping: when the server pinged it first, and when and how the
 * connection ended. */
typedef struct no_pong_client {
    int fd;
    double t_open, t_first_ping, t_end;
    int pings, end; /* end: 0 EOF or reset, 8 close frame, -1 still open at the deadline */
    atomic_bool done;
} no_pong_client;

static void *no_pong_run(void *arg)
{
    no_pong_client *r = arg;
    static const char req[] = "{\"type\":\"get_params\"}";
    double next_req = 0;
    int code = 0, k;
    do {
        double t = now_s() - r->t_open;
        if (t >= next_req) {
            rawws_send(r->fd, 1, req, sizeof req - 1, true); /* fails once the server hung up: then read says so */
            next_req += 0.5;
        }
        k = rawws_next_control(r->fd, 100, &code);
        if (k == 9 && !r->pings++) r->t_first_ping = now_s() - r->t_open;
    } while (k == 9 || k == 10 || (k == -1 && now_s() - r->t_open < PING_TIMEOUT_S + 10));
    r->end = k;
    r->t_end = now_s() - r->t_open;
    atomic_store(&r->done, true);
    return NULL;
}

/* Runs the client loop (the well-behaved client answers pings inside it) until time t. */
static void run_until(fixture *fx, double t)
{
    while (now_s() < t) wsc_run(fx->w, 50);
}

/* The daemon runs with --ping-interval 1 --ping-timeout 3. */
static void test_ping_drops_silent_client(void **state)
{
    fixture *fx = *state;
    view *v;
    wsc_conn *good = connect_view(fx, &v);
    wait_frames(fx, v, 2);
    /* two clients never answer pings: one reads and sends requests, the other neither reads nor writes */
    int mute = rawws_open(fx->d.port, SUBPROTOCOL);
    no_pong_client r = { .fd = rawws_open(fx->d.port, SUBPROTOCOL), .t_first_ping = -1 };
    r.t_open = now_s();
    assert_true(mute >= 0 && r.fd >= 0);
    pthread_t th;
    assert_int_equal(pthread_create(&th, NULL, no_pong_run, &r), 0);
    run_until(fx, r.t_open + PING_TIMEOUT_S - 1);
    double clients_before = clients_now(fx);
    while (!atomic_load(&r.done)) wsc_run(fx->w, 50);
    pthread_join(th, NULL);
    /* nobody dropped a second before the timeout */
    if (clients_before != 3) fail_msg("%g clients 1 s before the ping timeout (want 3)", clients_before);
    /* pinged after the interval without a pong; hung up after the timeout without one, not before
     * (its requests do not count) */
    if (r.pings < 1 || r.t_first_ping < PING_INTERVAL_S - 0.3 || r.t_first_ping > PING_TIMEOUT_S - 0.5)
        fail_msg("client that never pongs: %d pings, the first at %.2f s (want one after ~%d s)", r.pings, r.t_first_ping,
                 PING_INTERVAL_S);
    if (r.end != 0 || r.t_end < PING_TIMEOUT_S - 0.3 || r.t_end > PING_TIMEOUT_S + 2.5)
        fail_msg("client that never pongs: %s after %.2f s (want the connection closed after ~%d s)",
                 r.end == -1 ? "still open" : r.end == 8 ? "close frame" : "closed", r.t_end, PING_TIMEOUT_S);
    /* the well-behaved client (lws answers pings) still streams at twice the timeout */
    run_until(fx, r.t_open + 2 * PING_TIMEOUT_S - 1);
    uint64_t n0 = v->ok;
    run_until(fx, r.t_open + 2 * PING_TIMEOUT_S);
    assert_true(wsc_is_open(good));
    if (v->ok - n0 < 10)
        fail_msg("the well-behaved client got %llu frames in its last second", (unsigned long long)(v->ok - n0));
    assert_int_equal(v->bad, 0);
    /* the mute one was dropped too: only the well-behaved client is left */
    double clients_after = clients_now(fx);
    if (clients_after != 1) fail_msg("%g clients at twice the ping timeout (want 1)", clients_after);
    int code, k;
    do k = rawws_next_control(mute, WAIT_MS, &code);
    while (k == 9);
    assert_int_equal(k, 0);
    rawws_free(mute);
    rawws_free(r.fd);
}

/* Runs exe with args to completion; returns its exit status and what it printed (both streams). */
static int run_capture(const char *exe, const char *const *args, char *out, size_t cap)
{
    int fds[2];
    assert_int_equal(pipe(fds), 0);
    pid_t pid = fork();
    if (pid == 0) {
        dup2(fds[1], 1);
        dup2(fds[1], 2);
        close(fds[0]);
        char *argv[32];
        int n = 0;
        argv[n++] = (char *)exe;
        for (; args[n - 1] && n < 31; n++) argv[n] = (char *)args[n - 1];
        argv[n] = NULL;
        execv(exe, argv);
        _exit(127);
    }
    close(fds[1]);
    size_t len = 0;
    ssize_t r;
    while ((r = read(fds[0], out + len, cap - 1 - len)) > 0) len += (size_t)r;
    out[len] = '\0';
    close(fds[0]);
    int status;
    waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

static void test_flags(void **state)
{
    const config *cfg = *state;
    static char out[16384];
    const char *help[] = { "--help", NULL };
    assert_int_equal(run_capture(cfg->exe, help, out, sizeof out), 0);
    static const char *const flags[] = { "--groom", "--collider", "--strands", "--verts", "--seed", "--backend", "--device", "--threads",
                                         "--listen", "--port", "--web", "--assets", "--rate", "--max-error",
                                         "--keyframe-interval", "--client-buffer", "--ping-interval", "--ping-timeout",
                                         "--no-net", "--steps", "default" };
    for (size_t i = 0; i < sizeof flags / sizeof flags[0]; i++)
        if (!strstr(out, flags[i])) fail_msg("--help does not mention %s", flags[i]);
    static const char *const bad[][4] = {
        { "--strands", "0", NULL }, { "--strands", "12x", NULL }, { "--bogus", NULL, NULL }, { "--port", "70000", NULL },
        { "--port", NULL, NULL },   { "--backend", "gpu", NULL }, { "--max-error", "1", NULL }, { "--rate", "nan", NULL },
        { "--web", "/nonexistent-dir", NULL }, { "--no-net=1", NULL, NULL }, { "--steps", "-1", NULL },
        { "--ping-interval", "0", NULL }, { "--ping-interval", "65535", NULL }, { "--ping-timeout", "65536", NULL },
        { "--ping-timeout", "20", NULL }, { "--ping-timeout=5", "--ping-interval", "5" }, { "--ping-timeout", "x", NULL },
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        int rc = run_capture(cfg->exe, bad[i], out, sizeof out);
        char name[32];
        snprintf(name, sizeof name, "%.*s", (int)strcspn(bad[i][0], "="), bad[i][0]);
        if (rc != 2 || !strstr(out, name)) fail_msg("%s %s: exit %d, said: %s", bad[i][0], bad[i][1] ? bad[i][1] : "", rc, out);
    }
    const char *missing[] = { "--no-net", "--groom", "/nonexistent/x.tfx", NULL };
    assert_int_equal(run_capture(cfg->exe, missing, out, sizeof out), 1);
    assert_non_null(strstr(out, "x.tfx"));
    /* a groom file over the vertex limit once resampled: refused at start-up as by set_groom */
    char dir[64], big[96];
    snprintf(dir, sizeof dir, "/tmp/strandcast-big-XXXXXX");
    assert_non_null(mkdtemp(dir));
    snprintf(big, sizeof big, "%s/big.hair", dir);
    write_hair(big, 70000, 2, 0.0f);
    const char *too_big[] = { "--no-net", "--groom", big, "--verts", "32", NULL };
    int rc = run_capture(cfg->exe, too_big, out, sizeof out);
    unlink(big);
    rmdir(dir);
    if (rc != 1 || !strstr(out, "2240000")) fail_msg("a 70,000 x 32 groom file: exit %d, said: %s", rc, out);
    /* a collision mesh that cannot be read or is malformed: exit 1 with the loader's message */
    const char *no_mesh[] = { "--no-net", "--collider", "/nonexistent/body.obj", NULL };
    rc = run_capture(cfg->exe, no_mesh, out, sizeof out);
    if (rc != 1 || !strstr(out, "body.obj")) fail_msg("a missing --collider: exit %d, said: %s", rc, out);
    char open_mesh[96];
    snprintf(dir, sizeof dir, "/tmp/strandcast-mesh-XXXXXX");
    assert_non_null(mkdtemp(dir));
    snprintf(open_mesh, sizeof open_mesh, "%s/open.obj", dir);
    write_file(open_mesh, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", 32);
    const char *bad_mesh[] = { "--no-net", "--collider", open_mesh, NULL };
    rc = run_capture(cfg->exe, bad_mesh, out, sizeof out);
    unlink(open_mesh);
    rmdir(dir);
    if (rc != 1 || !strstr(out, "open.obj")) fail_msg("an open --collider mesh: exit %d, said: %s", rc, out);
    const char *empty_mesh[] = { "--collider=", NULL };
    assert_int_equal(run_capture(cfg->exe, empty_mesh, out, sizeof out), 2);
    const char *run[] = { "--no-net", "--steps", "5", "--backend", "cpu", "--strands", "16", "--verts", "4",
                          "--threads", "1", NULL };
    assert_int_equal(run_capture(cfg->exe, run, out, sizeof out), 0);
    assert_non_null(strstr(out, "stopped after 5 steps"));
}

/* Counts the occurrences of needle in hay. */
static int count_of(const char *hay, const char *needle)
{
    int n = 0;
    for (const char *p = strstr(hay, needle); p; p = strstr(p + 1, needle)) n++;
    return n;
}

/* strandcastc, the command-line client (built beside strandcastd): it subscribes, waits for the
 * reply, decodes frames with the C decoder, prints them and records them as SCFR; bad flags
 * exit 2 and a port nobody listens on exits 1. */
static void test_cli_client(void **state)
{
    fixture *fx = *state;
    char exe[1024], port[16], rec[160];
    snprintf(exe, sizeof exe, "%s", fx->cfg->exe);
    char *slash = strrchr(exe, '/');
    snprintf(slash ? slash + 1 : exe, sizeof exe - (size_t)(slash ? slash + 1 - exe : 0), "strandcastc");
    snprintf(port, sizeof port, "%d", fx->d.port);
    snprintf(rec, sizeof rec, "%s/rec.scfr", fx->dir);
    const char *args[] = { "--port", port, "--frames", "12", "--json", "--out", rec, "--send",
                           "{\"type\":\"subscribe\",\"stride\":4,\"max_error\":0.001,\"id\":\"s\"}", NULL };
    static char out[1 << 17];
    int rc = run_capture(exe, args, out, sizeof out);
    if (rc != 0) fail_msg("strandcastc exited %d:\n%s", rc, out);
    if (!strstr(out, "{\"cli\":\"hello\",\"server\":\"strandcastd\"") || !strstr(out, "\"strands\":128,\"verts\":8,"))
        fail_msg("no hello summary:\n%s", out);
    const char *sub = strstr(out, "{\"type\":\"subscribed\",\"id\":\"s\"");
    const char *first = strstr(out, "{\"cli\":\"frame\",\"frame\":0,");
    if (!sub || !first || first < sub) fail_msg("frames shown before the subscribe's reply:\n%s", out);
    assert_true(strstr(first, "\"keyframe\":true") < strchr(first, '\n')); /* the new stream starts with a keyframe */
    if (count_of(out, "{\"cli\":\"frame\"") != 12 || count_of(out, "\"strands\":32,\"strands_total\":128,\"verts\":8,\"stride\":4,") != 12)
        fail_msg("want 12 frames of every 4th strand:\n%s", out);
    if (!strstr(out, "\"frames\":12,") || !strstr(out, "\"recorded\":12,") || !strstr(out, "\"ok\":true}"))
        fail_msg("summary:\n%s", out);
    /* the recording: SCFR header, then 12 frames of 32 x 8 finite positions near the head */
    size_t len;
    FILE *fp = fopen(rec, "rb");
    assert_non_null(fp);
    static float xyz[16 + 12 * 32 * 8 * 3];
    len = fread(xyz, 1, sizeof xyz, fp);
    fclose(fp);
    assert_int_equal(len, 16 + 12 * 32 * 8 * 3 * sizeof(float));
    uint32_t h[4];
    memcpy(h, xyz, sizeof h);
    assert_memory_equal(h, "SCFR", 4);
    assert_true(h[1] == 32 && h[2] == 8 && h[3] == 12);
    for (size_t i = 4; i < len / sizeof(float); i++)
        if (!(fabsf(xyz[i]) < 1.0f)) fail_msg("recorded coordinate %zu is %g", i - 4, (double)xyz[i]);

    const char *bad[] = { "--port", "0", NULL };
    assert_int_equal(run_capture(exe, bad, out, sizeof out), 2);
    const char *bad2[] = { "--frames", "-1", NULL };
    assert_int_equal(run_capture(exe, bad2, out, sizeof out), 2);
    const char *nobody[] = { "--port", "1", "--frames", "1", NULL };
    rc = run_capture(exe, nobody, out, sizeof out);
    if (rc != 1 || !strstr(out, "cannot connect")) fail_msg("no daemon: exit %d:\n%s", rc, out);
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: %s STRANDCASTD [TEST]\n", argv[0]);
        return 2;
    }
    static config cfg;
    cfg.exe = argv[1];
    if (argc > 2) cmocka_set_test_filter(argv[2]);
    signal(SIGPIPE, SIG_IGN);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_prestate_setup_teardown(test_hello_and_frames, setup, teardown, &cfg),
        cmocka_unit_test_prestate_setup_teardown(test_params_broadcast_and_physics, setup, teardown, &cfg),
        cmocka_unit_test_prestate_setup_teardown(test_motion_moves_roots, setup, teardown, &cfg),
        cmocka_unit_test_prestate_setup_teardown(test_bad_inputs_keep_stream, setup, teardown, &cfg),
        cmocka_unit_test_prestate_setup_teardown(test_subprotocol_refused, setup, teardown, &cfg),
        cmocka_unit_test_prestate_setup_teardown(test_http_static_and_metrics, setup, teardown, &cfg),
        cmocka_unit_test_prestate_setup_teardown(test_pause_step_subscribe_groom, setup, teardown, &cfg),
        cmocka_unit_test_prestate_setup_teardown(test_slow_client_skips, setup, teardown, &cfg),
        cmocka_unit_test_prestate_setup_teardown(test_rate_streams, setup, teardown, &cfg),
        cmocka_unit_test_prestate_setup_teardown(test_stream_slots, setup, teardown, &cfg),
        cmocka_unit_test_prestate_setup_teardown(test_cli_client, setup, teardown, &cfg),
        cmocka_unit_test_prestate_setup_teardown(test_stream_failure_is_reported, setup, teardown, &cfg),
        cmocka_unit_test_prestate_setup_teardown(test_sigterm_closes_clients, setup, teardown, &cfg),
        cmocka_unit_test_prestate_setup_teardown(test_sigint_closes_clients, setup, teardown, &cfg),
        cmocka_unit_test_prestate_setup_teardown(test_listen_ipv6, setup_ipv6, teardown, &cfg),
        cmocka_unit_test_prestate(test_default_address, &cfg),
        cmocka_unit_test_prestate(test_flags, &cfg),
        cmocka_unit_test_prestate_setup_teardown(test_reader_that_never_reads_is_closed, setup, teardown, &cfg),
        cmocka_unit_test_prestate_setup_teardown(test_ping_drops_silent_client, setup_ping, teardown, &cfg),
        cmocka_unit_test_prestate_setup_teardown(test_collider_mesh, setup_ratboy, teardown_ratboy, &cfg),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
