/* strandcastd: entry point: parses the flags into an app_desc and runs the daemon. */
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "app/app.h"
#include "app/app_budget.h"
#include "bus/bus.h"
#include "core/cli.h"
#include "codec/codec.h"
#include "groom/groom.h"
#include "net/net.h"
#include "proto/proto.h"

#define PROG "strandcastd"

static void usage(FILE *f)
{
    fprintf(f,
            "usage: strandcastd [options]\n"
            "Simulates strand hair in real time and streams it to WebSocket clients; serves the viewer page.\n\n"
            "Scene\n"
            "  --groom STYLE|FILE     straight | wavy | curly (procedural), hairmesh:STYLE (the strands traced\n"
            "                         through the procedural hair mesh of that style), or a .tfx / .hair file\n"
            "                         (default straight)\n"
            "  --collider FILE        character collision mesh, .obj or .tfxmesh, in the groom's frame (default none);\n"
            "                         the hair collides with it as well as with the head ellipsoid and capsules\n"
            "  --strands N            procedural strand count, 1..%d (default %u)\n"
            "  --verts N              vertices per strand, 2..%d (default %u; a file keeps its own unless given)\n"
            "  --seed N               procedural groom seed (default: the groom module's fixed seed)\n"
            "Solver\n"
            "  --solver S             dftl | hairmesh | pbd (default dftl; the solver parameter, changeable at run\n"
            "                         time; hairmesh needs a hair-mesh groom)\n"
            "  --backend B            auto | cpu | vulkan (default auto: a hardware Vulkan device, else cpu)\n"
            "  --device N             Vulkan device: 0 = automatic (default), N = vulkaninfo's GPU<N-1>\n"
            "  --threads N            CPU solver threads (default 0 = every online core)\n"
            "Network\n"
            "  --room NAME            the room this daemon serves: 1..64 letters, digits, '-', '_' (default\n"
            "                         \"default\", the room of the path /; any other at /rooms/NAME); clients asking\n"
            "                         for another room get error unknown_room and close 4404\n"
            "Scaling out (proto/PROTOCOL.md \"Scaling out\")\n"
            "  --nats URL             NATS server, nats://[user:password@|token@]HOST:PORT: with --room, a\n"
            "                         simulation node (edge relays' clients of that room are served too)\n"
            "  --relay                an edge relay (needs --nats): no simulation; the page, /metrics and\n"
            "                         WebSockets of any room (/rooms/NAME), relayed to the room's node\n"
            "  --nats-creds FILE      NATS credentials file (user JWT + NKey seed) for nodes and edges, for a\n"
            "                         nats-server in operator mode; make one with nsc (the NATS project's tool, not\n"
            "                         in Debian): nsc generate creds --account A --name U -o FILE. A server that\n"
            "                         refuses it (or refuses the URL's token) stops start-up with its reason\n"
            "  --listen ADDR          IP address to bind (default 127.0.0.1; localhost; ::1; 0.0.0.0 = every interface)\n"
            "  --port N               TCP port (default 7681; 0 = a free port, printed at start-up)\n"
            "  --web DIR              folder served at / (default %s/web)\n"
            "  --assets DIR           folder whose .tfx/.hair grooms and .obj/.tfxmesh colliders clients may pick\n"
            "                         with set_groom\n"
            "                         (default %s/../shared/assets when present)\n"
            "  --rate HZ              frames per second streamed, 1..1000 (default %.0f; at most one per step)\n"
            "  --max-error M          default stream position error bound in metres, %g..%g (default %g)\n"
            "  --keyframe-interval N  frames between keyframes, 1..10000 (default %u)\n"
            "  --client-buffer BYTES  kernel send buffer per client, 4096..67108864 (default 262144); a client\n"
            "                         that reads slower than the stream skips frames once it is full\n"
            "  --ping-interval S      seconds without a pong from a client before the server pings it,\n"
            "                         1..%d (default %d)\n"
            "  --ping-timeout S       seconds without a pong after which a client is dropped, more than the\n"
            "                         interval, 2..%d (default %d: the interval + %d, at most %d)\n"
            "  --max-clients N        WebSocket clients at once, 1..%d; more are refused with HTTP 503\n"
            "                         (default %d per online core: %d here)\n"
            "Access\n"
            "  --token-file FILE      clients must send {\"type\":\"auth\",\"token\":...} with the token in FILE (its\n"
            "                         first line, 16..256 printable bytes) before changing anything; without it a\n"
            "                         client is read-only (hello, frames, subscribe). The viewer takes it from\n"
            "                         the page URL: http://HOST:PORT/#token=TOKEN\n"
            "  --insecure-open        allow --listen beyond loopback without --token-file (anyone may change it)\n"
            "  --allow-origin ORIGIN  browsers from this origin only, e.g. https://example.org (repeatable, up to\n"
            "                         16; requests without an Origin header, from non-browser clients, pass)\n"
            "  --tls-cert PEM --tls-key PEM   serve https:// and wss:// only, with this certificate and key\n"
            "  --no-net               simulate and log only (no sockets)\n"
            "Limits\n"
            "  --min-step-rate HZ     refuse grooms (--groom, set_groom) and solver switches this machine would step\n"
            "                         slower than this, measured at start-up per solver (dftl, pbd) on a 2048 x 32\n"
            "                         groom; 0 = no limit (default %.0f)\n"
            "Run\n"
            "  --steps N              exit after N simulation steps (default 0 = until SIGINT/SIGTERM)\n"
            "  --record FILE          write the initial state and every input that changes the simulation, with\n"
            "                         its step, to FILE (format: proto/RECORD.md); a write error is logged and\n"
            "                         counted (strandcast_record_errors_total), the simulation goes on\n"
            "  --record-digests       with --record: also a digest of the positions after every step, which\n"
            "                         --replay checks bit for bit (CPU backend)\n"
            "  --replay FILE          run a recording again from its initial state (groom, collider, counts, seed,\n"
            "                         backend, threads and parameters come from FILE), streamed like a live\n"
            "                         session; clients' changes are refused (bad_state) until its last step, then\n"
            "                         the daemon pauses and is live (with --no-net it exits)\n"
            "  --help                 this text;  --version  the version\n\n"
            "The simulation runs in real time (one step of dt per dt of wall time) and logs steps/s every %.0f s.\n"
            "Protocol: WebSocket subprotocol %s, spec in proto/PROTOCOL.md. Metrics: GET /metrics.\n"
            "Exit status: 0 after SIGINT/SIGTERM or --steps, 1 on a run-time error, 2 on bad flags.\n",
            PROTO_MAX_STRANDS, GROOM_DEFAULT_STRANDS, PROTO_MAX_VERTS, GROOM_DEFAULT_VERTS, STRANDCAST_SOURCE_DIR,
            STRANDCAST_SOURCE_DIR, APP_DEFAULT_RATE, PROTO_MIN_ERROR, PROTO_MAX_ERROR, (double)CODEC_DEFAULT_MAX_ERROR,
            CODEC_DEFAULT_KEY_INTERVAL, NET_MAX_HANGUP_S - 1, NET_DEFAULT_PING_S, NET_MAX_HANGUP_S,
            NET_DEFAULT_PING_S + NET_DEFAULT_HANGUP_EXTRA_S, NET_DEFAULT_HANGUP_EXTRA_S, NET_MAX_HANGUP_S, APP_MAX_CLIENTS,
            APP_CLIENTS_PER_CORE, app_default_max_clients(), APP_MIN_STEP_RATE, APP_LOG_INTERVAL_S, PROTO_SUBPROTOCOL);
}

static int bad(const char *flag, const char *value, const char *why) { return core_cli_bad(PROG, flag, value, why); }

static bool is_dir(const char *p)
{
    struct stat sb;
    return stat(p, &sb) == 0 && S_ISDIR(sb.st_mode);
}

enum {
    OPT_GROOM = 256, OPT_COLLIDER, OPT_STRANDS, OPT_VERTS, OPT_SEED, OPT_SOLVER, OPT_BACKEND, OPT_DEVICE, OPT_THREADS, OPT_LISTEN,
    OPT_PORT, OPT_WEB, OPT_ASSETS, OPT_RATE, OPT_MAX_ERROR, OPT_KEY_INTERVAL, OPT_CLIENT_BUFFER, OPT_PING_INTERVAL,
    OPT_PING_TIMEOUT, OPT_MAX_CLIENTS, OPT_MIN_STEP_RATE, OPT_TOKEN_FILE, OPT_INSECURE_OPEN, OPT_ALLOW_ORIGIN, OPT_TLS_CERT, OPT_TLS_KEY,
    OPT_NO_NET, OPT_STEPS, OPT_RECORD, OPT_RECORD_DIGESTS, OPT_REPLAY, OPT_VERSION, OPT_ROOM, OPT_NATS, OPT_NATS_CREDS, OPT_RELAY
};

static const struct option options[] = {
    { "groom", required_argument, NULL, OPT_GROOM },
    { "collider", required_argument, NULL, OPT_COLLIDER },
    { "strands", required_argument, NULL, OPT_STRANDS },
    { "verts", required_argument, NULL, OPT_VERTS },
    { "seed", required_argument, NULL, OPT_SEED },
    { "solver", required_argument, NULL, OPT_SOLVER },
    { "backend", required_argument, NULL, OPT_BACKEND },
    { "device", required_argument, NULL, OPT_DEVICE },
    { "threads", required_argument, NULL, OPT_THREADS },
    { "listen", required_argument, NULL, OPT_LISTEN },
    { "port", required_argument, NULL, OPT_PORT },
    { "web", required_argument, NULL, OPT_WEB },
    { "assets", required_argument, NULL, OPT_ASSETS },
    { "rate", required_argument, NULL, OPT_RATE },
    { "max-error", required_argument, NULL, OPT_MAX_ERROR },
    { "keyframe-interval", required_argument, NULL, OPT_KEY_INTERVAL },
    { "client-buffer", required_argument, NULL, OPT_CLIENT_BUFFER },
    { "ping-interval", required_argument, NULL, OPT_PING_INTERVAL },
    { "ping-timeout", required_argument, NULL, OPT_PING_TIMEOUT },
    { "max-clients", required_argument, NULL, OPT_MAX_CLIENTS },
    { "min-step-rate", required_argument, NULL, OPT_MIN_STEP_RATE },
    { "token-file", required_argument, NULL, OPT_TOKEN_FILE },
    { "insecure-open", no_argument, NULL, OPT_INSECURE_OPEN },
    { "allow-origin", required_argument, NULL, OPT_ALLOW_ORIGIN },
    { "tls-cert", required_argument, NULL, OPT_TLS_CERT },
    { "tls-key", required_argument, NULL, OPT_TLS_KEY },
    { "no-net", no_argument, NULL, OPT_NO_NET },
    { "steps", required_argument, NULL, OPT_STEPS },
    { "record", required_argument, NULL, OPT_RECORD },
    { "record-digests", no_argument, NULL, OPT_RECORD_DIGESTS },
    { "replay", required_argument, NULL, OPT_REPLAY },
    { "help", no_argument, NULL, 'h' },
    { "version", no_argument, NULL, OPT_VERSION },
    { "room", required_argument, NULL, OPT_ROOM },
    { "nats", required_argument, NULL, OPT_NATS },
    { "nats-creds", required_argument, NULL, OPT_NATS_CREDS },
    { "relay", no_argument, NULL, OPT_RELAY },
    { NULL, 0, NULL, 0 },
};

#define MAX_ORIGINS 16
#define MIN_TOKEN 16 /* bytes: a token shorter than this could be guessed */

/* What the flags gather besides the desc: the token read from its file and the origins. */
typedef struct extra_args {
    bool verts_given;
    char token[PROTO_MAX_TOKEN + 1];
    const char *origins[MAX_ORIGINS + 1];
    int norigins;
} extra_args;

/* The token: the file's first line without its line end; printable ASCII, MIN_TOKEN..PROTO_MAX_TOKEN bytes. */
static int read_token(const char *flag, const char *path, char *out)
{
    FILE *f = fopen(path, "rb");
    if (!f) return bad(flag, path, strerror(errno));
    char buf[PROTO_MAX_TOKEN + 3];
    size_t n = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[n] = '\0';
    n = strcspn(buf, "\r\n");
    buf[n] = '\0';
    if (n < MIN_TOKEN || n > PROTO_MAX_TOKEN) return bad(flag, path, "the token (its first line) must be 16..256 bytes");
    for (size_t i = 0; i < n; i++)
        if (buf[i] <= ' ' || buf[i] > '~') return bad(flag, path, "the token may hold printable ASCII only, no spaces");
    struct stat sb;
    if (stat(path, &sb) == 0 && (sb.st_mode & 077))
        fprintf(stderr, "strandcastd: warning: %s is readable by other users (chmod 600 it)\n", path);
    memcpy(out, buf, n + 1);
    return 0;
}

/* True for the loopback addresses --listen may name (127.0.0.0/8, ::1, localhost). */
static bool loopback(const char *listen)
{
    return !listen || strncmp(listen, "127.", 4) == 0 || strcmp(listen, "::1") == 0 || strcmp(listen, "localhost") == 0;
}

/* One flag's value into d; 0 or an exit status. */
static int apply(int opt, const char *flag, const char *v, app_desc *d, extra_args *x)
{
    unsigned long long u = 0;
    double f = 0;
    int rc = 0;
    switch (opt) {
    case OPT_GROOM:
        if (!*v) return bad(flag, v, "expected a style or a file");
        d->groom = v;
        break;
    case OPT_COLLIDER:
        if (!*v) return bad(flag, v, "expected an .obj or .tfxmesh file");
        d->collider = v;
        break;
    case OPT_STRANDS:
        if (!(rc = core_cli_u64(PROG, flag, v, 1, PROTO_MAX_STRANDS, &u))) d->strands = (uint32_t)u;
        break;
    case OPT_VERTS:
        if (!(rc = core_cli_u64(PROG, flag, v, 2, PROTO_MAX_VERTS, &u))) d->verts = (uint32_t)u;
        x->verts_given = true;
        break;
    case OPT_SEED: /* at most 2^53 - 1: exact in JSON */
        if (!(rc = core_cli_u64(PROG, flag, v, 0, 9007199254740991ull, &u))) d->seed = u;
        break;
    case OPT_SOLVER: {
        int32_t k = 0;
        while (k <= SIM_SOLVER_PBD && strcmp(v, sim_solver_name(k)) != 0) k++;
        if (k > SIM_SOLVER_PBD) return bad(flag, v, "expected dftl, hairmesh or pbd");
        d->solver = k;
        break;
    }
    case OPT_BACKEND:
        if (strcmp(v, "auto") == 0) d->backend = SIM_BACKEND_AUTO;
        else if (strcmp(v, "cpu") == 0) d->backend = SIM_BACKEND_CPU;
        else if (strcmp(v, "vulkan") == 0) d->backend = SIM_BACKEND_VULKAN;
        else return bad(flag, v, "expected auto, cpu or vulkan");
        break;
    case OPT_DEVICE:
        if (!(rc = core_cli_u64(PROG, flag, v, 0, 64, &u))) d->device = (int)u;
        break;
    case OPT_THREADS:
        if (!(rc = core_cli_u64(PROG, flag, v, 0, 256, &u))) d->threads = (int)u;
        break;
    case OPT_ROOM:
        if (!proto_room_valid(v)) return bad(flag, v, "expected 1..64 letters, digits, '-' or '_'");
        d->room = v;
        break;
    case OPT_NATS:
        if (strncmp(v, "nats://", 7) != 0 && strncmp(v, "tls://", 6) != 0)
            return bad(flag, v, "expected nats://[user:password@|token@]HOST:PORT");
        d->nats = v;
        break;
    case OPT_NATS_CREDS: {
        core_err err;
        if (bus_creds_check(v, &err) != CORE_OK) return bad(flag, v, err.msg);
        d->nats_creds = v;
        break;
    }
    case OPT_RELAY: d->relay = true; break;
    case OPT_LISTEN:
        if (!*v) return bad(flag, v, "expected an address");
        d->listen = v;
        break;
    case OPT_PORT:
        if (!(rc = core_cli_u64(PROG, flag, v, 0, 65535, &u))) d->port = u == 0 ? NET_PORT_ANY : (int)u;
        break;
    case OPT_WEB:
        if (!is_dir(v)) return bad(flag, v, "not a folder");
        d->web_dir = v;
        break;
    case OPT_ASSETS:
        if (!is_dir(v)) return bad(flag, v, "not a folder");
        d->assets_dir = v;
        break;
    case OPT_RATE:
        if (!(rc = core_cli_f64(PROG, flag, v, 1, 1000, &f))) d->rate = f;
        break;
    case OPT_MAX_ERROR:
        if (!(rc = core_cli_f64(PROG, flag, v, PROTO_MIN_ERROR, PROTO_MAX_ERROR, &f))) d->max_error = f;
        break;
    case OPT_KEY_INTERVAL:
        if (!(rc = core_cli_u64(PROG, flag, v, 1, 10000, &u))) d->keyframe_interval = (int)u;
        break;
    case OPT_CLIENT_BUFFER:
        if (!(rc = core_cli_u64(PROG, flag, v, 4096, 64u << 20, &u))) d->client_buffer = (int)u;
        break;
    case OPT_PING_INTERVAL:
        if (!(rc = core_cli_u64(PROG, flag, v, 1, NET_MAX_HANGUP_S - 1, &u))) d->ping_interval = (int)u;
        break;
    case OPT_PING_TIMEOUT:
        if (!(rc = core_cli_u64(PROG, flag, v, 2, NET_MAX_HANGUP_S, &u))) d->ping_timeout = (int)u;
        break;
    case OPT_MAX_CLIENTS:
        if (!(rc = core_cli_u64(PROG, flag, v, 1, APP_MAX_CLIENTS, &u))) d->max_clients = (int)u;
        break;
    case OPT_MIN_STEP_RATE: /* 0 turns the budget off (the desc's 0 is the default) */
        if (!(rc = core_cli_f64(PROG, flag, v, 0, 1000, &f))) d->min_step_rate = f > 0.0 ? f : -1.0;
        break;
    case OPT_STEPS:
        if (!(rc = core_cli_u64(PROG, flag, v, 0, (unsigned long long)LLONG_MAX, &u))) d->steps = u;
        break;
    case OPT_TOKEN_FILE:
        if ((rc = read_token(flag, v, x->token)) == 0) d->token = x->token;
        break;
    case OPT_INSECURE_OPEN: d->insecure_open = true; break;
    case OPT_ALLOW_ORIGIN:
        if (strncmp(v, "http://", 7) != 0 && strncmp(v, "https://", 8) != 0)
            return bad(flag, v, "expected an origin: http(s)://host[:port]");
        if (x->norigins == MAX_ORIGINS) return bad(flag, v, "at most 16 origins");
        x->origins[x->norigins++] = v;
        d->allow_origins = x->origins;
        break;
    case OPT_TLS_CERT: d->tls_cert = v; break;
    case OPT_TLS_KEY: d->tls_key = v; break;
    case OPT_NO_NET: d->no_net = true; break;
    case OPT_RECORD: d->record = v; break;
    case OPT_RECORD_DIGESTS: d->record_digests = true; break;
    case OPT_REPLAY: d->replay = v; break;
    }
    return rc;
}

/* Returns 0 and fills d, or an exit status (help/version print and return -1). */
static int parse_args(int argc, char **argv, app_desc *d, extra_args *x)
{
    core_cli_begin();
    char flag[64];
    int opt, status;
    while ((opt = core_cli_next(PROG, argc, argv, options, flag, sizeof flag, &status)) > 0) {
        if (opt == 'h') {
            usage(stdout);
            return -1;
        }
        if (opt == OPT_VERSION) {
            printf("strandcastd %s (protocol %s)\n", STRANDCAST_VERSION, PROTO_SUBPROTOCOL);
            return -1;
        }
        int rc = apply(opt, flag, optarg, d, x);
        if (rc) return rc;
    }
    return status;
}

int main(int argc, char **argv)
{
    app_desc d = { 0 };
    static extra_args x;
    int rc = parse_args(argc, argv, &d, &x);
    if (rc) return rc < 0 ? 0 : rc;
    if (d.relay && d.token)
        return bad("--token-file", NULL,
                   "an edge relay hands auth to the room's simulation node: give --token-file to the nodes");
    if (d.relay && !loopback(d.listen) && !d.insecure_open)
        return bad("--listen", d.listen,
                   "an edge relay beyond loopback lets anyone reach the rooms' nodes: give the nodes --token-file FILE "
                   "(clients then need its token to make changes) and this relay --insecure-open");
    if (!d.no_net && !loopback(d.listen) && !d.token && !d.insecure_open)
        return bad("--listen", d.listen,
                   "beyond loopback anyone could change the simulation: give --token-file FILE (clients then need "
                   "its token to make changes), or --insecure-open");
    if (d.record && d.replay) return bad("--record", d.record, "not with --replay");
    if (d.relay && !d.nats) return bad("--relay", NULL, "needs --nats URL");
    if (d.nats_creds && !d.nats) return bad("--nats-creds", d.nats_creds, "needs --nats URL");
    if (d.nats && d.no_net) return bad("--nats", d.nats, "not with --no-net");
    if (d.record_digests && !d.record) return bad("--record-digests", NULL, "needs --record FILE");
    if (!d.tls_cert != !d.tls_key) return bad(d.tls_cert ? "--tls-cert" : "--tls-key", NULL, "needs both --tls-cert and --tls-key");
    int interval = d.ping_interval ? d.ping_interval : NET_DEFAULT_PING_S;
    if (d.ping_timeout && d.ping_timeout <= interval) {
        char why[96];
        snprintf(why, sizeof why, "must be more than the ping interval (%d s)", interval);
        char value[24];
        snprintf(value, sizeof value, "%d", d.ping_timeout);
        return bad("--ping-timeout", value, why);
    }
    bool procedural = !d.groom || strcmp(d.groom, "straight") == 0 || strcmp(d.groom, "wavy") == 0 ||
                      strcmp(d.groom, "curly") == 0 || strncmp(d.groom, "hairmesh:", 9) == 0;
    if (!procedural && d.strands) return bad("--strands", NULL, "a groom file sets its own strand count");
    uint64_t strands = d.strands ? d.strands : GROOM_DEFAULT_STRANDS, verts = d.verts ? d.verts : GROOM_DEFAULT_VERTS;
    if (procedural && strands * verts > PROTO_MAX_VERTICES) return bad("--strands", NULL, "strands x verts is over 2097152");
    if (!procedural && !x.verts_given) d.verts = 0;
    if (!d.web_dir && is_dir(STRANDCAST_SOURCE_DIR "/web")) d.web_dir = STRANDCAST_SOURCE_DIR "/web";
    if (!d.assets_dir && is_dir(STRANDCAST_SOURCE_DIR "/../shared/assets")) d.assets_dir = STRANDCAST_SOURCE_DIR "/../shared/assets";
    core_err err = { "" };
    if (app_run(&d, &err) != CORE_OK) {
        fprintf(stderr, "strandcastd: %s\n", err.msg);
        return 1;
    }
    return 0;
}
