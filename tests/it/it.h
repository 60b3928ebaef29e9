/* Integration tests: the real strandcastd on a free loopback port, driven by real WebSocket
 * clients. Shared types and helpers of the scenario files (tests/it/it_*.c); the scenarios
 * themselves are listed once, in scenarios.h. */
#ifndef IT_H
#define IT_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <cjson/cJSON.h>
#include <stdbool.h>

#include "codec/codec.h"
#include "proto/proto.h"
#include "support/daemon.h"
#include "support/rawws.h"
#include "wsc/wsc.h"

#define SUBPROTOCOL PROTO_SUBPROTOCOL
#define NSTRANDS 128
#define NVERTS 8
#define WAIT_MS 8000 /* generous: the ASan build is slow */
#define PING_INTERVAL_S 1 /* setup_ping's --ping-interval and --ping-timeout */
#define PING_TIMEOUT_S 3

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
    double last_frame_s, max_gap_s;  /* arrival (monotonic s) of the last frame; longest gap between two */
    char last_error[256];
} view;

typedef struct fixture {
    const config *cfg;
    char dir[64];
    char web[96], assets[96];
    char files[64];           /* a folder of files made before the daemon started (token, TLS), or "" */
    daemon_proc d;
    wsc *w;
    view views[8];
    int nviews;
} fixture;

typedef struct reach_arg {
    const uint64_t *count;
    uint64_t n;
} reach_arg;

typedef struct time_arg {
    view *v;
    double t;
} time_arg;

typedef struct count_arg {
    view *v;
    uint32_t strands, verts;
} count_arg;

/* ---- it_support.c: fixtures and helpers shared by the scenarios (test thread) ---- */

uint64_t gcd(uint64_t a, uint64_t b);
/* wsc frame callback: decodes into the view (user) and tracks seq/keyframe steps. */
void on_frame(wsc_conn *c, const uint8_t *data, size_t len, void *user);
/* Writes a whole file (fails the test on error). */
void write_file(const char *path, const void *data, size_t len);
/* Runs exe with args (NULL-terminated, without argv[0]) to its end, its stdout and stderr into
 * out (NUL-terminated, at most cap - 1 bytes); returns its exit status (128 + signal if killed). */
int run_capture(const char *exe, const char *const *args, char *out, size_t cap);
/* A Cem Yuksel .hair file of hairs x pts points (straight strands, tips up by `up`). */
void write_hair(const char *path, uint32_t hairs, uint32_t pts, float up);
/* Starts the daemon with the common flags plus extra (NULL-terminated, may be NULL) into a new
 * fixture (*state, whose prestate is the config); teardown stops it and frees everything. */
int setup_with(void **state, const char *const *extra);
int setup(void **state);
int setup_ping(void **state);
int setup_ipv6(void **state);
/* The common fixture with --backend auto (the probe loads lavapipe: release tree only). */
int setup_auto(void **state);
int teardown(void **state);
/* A new client connection whose frames decode into a fresh view (*out). */
wsc_conn *connect_view(fixture *fx, view **out);
/* The same, over TLS (wss) when tls. */
wsc_conn *connect_view_via(fixture *fx, bool tls, view **out);
/* The next text message of type on c within ms (fails the test otherwise); the caller frees it. */
cJSON *expect_msg_within(fixture *fx, wsc_conn *c, const char *type, int ms);
cJSON *expect_msg(fixture *fx, wsc_conn *c, const char *type);
/* Field k of o (fails when missing); as a number; as a string. */
const cJSON *get(const cJSON *o, const char *k);
double num(const cJSON *o, const char *k);
const char *str(const cJSON *o, const char *k);
/* wsc_until predicates: *count >= n (reach_arg); a frame at sim time t (time_arg); a frame of
 * the given shape (count_arg). */
bool counted(void *arg);
bool at_time(void *arg);
bool frame_shape(void *arg);
/* Waits until v has decoded n frames / a frame at sim time t (fails the test otherwise). */
void wait_frames(fixture *fx, view *v, uint64_t n);
void wait_sim_time(fixture *fx, view *v, double t);
/* Mean y of the strand tips of v's last frame. */
double mean_tip_y(const view *v);
/* Sends the raw HTTP request and checks the reply's status and that its body holds needle (NULL:
 * not checked); fails the test otherwise. */
void expect_http(fixture *fx, const char *request, int status, const char *needle, int timeout_ms);
/* Monotonic seconds. */
double now_s(void);
/* The value of a /metrics line name (NAN when absent). */
double metric(const char *body, const char *name);
/* GETs the groom data binary a hello's or groom message's "groom" object g names (url) and
 * checks it (200, size, proto_groom_bin_read, counts, its tag = etag = the ETag header); fails
 * the test otherwise. Returns its floats in native order: nstrands rest lengths, then 3
 * nstrands root coordinates; the caller frees them. */
float *fetch_groom_data(fixture *fx, const cJSON *g);

/* ---- the scenarios (it_protocol.c, it_streams.c, it_lifecycle.c, it_programs.c, it_collider.c) ---- */

/* The daemon on Ratboy with its body mesh (it_collider.c); the scenario skips without the assets. */
int setup_ratboy(void **state);
/* The common fixture with --max-clients 2 (it_lifecycle.c). */
int setup_two_clients(void **state);
/* The common fixture with a groom budget of 400 steps/s (it_lifecycle.c). */
int setup_budget(void **state);
/* The hair-mesh solver on a groom traced through a procedural hair mesh (it_streams.c). */
int setup_hairmesh(void **state);
/* The common fixture on a 65,536 x 4 groom (it_lifecycle.c). */
int setup_large_groom(void **state);
/* it_access.c: with --token-file (IT_TOKEN); with --allow-origin https://good.example; with a
 * self-signed --tls-cert/--tls-key made by openssl. */
int setup_token(void **state);
int setup_origin(void **state);
int setup_tls(void **state);
/* it_rooms.c: the daemon serving room "studio-2" (--room). */
int setup_room(void **state);
/* it_nats.c: nats-server, simulation nodes of rooms r1 and r2 and two edge relays (the server
 * requiring a token in setup_nats_token); skipped without nats-server. */
int setup_nats(void **state);
int setup_nats_token(void **state);
int setup_nats_client_token(void **state); /* the node of r1 with --token-file (IT_TOKEN) */
/* nats-server in operator mode (credentials made by tests/support/natscreds.c), with nodes and
 * edges using the user's --nats-creds as setup_nats starts them, or (_server) none. */
int setup_nats_creds(void **state);
int setup_nats_creds_server(void **state);
int teardown_nats(void **state);
#define IT_TOKEN "k3Jq9-Vx2Lm7Tz8Wb4Np6Rs1Yd5Hf0Gc"
int teardown_ratboy(void **state);
#define IT_SCENARIO(name, su, td, timeout, labels) void test_##name(void **state);
#include "scenarios.h"
#undef IT_SCENARIO

#endif
