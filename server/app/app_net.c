/* app: the net-thread side: parse client text into commands, reply to rejects, /metrics lines. */
#include <time.h>

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

void app_on_open(void *user, uint32_t client)
{
    app_cmd c = { .kind = APP_CMD_OPEN, .client = client };
    post_essential(user, &c);
}

void app_on_close(void *user, uint32_t client)
{
    app_cmd c = { .kind = APP_CMD_CLOSE, .client = client };
    post_essential(user, &c);
}

void app_on_text(void *user, uint32_t client, const char *text, size_t len)
{
    app_gate *g = user;
    app_cmd c = { .kind = APP_CMD_MSG, .client = client };
    proto_error e;
    if (proto_parse(g->parser, text, len, &c.msg, &e) != CORE_OK) {
        app_reply_error(g->out, client, &c.msg.id, &e);
        return;
    }
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
    return app_stats_metrics(&s, atomic_load(&g->out->accepted), atomic_load(&g->out->rejected), buf, cap);
}
