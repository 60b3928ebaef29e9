/* Integration tests: fixtures (the daemon and its clients) and helpers shared by the scenarios. */
#include <math.h>
#include <signal.h>
#include <time.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "it.h"

uint64_t gcd(uint64_t a, uint64_t b)
{
    while (b) {
        uint64_t t = a % b;
        a = b;
        b = t;
    }
    return a;
}

double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

void on_frame(wsc_conn *c, const uint8_t *data, size_t len, void *user)
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
    double t = now_s();
    if (v->ok && t - v->last_frame_s > v->max_gap_s) v->max_gap_s = t - v->last_frame_s;
    v->last_frame_s = t;
    v->ok++;
    v->keys += info.keyframe;
    v->info = info;
}

void write_file(const char *path, const void *data, size_t len)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, len, f), len);
    fclose(f);
}

/* A valid Cem Yuksel .hair file: hairs strands of pts points (2 cm apart) hanging from a ring,
 * lifted by up m. */
void write_hair(const char *path, uint32_t hairs, uint32_t pts, float up)
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
int setup_with(void **state, const char *const *extra)
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
    /* --min-step-rate 0: no groom budget (its measurement takes seconds under the sanitizers;
     * groom_budget_refuses tests it) */
    char *argv[32] = { (char *)fx->cfg->exe, "--port", "0", "--backend", "cpu", "--strands", strands, "--verts", verts,
                       "--threads", "1", "--web", fx->web, "--assets", fx->assets, "--client-buffer", "8192",
                       "--min-step-rate", "0", NULL };
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

int setup(void **state)
{
    return setup_with(state, NULL);
}

int setup_ping(void **state)
{
    static const char *const extra[] = { "--ping-interval", "1", "--ping-timeout", "3", NULL };
    return setup_with(state, extra);
}

int setup_auto(void **state)
{
    static const char *const extra[] = { "--backend", "auto", NULL };
    return setup_with(state, extra);
}

int setup_ipv6(void **state)
{
    static const char *const extra[] = { "--listen", "::1", NULL };
    return setup_with(state, extra);
}

int teardown(void **state)
{
    fixture *fx = *state;
    wsc_free(fx->w);
    int rc = fx->d.pid ? daemon_stop(&fx->d, SIGTERM, 15000) : 0; /* 0: the test stopped it itself */
    for (int i = 0; i < fx->nviews; i++) {
        codec_decoder_free(&fx->views[i].dec);
        free(fx->views[i].xyz);
    }
    char cmd[160];
    snprintf(cmd, sizeof cmd, "rm -rf %s %s", fx->dir, fx->files);
    if (system(cmd) != 0) fprintf(stderr, "could not remove %s %s\n", fx->dir, fx->files);
    free(fx);
    if (rc != 0) fprintf(stderr, "strandcastd exited with %d after SIGTERM (want 0)\n", rc);
    return rc == 0 ? 0 : -1;
}

/* Connects a client with a frame view; waits for it to open. */
wsc_conn *connect_view(fixture *fx, view **out) { return connect_view_via(fx, false, out); }

wsc_conn *connect_view_via(fixture *fx, bool tls, view **out)
{
    assert_true(fx->nviews < 8);
    view *v = &fx->views[fx->nviews++];
    codec_decoder_init(&v->dec);
    wsc_conn *c = tls ? wsc_connect_tls(fx->w, fx->d.port, SUBPROTOCOL, on_frame, v)
                      : wsc_connect(fx->w, fx->d.port, SUBPROTOCOL, on_frame, v);
    assert_true(wsc_wait_open(fx->w, c, WAIT_MS));
    if (out) *out = v;
    return c;
}

cJSON *expect_msg_within(fixture *fx, wsc_conn *c, const char *type, int ms)
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

cJSON *expect_msg(fixture *fx, wsc_conn *c, const char *type) { return expect_msg_within(fx, c, type, WAIT_MS); }

const cJSON *get(const cJSON *o, const char *k)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, k);
    if (!v) fail_msg("missing key \"%s\"", k);
    return v;
}

double num(const cJSON *o, const char *k)
{
    const cJSON *v = get(o, k);
    assert_true(cJSON_IsNumber(v));
    return v->valuedouble;
}

const char *str(const cJSON *o, const char *k)
{
    const cJSON *v = get(o, k);
    assert_true(cJSON_IsString(v));
    return v->valuestring;
}

/* A wsc_until condition: a view's counter (frames, keyframes) has reached n. */
bool counted(void *arg)
{
    reach_arg *c = arg;
    return *c->count >= c->n;
}

void wait_frames(fixture *fx, view *v, uint64_t n)
{
    reach_arg f = { &v->ok, n };
    if (!wsc_until(fx->w, counted, &f, WAIT_MS)) fail_msg("only %llu frames decoded (want %llu; %llu bad: %s)",
                                                             (unsigned long long)v->ok, (unsigned long long)n,
                                                             (unsigned long long)v->bad, v->last_error);
}

bool at_time(void *arg)
{
    time_arg *a = arg;
    return a->v->ok && fabs(a->v->info.sim.sim_time - a->t) < 1e-3;
}

void wait_sim_time(fixture *fx, view *v, double t)
{
    time_arg a = { v, t };
    if (!wsc_until(fx->w, at_time, &a, WAIT_MS)) fail_msg("no frame at sim time %g (last %g)", t, v->info.sim.sim_time);
}

/* Mean y of the last vertex of every decoded strand. */
double mean_tip_y(const view *v)
{
    double s = 0;
    for (uint32_t i = 0; i < v->info.nstrands_sent; i++) s += v->xyz[3 * ((size_t)i * v->info.nverts + v->info.nverts - 1) + 1];
    return s / v->info.nstrands_sent;
}

/* The value of a metric line "name value" in a Prometheus text body (-1 when absent). */
double metric(const char *body, const char *name)
{
    char pat[160];
    snprintf(pat, sizeof pat, "\n%s ", name);
    const char *p = strstr(body, pat);
    return p ? atof(p + strlen(pat)) : -1.0;
}

bool frame_shape(void *arg)
{
    count_arg *a = arg;
    return a->v->ok && a->v->info.nstrands_total == a->strands && a->v->info.nverts == a->verts;
}

void expect_http(fixture *fx, const char *request, int status, const char *needle, int timeout_ms)
{
    http_reply r;
    assert_int_equal(http_exchange(fx->d.port, request, &r, timeout_ms), 0);
    if (r.status != status || (needle && (!r.body || !strstr(r.body, needle))))
        fail_msg("HTTP %d (want %d%s%s): %s", r.status, status, needle ? " with " : "", needle ? needle : "",
                 r.body ? r.body : "");
    http_reply_free(&r);
}

float *fetch_groom_data(fixture *fx, const cJSON *g)
{
    http_reply r;
    assert_int_equal(http_get(fx->d.port, str(g, "url"), &r), 0);
    if (r.status != 200) fail_msg("GET %s: %d\n%.300s", str(g, "url"), r.status, r.raw);
    assert_string_equal(r.content_type, "application/octet-stream");
    if (r.body_len != (size_t)num(g, "bytes"))
        fail_msg("GET %s: %zu bytes, the groom says %.0f", str(g, "url"), r.body_len, num(g, "bytes"));
    uint32_t ns, nv;
    core_err err;
    if (proto_groom_bin_read((const unsigned char *)r.body, r.body_len, &ns, &nv, &err) != CORE_OK) fail_msg("%s", err.msg);
    assert_true(ns == num(g, "strands") && nv == num(g, "verts"));
    char etag[17], hdr[32];
    proto_bin_etag((const unsigned char *)r.body, r.body_len, etag);
    assert_string_equal(etag, str(g, "etag"));
    snprintf(hdr, sizeof hdr, "\"%s\"", etag);
    if (!strstr(r.raw, hdr)) fail_msg("no ETag %s in:\n%.300s", hdr, r.raw);
    float *out = malloc(16 * (size_t)ns);
    assert_non_null(out);
    for (size_t i = 0; i < 4 * (size_t)ns; i++) {
        const unsigned char *p = (const unsigned char *)r.body + PROTO_GROOM_HEADER + 4 * i;
        uint32_t bits = (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
        memcpy(&out[i], &bits, 4);
    }
    http_reply_free(&r);
    return out;
}

int run_capture(const char *exe, const char *const *args, char *out, size_t cap)
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
