/* app: the net-thread side: parse client text into commands, reply to rejects, /metrics lines. */
#include <string.h>
#include <time.h>

#include "app_nats.h"
#include "app_net.h"

/* Queues c, or answers busy when the mailbox is full; true when queued. */
static bool post(app_gate *g, const app_cmd *c, const proto_id *id)
{
    if (app_mailbox_post(g->mb, c) == CORE_OK) return true;
    proto_error e;
    proto_fail(&e, PROTO_ERR_BUSY, "", "the server's command queue is full; retry later");
    app_reply_error(g->out, c->client, id, &e);
    return false;
}

/* Opens and closes must not be lost (a client would get no hello, or keep its stream alive):
 * when the mailbox is full, wait for the sim thread to make room. */
static void post_essential(app_gate *g, const app_cmd *c)
{
    while (app_mailbox_post(g->mb, c) != CORE_OK && !atomic_load(g->sim_done)) {
        struct timespec ms = { 0, 1000000 };
        app_mailbox_wake(g->mb);
        nanosleep(&ms, NULL);
    }
}

/* The room the client's path names is served here; else it gets an error (no id) and is closed
 * (PROTOCOL.md "Rooms"). */
static bool room_served(app_gate *g, uint32_t client, const char *path)
{
    char room[PROTO_MAX_ROOM + 1];
    proto_error e;
    int code = PROTO_CLOSE_BAD_ROOM;
    if (proto_room_of_path(path, room, &e) == CORE_OK) {
        if (strcmp(room, g->room) == 0) return true;
        proto_fail(&e, PROTO_ERR_UNKNOWN_ROOM, "room", "this server serves room \"%s\", not \"%s\"", g->room, room);
        code = PROTO_CLOSE_UNKNOWN_ROOM;
    }
    app_reply_error(g->out, client, NULL, &e);
    app_out_close(g->out, client, code, e.message);
    return false;
}

void app_on_open(void *user, uint32_t client, const char *path)
{
    app_gate *g = user;
    if (!room_served(g, client, path)) return;
    if (app_peers_open(&g->peers, client, g->token == NULL, core_now_ns()) != CORE_OK)
        core_log(CORE_LOG_WARN, "app", "client %u: out of memory for its entry; it is read-only and not rate-limited", client);
    app_cmd c = { .kind = APP_CMD_OPEN, .client = client };
    post_essential(g, &c);
}

void app_on_close(void *user, uint32_t client)
{
    app_gate *g = user;
    app_peers_close(&g->peers, client);
    app_cmd c = { .kind = APP_CMD_CLOSE, .client = client };
    post_essential(g, &c);
}

/* A request over the client's budget: answered rate_limited (echoing its id when it has one),
 * not carried out. The answer may be dropped from the client's own full queue, so a flood
 * cannot get the flooder closed for the answers it provoked. */
static void limited(app_gate *g, uint32_t client, const char *text, size_t len)
{
    atomic_fetch_add(&g->out->rejected, 1);
    app_send(g->out, client, app_peers_limited(g->parser, text, len), NET_TEXT_DROPPABLE);
}

/* Same length and bytes, in time that does not depend on where they differ. */
static bool same_secret(const char *a, const char *b)
{
    size_t na = strlen(a), nb = strlen(b);
    unsigned diff = (unsigned)(na ^ nb);
    for (size_t i = 0; i < na; i++) diff |= (unsigned char)a[i] ^ (unsigned char)(nb ? b[i % nb] : 0);
    return diff == 0;
}

/* Access control: auth is answered here; without it (when the server has a token) a client
 * may only subscribe. True when m goes on to the sim thread. */
static bool allowed(app_gate *g, uint32_t client, const proto_msg *m)
{
    app_peer *p = app_peers_find(&g->peers, client);
    if (m->type == PROTO_AUTH) {
        if (!g->token || same_secret(m->u.auth.token, g->token)) {
            if (p) p->writer = true;
            app_reply_ok(g->out, client, m, -1);
        } else {
            app_reply_fail(g->out, client, &m->id, PROTO_ERR_FORBIDDEN, "token", "wrong token");
        }
        return false;
    }
    if (m->type == PROTO_SUBSCRIBE || (p && p->writer)) return true;
    app_reply_fail(g->out, client, &m->id, PROTO_ERR_FORBIDDEN, "",
                   "this connection is read-only: send {\"type\":\"auth\",\"token\":...} with the server's token first");
    return false;
}

void app_on_text(void *user, uint32_t client, const char *text, size_t len)
{
    app_gate *g = user;
    if (!app_peers_take(&g->peers, client, core_now_ns())) {
        limited(g, client, text, len);
        return;
    }
    app_cmd c = { .kind = APP_CMD_MSG, .client = client };
    proto_error e;
    if (proto_parse(g->parser, text, len, &c.msg, &e) != CORE_OK) {
        app_reply_error(g->out, client, &c.msg.id, &e);
        return;
    }
    if (!allowed(g, client, &c.msg)) return;
    if (c.msg.type != PROTO_SET_GROOM) {
        post(g, &c, &c.msg.id);
        return;
    }
    /* a groom change loads a groom, a mesh and its distance grid and builds a simulation on the
     * loader thread (seconds for the largest): one at a time, so that no client can queue up
     * minutes of work */
    if (atomic_fetch_add(g->grooms_pending, 1) > 0) {
        atomic_fetch_sub(g->grooms_pending, 1);
        proto_fail(&e, PROTO_ERR_BUSY, "", "a groom change is already in progress; retry after its groom message");
        app_reply_error(g->out, client, &c.msg.id, &e);
        return;
    }
    if (!post(g, &c, &c.msg.id)) atomic_fetch_sub(g->grooms_pending, 1);
}

size_t app_metrics(void *user, char *buf, size_t cap)
{
    app_gate *g = user;
    app_stats s = app_stats_read(g->board);
    size_t n = app_stats_metrics(&s, atomic_load(&g->out->accepted), atomic_load(&g->out->rejected), buf, cap);
    if (g->bus && n + 1 < cap) n += app_nats_metrics(g->bus, buf + n, cap - n);
    if (!g->rec || n + 1 >= cap) return n;
    int k = snprintf(buf + n, cap - n,
                     "# HELP strandcast_record_bytes_total Bytes written to the --record file.\n"
                     "# TYPE strandcast_record_bytes_total counter\nstrandcast_record_bytes_total %llu\n"
                     "# HELP strandcast_record_errors_total Failed writes to the --record file and records dropped "
                     "(the recording is incomplete when above 0).\n"
                     "# TYPE strandcast_record_errors_total counter\nstrandcast_record_errors_total %llu\n",
                     (unsigned long long)atomic_load(&g->rec->bytes),
                     (unsigned long long)(atomic_load(&g->rec->errors) + atomic_load(&g->rec->dropped)));
    if (k < 0) return n;
    return n + (size_t)k < cap ? n + (size_t)k : cap - 1;
}

void app_gate_free(app_gate *g) { app_peers_free(&g->peers); }
