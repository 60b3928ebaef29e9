/* app: messages to clients and the accepted/rejected counters. */
#include <string.h>

#include "app_outbox.h"

void app_send(app_outbox *o, uint32_t client, char *text, unsigned flags)
{
    if (!text) {
        core_log(CORE_LOG_ERROR, "app", "out of memory building a message for client %u", client);
        return;
    }
    if (o->net && net_send_text(o->net, client, text, strlen(text), flags) != CORE_OK)
        core_log(CORE_LOG_WARN, "app", "message to client %u dropped (net inbox full)", client);
    proto_free(text);
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
