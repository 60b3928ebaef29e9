/* Integration tests: listening, shutdown on signals, and clients that never read or never answer pings. */
#include <math.h>
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "it.h"

void test_listen_ipv6(void **state)
{
    fixture *fx = *state;
    view v = { 0 };
    codec_decoder_init(&v.dec);
    wsc_conn *c6 = wsc_connect_host(fx->w, "::1", fx->d.port, NULL, SUBPROTOCOL, on_frame, &v);
    assert_true(wsc_wait_open(fx->w, c6, WAIT_MS));
    cJSON_Delete(expect_msg(fx, c6, "hello"));
    wait_frames(fx, &v, 3);
    wsc_conn *c4 = wsc_connect(fx->w, fx->d.port, SUBPROTOCOL, NULL, NULL);
    assert_false(wsc_wait_open(fx->w, c4, 2000)); /* nothing on 127.0.0.1 */
    codec_decoder_free(&v.dec);
    free(v.xyz);
}

/* Without --listen and --port the daemon serves 127.0.0.1:7681 and prints that URL. */
void test_default_address(void **state)
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

void test_sigterm_closes_clients(void **state) { signal_closes_clients(*state, SIGTERM); }

void test_sigint_closes_clients(void **state) { signal_closes_clients(*state, SIGINT); }

void test_reader_that_never_reads_is_closed(void **state)
{
    fixture *fx = *state;
    view *watch;
    connect_view(fx, &watch);
    wait_frames(fx, watch, 2);
    /* a client sends requests within its budget (300 a second) and never reads: its replies
     * pile up in a bounded queue, then the server gives up on it (1008) while everyone else
     * keeps streaming */
    /* its window is small from the connect on: with only a later SO_RCVBUF the kernel's first
     * window took the hello and early frames, and whether the server's writes stalled while
     * it still read the requests depended on the hello's size */
    int fd = rawws_open_rcvbuf(fx->d.port, SUBPROTOCOL, 4096);
    assert_true(fd >= 0);
    static const char req[] = "{\"type\":\"get_params\"}";
    for (int i = 0; i < 900; i++) {
        if (rawws_send(fd, 1, req, sizeof req - 1, true) != 0) break;
        if (i % 6 == 5) wsc_run(fx->w, 20);
    }
    uint64_t before = watch->ok;
    wsc_run(fx->w, 500);
    assert_int_equal(rawws_close_code(fd, WAIT_MS), 1008);
    rawws_free(fd);
    wait_frames(fx, watch, before + 10);
    assert_int_equal(watch->bad, 0);
    /* the memory held for it went with it: what stays queued is the watcher's few messages */
    http_reply r;
    assert_int_equal(http_get(fx->d.port, "/metrics", &r), 0);
    double held = metric(r.body, "strandcast_client_queued_bytes");
    http_reply_free(&r);
    printf("text bytes queued for clients after the close: %.0f\n", held);
    assert_true(held >= 0 && held < 65536);
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
void test_ping_drops_silent_client(void **state)
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

int setup_two_clients(void **state)
{
    static const char *const extra[] = { "--max-clients", "2", NULL };
    return setup_with(state, extra);
}

/* --max-clients: one more WebSocket upgrade is answered 503 with the reason, counted in
 * /metrics; once a client leaves, a new one gets in. */
void test_max_clients_refused(void **state)
{
    fixture *fx = *state;
    int a = rawws_open(fx->d.port, SUBPROTOCOL), b = rawws_open(fx->d.port, SUBPROTOCOL);
    assert_true(a >= 0 && b >= 0);
    static const char req[] = "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                              "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
                              "Sec-WebSocket-Protocol: " SUBPROTOCOL "\r\n\r\n";
    http_reply r;
    double t_end = now_s() + WAIT_MS / 1e3;
    do { /* the two are counted once their upgrades are through */
        assert_int_equal(http_exchange(fx->d.port, req, &r, 3000), 0);
        if (r.status == 503) break;
        http_reply_free(&r);
        wsc_run(fx->w, 50);
    } while (now_s() < t_end);
    assert_int_equal(r.status, 503);
    assert_non_null(strstr(r.body, "maximum of 2 clients"));
    http_reply_free(&r);
    assert_int_equal(http_get(fx->d.port, "/metrics", &r), 0);
    assert_true(metric(r.body, "strandcast_clients_refused_total") >= 1);
    http_reply_free(&r);
    rawws_free(a);
    int c = -1;
    t_end = now_s() + WAIT_MS / 1e3;
    while (c < 0 && now_s() < t_end) {
        wsc_run(fx->w, 50);
        c = rawws_open(fx->d.port, SUBPROTOCOL);
    }
    assert_true(c >= 0);
    rawws_free(b);
    rawws_free(c);
}

int setup_budget(void **state)
{
    /* 400 steps/s: 4,096 x 32 would need 5.2e7 particle-steps/s, out of reach of a 2-core machine
     * even with SPH at 30 Hz (the budget measured 1.4e7 there, where 100 steps/s let it in); a
     * start-up groom of 16 x 8, which the sanitizer tree on a busy host (3.5e5 measured) still
     * takes */
    static const char *const extra[] = { "--min-step-rate", "400", "--strands", "16", NULL };
    return setup_with(state, extra);
}

/* The largest groom (particles) the refusal of a too large set_groom names for solver, after
 * checking that it is refused too_large with that solver's name (id is the request's). */
static double refused_capacity(fixture *fx, wsc_conn *c, const char *solver, int id)
{
    char req[160];
    snprintf(req, sizeof req, "{\"type\":\"set_groom\",\"style\":\"wavy\",\"strands\":4096,\"verts\":32,\"id\":%d}", id);
    wsc_send_text(c, req);
    cJSON *e = expect_msg_within(fx, c, "error", 4 * WAIT_MS);
    assert_true(num(e, "id") == id);
    assert_string_equal(str(e, "code"), "too_large");
    char named[32];
    snprintf(named, sizeof named, "with the %s solver", solver);
    const char *msg = str(e, "message"), *about = strstr(msg, "it steps about ");
    assert_non_null(strstr(msg, named));
    assert_non_null(about);
    double cap = atof(about + strlen("it steps about "));
    cJSON_Delete(e);
    assert_true(cap > 0.0);
    return cap;
}

/* The groom budget: a groom this machine would step slower than --min-step-rate is refused
 * too_large with the numbers, whether procedural or from a file; a small one is taken. */
void test_groom_budget_refuses(void **state)
{
    fixture *fx = *state;
    wsc_conn *c = connect_view(fx, NULL);
    cJSON_Delete(expect_msg(fx, c, "hello"));
    refused_capacity(fx, c, "dftl", 1);
    wsc_send_text(c, "{\"type\":\"set_groom\",\"style\":\"wavy\",\"strands\":16,\"verts\":8,\"id\":2}");
    cJSON *ok = expect_msg_within(fx, c, "ok", 4 * WAIT_MS);
    assert_true(num(ok, "id") == 2);
    cJSON_Delete(ok);
}

/* Sends set_params solver=name with id and returns its reply, of type reply ("ok" or "error"). */
static cJSON *set_solver(fixture *fx, wsc_conn *c, const char *name, int id, const char *reply)
{
    char req[128];
    snprintf(req, sizeof req, "{\"type\":\"set_params\",\"values\":{\"solver\":\"%s\"},\"id\":%d}", name, id);
    wsc_send_text(c, req);
    cJSON *r = expect_msg_within(fx, c, reply, 4 * WAIT_MS);
    assert_true(num(r, "id") == id);
    return r;
}

/* The budget is the active solver's: PBD steps this machine's standard groom slower than DFTL,
 * so a groom DFTL takes can be too large for PBD, and switching to PBD then is refused
 * too_large (field solver) with the numbers while the groom keeps running under DFTL. */
void test_groom_budget_per_solver(void **state)
{
    fixture *fx = *state;
    wsc_conn *c = connect_view(fx, NULL);
    cJSON_Delete(expect_msg(fx, c, "hello"));
    double dftl = refused_capacity(fx, c, "dftl", 2);
    cJSON_Delete(set_solver(fx, c, "pbd", 3, "ok"));
    double pbd = refused_capacity(fx, c, "pbd", 4);
    /* measured 3-5x apart in the release tree (PBD with its shape constraints and 4 iterations),
     * 1.4x in the sanitizer tree */
    assert_true(pbd < 0.9 * dftl);
    cJSON_Delete(set_solver(fx, c, "dftl", 5, "ok"));
    /* halfway (geometrically) between the two capacities, in strands of 16 vertices */
    int strands = (int)(sqrt(pbd * dftl) / 16.0);
    assert_true(strands * 16.0 > pbd && strands * 16.0 < dftl);
    char req[160];
    snprintf(req, sizeof req, "{\"type\":\"set_groom\",\"style\":\"wavy\",\"strands\":%d,\"verts\":16,\"id\":6}", strands);
    wsc_send_text(c, req);
    cJSON *ok = expect_msg_within(fx, c, "ok", 8 * WAIT_MS);
    assert_true(num(ok, "id") == 6);
    cJSON_Delete(ok);
    cJSON *r = set_solver(fx, c, "pbd", 7, "error");
    assert_string_equal(str(r, "code"), "too_large");
    assert_string_equal(str(r, "field"), "values.solver");
    assert_non_null(strstr(str(r, "message"), "with the pbd solver"));
    cJSON_Delete(r);
    cJSON_Delete(set_solver(fx, c, "dftl", 8, "ok")); /* still dftl: the same value is taken */
}

int setup_large_groom(void **state)
{
    static const char *const extra[] = { "--strands", "65536", "--verts", "4", NULL };
    return setup_with(state, extra);
}

/* Resident memory of process pid, MiB (fails the test when unreadable). */
static double rss_mib(pid_t pid)
{
    char path[64], line[256];
    snprintf(path, sizeof path, "/proc/%d/status", (int)pid);
    FILE *f = fopen(path, "r");
    assert_non_null(f);
    double kib = -1.0;
    while (kib < 0.0 && fgets(line, sizeof line, f))
        if (strncmp(line, "VmRSS:", 6) == 0) kib = atof(line + 6);
    fclose(f);
    assert_true(kib > 0.0);
    return kib / 1024.0;
}

/* /metrics' value of name. */
static double metric_now(fixture *fx, const char *name)
{
    http_reply r;
    assert_int_equal(http_get(fx->d.port, "/metrics", &r), 0);
    double v = metric(r.body, name);
    http_reply_free(&r);
    return v;
}

/* A groom of the largest strand count: the hello stays a few KB (the per-strand data is one
 * shared binary at /groom.bin, fetched once; the rest is mostly the parameter schema, 8.2 KB
 * with every solver's parameters), and 100 idle clients that never read cost the
 * daemon little memory (each used to be sent its own multi-megabyte hello). */
void test_large_groom_hello_small(void **state)
{
    fixture *fx = *state;
    view *v;
    wsc_conn *c = connect_view(fx, &v);
    const char *text = wsc_next_of_type(fx->w, c, "hello", 4 * WAIT_MS);
    assert_non_null(text);
    size_t hello_len = strlen(text);
    cJSON *h = cJSON_Parse(text);
    assert_non_null(h);
    const cJSON *g = get(h, "groom");
    assert_true(num(g, "strands") == 65536);
    printf("hello for 65,536 strands: %zu bytes; /groom.bin %.0f bytes\n", hello_len, num(g, "bytes"));
    if (hello_len > 16384) fail_msg("the hello is %zu bytes for a 65,536-strand groom (want a few KB)", hello_len);
    float *data = fetch_groom_data(fx, g);
    for (int s = 0; s < 65536; s++) assert_true(data[s] > 0.0f && isfinite(data[65536 + 3 * s]));
    free(data);
    cJSON_Delete(h);
    /* its frames (a keyframe is hundreds of KB: sent in 16 KiB fragments) decode */
    wait_frames(fx, v, 3);
    assert_true(v->first_was_key && v->bad == 0 && v->info.nstrands_total == 65536);

    double rss0 = rss_mib(fx->d.pid);
    int fds[100];
    for (int i = 0; i < 100; i++) {
        fds[i] = rawws_open(fx->d.port, SUBPROTOCOL);
        assert_true(fds[i] >= 0);
    }
    double t_end = now_s() + 4 * WAIT_MS / 1e3;
    while (metric_now(fx, "strandcast_clients") < 101 && now_s() < t_end) wsc_run(fx->w, 50);
    assert_true(metric_now(fx, "strandcast_clients") == 101);
    wsc_run(fx->w, 1500); /* their hellos and frames are written (or queued) by now */
    double rss1 = rss_mib(fx->d.pid), queued = metric_now(fx, "strandcast_client_queued_bytes");
    printf("100 idle clients: RSS %.1f -> %.1f MiB (+%.1f), text queued for clients %.0f bytes\n", rss0, rss1, rss1 - rss0,
           queued);
    if (rss1 - rss0 > 64.0) fail_msg("100 idle clients took %.1f MiB", rss1 - rss0);
    if (queued > 100 * 8192.0) fail_msg("%.0f bytes of text queued for 100 idle clients", queued);
    for (int i = 0; i < 100; i++) rawws_free(fds[i]);
    wait_frames(fx, v, v->ok + 3);
    assert_int_equal(v->bad, 0);
}
