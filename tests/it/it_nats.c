/* Integration tests: rooms on simulation nodes and edge relays over a real nats-server (started
 * here on a free loopback port; the scenarios skip when the binary is absent). */
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "bus/bus.h"
#include "it.h"
#include "support/natscreds.h"
#include "support/natsd.h"

#define NATS_TOKEN "it-nats-token-5c1e"
#define NODE_LOST_MS 6000 /* the edges' 3 s heartbeat timeout, plus slack for a loaded host */

/* The last frames of one client, by seq, with a hash of their bytes. */
typedef struct seen {
    uint64_t seq[256], hash[256];
    size_t n;
    uint64_t frames;
    uint32_t strands;  /* of the last frame */
} seen;

typedef struct nats_fx {
    const config *cfg;
    natsd nats;
    char dir[64];            /* setup_nats_creds*: the operator-mode files (natscreds_setup), or "" */
    char creds[96];          /* the nodes' and edges' --nats-creds, or "" */
    natscreds_key account;   /* the account of dir/user.creds */
    daemon_proc nodes[2], edges[2];
    wsc *w;
    seen seen[4];
} nats_fx;

static uint64_t fnv(const uint8_t *p, size_t n)
{
    uint64_t h = 1469598103934665603ull;
    for (size_t i = 0; i < n; i++) h = (h ^ p[i]) * 1099511628211ull;
    return h;
}

static void on_raw(wsc_conn *c, const uint8_t *data, size_t len, void *user)
{
    (void)c;
    seen *s = user;
    codec_frame_info info;
    core_err err;
    if (codec_peek_header(data, len, &info, &err) != CORE_OK) return;
    s->seq[s->n % 256] = info.seq;
    s->hash[s->n % 256] = fnv(data, len);
    s->n++;
    s->frames++;
    s->strands = info.nstrands_sent;
}

/* The common flags of nodes and edges into argv from n on, with --nats-creds when the fixture
 * has credentials; returns the new count. */
static int nats_args(nats_fx *fx, char **argv, int n)
{
    argv[n++] = "--port";
    argv[n++] = "0";
    argv[n++] = "--nats";
    argv[n++] = fx->nats.url;
    if (fx->creds[0]) {
        argv[n++] = "--nats-creds";
        argv[n++] = fx->creds;
    }
    return n;
}

/* A node of room; with token_file, clients need that token to change anything. */
static void start_node(nats_fx *fx, int i, const char *room, const char *token_file)
{
    char *argv[32] = { (char *)fx->cfg->exe, "--backend", "cpu", "--strands", "64", "--verts", "8", "--threads", "1",
                       "--min-step-rate", "0", "--room", (char *)room };
    int n = nats_args(fx, argv, 13);
    if (token_file) {
        argv[n++] = "--token-file";
        argv[n++] = (char *)token_file;
    }
    assert_int_equal(daemon_start(&fx->nodes[i], fx->cfg->exe, argv, 20000), 0);
}

static void start_edge(nats_fx *fx, int i)
{
    char *argv[16] = { (char *)fx->cfg->exe, "--relay" };
    nats_args(fx, argv, 2);
    assert_int_equal(daemon_start(&fx->edges[i], fx->cfg->exe, argv, 20000), 0);
}

/* A new fixture (*state) for nats-server, or NULL (the scenario skipped) when it is not installed. */
static nats_fx *new_fx(void **state)
{
    if (!natsd_exe()) {
        print_message("nats-server is not installed (.ci/deps installs it): skipped\n");
        return NULL;
    }
    nats_fx *fx = calloc(1, sizeof *fx);
    fx->cfg = *state;
    fx->w = wsc_new();
    *state = fx;
    return fx;
}

/* Nodes of rooms r1 and r2 and two edges (token_file: the node of r1 requires its token from
 * clients). */
static void start_all(nats_fx *fx, const char *token_file)
{
    start_node(fx, 0, "r1", token_file);
    start_node(fx, 1, "r2", NULL);
    start_edge(fx, 0);
    start_edge(fx, 1);
}

/* nats-server (token: it requires it), nodes and edges (start_all). */
static int setup_nodes(void **state, const char *token, const char *token_file)
{
    nats_fx *fx = new_fx(state);
    if (!fx) return -1;
    assert_int_equal(natsd_start(&fx->nats, 0, token), 0);
    start_all(fx, token_file);
    return 0;
}

int setup_nats(void **state) { return setup_nodes(state, NULL, NULL); }
int setup_nats_token(void **state) { return setup_nodes(state, NATS_TOKEN, NULL); }

int setup_nats_client_token(void **state)
{
    char path[] = "/tmp/strandcast-nats-token-XXXXXX";
    int fd = mkstemp(path); /* mode 0600 */
    assert_true(fd >= 0);
    assert_true(write(fd, IT_TOKEN "\n", strlen(IT_TOKEN) + 1) == (ssize_t)strlen(IT_TOKEN) + 1);
    close(fd);
    int rc = setup_nodes(state, NULL, path); /* the node has read it */
    unlink(path);
    return rc;
}

/* The files setup_nats_creds* and the scenarios write in fx->dir. */
static const char *const creds_files[] = { "op.jwt", "server.conf", "user.creds", "other.creds", "seed.creds" };

/* nats-server in operator mode (natscreds_setup in a new folder: it knows one account, whose
 * user's credentials are fx->creds); with daemons, nodes and edges using them (start_all). */
static int setup_creds(void **state, bool daemons)
{
    nats_fx *fx = new_fx(state);
    if (!fx) return -1;
    snprintf(fx->dir, sizeof fx->dir, "/tmp/strandcast-nats-creds-XXXXXX");
    assert_non_null(mkdtemp(fx->dir));
    assert_int_equal(natscreds_setup(fx->dir, &fx->account), 0);
    char conf[96];
    snprintf(conf, sizeof conf, "%s/server.conf", fx->dir);
    snprintf(fx->creds, sizeof fx->creds, "%s/user.creds", fx->dir);
    assert_int_equal(natsd_start_conf(&fx->nats, 0, conf), 0);
    if (daemons) start_all(fx, NULL);
    return 0;
}

int setup_nats_creds(void **state) { return setup_creds(state, true); }
int setup_nats_creds_server(void **state) { return setup_creds(state, false); }

int teardown_nats(void **state)
{
    nats_fx *fx = *state;
    wsc_free(fx->w);
    int bad = 0; /* those the test did not stop itself exit cleanly (no leak, no error) */
    for (int i = 0; i < 2; i++) {
        if (fx->edges[i].pid > 0 && daemon_stop(&fx->edges[i], SIGTERM, 15000) != 0) bad++;
        if (fx->nodes[i].pid > 0 && daemon_stop(&fx->nodes[i], SIGTERM, 15000) != 0) bad++;
    }
    natsd_stop(&fx->nats);
    if (fx->dir[0]) {
        char path[128];
        for (size_t i = 0; i < sizeof creds_files / sizeof creds_files[0]; i++) {
            snprintf(path, sizeof path, "%s/%s", fx->dir, creds_files[i]);
            unlink(path);
        }
        rmdir(fx->dir);
    }
    free(fx);
    if (bad) fprintf(stderr, "%d strandcastd processes did not exit with 0 after SIGTERM\n", bad);
    return bad ? -1 : 0;
}

/* A client of room at edge i whose frames go into s; returns it after its hello (room checked). */
static wsc_conn *join(nats_fx *fx, int edge, const char *room, seen *s, double *client)
{
    static char paths[8][80];
    static int np;
    char *path = paths[np++ % 8];
    snprintf(path, 80, "/rooms/%s", room);
    wsc_conn *c = wsc_connect_path(fx->w, fx->edges[edge].port, path, SUBPROTOCOL, on_raw, s);
    const char *t = wsc_next_of_type(fx->w, c, "hello", 10000);
    if (!t) fail_msg("no hello from edge %d for room %s", edge, room);
    cJSON *h = cJSON_Parse(t);
    assert_string_equal(str(h, "room"), room);
    if (client) *client = num(h, "client");
    cJSON_Delete(h);
    return c;
}

static bool frames_reach(void *arg)
{
    const reach_arg *a = arg;
    return *a->count >= a->n;
}

static void wait_seen(nats_fx *fx, seen *s, uint64_t n, int ms)
{
    reach_arg a = { &s->frames, n };
    if (!wsc_until(fx->w, frames_reach, &a, ms)) fail_msg("%llu frames, want %llu", (unsigned long long)s->frames, (unsigned long long)n);
}

/* Frames both clients got with the same seq: at least min of them, every one byte-identical. */
static void same_frames(const seen *a, const seen *b, size_t min)
{
    size_t common = 0;
    for (size_t i = 0; i < (a->n < 256 ? a->n : 256); i++)
        for (size_t j = 0; j < (b->n < 256 ? b->n : 256); j++)
            if (a->seq[i] == b->seq[j]) {
                assert_true(a->hash[i] == b->hash[j]);
                common++;
            }
    if (common < min) fail_msg("only %zu frames in common", common);
}

/* The next message of type on c that satisfies key == value (a number), within ms. */
static cJSON *expect_params_by(nats_fx *fx, wsc_conn *c, double by)
{
    for (int i = 0; i < 50; i++) {
        const char *t = wsc_next_of_type(fx->w, c, "params", 5000);
        if (!t) break;
        cJSON *m = cJSON_Parse(t);
        const cJSON *b = cJSON_GetObjectItemCaseSensitive(m, "by");
        if (cJSON_IsNumber(b) && b->valuedouble == by) return m;
        cJSON_Delete(m);
    }
    fail_msg("no params by client %.0f", by);
    return NULL;
}

void test_nats_rooms_on_edges(void **state)
{
    nats_fx *fx = *state;
    double ida, idb;
    wsc_conn *a = join(fx, 0, "r1", &fx->seen[0], &ida);
    wsc_conn *b = join(fx, 1, "r1", &fx->seen[1], &idb);
    wsc_conn *c = join(fx, 0, "r2", &fx->seen[2], NULL);
    assert_true(ida != idb);
    wait_seen(fx, &fx->seen[0], 60, 15000);
    wait_seen(fx, &fx->seen[1], 60, 15000);
    wait_seen(fx, &fx->seen[2], 10, 15000);
    /* the same room on two edges: the same bytes */
    same_frames(&fx->seen[0], &fx->seen[1], 20);
    /* a change on one edge: its reply (id intact) there, the announcement on the other edge
     * with by = the sender */
    wsc_send_text(a, "{\"type\":\"set_params\",\"id\":\"edge-7\",\"values\":{\"gravity\":2.5}}");
    const char *t = wsc_next_of_type(fx->w, a, "ok", 5000);
    assert_non_null(t);
    cJSON *ok = cJSON_Parse(t);
    assert_string_equal(str(ok, "id"), "edge-7");
    cJSON_Delete(ok);
    cJSON *p = expect_params_by(fx, b, ida);
    assert_true(num(get(p, "values"), "gravity") == 2.5);
    cJSON_Delete(p);
    /* the other room does not see it */
    wsc_run(fx->w, 300);
    size_t nt;
    char *const *texts = wsc_texts(c, &nt);
    for (size_t i = 0; i < nt; i++) assert_null(strstr(texts[i], "\"gravity\":2.5"));
    /* stream settings are requests to the node: a stride-2 stream through the edge */
    wsc_send_text(b, "{\"type\":\"subscribe\",\"id\":3,\"stride\":2}");
    t = wsc_next_of_type(fx->w, b, "subscribed", 5000);
    assert_non_null(t);
    cJSON *sub = cJSON_Parse(t);
    assert_true(num(sub, "id") == 3 && num(get(sub, "stream"), "strands") == 32);
    cJSON_Delete(sub);
    uint64_t before = fx->seen[1].frames;
    wait_seen(fx, &fx->seen[1], before + 10, 10000);
    assert_int_equal(fx->seen[1].strands, 32);
    assert_int_equal(fx->seen[0].strands, 64);
    /* the edges' pages and metrics */
    http_reply r;
    assert_int_equal(http_get(fx->edges[1].port, "/rooms/r1", &r), 0);
    assert_int_equal(r.status, 200);
    assert_non_null(strstr(r.body, "<title>strandcast</title>"));
    http_reply_free(&r);
    /* the room's binaries: served by the edge at the room's path, the node's bytes */
    http_reply node_bin, edge_bin;
    assert_int_equal(http_get(fx->nodes[0].port, "/groom.bin", &node_bin), 0);
    assert_int_equal(http_get(fx->edges[1].port, "/rooms/r1/groom.bin", &edge_bin), 0);
    assert_int_equal(node_bin.status, 200);
    assert_int_equal(edge_bin.status, 200);
    assert_true(edge_bin.body_len == node_bin.body_len && memcmp(edge_bin.body, node_bin.body, node_bin.body_len) == 0);
    http_reply_free(&node_bin);
    http_reply_free(&edge_bin);
    assert_int_equal(http_get(fx->edges[1].port, "/metrics", &r), 0);
    assert_int_equal(r.status, 200);
    assert_true(metric(r.body, "strandcast_relay_frames_in_total") > 0);
    http_reply_free(&r);
    /* the node published each frame once, whatever the clients and edges */
    assert_int_equal(http_get(fx->nodes[0].port, "/metrics", &r), 0);
    double published = metric(r.body, "strandcast_nats_frames_published_total"),
           encoded = metric(r.body, "strandcast_frames_encoded_total");
    assert_true(published > 0 && published <= encoded);
    http_reply_free(&r);
}

void test_nats_node_killed(void **state)
{
    nats_fx *fx = *state;
    wsc_conn *a = join(fx, 0, "r1", &fx->seen[0], NULL);
    wsc_conn *c = join(fx, 1, "r2", &fx->seen[2], NULL);
    wait_seen(fx, &fx->seen[0], 10, 15000);
    daemon_stop(&fx->nodes[0], SIGKILL, 5000);
    double t0 = now_s();
    const char *t = wsc_next_of_type(fx->w, a, "error", NODE_LOST_MS);
    assert_non_null(t);
    cJSON *e = cJSON_Parse(t);
    assert_string_equal(str(e, "code"), "room_unavailable");
    cJSON_Delete(e);
    assert_int_equal(wsc_wait_closed(fx->w, a, 3000), PROTO_CLOSE_ROOM_UNAVAILABLE);
    double lost_s = now_s() - t0;
    print_message("node loss noticed after %.1f s\n", lost_s);
    assert_true(lost_s >= 2.0); /* by the heartbeat timeout, not by chance */
    /* the other room streams on */
    uint64_t before = fx->seen[2].frames;
    wait_seen(fx, &fx->seen[2], before + 30, 10000);
    assert_true(wsc_is_open(c));
    /* a new client of the dead room: refused the same way once the timeout passes */
    wsc_conn *late = wsc_connect_path(fx->w, fx->edges[0].port, "/rooms/r1", SUBPROTOCOL, NULL, NULL);
    assert_int_equal(wsc_wait_closed(fx->w, late, NODE_LOST_MS), PROTO_CLOSE_ROOM_UNAVAILABLE);
}

void test_nats_edge_killed(void **state)
{
    nats_fx *fx = *state;
    wsc_conn *a = join(fx, 0, "r1", &fx->seen[0], NULL);
    wsc_conn *b = join(fx, 1, "r1", &fx->seen[1], NULL);
    wait_seen(fx, &fx->seen[1], 10, 15000);
    daemon_stop(&fx->edges[1], SIGKILL, 5000);
    assert_true(wsc_wait_closed(fx->w, b, 5000) != -1 || !wsc_is_open(b));
    uint64_t before = fx->seen[0].frames;
    wait_seen(fx, &fx->seen[0], before + 240, 20000); /* past the node's 3 s edge timeout */
    assert_true(wsc_is_open(a));
    /* a client reconnecting to the edge left (as through a load balancer) gets the room */
    join(fx, 0, "r1", &fx->seen[3], NULL);
    wait_seen(fx, &fx->seen[3], 10, 10000);
}

void test_nats_restart(void **state)
{
    nats_fx *fx = *state;
    double ida;
    wsc_conn *a = join(fx, 0, "r1", &fx->seen[0], &ida);
    wsc_conn *b = join(fx, 1, "r1", &fx->seen[1], NULL);
    wait_seen(fx, &fx->seen[0], 10, 15000);
    int port = fx->nats.port;
    natsd_stop(&fx->nats);
    wsc_run(fx->w, 1500);
    assert_int_equal(natsd_start(&fx->nats, port, NULL), 0);
    uint64_t before = fx->seen[0].frames;
    wait_seen(fx, &fx->seen[0], before + 60, 20000);
    assert_true(wsc_is_open(a) && wsc_is_open(b));
    /* control still flows both ways */
    wsc_send_text(a, "{\"type\":\"set_params\",\"id\":9,\"values\":{\"gravity\":4}}");
    cJSON *p = expect_params_by(fx, b, ida);
    cJSON_Delete(p);
}

/* haproxy -f tests/haproxy.cfg in front of the two edges, on port (its pid). */
static pid_t start_haproxy(const nats_fx *fx, int port)
{
    static const char exe[] = "/usr/sbin/haproxy";
    if (access(exe, X_OK) != 0) fail_msg("%s is not installed (.ci/deps installs it)", exe);
    char listen[32], e1[32], e2[32];
    snprintf(listen, sizeof listen, "127.0.0.1:%d", port);
    snprintf(e1, sizeof e1, "127.0.0.1:%d", fx->edges[0].port);
    snprintf(e2, sizeof e2, "127.0.0.1:%d", fx->edges[1].port);
    pid_t pid = fork();
    if (pid == 0) {
        prctl(PR_SET_PDEATHSIG, SIGTERM);
        setenv("SC_LISTEN", listen, 1);
        setenv("SC_EDGE1", e1, 1);
        setenv("SC_EDGE2", e2, 1);
        execl(exe, exe, "-db", "-q", "-f", STRANDCAST_SOURCE_DIR "/tests/haproxy.cfg", (char *)NULL);
        _exit(127);
    }
    assert_true(pid > 0);
    return pid;
}

/* A client of room r1 through haproxy (retrying until haproxy listens and routes). */
static wsc_conn *join_via(nats_fx *fx, int port, seen *s)
{
    for (int i = 0; i < 20; i++) {
        wsc_conn *c = wsc_connect_path(fx->w, port, "/rooms/r1", SUBPROTOCOL, on_raw, s);
        const char *t = wsc_next_of_type(fx->w, c, "hello", 1500);
        if (t) return c;
        wsc_run(fx->w, 100);
    }
    fail_msg("no hello through haproxy");
    return NULL;
}

void test_nats_haproxy(void **state)
{
    nats_fx *fx = *state;
    int port = natsd_free_port();
    pid_t hp = start_haproxy(fx, port);
    wsc_conn *a = join_via(fx, port, &fx->seen[0]);
    wsc_conn *b = join_via(fx, port, &fx->seen[1]);
    wait_seen(fx, &fx->seen[0], 30, 15000);
    wait_seen(fx, &fx->seen[1], 30, 15000);
    /* leastconn put them on both edges */
    http_reply r;
    double clients[2];
    for (int i = 0; i < 2; i++) {
        assert_int_equal(http_get(fx->edges[i].port, "/metrics", &r), 0);
        clients[i] = metric(r.body, "strandcast_clients");
        http_reply_free(&r);
    }
    assert_true(clients[0] == 1 && clients[1] == 1);
    /* an edge stops: its client is cut, the other streams on, and reconnecting through haproxy
     * lands on the edge left */
    daemon_stop(&fx->edges[0], SIGKILL, 5000);
    wsc_run(fx->w, 1500); /* haproxy's health check marks it down */
    assert_true(!wsc_is_open(a) || !wsc_is_open(b));
    join_via(fx, port, &fx->seen[2]);
    wait_seen(fx, &fx->seen[2], 30, 15000);
    kill(hp, SIGTERM);
    waitpid(hp, NULL, 0);
}

/* The node's --token-file holds for its clients on an edge: read-only until auth. */
void test_nats_client_token(void **state)
{
    nats_fx *fx = *state;
    wsc_conn *a = join(fx, 0, "r1", &fx->seen[0], NULL);
    wsc_send_text(a, "{\"type\":\"set_params\",\"id\":1,\"values\":{\"gravity\":3}}");
    const char *t = wsc_next_of_type(fx->w, a, "error", 5000);
    assert_non_null(t);
    assert_non_null(strstr(t, "forbidden"));
    wsc_send_text(a, "{\"type\":\"auth\",\"id\":2,\"token\":\"" IT_TOKEN "\"}");
    assert_non_null(wsc_next_of_type(fx->w, a, "ok", 5000));
    wsc_send_text(a, "{\"type\":\"set_params\",\"id\":3,\"values\":{\"gravity\":3}}");
    t = wsc_next_of_type(fx->w, a, "ok", 5000);
    assert_non_null(t);
    assert_non_null(strstr(t, "\"id\":3"));
}

void test_nats_token(void **state)
{
    nats_fx *fx = *state;
    join(fx, 1, "r2", &fx->seen[0], NULL);
    wait_seen(fx, &fx->seen[0], 10, 15000);
}

static double node_texts_in(nats_fx *fx)
{
    http_reply r;
    assert_int_equal(http_get(fx->nodes[0].port, "/metrics", &r), 0);
    double v = metric(r.body, "strandcast_nats_texts_in_total");
    http_reply_free(&r);
    return v;
}

/* Sends get_params with id on c and waits for its params reply (earlier messages are read). */
static void expect_reply(nats_fx *fx, wsc_conn *c, const char *id)
{
    char msg[96], want[80];
    snprintf(msg, sizeof msg, "{\"type\":\"get_params\",\"id\":\"%s\"}", id);
    snprintf(want, sizeof want, "\"id\":\"%s\"", id);
    wsc_send_text(c, msg);
    for (;;) {
        const char *t = wsc_next_of_type(fx->w, c, "params", 5000);
        if (!t) fail_msg("no params with id %s", id);
        if (strstr(t, want)) return;
    }
}

/* The code of the next error on c (within 5 s). */
static void expect_error(nats_fx *fx, wsc_conn *c, const char *code)
{
    const char *t = wsc_next_of_type(fx->w, c, "error", 5000);
    if (!t) fail_msg("no error %s", code);
    cJSON *e = cJSON_Parse(t);
    assert_string_equal(str(e, "code"), code);
    cJSON_Delete(e);
}

/* The per-client limits hold at the edge: a flood through an edge reaches the node only within
 * the budget (128 at once, 400/s), the flooder gets rate_limited from the edge, and a client of
 * the same room on another edge streams on; messages that do not parse are answered by the
 * edge, and a binary or oversized one closes the connection there, none of them reaching the
 * node. */
void test_nats_edge_limits(void **state)
{
    nats_fx *fx = *state;
    wsc_conn *a = join(fx, 0, "r1", &fx->seen[0], NULL);
    wsc_conn *b = join(fx, 1, "r1", &fx->seen[1], NULL);
    wait_seen(fx, &fx->seen[1], 10, 15000);
    double in0 = node_texts_in(fx), t0 = now_s();
    char msg[128];
    for (int i = 0; i < 2000; i++) {
        snprintf(msg, sizeof msg, "{\"type\":\"set_params\",\"values\":{\"wind_x\":%d}}", i % 50);
        wsc_send_text(a, msg);
    }
    wsc_send_text(a, "{\"type\":\"get_params\",\"id\":\"last\"}");
    const char *t = wsc_next_of_type(fx->w, a, "error", 10000);
    assert_non_null(t);
    cJSON *e = cJSON_Parse(t);
    assert_string_equal(str(e, "code"), "rate_limited");
    cJSON_Delete(e);
    wsc_run(fx->w, 500); /* what the edge sent on has reached the node */
    double reached = node_texts_in(fx) - in0, elapsed = now_s() - t0;
    http_reply r;
    assert_int_equal(http_get(fx->edges[0].port, "/metrics", &r), 0);
    double refused = metric(r.body, "strandcast_control_messages_total{result=\"rejected\"}");
    http_reply_free(&r);
    print_message("flood of 2001 through an edge: %.0f reached the node in %.2f s, %.0f refused at the edge\n", reached,
                  elapsed, refused);
    assert_true(reached >= 1 && reached <= 128 + 400 * elapsed + 1);
    assert_true(refused >= 1000 && reached + refused == 2001);
    /* the other edge's client of the room streams on */
    uint64_t before = fx->seen[1].frames;
    wait_seen(fx, &fx->seen[1], before + 30, 10000);
    assert_true(wsc_is_open(a) && wsc_is_open(b));
    /* the budget back: bad messages are answered by the edge, ids intact, and go no further */
    wsc_run(fx->w, 1000);
    expect_reply(fx, a, "mark"); /* the flood's answers all read */
    double in1 = node_texts_in(fx);
    wsc_send_text(a, "{\"type\":\"set_params\",\"id\":\"j\",\"values\":");
    expect_error(fx, a, "bad_json");
    wsc_send_text(a, "{\"type\":\"set_params\",\"id\":\"p\",\"values\":{\"no_such_param\":1}}");
    t = wsc_next_of_type(fx->w, a, "error", 5000);
    assert_non_null(t);
    assert_non_null(strstr(t, "\"id\":\"p\""));
    wsc_send_text(a, "{\"type\":\"no_such_type\"}");
    expect_error(fx, a, "unknown_type");
    wsc_send_frame(a, "\x01\x02", 2, true, false, true);
    assert_int_equal(wsc_wait_closed(fx->w, a, 5000), 1003);
    wsc_conn *big = join(fx, 0, "r1", &fx->seen[2], NULL);
    char *huge = malloc(PROTO_MAX_MESSAGE + 2);
    memset(huge, ' ', PROTO_MAX_MESSAGE + 1);
    huge[PROTO_MAX_MESSAGE + 1] = '\0';
    wsc_send_text(big, huge);
    free(huge);
    assert_int_equal(wsc_wait_closed(fx->w, big, 5000), 1009);
    wsc_run(fx->w, 300);
    assert_true(node_texts_in(fx) == in1);
    /* a valid request through the edge still reaches the node and is answered, id intact */
    expect_reply(fx, b, "ok-b");
    assert_true(node_texts_in(fx) == in1 + 1);
}

/* The next message on sub whose Sc-Op is op (others skipped), within 5 s; the caller destroys it. */
static natsMsg *next_op(natsSubscription *sub, const char *op)
{
    for (int i = 0; i < 50; i++) {
        natsMsg *m = NULL;
        if (natsSubscription_NextMsg(&m, sub, 5000) != NATS_OK) break;
        const char *o = bus_header(m, "Sc-Op");
        if (o && strcmp(o, op) == 0) return m;
        natsMsg_Destroy(m);
    }
    fail_msg("no %s message", op);
    return NULL;
}

/* m's body holds needle. */
static bool has(natsMsg *m, const char *needle)
{
    const char *d = natsMsg_GetData(m);
    size_t n = (size_t)natsMsg_GetDataLength(m), k = strlen(needle);
    for (size_t i = 0; d && i + k <= n; i++)
        if (memcmp(d + i, needle, k) == 0) return true;
    return false;
}

/* Control is NATS request/reply: the node answers a request on its reply subject, whatever that
 * is (here an inbox of a bare NATS client acting as an edge), with the client's messages in the
 * order it made them: the hello, then the reply to a request that carried an id. A message
 * without a reply subject is not served. */
void test_nats_request_reply(void **state)
{
    nats_fx *fx = *state;
    natsConnection *nc = NULL;
    bus_desc bd = { .url = fx->nats.url, .name = "it request/reply" };
    core_err err;
    assert_int_equal(bus_connect(&nc, &bd, &err), CORE_OK);
    natsSubscription *sub = NULL;
    assert_int_equal(natsConnection_SubscribeSync(&sub, nc, "_INBOX.it-rr"), NATS_OK);
    char ctl[BUS_MAX_SUBJECT];
    bus_room_subject(ctl, sizeof ctl, "r1", "ctl");
    const char *open_h[] = { "Sc-Op", "open", "Sc-Edge", "itrr", "Sc-Client", "5", NULL };
    const char *text_h[] = { "Sc-Op", "text", "Sc-Edge", "itrr", "Sc-Client", "5", NULL };
    const char *close_h[] = { "Sc-Op", "close", "Sc-Edge", "itrr", "Sc-Client", "5", NULL };
    assert_int_equal(bus_request(nc, ctl, "_INBOX.it-rr", open_h, "/rooms/r1", 9, &err), CORE_OK);
    /* not a request (no reply subject): not served */
    static const char get0[] = "{\"type\":\"get_params\",\"id\":\"rr-0\"}", get1[] = "{\"type\":\"get_params\",\"id\":\"rr-1\"}";
    assert_int_equal(bus_publish(nc, ctl, text_h, get0, strlen(get0), &err), CORE_OK);
    assert_int_equal(bus_request(nc, ctl, "_INBOX.it-rr", text_h, get1, strlen(get1), &err), CORE_OK);
    natsMsg *m = next_op(sub, "start");
    assert_string_equal(bus_header(m, "Sc-Room"), "r1");
    assert_true(bus_header_u64(m, "Sc-Client", 0) == 5);
    assert_true(has(m, "\"type\":\"hello\""));
    natsMsg_Destroy(m);
    m = next_op(sub, "text");
    assert_true(has(m, "\"id\":\"rr-1\""));
    natsMsg_Destroy(m);
    assert_int_equal(bus_request(nc, ctl, "_INBOX.it-rr", close_h, NULL, 0, &err), CORE_OK);
    http_reply r;
    assert_int_equal(http_get(fx->nodes[0].port, "/metrics", &r), 0);
    assert_true(metric(r.body, "strandcast_nats_texts_in_total") == 1);
    http_reply_free(&r);
    bus_close(nc, &sub, 1);
}

/* Nodes and edges authenticate to a nats-server in operator mode with --nats-creds (a user JWT
 * signed by an account the server trusts, and the user's NKey seed): clients of a room on two
 * edges get its frames, a change through one edge is acknowledged and announced on the other,
 * and the server does require credentials (a connection without them is refused). */
void test_nats_creds(void **state)
{
    nats_fx *fx = *state;
    double ida;
    wsc_conn *a = join(fx, 0, "r1", &fx->seen[0], &ida);
    wsc_conn *b = join(fx, 1, "r1", &fx->seen[1], NULL);
    join(fx, 1, "r2", &fx->seen[2], NULL);
    wait_seen(fx, &fx->seen[0], 30, 15000);
    wait_seen(fx, &fx->seen[1], 30, 15000);
    wait_seen(fx, &fx->seen[2], 10, 15000);
    wsc_send_text(a, "{\"type\":\"set_params\",\"id\":\"creds-1\",\"values\":{\"gravity\":2.5}}");
    const char *t = wsc_next_of_type(fx->w, a, "ok", 5000);
    assert_non_null(t);
    assert_non_null(strstr(t, "\"id\":\"creds-1\""));
    cJSON *p = expect_params_by(fx, b, ida);
    assert_true(num(get(p, "values"), "gravity") == 2.5);
    cJSON_Delete(p);
    natsConnection *nc = NULL;
    bus_desc bare = { .url = fx->nats.url, .name = "it no credentials" };
    core_err err;
    assert_int_equal(bus_connect(&nc, &bare, &err), CORE_EIO);
    assert_null(nc);
    assert_non_null(strstr(err.msg, "refused this client"));
    bus_close(NULL, NULL, 0);
}

/* Runs a node (or with relay, an edge) with --nats-creds creds (NULL: none) against the
 * fixture's server and checks that it exits at start-up with status 1 and a message holding
 * each of the NULL-terminated needles. */
static void expect_refused(nats_fx *fx, bool relay, const char *creds, const char *const *needles)
{
    const char *args[24] = { "--port", "0", "--nats", fx->nats.url };
    int n = 4;
    if (relay) args[n++] = "--relay";
    else {
        static const char *const node[] = { "--backend", "cpu", "--strands", "16", "--verts", "4", "--threads", "1",
                                            "--min-step-rate", "0" };
        for (size_t i = 0; i < sizeof node / sizeof node[0]; i++) args[n++] = node[i];
    }
    if (creds) {
        args[n++] = "--nats-creds";
        args[n++] = creds;
    }
    static char out[16384];
    double t0 = now_s();
    int rc = run_capture(fx->cfg->exe, args, out, sizeof out);
    if (rc != 1) fail_msg("%s with %s: exit %d, want 1; said: %s", relay ? "an edge" : "a node", creds ? creds : "no creds", rc, out);
    for (const char *const *s = needles; *s; s++)
        if (!strstr(out, *s)) fail_msg("%s with %s: no \"%s\" in: %s", relay ? "an edge" : "a node", creds ? creds : "no creds", *s, out);
    print_message("%s with %s: exit 1 after %.2f s\n", relay ? "an edge" : "a node", creds ? creds : "no creds", now_s() - t0);
}

/* This process's stderr into a new temporary file until stderr_end, which returns what was
 * written there (at most cap - 1 bytes, NUL-terminated). */
typedef struct stderr_capture {
    int fd, saved;
} stderr_capture;

static stderr_capture stderr_begin(void)
{
    char log[] = "/tmp/strandcast-nats-log-XXXXXX";
    stderr_capture c = { mkstemp(log), -1 };
    assert_true(c.fd >= 0);
    unlink(log);
    fflush(stderr);
    c.saved = dup(2);
    dup2(c.fd, 2);
    return c;
}

static void stderr_end(stderr_capture c, char *text, size_t cap)
{
    fflush(stderr);
    dup2(c.saved, 2);
    close(c.saved);
    ssize_t n = pread(c.fd, text, cap - 1, 0);
    close(c.fd);
    text[n > 0 ? n : 0] = '\0';
}

/* A server that comes up after the connection began (in the background) and refuses creds:
 * libnats gives up after two refusals instead of retrying forever, and the bus logs the reason
 * as an error (read back from this process's stderr). */
static void refused_later(nats_fx *fx, const char *creds)
{
    int port = fx->nats.port;
    natsd_stop(&fx->nats);
    stderr_capture cap = stderr_begin();
    natsConnection *nc = NULL;
    bus_desc bd = { .url = fx->nats.url, .creds = creds, .name = "it refused later" };
    core_err err;
    core_status st = bus_connect(&nc, &bd, &err);
    char conf[96];
    snprintf(conf, sizeof conf, "%s/server.conf", fx->dir);
    int up = natsd_start_conf(&fx->nats, port, conf);
    double t0 = now_s();
    while (nc && natsConnection_Status(nc) != NATS_CONN_STATUS_CLOSED && now_s() - t0 < 10) nats_Sleep(20);
    bool closed = nc && natsConnection_Status(nc) == NATS_CONN_STATUS_CLOSED;
    bus_close(nc, NULL, 0); /* the closed callback has run once libnats' threads are gone */
    char text[4096];
    stderr_end(cap, text, sizeof text);
    assert_int_equal(st, CORE_OK);
    assert_int_equal(up, 0);
    if (!closed) fail_msg("libnats still retries %.1f s after the server refused the credentials", now_s() - t0);
    if (!strstr(text, "closed for good") || !strstr(text, "Authorization Violation")) fail_msg("logged: %s", text);
    print_message("refused after start-up: connection closed and logged within %.2f s\n", now_s() - t0);
}

/* Credentials the server refuses (a user of an account it does not know; a user's JWT with
 * another user's seed; none at all) stop a node or an edge at start-up with exit status 1 and
 * the server's reason, instead of a daemon retrying forever in silence; refused once the server
 * comes up later, the connection ends with the reason logged (refused_later). The good
 * credentials are accepted, and closing that connection logs no "lost". */
void test_nats_creds_refused(void **state)
{
    nats_fx *fx = *state;
    natscreds_key stranger, user, other_user;
    assert_int_equal(natscreds_key_new(&stranger, 'A'), 0);
    assert_int_equal(natscreds_key_new(&user, 'U'), 0);
    assert_int_equal(natscreds_key_new(&other_user, 'U'), 0);
    char other[128], seed[128];
    snprintf(other, sizeof other, "%s/other.creds", fx->dir);
    snprintf(seed, sizeof seed, "%s/seed.creds", fx->dir);
    char *jwt = natscreds_jwt(&stranger, &user, "stranger");
    assert_non_null(jwt);
    assert_int_equal(natscreds_write(other, jwt, user.seed), 0);
    free(jwt);
    jwt = natscreds_jwt(&fx->account, &user, "wrong-seed");
    assert_non_null(jwt);
    assert_int_equal(natscreds_write(seed, jwt, other_user.seed), 0);
    free(jwt);
    const char *const by_creds[] = { "refused this client", "Authorization Violation", "check the credentials file", NULL };
    expect_refused(fx, false, other, by_creds);
    expect_refused(fx, true, other, by_creds);
    expect_refused(fx, false, seed, by_creds);
    const char *const by_url[] = { "refused this client", "Authorization Violation", "token@", NULL };
    expect_refused(fx, false, NULL, by_url);
    expect_refused(fx, true, NULL, by_url);
    refused_later(fx, other);
    /* the good credentials are accepted by the same server */
    natsConnection *nc = NULL;
    bus_desc bd = { .url = fx->nats.url, .creds = fx->creds, .name = "it credentials" };
    core_err err;
    assert_int_equal(bus_connect(&nc, &bd, &err), CORE_OK);
    assert_non_null(nc);
    assert_int_equal(natsConnection_Status(nc), NATS_CONN_STATUS_CONNECTED);
    /* closing it on purpose is not reported as a lost connection */
    stderr_capture cap = stderr_begin();
    bus_close(nc, NULL, 0);
    char text[1024];
    stderr_end(cap, text, sizeof text);
    if (strstr(text, "lost")) fail_msg("a deliberate close logged: %s", text);
}
