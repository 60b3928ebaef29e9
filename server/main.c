/* strandcastd: entry point: parses the flags into an app_desc and runs the daemon. */
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "app/app.h"
#include "codec/codec.h"
#include "groom/groom.h"
#include "net/net.h"
#include "proto/proto.h"

#define EXIT_USAGE 2

static void usage(FILE *f)
{
    fprintf(f,
            "usage: strandcastd [options]\n"
            "Simulates strand hair in real time and streams it to WebSocket clients; serves the viewer page.\n\n"
            "Scene\n"
            "  --groom STYLE|FILE     straight | wavy | curly (procedural), or a .tfx / .hair file (default straight)\n"
            "  --collider FILE        character collision mesh, .obj or .tfxmesh, in the groom's frame (default none);\n"
            "                         the hair collides with it as well as with the head ellipsoid and capsules\n"
            "  --strands N            procedural strand count, 1..%d (default %u)\n"
            "  --verts N              vertices per strand, 2..%d (default %u; a file keeps its own unless given)\n"
            "  --seed N               procedural groom seed (default: the groom module's fixed seed)\n"
            "Solver\n"
            "  --backend B            auto | cpu | vulkan (default auto: a hardware Vulkan device, else cpu)\n"
            "  --device N             Vulkan device: 0 = automatic (default), N = vulkaninfo's GPU<N-1>\n"
            "  --threads N            CPU solver threads (default 0 = every online core)\n"
            "Network\n"
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
            "  --no-net               simulate and log only (no sockets)\n"
            "Run\n"
            "  --steps N              exit after N simulation steps (default 0 = until SIGINT/SIGTERM)\n"
            "  --help                 this text;  --version  the version\n\n"
            "The simulation runs in real time (one step of dt per dt of wall time) and logs steps/s every %.0f s.\n"
            "Protocol: WebSocket subprotocol %s, spec in proto/PROTOCOL.md. Metrics: GET /metrics.\n"
            "Exit status: 0 after SIGINT/SIGTERM or --steps, 1 on a run-time error, 2 on bad flags.\n",
            PROTO_MAX_STRANDS, GROOM_DEFAULT_STRANDS, PROTO_MAX_VERTS, GROOM_DEFAULT_VERTS, STRANDCAST_SOURCE_DIR,
            STRANDCAST_SOURCE_DIR, APP_DEFAULT_RATE, PROTO_MIN_ERROR, PROTO_MAX_ERROR, (double)CODEC_DEFAULT_MAX_ERROR,
            CODEC_DEFAULT_KEY_INTERVAL, NET_MAX_HANGUP_S - 1, NET_DEFAULT_PING_S, NET_MAX_HANGUP_S,
            NET_DEFAULT_PING_S + NET_DEFAULT_HANGUP_EXTRA_S, NET_DEFAULT_HANGUP_EXTRA_S, NET_MAX_HANGUP_S,
            APP_LOG_INTERVAL_S, PROTO_SUBPROTOCOL);
}

static int bad(const char *flag, const char *value, const char *why)
{
    fprintf(stderr, "strandcastd: %s %s: %s\nTry 'strandcastd --help'.\n", flag, value ? value : "", why);
    return EXIT_USAGE;
}

static int parse_u64(const char *flag, const char *v, unsigned long long lo, unsigned long long hi, unsigned long long *out)
{
    char why[96];
    snprintf(why, sizeof why, "expected an integer in [%llu, %llu]", lo, hi);
    if (!v || !*v || *v == '-' || *v == '+') return bad(flag, v, why);
    errno = 0;
    char *end;
    unsigned long long x = strtoull(v, &end, 10);
    if (errno || *end || x < lo || x > hi) return bad(flag, v, why);
    *out = x;
    return 0;
}

static int parse_f64(const char *flag, const char *v, double lo, double hi, double *out)
{
    char why[96];
    snprintf(why, sizeof why, "expected a number in [%g, %g]", lo, hi);
    if (!v || !*v) return bad(flag, v, why);
    errno = 0;
    char *end;
    double x = strtod(v, &end);
    if (errno || *end || !(x >= lo && x <= hi)) return bad(flag, v, why);
    *out = x;
    return 0;
}

static bool is_dir(const char *p)
{
    struct stat sb;
    return stat(p, &sb) == 0 && S_ISDIR(sb.st_mode);
}

/* Returns 0 and fills d, or an exit status (help/version print and return -1). */
static int parse_args(int argc, char **argv, app_desc *d, bool *verts_given)
{
    for (int i = 1; i < argc; i++) {
        char flag[64];
        const char *arg = argv[i], *value = NULL;
        const char *eq = strchr(arg, '=');
        if (strncmp(arg, "--", 2) == 0 && eq && (size_t)(eq - arg) < sizeof flag) {
            memcpy(flag, arg, (size_t)(eq - arg));
            flag[eq - arg] = '\0';
            value = eq + 1;
        } else {
            snprintf(flag, sizeof flag, "%s", arg);
        }
        if (strcmp(flag, "--help") == 0 || strcmp(flag, "-h") == 0) {
            usage(stdout);
            return -1;
        }
        if (strcmp(flag, "--version") == 0) {
            printf("strandcastd %s (protocol %s)\n", STRANDCAST_VERSION, PROTO_SUBPROTOCOL);
            return -1;
        }
        if (strcmp(flag, "--no-net") == 0) {
            if (value) return bad(flag, value, "takes no value");
            d->no_net = true;
            continue;
        }
        static const char *const with_value[] = { "--groom", "--collider", "--strands", "--verts", "--seed", "--backend", "--device",
                                                  "--threads", "--listen", "--port", "--web", "--assets", "--rate",
                                                  "--max-error", "--keyframe-interval", "--client-buffer", "--ping-interval",
                                                  "--ping-timeout", "--steps" };
        bool known = false;
        for (size_t k = 0; k < sizeof with_value / sizeof with_value[0]; k++) known = known || strcmp(flag, with_value[k]) == 0;
        if (!known) return bad(arg, NULL, "unknown option");
        if (!value) {
            if (i + 1 >= argc) return bad(flag, NULL, "needs a value");
            value = argv[++i];
        }
        unsigned long long u = 0;
        double f = 0;
        int rc = 0;
        if (strcmp(flag, "--groom") == 0) {
            if (!*value) return bad(flag, value, "expected a style or a file");
            d->groom = value;
        } else if (strcmp(flag, "--collider") == 0) {
            if (!*value) return bad(flag, value, "expected an .obj or .tfxmesh file");
            d->collider = value;
        } else if (strcmp(flag, "--strands") == 0) {
            if (!(rc = parse_u64(flag, value, 1, PROTO_MAX_STRANDS, &u))) d->strands = (uint32_t)u;
        } else if (strcmp(flag, "--verts") == 0) {
            if (!(rc = parse_u64(flag, value, 2, PROTO_MAX_VERTS, &u))) d->verts = (uint32_t)u;
            *verts_given = true;
        } else if (strcmp(flag, "--seed") == 0) {
            if (!(rc = parse_u64(flag, value, 0, 9007199254740991ull, &u))) d->seed = u; /* exact in JSON */
        } else if (strcmp(flag, "--backend") == 0) {
            if (strcmp(value, "auto") == 0) d->backend = SIM_BACKEND_AUTO;
            else if (strcmp(value, "cpu") == 0) d->backend = SIM_BACKEND_CPU;
            else if (strcmp(value, "vulkan") == 0) d->backend = SIM_BACKEND_VULKAN;
            else return bad(flag, value, "expected auto, cpu or vulkan");
        } else if (strcmp(flag, "--device") == 0) {
            if (!(rc = parse_u64(flag, value, 0, 64, &u))) d->device = (int)u;
        } else if (strcmp(flag, "--threads") == 0) {
            if (!(rc = parse_u64(flag, value, 0, 256, &u))) d->threads = (int)u;
        } else if (strcmp(flag, "--listen") == 0) {
            if (!*value) return bad(flag, value, "expected an address");
            d->listen = value;
        } else if (strcmp(flag, "--port") == 0) {
            if (!(rc = parse_u64(flag, value, 0, 65535, &u))) d->port = u == 0 ? NET_PORT_ANY : (int)u;
        } else if (strcmp(flag, "--web") == 0) {
            if (!is_dir(value)) return bad(flag, value, "not a folder");
            d->web_dir = value;
        } else if (strcmp(flag, "--assets") == 0) {
            if (!is_dir(value)) return bad(flag, value, "not a folder");
            d->assets_dir = value;
        } else if (strcmp(flag, "--rate") == 0) {
            if (!(rc = parse_f64(flag, value, 1, 1000, &f))) d->rate = f;
        } else if (strcmp(flag, "--max-error") == 0) {
            if (!(rc = parse_f64(flag, value, PROTO_MIN_ERROR, PROTO_MAX_ERROR, &f))) d->max_error = f;
        } else if (strcmp(flag, "--keyframe-interval") == 0) {
            if (!(rc = parse_u64(flag, value, 1, 10000, &u))) d->keyframe_interval = (int)u;
        } else if (strcmp(flag, "--client-buffer") == 0) {
            if (!(rc = parse_u64(flag, value, 4096, 64u << 20, &u))) d->client_buffer = (int)u;
        } else if (strcmp(flag, "--ping-interval") == 0) {
            if (!(rc = parse_u64(flag, value, 1, NET_MAX_HANGUP_S - 1, &u))) d->ping_interval = (int)u;
        } else if (strcmp(flag, "--ping-timeout") == 0) {
            if (!(rc = parse_u64(flag, value, 2, NET_MAX_HANGUP_S, &u))) d->ping_timeout = (int)u;
        } else if (strcmp(flag, "--steps") == 0) {
            if (!(rc = parse_u64(flag, value, 0, (unsigned long long)LLONG_MAX, &u))) d->steps = u;
        }
        if (rc) return rc;
    }
    return 0;
}

int main(int argc, char **argv)
{
    app_desc d = { 0 };
    bool verts_given = false;
    int rc = parse_args(argc, argv, &d, &verts_given);
    if (rc) return rc < 0 ? 0 : rc;
    int interval = d.ping_interval ? d.ping_interval : NET_DEFAULT_PING_S;
    if (d.ping_timeout && d.ping_timeout <= interval) {
        char why[96];
        snprintf(why, sizeof why, "must be more than the ping interval (%d s)", interval);
        char value[24];
        snprintf(value, sizeof value, "%d", d.ping_timeout);
        return bad("--ping-timeout", value, why);
    }
    bool procedural = !d.groom || strcmp(d.groom, "straight") == 0 || strcmp(d.groom, "wavy") == 0 ||
                      strcmp(d.groom, "curly") == 0;
    if (!procedural && d.strands) return bad("--strands", NULL, "a groom file sets its own strand count");
    uint64_t strands = d.strands ? d.strands : GROOM_DEFAULT_STRANDS, verts = d.verts ? d.verts : GROOM_DEFAULT_VERTS;
    if (procedural && strands * verts > PROTO_MAX_VERTICES) return bad("--strands", NULL, "strands x verts is over 2097152");
    if (!procedural && !verts_given) d.verts = 0;
    if (!d.web_dir && is_dir(STRANDCAST_SOURCE_DIR "/web")) d.web_dir = STRANDCAST_SOURCE_DIR "/web";
    if (!d.assets_dir && is_dir(STRANDCAST_SOURCE_DIR "/../shared/assets")) d.assets_dir = STRANDCAST_SOURCE_DIR "/../shared/assets";
    core_err err = { "" };
    if (app_run(&d, &err) != CORE_OK) {
        fprintf(stderr, "strandcastd: %s\n", err.msg);
        return 1;
    }
    return 0;
}
