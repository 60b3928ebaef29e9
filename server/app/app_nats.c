/* app: the simulation node's NATS bridge: edge clients as remote clients, frames, broadcasts, heartbeat. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "app_nats.h"

static unsigned long long now_ms(void) { return core_now_ns() / 1000000ull; }

/* The remote client with this id (tab_lock held), or NULL. */
static app_remote *find_id(app_nats *b, uint32_t id)
{
    if (!(id & APP_REMOTE_CLIENT)) return NULL;
    app_remote *r = &b->remote[id % APP_MAX_CLIENTS];
    return r->id == id ? r : NULL;
}

/* The remote client of (edge, eclient) (tab_lock held), or NULL. */
static app_remote *find_edge_client(app_nats *b, int edge, uint32_t eclient)
{
    for (size_t i = 0; i < APP_MAX_CLIENTS; i++)
        if (b->remote[i].id && b->remote[i].edge == edge && b->remote[i].eclient == eclient) return &b->remote[i];
    return NULL;
}

/* The edge's slot, made when make (tab_lock held); -1 when unknown or the table is full. */
static int edge_slot(app_nats *b, const char *id, bool make)
{
    int free_slot = -1;
    for (int i = 0; i < APP_MAX_EDGES; i++) {
        if (strcmp(b->edges[i].id, id) == 0) return i;
        if (!b->edges[i].id[0] && free_slot < 0) free_slot = i;
    }
    if (!make || free_slot < 0) return -1;
    snprintf(b->edges[free_slot].id, APP_EDGE_ID, "%s", id);
    b->edges[free_slot].clients = 0;
    return free_slot;
}

/* Where everything for an edge's clients goes: the reply subject of its requests. */
static void edge_subject(const app_nats *b, int edge, char *out, size_t cap)
{
    snprintf(out, cap, "%s", b->edges[edge].reply);
}

/* Publishes to the edge of remote client r (tab_lock held): op with headers (pairs after the
 * client's, NULL-terminated) and data. */
static void to_edge(app_nats *b, const app_remote *r, const char *op, const char *const *more, const void *data, size_t len)
{
    char subj[BUS_MAX_SUBJECT], client[16];
    edge_subject(b, r->edge, subj, sizeof subj);
    snprintf(client, sizeof client, "%u", r->eclient);
    const char *h[16] = { "Sc-Op", op, "Sc-Room", b->room, "Sc-Client", client };
    int n = 6;
    for (; more && *more && n < 14; more++) h[n++] = *more;
    h[n] = NULL;
    if (bus_publish(b->nc, subj, h, data, len, NULL) != CORE_OK) atomic_fetch_add(&b->publish_errors, 1);
}

/* One blob to subj (an edge's or the room's) (tab_lock held). */
static void send_blob(app_nats *b, const char *subj, const app_nats_binary *x)
{
    const char *h[] = { "Sc-Op", "blob", "Sc-Room", b->room, "Sc-Path", x->path, "Sc-Etag", x->etag, NULL };
    const void *data = x->body ? net_buf_data(x->body) : NULL;
    size_t len = x->body ? net_buf_len(x->body) : 0;
    core_err err;
    core_status st = bus_publish(b->nc, subj, h, data, len, &err);
    if (st != CORE_OK) atomic_fetch_add(&b->publish_errors, 1);
    /* before NATS is up no edge knows the room: each gets the blobs when it joins (blobs_to_edge) */
    if (st != CORE_OK && st != CORE_ESTATE)
        core_log(CORE_LOG_WARN, "nats", "%s (%zu bytes; over the NATS server's max_payload?): edges cannot serve it", err.msg, len);
}

/* The edge of r gets the current blobs unless it has them (tab_lock held). */
static void blobs_to_edge(app_nats *b, const app_remote *r)
{
    app_edge *e = &b->edges[r->edge];
    if (e->blob_gen == b->blob_gen) return;
    char subj[BUS_MAX_SUBJECT];
    edge_subject(b, r->edge, subj, sizeof subj);
    for (int i = 0; i < APP_NATS_BLOBS; i++)
        if (b->blobs[i].path[0]) send_blob(b, subj, &b->blobs[i]);
    e->blob_gen = b->blob_gen;
}

/* Forgets remote client r (tab_lock held). */
static void forget(app_nats *b, app_remote *r)
{
    if (r->stream >= 0 && r->stream < NET_MAX_STREAMS) b->on_stream[r->stream]--;
    if (b->edges[r->edge].clients) b->edges[r->edge].clients--;
    memset(r, 0, sizeof *r);
}

/* Moves r to stream (tab_lock held); the edge gets its latest keyframe now, or the next one. */
static void set_stream(app_nats *b, app_remote *r, int32_t stream)
{
    if (r->stream >= 0 && r->stream < NET_MAX_STREAMS) b->on_stream[r->stream]--;
    r->stream = stream;
    if (stream < 0 || stream >= NET_MAX_STREAMS) return;
    b->on_stream[stream]++;
    if (b->key[stream]) {
        char s[12], seq[24];
        snprintf(s, sizeof s, "%d", stream);
        snprintf(seq, sizeof seq, "%llu", (unsigned long long)b->key_seq[stream]);
        const char *more[] = { "Sc-Stream", s, "Sc-Seq", seq, "Sc-Key", "1", NULL };
        to_edge(b, r, "frame", more, net_buf_data(b->key[stream]), net_buf_len(b->key[stream]));
    } else {
        b->key_to[stream] |= 1ull << r->edge;
    }
}

static void on_open(app_nats *b, int edge, uint32_t eclient, const char *path)
{
    pthread_mutex_lock(&b->tab_lock);
    uint32_t id = 0;
    if (!find_edge_client(b, edge, eclient)) {
        for (size_t i = 0; i < APP_MAX_CLIENTS && !id; i++) {
            app_remote *r = &b->remote[i];
            if (r->id) continue;
            b->next_gen = (b->next_gen + 1) & 0x7FFFFu;
            id = APP_REMOTE_CLIENT | (b->next_gen << 12) | (uint32_t)i;
            *r = (app_remote){ .id = id, .edge = edge, .eclient = eclient, .stream = -1 };
            b->edges[edge].clients++;
        }
    }
    pthread_mutex_unlock(&b->tab_lock);
    if (!id) {
        core_log(CORE_LOG_WARN, "nats", "edge %s client %u: no room for another remote client", b->edges[edge].id, eclient);
        return;
    }
    app_on_open(&b->gate, id, path);
}

static void on_close(app_nats *b, int edge, uint32_t eclient)
{
    pthread_mutex_lock(&b->tab_lock);
    app_remote *r = find_edge_client(b, edge, eclient);
    uint32_t id = r ? r->id : 0;
    if (r) forget(b, r);
    pthread_mutex_unlock(&b->tab_lock);
    if (id) app_on_close(&b->gate, id);
}

/* A control request from an edge (the delivery thread): open, text, close or beat; what it
 * causes for the edge's clients is answered on the request's reply subject. */
static void on_ctl(natsConnection *nc, natsSubscription *sub, natsMsg *m, void *closure)
{
    (void)nc;
    (void)sub;
    app_nats *b = closure;
    const char *op = bus_header(m, "Sc-Op"), *edge_id = bus_header(m, "Sc-Edge"), *reply = natsMsg_GetReply(m);
    uint32_t eclient = (uint32_t)bus_header_u64(m, "Sc-Client", 0);
    if (!op || !edge_id || strlen(edge_id) >= APP_EDGE_ID || !reply || !*reply || strlen(reply) >= BUS_MAX_SUBJECT) {
        natsMsg_Destroy(m);
        return;
    }
    pthread_mutex_lock(&b->gate_lock);
    pthread_mutex_lock(&b->tab_lock);
    int edge = edge_slot(b, edge_id, strcmp(op, "open") == 0 || strcmp(op, "beat") == 0);
    if (edge >= 0) {
        b->edges[edge].last_ms = now_ms();
        snprintf(b->edges[edge].reply, sizeof b->edges[edge].reply, "%s", reply);
    }
    uint32_t id = 0;
    if (edge >= 0 && strcmp(op, "text") == 0) {
        app_remote *r = find_edge_client(b, edge, eclient);
        id = r ? r->id : 0;
    }
    pthread_mutex_unlock(&b->tab_lock);
    const char *data = natsMsg_GetData(m);
    size_t len = (size_t)natsMsg_GetDataLength(m);
    if (edge < 0) { /* an unknown edge's text or close: its client was never opened here */
        pthread_mutex_unlock(&b->gate_lock);
        natsMsg_Destroy(m);
        return;
    }
    if (strcmp(op, "open") == 0) {
        char path[PROTO_MAX_ROOM + 64];
        snprintf(path, sizeof path, "%.*s", (int)(len < sizeof path - 1 ? len : sizeof path - 1), data ? data : "");
        on_open(b, edge, eclient, path);
    } else if (strcmp(op, "close") == 0) {
        on_close(b, edge, eclient);
    } else if (strcmp(op, "text") == 0) {
        atomic_fetch_add(&b->texts_in, 1);
        if (id && len <= PROTO_MAX_MESSAGE) app_on_text(&b->gate, id, data ? data : "", len);
    }
    pthread_mutex_unlock(&b->gate_lock);
    natsMsg_Destroy(m);
}

/* Edges not heard from for BUS_BEAT_TIMEOUT_MS while the link is up lose their clients here. */
static void drop_silent_edges(app_nats *b)
{
    unsigned long long now = now_ms();
    pthread_mutex_lock(&b->gate_lock);
    for (int e = 0; e < APP_MAX_EDGES; e++) {
        pthread_mutex_lock(&b->tab_lock);
        bool gone = b->edges[e].id[0] && now - b->edges[e].last_ms > BUS_BEAT_TIMEOUT_MS;
        if (gone) core_log(CORE_LOG_WARN, "nats", "edge %s silent for %d ms: its %u clients are gone", b->edges[e].id,
                           BUS_BEAT_TIMEOUT_MS, b->edges[e].clients);
        pthread_mutex_unlock(&b->tab_lock);
        for (size_t i = 0; gone && i < APP_MAX_CLIENTS; i++) {
            pthread_mutex_lock(&b->tab_lock);
            uint32_t id = b->remote[i].id && b->remote[i].edge == e ? b->remote[i].id : 0;
            if (id) forget(b, &b->remote[i]);
            pthread_mutex_unlock(&b->tab_lock);
            if (id) app_on_close(&b->gate, id);
        }
        if (gone) {
            pthread_mutex_lock(&b->tab_lock);
            memset(&b->edges[e], 0, sizeof b->edges[e]);
            pthread_mutex_unlock(&b->tab_lock);
        }
    }
    pthread_mutex_unlock(&b->gate_lock);
}

static void *beat_main(void *arg)
{
    app_nats *b = arg;
    char subj[BUS_MAX_SUBJECT];
    bus_room_subject(subj, sizeof subj, b->room, "beat");
    const char *h[] = { "Sc-Node", b->node_id, NULL };
    unsigned long long last = 0;
    while (!atomic_load(&b->stop)) {
        unsigned long long now = now_ms();
        if (now - last >= BUS_BEAT_MS) {
            last = now;
            bus_publish(b->nc, subj, h, NULL, 0, NULL);
        }
        if (atomic_load(&b->link_up)) drop_silent_edges(b);
        struct timespec ts = { 0, 100 * 1000 * 1000 };
        nanosleep(&ts, NULL);
    }
    return NULL;
}

/* The link went down or came back: silence while it was down is not the edges' (any libnats thread). */
static void on_link(void *user, bool up)
{
    app_nats *b = user;
    if (up) {
        pthread_mutex_lock(&b->tab_lock);
        for (int e = 0; e < APP_MAX_EDGES; e++) b->edges[e].last_ms = now_ms();
        pthread_mutex_unlock(&b->tab_lock);
    }
    atomic_store(&b->link_up, up);
}

core_status app_nats_open(app_nats *b, const app_nats_desc *d, core_err *err)
{
    memset(b, 0, sizeof *b);
    if (!d->room || !proto_room_valid(d->room)) return core_fail(err, CORE_EINVAL, "nats: a valid room name is required");
    snprintf(b->room, sizeof b->room, "%s", d->room);
    snprintf(b->node_id, sizeof b->node_id, "%llx", (unsigned long long)(core_now_ns() ^ ((uint64_t)getpid() << 40)));
    b->gate = d->gate;
    memset(&b->gate.peers, 0, sizeof b->gate.peers);
    for (int i = 0; i < NET_MAX_STREAMS; i++) b->key[i] = NULL;
    pthread_mutex_init(&b->gate_lock, NULL);
    pthread_mutex_init(&b->tab_lock, NULL);
    atomic_store(&b->link_up, true);
    bus_desc bd = { .url = d->url, .creds = d->creds, .name = "strandcastd node", .on_link = on_link, .user = b };
    core_status st = bus_connect(&b->nc, &bd, err);
    if (st != CORE_OK) return st;
    char subj[BUS_MAX_SUBJECT];
    bus_room_subject(subj, sizeof subj, b->room, "ctl");
    natsStatus s = natsConnection_Subscribe(&b->ctl, b->nc, subj, on_ctl, b);
    if (s != NATS_OK) return core_fail(err, CORE_EIO, "nats: subscribe %s: %s", subj, natsStatus_GetText(s));
    if (pthread_create(&b->beat, NULL, beat_main, b) != 0) return core_fail(err, CORE_EBACKEND, "nats: cannot start the heartbeat thread");
    b->beat_started = true;
    core_log(CORE_LOG_INFO, "nats", "simulation node of room %s on %s (control: %s)", b->room, d->url, subj);
    return CORE_OK;
}

void app_nats_close(app_nats *b)
{
    if (!b || !b->room[0]) return;
    atomic_store(&b->stop, true);
    if (b->beat_started) pthread_join(b->beat, NULL);
    if (b->nc) {
        char subj[BUS_MAX_SUBJECT];
        bus_room_subject(subj, sizeof subj, b->room, "beat");
        const char *h[] = { "Sc-Node", b->node_id, "Sc-Op", "bye", NULL };
        bus_publish(b->nc, subj, h, NULL, 0, NULL); /* edges need not wait for the timeout */
    }
    bus_close(b->nc, &b->ctl, 1);
    for (int i = 0; i < NET_MAX_STREAMS; i++) net_buf_unref(b->key[i]);
    for (int i = 0; i < APP_NATS_BLOBS; i++) net_buf_unref(b->blobs[i].body);
    app_peers_free(&b->gate.peers);
    pthread_mutex_destroy(&b->gate_lock);
    pthread_mutex_destroy(&b->tab_lock);
    b->room[0] = '\0';
}

void app_nats_text(app_nats *b, uint32_t client, const char *text, size_t len, unsigned flags)
{
    char f[12];
    snprintf(f, sizeof f, "%u", flags);
    const char *more[] = { "Sc-Flags", f, NULL };
    pthread_mutex_lock(&b->tab_lock);
    app_remote *r = find_id(b, client);
    if (r) to_edge(b, r, "text", more, text, len);
    pthread_mutex_unlock(&b->tab_lock);
}

void app_nats_broadcast(app_nats *b, const char *text, size_t len, unsigned flags)
{
    char subj[BUS_MAX_SUBJECT], f[12];
    bus_room_subject(subj, sizeof subj, b->room, "bcast");
    snprintf(f, sizeof f, "%u", flags);
    const char *h[] = { "Sc-Flags", f, NULL };
    if (bus_publish(b->nc, subj, h, text, len, NULL) != CORE_OK) atomic_fetch_add(&b->publish_errors, 1);
}

/* start or subscribe: the op with the stream and rate, then the stream's keyframe. */
static void place(app_nats *b, uint32_t client, const char *op, const char *text, size_t len, uint32_t stream, double max_rate)
{
    char s[12], rate[32];
    snprintf(s, sizeof s, "%u", stream);
    snprintf(rate, sizeof rate, "%.17g", max_rate);
    const char *more[] = { "Sc-Stream", s, "Sc-Rate", rate, NULL };
    pthread_mutex_lock(&b->tab_lock);
    app_remote *r = find_id(b, client);
    if (r) {
        blobs_to_edge(b, r); /* before the hello that names them */
        to_edge(b, r, op, more, text, len);
        set_stream(b, r, stream < NET_MAX_STREAMS ? (int32_t)stream : -1);
    }
    pthread_mutex_unlock(&b->tab_lock);
}

void app_nats_start(app_nats *b, uint32_t client, const char *hello, size_t len, uint32_t stream, double max_rate)
{
    place(b, client, "start", hello, len, stream, max_rate);
}

void app_nats_subscribe(app_nats *b, uint32_t client, uint32_t stream, double max_rate)
{
    place(b, client, "subscribe", NULL, 0, stream, max_rate);
}

void app_nats_close_client(app_nats *b, uint32_t client, int code, const char *reason)
{
    char c[12];
    snprintf(c, sizeof c, "%d", code);
    const char *more[] = { "Sc-Code", c, NULL };
    pthread_mutex_lock(&b->tab_lock);
    app_remote *r = find_id(b, client);
    if (r) to_edge(b, r, "close", more, reason, strlen(reason));
    pthread_mutex_unlock(&b->tab_lock);
}

void app_nats_frame(app_nats *b, uint32_t stream, net_buf *frame, uint64_t seq, bool key)
{
    if (stream >= NET_MAX_STREAMS) return;
    pthread_mutex_lock(&b->tab_lock);
    if (key) {
        net_buf_ref(frame);
        net_buf_unref(b->key[stream]);
        b->key[stream] = frame;
        b->key_seq[stream] = seq;
    }
    bool wanted = b->on_stream[stream] > 0;
    uint64_t direct = key ? b->key_to[stream] : 0;
    if (key) b->key_to[stream] = 0;
    if (!wanted && !direct) { /* no edge takes this stream: only its keyframe is kept */
        pthread_mutex_unlock(&b->tab_lock);
        return;
    }
    char s[12], sq[24];
    snprintf(s, sizeof s, "%u", stream);
    snprintf(sq, sizeof sq, "%llu", (unsigned long long)seq);
    /* edges that joined before the stream's first keyframe get it on their own subject too */
    for (int e = 0; direct && e < APP_MAX_EDGES; e++) {
        if (!(direct & (1ull << e)) || !b->edges[e].id[0]) continue;
        char subj[BUS_MAX_SUBJECT];
        edge_subject(b, e, subj, sizeof subj);
        const char *h[] = { "Sc-Op", "frame", "Sc-Room", b->room, "Sc-Stream", s, "Sc-Seq", sq, "Sc-Key", "1", NULL };
        bus_publish(b->nc, subj, h, net_buf_data(frame), net_buf_len(frame), NULL);
    }
    pthread_mutex_unlock(&b->tab_lock);
    if (!wanted) return;
    char subj[BUS_MAX_SUBJECT], leaf[24];
    snprintf(leaf, sizeof leaf, "stream.%u", stream);
    bus_room_subject(subj, sizeof subj, b->room, leaf);
    const char *h[] = { "Sc-Seq", sq, "Sc-Key", key ? "1" : "0", NULL };
    if (bus_publish(b->nc, subj, h, net_buf_data(frame), net_buf_len(frame), NULL) != CORE_OK) {
        atomic_fetch_add(&b->publish_errors, 1);
        return;
    }
    atomic_fetch_add(&b->frames_out, 1);
    atomic_fetch_add(&b->bytes_out, net_buf_len(frame));
}

void app_nats_drop(app_nats *b, uint32_t stream)
{
    if (stream >= NET_MAX_STREAMS) return;
    pthread_mutex_lock(&b->tab_lock);
    net_buf_unref(b->key[stream]);
    b->key[stream] = NULL;
    bool wanted = b->on_stream[stream] > 0;
    pthread_mutex_unlock(&b->tab_lock);
    if (!wanted) return;
    char subj[BUS_MAX_SUBJECT], leaf[24];
    snprintf(leaf, sizeof leaf, "stream.%u", stream);
    bus_room_subject(subj, sizeof subj, b->room, leaf);
    const char *h[] = { "Sc-Op", "drop", NULL };
    bus_publish(b->nc, subj, h, NULL, 0, NULL);
}

void app_nats_blob(app_nats *b, const char *path, net_buf *body, const char *etag)
{
    pthread_mutex_lock(&b->tab_lock);
    app_nats_binary *x = NULL;
    for (int i = 0; i < APP_NATS_BLOBS && !x; i++)
        if (!b->blobs[i].path[0] || strcmp(b->blobs[i].path, path) == 0) x = &b->blobs[i];
    if (x) {
        snprintf(x->path, sizeof x->path, "%s", path);
        if (body) net_buf_ref(body);
        net_buf_unref(x->body);
        x->body = body;
        snprintf(x->etag, sizeof x->etag, "%s", body && etag ? etag : "");
        b->blob_gen++;
        char subj[BUS_MAX_SUBJECT];
        bus_room_subject(subj, sizeof subj, b->room, "blob");
        send_blob(b, subj, x);
        for (int e = 0; e < APP_MAX_EDGES; e++) /* those with clients here are subscribed to the room's blobs */
            if (b->edges[e].id[0] && b->edges[e].clients && b->edges[e].blob_gen == b->blob_gen - 1) b->edges[e].blob_gen = b->blob_gen;
    }
    pthread_mutex_unlock(&b->tab_lock);
}

size_t app_nats_metrics(app_nats *b, char *buf, size_t cap)
{
    int k = snprintf(buf, cap,
                     "# HELP strandcast_nats_frames_published_total Frames published on NATS (once per stream, whatever the edges).\n"
                     "# TYPE strandcast_nats_frames_published_total counter\nstrandcast_nats_frames_published_total %llu\n"
                     "# HELP strandcast_nats_bytes_published_total Frame bytes published on NATS.\n"
                     "# TYPE strandcast_nats_bytes_published_total counter\nstrandcast_nats_bytes_published_total %llu\n"
                     "# HELP strandcast_nats_publish_errors_total Messages libnats refused (connection closed).\n"
                     "# TYPE strandcast_nats_publish_errors_total counter\nstrandcast_nats_publish_errors_total %llu\n"
                     "# HELP strandcast_nats_texts_in_total Client messages received from edge relays (after their budget).\n"
                     "# TYPE strandcast_nats_texts_in_total counter\nstrandcast_nats_texts_in_total %llu\n",
                     (unsigned long long)atomic_load(&b->frames_out), (unsigned long long)atomic_load(&b->bytes_out),
                     (unsigned long long)atomic_load(&b->publish_errors), (unsigned long long)atomic_load(&b->texts_in));
    if (k < 0) return 0;
    return (size_t)k < cap ? (size_t)k : cap - 1;
}
