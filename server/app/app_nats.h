/* app: the simulation node's side of NATS (strandcastd --nats URL --room NAME): the clients of edge
 * relays become remote clients of this daemon (ids with APP_REMOTE_CLIENT set) that go through
 * the same gate and commands as WebSocket clients; their edge's control messages are NATS
 * requests, and what is sent to them goes to the requests' reply subject, broadcasts once to
 * the room's, each stream's frames once to the stream's subject, and a heartbeat every
 * BUS_BEAT_MS. Subjects: proto/PROTOCOL.md "Scaling out". */
#ifndef APP_NATS_H
#define APP_NATS_H

#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

#include "app.h"
#include "app_net.h"
#include "bus/bus.h"

#define APP_REMOTE_CLIENT 0x80000000u /* client ids of edge relays' clients have this bit */
#define APP_MAX_EDGES 64              /* edge relays with clients in this room at once */
#define APP_EDGE_ID 24                /* bytes of an edge's id (letters, digits), NUL included */
#define APP_NATS_BLOBS 3              /* the groom data, hair mesh and collision mesh binaries */

typedef struct app_remote {
    uint32_t id;                       /* 0: free */
    int edge;                          /* index in app_nats.edges */
    uint32_t eclient;                  /* the client's number at its edge */
    int32_t stream;                    /* the node stream it is on; -1 none */
} app_remote;

typedef struct app_edge {
    char id[APP_EDGE_ID];              /* "": free */
    char reply[BUS_MAX_SUBJECT];       /* where its requests ask to be answered (their msg->reply) */
    unsigned long long last_ms;        /* when it was last heard from */
    uint32_t clients;
    uint64_t blob_gen;                 /* the blobs' generation this edge holds */
} app_edge;

/* A binary the node serves over HTTP (groom.bin, ...), for the edges to serve too. */
typedef struct app_nats_binary {
    char path[NET_MAX_BLOB_PATH];      /* "/groom.bin"; "": unused */
    net_buf *body;                     /* NULL: none (404) */
    char etag[NET_MAX_ETAG + 1];
} app_nats_binary;

typedef struct app_nats {
    natsConnection *nc;
    natsSubscription *ctl;
    char room[PROTO_MAX_ROOM + 1];
    char node_id[20];                  /* this run's id, sent with every heartbeat */
    app_gate gate;                     /* the remote clients' gate (own peers table); under gate_lock */
    pthread_mutex_t gate_lock;         /* serialises the gate calls (delivery and beat threads) */
    pthread_mutex_t tab_lock;          /* guards what follows (any thread); taken inside gate_lock */
    app_remote remote[APP_MAX_CLIENTS];
    app_edge edges[APP_MAX_EDGES];
    uint32_t next_gen;
    uint32_t on_stream[NET_MAX_STREAMS]; /* remote clients on each stream (frames go out when > 0) */
    uint64_t key_to[NET_MAX_STREAMS];    /* edges (bits) that get the stream's next keyframe themselves */
    app_nats_binary blobs[APP_NATS_BLOBS];
    uint64_t blob_gen;                   /* bumped by every app_nats_blob */
    /* sim thread only: each stream's latest keyframe, for remote clients that join it */
    net_buf *key[NET_MAX_STREAMS];
    uint64_t key_seq[NET_MAX_STREAMS];
    atomic_bool link_up, stop;
    atomic_uint_fast64_t frames_out, bytes_out, publish_errors;
    atomic_uint_fast64_t texts_in;       /* client messages received from edges */
    pthread_t beat;
    bool beat_started;
} app_nats;

/* Zero means default for every field but the required ones. */
typedef struct app_nats_desc {
    const char *url, *creds;           /* bus_desc's (url required) */
    const char *room;                  /* the room this node simulates (required) */
    app_gate gate;                     /* a copy of the WebSocket gate: parser, mailbox, outbox, ... (its peers
                                        * table is not shared: the copy gets its own) */
} app_nats_desc;

/* Connects, subscribes to the room's control subject and starts the heartbeat thread. b must stay
 * at its address until app_nats_close. Any thread, before the sim thread starts. */
core_status app_nats_open(app_nats *b, const app_nats_desc *d, core_err *err);
/* Stops the heartbeat (edges notice the node gone), closes the connection, frees everything.
 * After the sim and net threads have stopped. NULL or never opened: nothing. */
void app_nats_close(app_nats *b);

/* Text for one remote client (to its edge); unknown clients are ignored. Any thread. */
void app_nats_text(app_nats *b, uint32_t client, const char *text, size_t len, unsigned flags);
/* Text for every started remote client of the room (once, on the room subject). Any thread. */
void app_nats_broadcast(app_nats *b, const char *text, size_t len, unsigned flags);
/* A remote client gets its hello and starts on a stream / moves to another (the edge gets the
 * stream's latest keyframe with it). Sim thread. */
void app_nats_start(app_nats *b, uint32_t client, const char *hello, size_t len, uint32_t stream, double max_rate);
void app_nats_subscribe(app_nats *b, uint32_t client, uint32_t stream, double max_rate);
/* Closes a remote client at its edge once the text sent before has gone out. Any thread. */
void app_nats_close_client(app_nats *b, uint32_t client, int code, const char *reason);
/* A stream's frame (the caller keeps its reference): published once on the stream's subject while
 * a remote client is on it. Sim thread. */
void app_nats_frame(app_nats *b, uint32_t stream, net_buf *frame, uint64_t seq, bool key);
/* A stream's retained frames are void (groom change, last subscriber gone): edges drop theirs. Sim thread. */
void app_nats_drop(app_nats *b, uint32_t stream);
/* A binary served at path (body NULL: none) changed: sent to the edges with clients in the room
 * now (strandcast.room.R.blob), and to any other edge before its next client's hello. Sim thread. */
void app_nats_blob(app_nats *b, const char *path, net_buf *body, const char *etag);
/* Prometheus lines for /metrics (strandcast_nats_*); returns the bytes written. Any thread. */
size_t app_nats_metrics(app_nats *b, char *buf, size_t cap);

#endif
