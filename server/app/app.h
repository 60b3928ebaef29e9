/* app: the strandcastd pipeline (groom -> sim -> codec -> net, commands back); main.c fills the
 * desc. The only header of the app folder that code outside it includes. */
#ifndef APP_H
#define APP_H

#include <stdbool.h>
#include <stdint.h>

#include "core/core.h"
#include "sim/sim.h"

#define APP_DEFAULT_RATE 60.0         /* stream Hz */
#define APP_LOG_INTERVAL_S 5.0
#define APP_CLIENTS_PER_CORE 64  /* default client limit per core: 100 clients stream in real time on 2 */
#define APP_MAX_CLIENTS 4096

/* Everything strandcastd's flags set; zero means default for every field. */
typedef struct app_desc {
    const char *groom;         /* "straight" | "wavy" | "curly" or a .tfx/.hair path; NULL = straight */
    const char *collider;      /* .obj/.tfxmesh collision mesh path; NULL = none */
    uint32_t strands;          /* procedural strand count; 0 = GROOM_DEFAULT_STRANDS */
    uint32_t verts;            /* vertices per strand; 0 = GROOM_DEFAULT_VERTS (procedural) or the file's own */
    uint64_t seed;             /* procedural seed; 0 = the groom module's default */
    int32_t solver;            /* sim_solver to start with (the solver parameter); 0 = dftl */
    sim_backend_kind backend;
    int device, threads;
    const char *room;          /* the room this daemon serves (proto_room_valid); NULL = PROTO_DEFAULT_ROOM */
    const char *nats;          /* NATS URL: a simulation node (publishes the room's frames, serves edges'
                                * clients); with relay an edge; NULL = neither */
    const char *nats_creds;    /* NATS .creds file; NULL = none (user:password@ or token@ may be in the URL) */
    bool relay;                /* an edge relay (needs nats): no simulation, serves any room's clients */
    const char *listen;        /* NULL = 127.0.0.1 */
    int port;                  /* 0 = NET_DEFAULT_PORT; NET_PORT_ANY = a free port */
    const char *web_dir;       /* NULL = no static files */
    const char *assets_dir;    /* folder set_groom files come from; NULL = none */
    double rate;               /* stream frames per second; 0 = 60 */
    double max_error;          /* default stream max position error, m; 0 = CODEC_DEFAULT_MAX_ERROR */
    int keyframe_interval;     /* frames between keyframes; 0 = CODEC_DEFAULT_KEY_INTERVAL */
    int client_buffer;         /* kernel send buffer per client, bytes; 0 = 256 KiB */
    int max_clients;           /* WebSocket clients at once (more get HTTP 503); 0 = APP_CLIENTS_PER_CORE
                                * per online core, at least that and at most APP_MAX_CLIENTS */
    int ping_interval;         /* seconds without a pong before a client is pinged; 0 = 20 */
    int ping_timeout;          /* seconds without a pong before a client is dropped (> ping_interval);
                                * 0 = ping_interval + 10 */
    const char *token;         /* clients must send auth with this before changing shared state;
                                * NULL = every client may (only on loopback, or insecure_open) */
    bool insecure_open;        /* allow listening beyond loopback without a token */
    double min_step_rate;      /* grooms that would step slower (steps/s) are refused; 0 =
                                * APP_MIN_STEP_RATE (app_budget.h), negative = no budget */
    const char *const *allow_origins; /* NULL-terminated browser Origins allowed to connect; NULL = any */
    const char *tls_cert, *tls_key;   /* PEM files: serve https/wss only; NULL = plain */
    bool no_net;               /* simulate and log only */
    uint64_t steps;            /* stop after this many steps; 0 = run until SIGINT/SIGTERM */
    const char *record;        /* write the initial state and every input to this file (proto/RECORD.md) */
    bool record_digests;       /* with record: a digest of the positions after every step */
    const char *replay;        /* run this recording (its initial state replaces groom, collider, strands,
                                * verts, seed, backend, threads and every parameter, solver included);
                                * not with record */
} app_desc;

/* The client limit when app_desc.max_clients is 0: APP_CLIENTS_PER_CORE per online core, at
 * most APP_MAX_CLIENTS. Any thread. */
int app_default_max_clients(void);

/* Runs the daemon on the calling thread (which becomes the signal-waiting controller; SIGINT
 * and SIGTERM are blocked in it and in every thread it starts) until SIGINT/SIGTERM or
 * desc->steps steps. Prints "strandcastd: open http://ADDR:PORT/" (https with TLS) on stdout
 * once listening.
 * Returns CORE_OK after a clean shutdown, or the error that stopped start-up or the simulation
 * (err says why). */
core_status app_run(const app_desc *desc, core_err *err);

#endif
