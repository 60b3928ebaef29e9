/* app: the edge relay: WebSocket clients of any room, relayed to and from the rooms' nodes over NATS. */
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "app_parser.h"
#include "app_peers.h"
#include "app_process.h"
#include "app_relay.h"
#include "bus/bus.h"
#include "net/net.h"
#include "proto/proto.h"

#define RELAY_MAX_ROOMS 64

typedef struct relay_client {
    uint32_t id;                       /* 0: free */
    int room;                          /* index in relay.rooms */
    bool started;                      /* got its hello */
    int lstream;                       /* local net stream; -1 none */
} relay_client;

typedef struct relay_stream {
    int room;                          /* -1: free */
    int32_t slot;                      /* the node's stream number */
    uint32_t users;
    natsSubscription *sub;
    uint64_t last_seq;                 /* newest frame handed to net (older ones are dropped) */
} relay_stream;

typedef struct relay_room {
    char name[PROTO_MAX_ROOM + 1];     /* "": free */
    uint32_t users;
    natsSubscription *bcast, *beat, *blob;
    unsigned long long last_beat_ms;   /* the node's last heartbeat (or when the room was opened here) */
    char node[24];                     /* the node's id from its heartbeats ("" before the first) */
} relay_room;

typedef struct relay {
    const app_desc *d;
    net *net;
    natsConnection *nc;
    char id[24];                       /* this edge's id */
    char subject[BUS_MAX_SUBJECT];     /* strandcast.edge.ID: the reply subject of its requests */
    natsSubscription *inbox;
    pthread_mutex_t lock;              /* guards the tables (net thread, delivery thread, main thread) */
    relay_client *clients;
    size_t nclients;                   /* capacity of clients (max_clients) */
    relay_stream streams[NET_MAX_STREAMS];
    relay_room rooms[RELAY_MAX_ROOMS];
    proto_parser parser;               /* read-only after start */
    app_peers peers;                   /* each client's control-message budget (net thread only) */
    atomic_bool link_up;
    atomic_uint_fast64_t frames_in, frames_dropped, nodes_lost;
    atomic_uint_fast64_t texts_forwarded, texts_refused; /* client messages sent on to a node / answered here */
} relay;

static unsigned long long now_ms(void) { return core_now_ns() / 1000000ull; }

static relay_client *find_client(relay *r, uint32_t id)
{
    for (size_t i = 0; i < r->nclients; i++)
        if (r->clients[i].id == id) return &r->clients[i];
    return NULL;
}

/* A control message of client id to room's node, as a request the node answers on this edge's
 * subject (PROTOCOL.md "Scaling out": why that keeps each client's order). */
static void to_node(relay *r, const char *room, const char *op, uint32_t id, const void *data, size_t len)
{
    char subj[BUS_MAX_SUBJECT], c[16];
    bus_room_subject(subj, sizeof subj, room, "ctl");
    snprintf(c, sizeof c, "%u", id);
    const char *h[] = { "Sc-Op", op, "Sc-Edge", r->id, "Sc-Client", c, NULL };
    bus_request(r->nc, subj, r->subject, h, data, len, NULL);
}

/* An error without id, then a close, for one client (any thread). */
static void refuse(relay *r, uint32_t client, const proto_error *e, int code)
{
    char *text = proto_build_error(NULL, e);
    if (text) net_send_text(r->net, client, text, strlen(text), 0);
    proto_free(text);
    net_close_client(r->net, client, code, e->message);
}

static void on_bcast(natsConnection *nc, natsSubscription *sub, natsMsg *m, void *closure);
static void on_beat(natsConnection *nc, natsSubscription *sub, natsMsg *m, void *closure);
static void on_frame(natsConnection *nc, natsSubscription *sub, natsMsg *m, void *closure);
static void on_blob(natsConnection *nc, natsSubscription *sub, natsMsg *m, void *closure);

/* The room's entry, opened (subscribed to its broadcasts and heartbeat) when new; -1 when full
 * (lock held). */
static int open_room(relay *r, const char *name)
{
    int free_slot = -1;
    for (int i = 0; i < RELAY_MAX_ROOMS; i++) {
        if (strcmp(r->rooms[i].name, name) == 0) return i;
        if (!r->rooms[i].name[0] && free_slot < 0) free_slot = i;
    }
    if (free_slot < 0) return -1;
    relay_room *rm = &r->rooms[free_slot];
    memset(rm, 0, sizeof *rm);
    snprintf(rm->name, sizeof rm->name, "%s", name);
    rm->last_beat_ms = now_ms();
    char subj[BUS_MAX_SUBJECT];
    bus_room_subject(subj, sizeof subj, name, "bcast");
    natsConnection_Subscribe(&rm->bcast, r->nc, subj, on_bcast, r);
    bus_room_subject(subj, sizeof subj, name, "beat");
    natsConnection_Subscribe(&rm->beat, r->nc, subj, on_beat, r);
    bus_room_subject(subj, sizeof subj, name, "blob");
    natsConnection_Subscribe(&rm->blob, r->nc, subj, on_blob, r);
    return free_slot;
}

/* Drops a use of local stream ls (lock held); its subscription goes into *dead when unused. */
static void release_stream(relay *r, int ls, natsSubscription **dead)
{
    if (ls < 0 || ls >= NET_MAX_STREAMS) return;
    relay_stream *s = &r->streams[ls];
    if (s->users == 0 || --s->users > 0) return;
    *dead = s->sub;
    s->sub = NULL;
    s->room = -1;
    net_drop_stream(r->net, (uint32_t)ls);
}

/* The local stream of (room, slot), subscribed when new; -1 when every local stream is taken
 * (lock held). */
static int use_stream(relay *r, int room, int32_t slot)
{
    int free_slot = -1;
    for (int i = 0; i < NET_MAX_STREAMS; i++) {
        if (r->streams[i].room == room && r->streams[i].slot == slot) {
            r->streams[i].users++;
            return i;
        }
        if (r->streams[i].room < 0 && free_slot < 0) free_slot = i;
    }
    if (free_slot < 0) return -1;
    relay_stream *s = &r->streams[free_slot];
    *s = (relay_stream){ .room = room, .slot = slot, .users = 1 };
    char subj[BUS_MAX_SUBJECT], leaf[24];
    snprintf(leaf, sizeof leaf, "stream.%d", slot);
    bus_room_subject(subj, sizeof subj, r->rooms[room].name, leaf);
    natsConnection_Subscribe(&s->sub, r->nc, subj, on_frame, r);
    return free_slot;
}

/* Closes a room's entry when its last client left (lock held); its subscriptions into dead[0..2]. */
static void leave_room(relay *r, int room, natsSubscription **dead)
{
    relay_room *rm = &r->rooms[room];
    if (rm->users == 0 || --rm->users > 0) return;
    dead[0] = rm->bcast;
    dead[1] = rm->beat;
    dead[2] = rm->blob;
    memset(rm, 0, sizeof *rm);
}

/* A binary of a room's node (Sc-Path "/groom.bin", ...; empty without Sc-Etag: none), served here
 * at PROTO_ROOM_PREFIX ROOM PATH. */
static void take_blob(relay *r, natsMsg *m)
{
    const char *room = bus_header(m, "Sc-Room"), *path = bus_header(m, "Sc-Path"), *etag = bus_header(m, "Sc-Etag");
    if (!room || !path || !proto_room_valid(room)) return;
    char full[NET_MAX_BLOB_PATH];
    int k = snprintf(full, sizeof full, PROTO_ROOM_PREFIX "%s%s", room, path);
    if (k < 0 || (size_t)k >= sizeof full) return;
    size_t len = (size_t)natsMsg_GetDataLength(m);
    net_buf *b = etag && *etag ? net_buf_new(len) : NULL;
    if (b && len) memcpy(net_buf_data(b), natsMsg_GetData(m), len);
    if (net_set_blob(r->net, full, b, etag) != CORE_OK) core_log(CORE_LOG_WARN, "relay", "cannot serve %s", full);
}

static void on_blob(natsConnection *nc, natsSubscription *sub, natsMsg *m, void *closure)
{
    (void)nc;
    (void)sub;
    take_blob(closure, m);
    natsMsg_Destroy(m);
}

static void destroy_subs(natsSubscription **subs, int n)
{
    for (int i = 0; i < n; i++) {
        if (!subs[i]) continue;
        natsSubscription_Unsubscribe(subs[i]);
        natsSubscription_Destroy(subs[i]);
    }
}

/* ---- net thread ---- */

static void relay_open(void *user, uint32_t client, const char *path)
{
    relay *r = user;
    char room[PROTO_MAX_ROOM + 1];
    proto_error e;
    if (proto_room_of_path(path, room, &e) != CORE_OK) {
        refuse(r, client, &e, PROTO_CLOSE_BAD_ROOM);
        return;
    }
    pthread_mutex_lock(&r->lock);
    relay_client *c = find_client(r, 0);
    int ri = c ? open_room(r, room) : -1;
    if (ri >= 0) {
        *c = (relay_client){ .id = client, .room = ri, .lstream = -1 };
        r->rooms[ri].users++;
    }
    pthread_mutex_unlock(&r->lock);
    if (ri < 0) {
        proto_fail(&e, PROTO_ERR_BUSY, "room", "this edge relays as many rooms and clients as it can; try another edge");
        refuse(r, client, &e, 1013); /* try again later */
        return;
    }
    if (app_peers_open(&r->peers, client, true, core_now_ns()) != CORE_OK)
        core_log(CORE_LOG_WARN, "relay", "client %u: out of memory for its budget; its node still limits it", client);
    to_node(r, room, "open", client, path, strlen(path));
}

/* An answer of this edge to a client's message that goes no further (any error). */
static void answer(relay *r, uint32_t client, char *text, unsigned flags)
{
    atomic_fetch_add(&r->texts_refused, 1);
    if (text) net_send_text(r->net, client, text, strlen(text), flags);
    proto_free(text);
}

/* A client's message goes on to its node only within its budget (else rate_limited, droppable as
 * a daemon's) and when it parses (else the error the node would give, at once): a flooding client
 * costs NATS and its node no more than the budget (PROTOCOL.md "Scaling out"). */
static void relay_text(void *user, uint32_t client, const char *text, size_t len)
{
    relay *r = user;
    if (!app_peers_take(&r->peers, client, core_now_ns())) {
        answer(r, client, app_peers_limited(&r->parser, text, len), NET_TEXT_DROPPABLE);
        return;
    }
    proto_msg m;
    proto_error e;
    if (proto_parse(&r->parser, text, len, &m, &e) != CORE_OK) {
        answer(r, client, proto_build_error(&m.id, &e), 0);
        return;
    }
    char room[PROTO_MAX_ROOM + 1] = "";
    pthread_mutex_lock(&r->lock);
    relay_client *c = find_client(r, client);
    if (c) snprintf(room, sizeof room, "%s", r->rooms[c->room].name);
    pthread_mutex_unlock(&r->lock);
    if (!room[0]) return;
    atomic_fetch_add(&r->texts_forwarded, 1);
    to_node(r, room, "text", client, text, len);
}

static void relay_close(void *user, uint32_t client)
{
    relay *r = user;
    char room[PROTO_MAX_ROOM + 1] = "";
    natsSubscription *dead[4] = { NULL, NULL, NULL, NULL };
    app_peers_close(&r->peers, client);
    pthread_mutex_lock(&r->lock);
    relay_client *c = find_client(r, client);
    if (c) {
        snprintf(room, sizeof room, "%s", r->rooms[c->room].name);
        release_stream(r, c->lstream, &dead[0]);
        leave_room(r, c->room, &dead[1]);
        memset(c, 0, sizeof *c);
    }
    pthread_mutex_unlock(&r->lock);
    destroy_subs(dead, 4);
    if (room[0]) to_node(r, room, "close", client, NULL, 0);
}

/* ---- the NATS delivery thread ---- */

/* Puts client c on the node's stream slot of its room (lock held); the local stream, or -1. */
static int place(relay *r, relay_client *c, int32_t slot, natsSubscription **dead)
{
    int ls = slot >= 0 && slot < NET_MAX_STREAMS ? use_stream(r, c->room, slot) : -1;
    release_stream(r, c->lstream, dead);
    c->lstream = ls;
    return ls;
}

/* A message of the node to one client of this edge: start, subscribe, text, close, or a frame
 * for a stream a client here just joined. */
static void on_inbox(natsConnection *nc, natsSubscription *sub, natsMsg *m, void *closure)
{
    (void)nc;
    (void)sub;
    relay *r = closure;
    const char *op = bus_header(m, "Sc-Op"), *room = bus_header(m, "Sc-Room");
    uint32_t client = (uint32_t)bus_header_u64(m, "Sc-Client", 0);
    const char *data = natsMsg_GetData(m);
    size_t len = (size_t)natsMsg_GetDataLength(m);
    if (!op || !room) {
        natsMsg_Destroy(m);
        return;
    }
    if (strcmp(op, "blob") == 0) {
        take_blob(r, m);
        natsMsg_Destroy(m);
        return;
    }
    natsSubscription *dead = NULL;
    int32_t slot = (int32_t)bus_header_u64(m, "Sc-Stream", NET_MAX_STREAMS);
    double rate = 0;
    const char *rs = bus_header(m, "Sc-Rate");
    if (rs) rate = strtod(rs, NULL);
    pthread_mutex_lock(&r->lock);
    relay_client *c = find_client(r, client);
    bool mine = c && strcmp(r->rooms[c->room].name, room) == 0;
    if (strcmp(op, "start") == 0 && mine) {
        int ls = place(r, c, slot, &dead);
        c->started = true;
        net_start_client(r->net, client, data ? data : "", len, ls >= 0 ? (uint32_t)ls : NET_MAX_STREAMS, rate);
    } else if (strcmp(op, "subscribe") == 0 && mine) {
        int ls = place(r, c, slot, &dead);
        net_subscribe(r->net, client, ls >= 0 ? (uint32_t)ls : NET_MAX_STREAMS, rate);
    } else if (strcmp(op, "text") == 0 && mine) {
        net_send_text(r->net, client, data ? data : "", len, (unsigned)bus_header_u64(m, "Sc-Flags", 0));
    } else if (strcmp(op, "close") == 0 && mine) {
        char reason[NET_MAX_CLOSE_REASON + 1];
        snprintf(reason, sizeof reason, "%.*s", (int)(len < sizeof reason - 1 ? len : sizeof reason - 1), data ? data : "");
        net_close_client(r->net, client, (int)bus_header_u64(m, "Sc-Code", 1000), reason);
    } else if (strcmp(op, "frame") == 0) {
        for (int i = 0; i < NET_MAX_STREAMS; i++) {
            relay_stream *s = &r->streams[i];
            if (s->room < 0 || s->slot != slot || strcmp(r->rooms[s->room].name, room) != 0) continue;
            uint64_t seq = bus_header_u64(m, "Sc-Seq", 0);
            net_buf *b = seq > s->last_seq ? net_buf_new(len) : NULL;
            if (!b) break;
            memcpy(net_buf_data(b), data, len);
            s->last_seq = seq;
            net_publish(r->net, (uint32_t)i, b, seq, bus_header_u64(m, "Sc-Key", 0) == 1);
            break;
        }
    }
    pthread_mutex_unlock(&r->lock);
    destroy_subs(&dead, 1);
    natsMsg_Destroy(m);
}

/* A frame (or a drop) of a stream some client here uses: to net, newest first. */
static void on_frame(natsConnection *nc, natsSubscription *sub, natsMsg *m, void *closure)
{
    (void)nc;
    relay *r = closure;
    const char *op = bus_header(m, "Sc-Op");
    uint64_t seq = bus_header_u64(m, "Sc-Seq", 0);
    bool key = bus_header_u64(m, "Sc-Key", 0) == 1;
    size_t len = (size_t)natsMsg_GetDataLength(m);
    pthread_mutex_lock(&r->lock);
    for (int i = 0; i < NET_MAX_STREAMS; i++) {
        relay_stream *s = &r->streams[i];
        if (s->sub != sub) continue;
        if (op && strcmp(op, "drop") == 0) {
            net_drop_stream(r->net, (uint32_t)i);
        } else if (seq > s->last_seq) {
            net_buf *b = net_buf_new(len);
            if (b) {
                memcpy(net_buf_data(b), natsMsg_GetData(m), len);
                s->last_seq = seq;
                net_publish(r->net, (uint32_t)i, b, seq, key);
                atomic_fetch_add(&r->frames_in, 1);
            }
        } else {
            atomic_fetch_add(&r->frames_dropped, 1);
        }
        break;
    }
    pthread_mutex_unlock(&r->lock);
    natsMsg_Destroy(m);
}

/* The room index of a room subscription (lock held), or -1. */
static int room_of_sub(relay *r, natsSubscription *sub)
{
    for (int i = 0; i < RELAY_MAX_ROOMS; i++)
        if (r->rooms[i].name[0] && (r->rooms[i].bcast == sub || r->rooms[i].beat == sub)) return i;
    return -1;
}

/* An announcement of a room's node: to every client here that has its hello. */
static void on_bcast(natsConnection *nc, natsSubscription *sub, natsMsg *m, void *closure)
{
    (void)nc;
    relay *r = closure;
    unsigned flags = (unsigned)bus_header_u64(m, "Sc-Flags", 0);
    pthread_mutex_lock(&r->lock);
    int room = room_of_sub(r, sub);
    for (size_t i = 0; room >= 0 && i < r->nclients; i++) {
        relay_client *c = &r->clients[i];
        if (c->id && c->started && c->room == room)
            net_send_text(r->net, c->id, natsMsg_GetData(m), (size_t)natsMsg_GetDataLength(m), flags);
    }
    pthread_mutex_unlock(&r->lock);
    natsMsg_Destroy(m);
}

/* Every client of room gets error room_unavailable and close 4503 (lock held). */
static void node_lost(relay *r, int room, const char *why)
{
    relay_room *rm = &r->rooms[room];
    proto_error e;
    proto_fail(&e, PROTO_ERR_ROOM_UNAVAILABLE, "room", "the simulation node of room \"%s\" %s; reconnect later", rm->name, why);
    core_log(CORE_LOG_WARN, "relay", "%s", e.message);
    atomic_fetch_add(&r->nodes_lost, 1);
    for (size_t i = 0; i < r->nclients; i++)
        if (r->clients[i].id && r->clients[i].room == room) refuse(r, r->clients[i].id, &e, PROTO_CLOSE_ROOM_UNAVAILABLE);
    rm->node[0] = '\0';
    rm->last_beat_ms = now_ms();
}

/* A room's node heartbeat: its id (a new one means the node restarted: its clients here lost
 * their session), or its goodbye. */
static void on_beat(natsConnection *nc, natsSubscription *sub, natsMsg *m, void *closure)
{
    (void)nc;
    relay *r = closure;
    const char *node = bus_header(m, "Sc-Node"), *op = bus_header(m, "Sc-Op");
    pthread_mutex_lock(&r->lock);
    int room = room_of_sub(r, sub);
    if (room >= 0 && node) {
        relay_room *rm = &r->rooms[room];
        if (op && strcmp(op, "bye") == 0) node_lost(r, room, "stopped");
        else if (rm->node[0] && strcmp(rm->node, node) != 0) node_lost(r, room, "restarted");
        else {
            snprintf(rm->node, sizeof rm->node, "%s", node);
            rm->last_beat_ms = now_ms();
        }
    }
    pthread_mutex_unlock(&r->lock);
    natsMsg_Destroy(m);
}

static void on_link(void *user, bool up)
{
    relay *r = user;
    if (up) {
        pthread_mutex_lock(&r->lock);
        for (int i = 0; i < RELAY_MAX_ROOMS; i++) r->rooms[i].last_beat_ms = now_ms();
        pthread_mutex_unlock(&r->lock);
    }
    atomic_store(&r->link_up, up);
}

/* ---- the main thread ---- */

/* Once a second: this edge's heartbeat to each room's node; rooms whose node is silent lose
 * their clients here. */
static void tick(relay *r, unsigned long long *last_beat)
{
    unsigned long long now = now_ms();
    bool beat = now - *last_beat >= BUS_BEAT_MS;
    if (beat) *last_beat = now;
    pthread_mutex_lock(&r->lock);
    for (int i = 0; i < RELAY_MAX_ROOMS; i++) {
        relay_room *rm = &r->rooms[i];
        if (!rm->name[0]) continue;
        if (beat) to_node(r, rm->name, "beat", 0, NULL, 0);
        if (atomic_load(&r->link_up) && now - rm->last_beat_ms > BUS_BEAT_TIMEOUT_MS)
            node_lost(r, i, rm->node[0] ? "stopped answering" : "is not running");
    }
    pthread_mutex_unlock(&r->lock);
}

static size_t relay_metrics(void *user, char *buf, size_t cap)
{
    relay *r = user;
    int k = snprintf(buf, cap,
                     "# HELP strandcast_relay_frames_in_total Frames received from simulation nodes over NATS.\n"
                     "# TYPE strandcast_relay_frames_in_total counter\nstrandcast_relay_frames_in_total %llu\n"
                     "# HELP strandcast_relay_frames_stale_total Frames from NATS older than one already relayed (dropped).\n"
                     "# TYPE strandcast_relay_frames_stale_total counter\nstrandcast_relay_frames_stale_total %llu\n"
                     "# HELP strandcast_relay_nodes_lost_total Times a room's simulation node was found gone.\n"
                     "# TYPE strandcast_relay_nodes_lost_total counter\nstrandcast_relay_nodes_lost_total %llu\n"
                     "# HELP strandcast_control_messages_total Client control messages: sent on to their node (accepted) "
                     "or answered with an error here (rejected: over the budget, or not valid).\n"
                     "# TYPE strandcast_control_messages_total counter\n"
                     "strandcast_control_messages_total{result=\"accepted\"} %llu\n"
                     "strandcast_control_messages_total{result=\"rejected\"} %llu\n",
                     (unsigned long long)atomic_load(&r->frames_in), (unsigned long long)atomic_load(&r->frames_dropped),
                     (unsigned long long)atomic_load(&r->nodes_lost), (unsigned long long)atomic_load(&r->texts_forwarded),
                     (unsigned long long)atomic_load(&r->texts_refused));
    if (k < 0) return 0;
    return (size_t)k < cap ? (size_t)k : cap - 1;
}

static core_status start(relay *r, core_err *err)
{
    const app_desc *d = r->d;
    r->nclients = (size_t)(d->max_clients > 0 ? d->max_clients : app_default_max_clients());
    r->clients = calloc(r->nclients, sizeof *r->clients);
    if (!r->clients) return core_fail(err, CORE_ENOMEM, "relay: out of memory");
    core_status st = app_parser_init(&r->parser, err);
    if (st != CORE_OK) return st;
    for (int i = 0; i < NET_MAX_STREAMS; i++) r->streams[i].room = -1;
    snprintf(r->id, sizeof r->id, "%llx", (unsigned long long)(core_now_ns() ^ ((uint64_t)getpid() << 40)));
    atomic_store(&r->link_up, true);
    net_desc nd = {
        .listen = d->listen, .port = d->port, .web_dir = d->web_dir, .subprotocol = PROTO_SUBPROTOCOL,
        .max_message = PROTO_MAX_MESSAGE, .sndbuf = d->client_buffer, .max_clients = (int)r->nclients,
        .allow_origins = d->allow_origins, .tls_cert = d->tls_cert, .tls_key = d->tls_key, .page_prefix = PROTO_ROOM_PREFIX,
        .ping_s = d->ping_interval, .hangup_s = d->ping_timeout,
        .cb = { r, relay_open, relay_text, relay_close, relay_metrics },
    };
    if ((st = net_create(&r->net, &nd, err)) != CORE_OK) return st;
    bus_desc bd = { .url = d->nats, .creds = d->nats_creds, .name = "strandcastd edge", .on_link = on_link, .user = r };
    if ((st = bus_connect(&r->nc, &bd, err)) != CORE_OK) return st;
    snprintf(r->subject, sizeof r->subject, BUS_PREFIX ".edge.%s", r->id);
    natsStatus s = natsConnection_Subscribe(&r->inbox, r->nc, r->subject, on_inbox, r);
    if (s != NATS_OK) return core_fail(err, CORE_EIO, "relay: subscribe %s: %s", r->subject, natsStatus_GetText(s));
    core_log(CORE_LOG_INFO, "relay", "edge %s on %s: any room at /rooms/NAME", r->id, d->nats);
    return CORE_OK;
}

static void stop(relay *r)
{
    natsSubscription *dead[1 + 3 * RELAY_MAX_ROOMS + NET_MAX_STREAMS] = { r->inbox };
    int n = 1;
    for (int i = 0; i < RELAY_MAX_ROOMS; i++) {
        dead[n++] = r->rooms[i].bcast;
        dead[n++] = r->rooms[i].beat;
        dead[n++] = r->rooms[i].blob;
    }
    for (int i = 0; i < NET_MAX_STREAMS; i++) dead[n++] = r->streams[i].sub;
    if (r->nc || r->net) bus_close(r->nc, dead, n);
    net_destroy(r->net);
    app_peers_free(&r->peers);
    free(r->clients);
}

core_status app_relay_run(const app_desc *desc, core_err *err)
{
    if (!desc->nats) return core_fail(err, CORE_EINVAL, "--relay needs --nats URL");
    sigset_t set, old;
    app_process_block_signals(&set, &old);
    relay *r = calloc(1, sizeof *r);
    if (!r) return core_fail(err, CORE_ENOMEM, "out of memory");
    r->d = desc;
    pthread_mutex_init(&r->lock, NULL);
    core_status st = start(r, err);
    pthread_t net_thread;
    bool net_started = false;
    if (st == CORE_OK) {
        const char *host = desc->listen && *desc->listen ? desc->listen : "127.0.0.1";
        printf("strandcastd: open %s://%s:%d/  (edge relay: any room at /rooms/NAME; WebSocket subprotocol %s)\n",
               desc->tls_cert ? "https" : "http", host, net_port(r->net), PROTO_SUBPROTOCOL);
        fflush(stdout);
        if (pthread_create(&net_thread, NULL, app_process_net_main, r->net) != 0) st = core_fail(err, CORE_EBACKEND, "cannot start the net thread");
        else net_started = true;
    }
    unsigned long long last_beat = 0;
    const struct timespec ts = { 0, 100 * 1000 * 1000 };
    while (st == CORE_OK && !app_process_stop_signal(&set, ts, "relay")) tick(r, &last_beat);
    if (net_started) {
        net_stop(r->net);
        pthread_join(net_thread, NULL);
    }
    stop(r);
    pthread_mutex_destroy(&r->lock);
    free(r);
    pthread_sigmask(SIG_SETMASK, &old, NULL);
    return st;
}
