/* app: messages to clients and the accepted/rejected counters. */
#include <string.h>

#include "app_nats.h"
#include "app_outbox.h"

static bool remote(const app_outbox *o, uint32_t client) { return o->bus && (client & APP_REMOTE_CLIENT); }

void app_send(app_outbox *o, uint32_t client, char *text, unsigned flags)
{
    if (!text) {
        core_log(CORE_LOG_ERROR, "app", "out of memory building a message for client %u", client);
        return;
    }
    size_t len = strlen(text);
    if (remote(o, client)) app_nats_text(o->bus, client, text, len, flags);
    else if (o->net && net_send_text(o->net, client, text, len, flags) != CORE_OK)
        core_log(CORE_LOG_WARN, "app", "message to client %u dropped (net inbox full)", client);
    if (client == NET_ALL && o->bus) app_nats_broadcast(o->bus, text, len, flags);
    proto_free(text);
}

void app_out_start(app_outbox *o, uint32_t client, const char *hello, uint32_t stream, double max_rate)
{
    if (remote(o, client)) app_nats_start(o->bus, client, hello, strlen(hello), stream, max_rate);
    else if (o->net) net_start_client(o->net, client, hello, strlen(hello), stream, max_rate);
}

void app_out_subscribe(app_outbox *o, uint32_t client, uint32_t stream, double max_rate)
{
    if (remote(o, client)) app_nats_subscribe(o->bus, client, stream, max_rate);
    else if (o->net) net_subscribe(o->net, client, stream, max_rate);
}

void app_out_close(app_outbox *o, uint32_t client, int code, const char *reason)
{
    if (remote(o, client)) app_nats_close_client(o->bus, client, code, reason);
    else if (o->net) net_close_client(o->net, client, code, reason);
}

void app_reply_error(app_outbox *o, uint32_t client, const proto_id *id, const proto_error *e)
{
    atomic_fetch_add(&o->rejected, 1);
    app_send(o, client, proto_build_error(id, e), 0);
}

void app_reply_fail(app_outbox *o, uint32_t client, const proto_id *id, proto_code code, const char *field,
                    const char *msg)
{
    proto_error e;
    proto_fail(&e, code, field, "%s", msg);
    app_reply_error(o, client, id, &e);
}

void app_reply_ok(app_outbox *o, uint32_t client, const proto_msg *m, int64_t step)
{
    atomic_fetch_add(&o->accepted, 1);
    app_send(o, client, proto_build_ok(&m->id, m->type, step), 0);
}

void app_count_accepted(app_outbox *o) { atomic_fetch_add(&o->accepted, 1); }
