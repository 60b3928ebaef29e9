/* strandbench latency: how long a parameter change takes to show, on loopback against the real
 * strandcastd with its default scene: from sending set_params to decoding the first frame whose
 * header's sim_step reaches the step the ok reply names (proto/PROTOCOL.md, ok). */
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "bench.h"
#include "codec/codec.h"
#include "core/cli.h"
#include "proto/proto.h"
#include "support/daemon.h"
#include "wsc/wsc.h"

#define PROG "strandbench latency"
#define WAIT_MS 10000

static const char *const LATENCY_USAGE =
    "usage: strandbench latency [--changes N] [--gap-ms N] [--strands N --verts N] [--daemon PATH] [--json]\n"
    "Starts strandcastd with its default scene (or a straight groom of --strands x --verts) on a loopback port, connects one client and sends N\n"
    "parameter changes one after another (gravity, alternating between two values), each a random\n"
    "pause after the previous one shows (uniform in [0, --gap-ms], the same sequence every run: a\n"
    "user's changes come at any point of the server's step, and on average no faster than its real\n"
    "time). For each it measures, on the client's monotonic clock, the time from\n"
    "sending set_params to its ok reply, and to the first frame decoded after the reply whose\n"
    "sim_step is at least the reply's step (the first frame showing the change). Prints p50, p99\n"
    "and the maximum of both (target: p99 change-to-frame <= 25 ms).\n"
    "  --changes N    parameter changes to time, 1..100000 (default 1000)\n"
    "  --gap-ms N     longest random pause between one change showing and the next, 0..1000 ms\n"
    "                 (default 33: two frames at 60 Hz; 0: back to back, which a fast server answers\n"
    "                 faster than real time, so the real-time pacing shows in the figures)\n"
    "  --strands N    strands of the daemon's groom (with --verts; default: its default scene)\n"
    "  --verts N      vertices per strand of the daemon's groom\n"
    "  --daemon PATH  the strandcastd to run (default: next to this program's folder)\n"
    "  --json         one JSON row: {\"bench\":\"latency\",\"changes\":N,\"p50_ms\":..,\"p99_ms\":..,...}\n";

typedef struct latency_opts {
    unsigned changes;
    unsigned gap_ms;
    const char *strands, *verts; /* passed to the daemon as given (it checks them) */
    const char *daemon;
    bool json;
} latency_opts;

enum { OPT_CHANGES = 256, OPT_GAP, OPT_STRANDS, OPT_VERTS, OPT_DAEMON, OPT_JSON };

static const struct option latency_options[] = {
    { "changes", required_argument, NULL, OPT_CHANGES },
    { "gap-ms", required_argument, NULL, OPT_GAP },
    { "strands", required_argument, NULL, OPT_STRANDS },
    { "verts", required_argument, NULL, OPT_VERTS },
    { "daemon", required_argument, NULL, OPT_DAEMON },
    { "json", no_argument, NULL, OPT_JSON },
    { "help", no_argument, NULL, 'h' },
    { NULL, 0, NULL, 0 },
};

/* Returns 0 and fills o, or an exit status (--help prints and returns -1). */
static int parse_opts(int argc, char **argv, latency_opts *o)
{
    memset(o, 0, sizeof *o);
    o->changes = 1000;
    o->gap_ms = 33;
    core_cli_begin();
    char flag[64];
    int opt, status;
    while ((opt = core_cli_next(PROG, argc, argv, latency_options, flag, sizeof flag, &status)) > 0) {
        unsigned long long u = 0;
        int rc = 0;
        switch (opt) {
        case 'h': fputs(LATENCY_USAGE, stdout); return -1;
        case OPT_CHANGES:
            if (!(rc = core_cli_u64(PROG, flag, optarg, 1, 100000, &u))) o->changes = (unsigned)u;
            break;
        case OPT_GAP:
            if (!(rc = core_cli_u64(PROG, flag, optarg, 0, 1000, &u))) o->gap_ms = (unsigned)u;
            break;
        case OPT_STRANDS: o->strands = optarg; break;
        case OPT_VERTS: o->verts = optarg; break;
        case OPT_DAEMON: o->daemon = optarg; break;
        case OPT_JSON: o->json = true; break;
        }
        if (rc) return rc;
    }
    if (status == 0 && !o->strands != !o->verts) {
        fprintf(stderr, "%s: --strands and --verts go together\n", PROG);
        return 2;
    }
    return status;
}

/* The client: its decoder and, for the change being timed, when the first frame showing it was
 * decoded. A frame counts when the reply had arrived before it (the text messages received
 * before the frame, in the connection's order, include the reply) and its step reaches the
 * reply's. */
typedef struct latency_rx {
    codec_decoder dec;
    float *xyz;
    size_t cap;
    uint64_t frames, bad;
    size_t reply_at;             /* the reply's index among the received texts (SIZE_MAX: not yet) */
    uint64_t want_step;          /* the reply's step */
    unsigned long long shown_ns; /* when the first frame showing the change was decoded (0: not yet) */
    uint64_t pending_step[64];   /* frames decoded while the reply was not yet read: step, */
    size_t pending_texts[64];    /* texts received before each, */
    unsigned long long pending_ns[64]; /* and when */
    size_t npending;
    char error[CORE_ERR_MAX];
} latency_rx;

static void on_frame(wsc_conn *conn, const uint8_t *data, size_t len, void *user)
{
    latency_rx *rx = user;
    codec_frame_info info;
    core_err err;
    if (codec_peek_header(data, len, &info, &err) != CORE_OK) goto bad;
    size_t need = 3u * (size_t)info.nstrands_sent * info.nverts;
    if (need > rx->cap) {
        float *x = realloc(rx->xyz, need * sizeof *x);
        if (!x) {
            core_fail(&err, CORE_ENOMEM, "out of memory for %zu positions", need);
            goto bad;
        }
        rx->xyz = x;
        rx->cap = need;
    }
    if (codec_decode(&rx->dec, data, len, rx->xyz, rx->cap, &info, &err) != CORE_OK) goto bad;
    const unsigned long long t = core_now_ns();
    rx->frames++;
    size_t ntexts;
    wsc_texts(conn, &ntexts);
    if (rx->shown_ns) return;
    if (rx->reply_at != SIZE_MAX) {
        if (ntexts > rx->reply_at && info.sim.sim_step >= rx->want_step) rx->shown_ns = t;
    } else if (rx->npending < sizeof rx->pending_ns / sizeof rx->pending_ns[0]) {
        /* the reply may be among the texts already received but not yet read: decided once it is */
        rx->pending_step[rx->npending] = info.sim.sim_step;
        rx->pending_texts[rx->npending] = ntexts;
        rx->pending_ns[rx->npending++] = t;
    }
    return;
bad:
    if (rx->bad++ == 0) snprintf(rx->error, sizeof rx->error, "%s", err.msg);
}

typedef struct until_reply {
    wsc_conn *conn;
    size_t next;       /* texts already looked at */
    double id;         /* the request's id */
    const char *reply; /* its reply, once seen (at index next) */
} until_reply;

static bool got_reply(void *arg)
{
    until_reply *u = arg;
    size_t n;
    char *const *t = wsc_texts(u->conn, &n);
    for (; u->next < n; u->next++) {
        char type[32];
        proto_id id;
        if (proto_read_envelope(t[u->next], strlen(t[u->next]), type, sizeof type, &id) == CORE_OK &&
            id.kind == PROTO_ID_NUMBER && id.num == u->id) {
            u->reply = t[u->next];
            return true;
        }
    }
    return !wsc_is_open(u->conn);
}

static bool shown(void *arg)
{
    const latency_rx *rx = arg;
    return rx->shown_ns != 0 || rx->bad != 0;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* The q-quantile (0..1) of the sorted v[0..n): the nearest rank. */
static double quantile(const double *v, size_t n, double q)
{
    size_t k = (size_t)ceil(q * (double)n);
    return v[k ? k - 1 : 0];
}

/* Times o->changes parameter changes on the connected client; fills the sorted latencies (ms). */
static int measure(const latency_opts *o, wsc *w, wsc_conn *conn, latency_rx *rx, double *to_reply, double *to_frame)
{
    until_reply u = { conn, 0, 0.0, NULL };
    uint64_t lcg = 0x2545f4914f6cdd1dull; /* the pauses: the same sequence every run */
    size_t n;
    wsc_texts(conn, &n);
    u.next = n;
    for (unsigned i = 0; i < o->changes; i++) {
        char msg[128];
        snprintf(msg, sizeof msg, "{\"type\":\"set_params\",\"id\":%u,\"values\":{\"gravity\":%s}}", i + 1,
                 i % 2 ? "9.81" : "9.8");
        rx->reply_at = SIZE_MAX;
        rx->npending = 0;
        rx->shown_ns = 0;
        u.id = i + 1;
        u.reply = NULL;
        unsigned long long t0 = core_now_ns();
        wsc_send_text(conn, msg);
        if (!wsc_until(w, got_reply, &u, WAIT_MS) || !u.reply) {
            fprintf(stderr, "%s: change %u: no reply in %d ms\n", PROG, i + 1, WAIT_MS);
            return 1;
        }
        unsigned long long t1 = core_now_ns();
        if (proto_read_ok_step(u.reply, strlen(u.reply), &rx->want_step) != CORE_OK) {
            fprintf(stderr, "%s: change %u: the reply has no step: %s\n", PROG, i + 1, u.reply);
            return 1;
        }
        rx->reply_at = u.next;
        for (size_t k = 0; k < rx->npending && !rx->shown_ns; k++) /* frames read in the same pass as the reply */
            if (rx->pending_texts[k] > rx->reply_at && rx->pending_step[k] >= rx->want_step) rx->shown_ns = rx->pending_ns[k];
        if (!wsc_until(w, shown, rx, WAIT_MS) || rx->bad) {
            fprintf(stderr, "%s: change %u: no frame at step %llu in %d ms%s%s\n", PROG, i + 1,
                    (unsigned long long)rx->want_step, WAIT_MS, rx->bad ? ": " : "", rx->error);
            return 1;
        }
        to_reply[i] = (double)(t1 - t0) / 1e6;
        to_frame[i] = (double)(rx->shown_ns - t0) / 1e6;
        lcg = lcg * 6364136223846793005ull + 1442695040888963407ull;
        if (o->gap_ms) wsc_run(w, (int)((lcg >> 33) % (o->gap_ms + 1u)));
    }
    qsort(to_reply, o->changes, sizeof *to_reply, cmp_double);
    qsort(to_frame, o->changes, sizeof *to_frame, cmp_double);
    return 0;
}

int bench_latency_main(int argc, char **argv)
{
    latency_opts o;
    int rc = parse_opts(argc, argv, &o);
    if (rc) return rc < 0 ? 0 : rc;
    char path[4096];
    const char *exe = bench_find_daemon(o.daemon, path, sizeof path);
    if (!exe) {
        fprintf(stderr, "%s: strandcastd not found next to this program; give --daemon PATH\n", PROG);
        return 1;
    }
    /* the default scene or the given groom; --min-step-rate 0 so that a loaded machine still runs it */
    char *dargv[] = { (char *)exe, "--port", "0", "--min-step-rate", "0", NULL, NULL, NULL, NULL, NULL };
    if (o.strands) {
        dargv[5] = "--strands", dargv[6] = (char *)o.strands;
        dargv[7] = "--verts", dargv[8] = (char *)o.verts;
    }
    daemon_proc d;
    if (daemon_start(&d, exe, dargv, 60000) != 0) {
        fprintf(stderr, "%s: could not start %s\n", PROG, exe);
        return 1;
    }
    latency_rx rx;
    memset(&rx, 0, sizeof rx);
    codec_decoder_init(&rx.dec);
    double *to_reply = malloc(o.changes * sizeof *to_reply), *to_frame = malloc(o.changes * sizeof *to_frame);
    wsc *w = wsc_new();
    wsc_conn *conn = w ? wsc_connect(w, d.port, PROTO_SUBPROTOCOL, on_frame, &rx) : NULL;
    rc = 1;
    if (!to_reply || !to_frame || !conn || !wsc_wait_open(w, conn, WAIT_MS) || !wsc_next_of_type(w, conn, "hello", WAIT_MS)) {
        fprintf(stderr, "%s: no connection to the daemon on port %d\n", PROG, d.port);
    } else {
        wsc_run(w, 500); /* the first keyframe, the hair leaving its rest pose */
        rc = measure(&o, w, conn, &rx, to_reply, to_frame);
    }
    wsc_free(w);
    /* its exit status is the integration tests' business (a sanitizer build's leak report about
       the Vulkan driver the automatic backend probe loads, say), not the measurement's */
    int drc = daemon_stop(&d, SIGTERM, 15000);
    if (drc != 0) fprintf(stderr, "%s: strandcastd exited with %d\n", PROG, drc);
    if (rc == 0) {
        const size_t n = o.changes;
        const double p50 = quantile(to_frame, n, 0.5), p99 = quantile(to_frame, n, 0.99), max = to_frame[n - 1];
        const double r50 = quantile(to_reply, n, 0.5), r99 = quantile(to_reply, n, 0.99);
        if (o.json)
            printf("{\"bench\":\"latency\",\"changes\":%zu,\"gap_ms\":%u,\"p50_ms\":%.3f,\"p99_ms\":%.3f,\"max_ms\":%.3f,"
                   "\"reply_p50_ms\":%.3f,\"reply_p99_ms\":%.3f,\"frames\":%llu,\"target_p99_ms\":25,\"nproc\":%ld}\n",
                   n, o.gap_ms, p50, p99, max, r50, r99, (unsigned long long)rx.frames, sysconf(_SC_NPROCESSORS_ONLN));
        else
            printf("strandbench latency: %zu parameter changes on loopback, pauses up to %u ms, %s (%ld cores)\n"
                   "  change to first frame showing it: p50 %.2f ms, p99 %.2f ms, max %.2f ms (target p99 <= 25 ms)\n"
                   "  change to its reply:              p50 %.2f ms, p99 %.2f ms\n",
                   n, o.gap_ms, o.strands ? "the given groom" : "default scene", sysconf(_SC_NPROCESSORS_ONLN), p50, p99,
                   max, r50, r99);
    }
    free(to_reply);
    free(to_frame);
    free(rx.xyz);
    codec_decoder_free(&rx.dec);
    return rc;
}
