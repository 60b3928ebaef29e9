/* bus: connecting to NATS (reconnect forever, credentials), subjects and header helpers. */
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bus.h"

typedef struct link_cb {
    void (*fn)(void *user, bool up);
    void *user;
} link_cb;

static void on_down(natsConnection *nc, void *closure)
{
    link_cb *l = closure;
    if (!natsConnection_IsClosed(nc)) /* closed: bus_close, or on_closed says why */
        core_log(CORE_LOG_WARN, "bus", "NATS connection lost; reconnecting");
    if (l->fn) l->fn(l->user, false);
}

static void on_up(natsConnection *nc, void *closure)
{
    (void)nc;
    link_cb *l = closure;
    core_log(CORE_LOG_INFO, "bus", "NATS connection up");
    if (l->fn) l->fn(l->user, true);
}

static void on_closed(natsConnection *nc, void *closure)
{
    const char *text = NULL;
    natsStatus s = natsConnection_GetLastError(nc, &text);
    /* reconnecting forever, libnats gives up only when the server refuses this client twice (its
     * authorization); other errors are those of the last attempt before bus_close */
    if (s == NATS_CONNECTION_AUTH_FAILED || s == NATS_NOT_PERMITTED)
        core_log(CORE_LOG_ERROR, "bus", "NATS connection closed for good (no more reconnects): %s%s%s", natsStatus_GetText(s),
                 text && *text ? ": " : "", text ? text : "");
    free(closure); /* the last callback of a connection */
}

/* libnats' last error of this thread without its "(file.c:line): " prefix ("" when none). */
static const char *last_error(void)
{
    const char *t = nats_GetLastError(NULL);
    if (!t) return "";
    const char *p = t[0] == '(' ? strstr(t, "): ") : NULL;
    return p ? p + 3 : t;
}

core_status bus_connect(natsConnection **out, const bus_desc *d, core_err *err)
{
    *out = NULL;
    if (!d->url || !*d->url) return core_fail(err, CORE_EINVAL, "bus: a NATS URL is required");
    natsStatus s = nats_Open(-1);
    /* one delivery thread for every subscription: callbacks run in arrival order, one at a time */
    if (s == NATS_OK) s = nats_SetMessageDeliveryPoolSize(1);
    natsOptions *o = NULL;
    link_cb *l = calloc(1, sizeof *l);
    if (!l) return core_fail(err, CORE_ENOMEM, "bus: out of memory");
    l->fn = d->on_link;
    l->user = d->user;
    if (s == NATS_OK) s = natsOptions_Create(&o);
    if (s == NATS_OK) s = natsOptions_SetURL(o, d->url);
    if (s == NATS_OK) s = natsOptions_SetName(o, d->name ? d->name : "strandcastd");
    if (s == NATS_OK) s = natsOptions_UseGlobalMessageDelivery(o, true);
    if (s == NATS_OK) s = natsOptions_SetMaxReconnect(o, -1);
    if (s == NATS_OK) s = natsOptions_SetReconnectWait(o, BUS_RECONNECT_WAIT_MS);
    if (s == NATS_OK) s = natsOptions_SetReconnectBufSize(o, 8 * 1024 * 1024);
    if (s == NATS_OK) s = natsOptions_SetPingInterval(o, 1000);
    if (s == NATS_OK) s = natsOptions_SetMaxPingsOut(o, 2);
    if (s == NATS_OK) s = natsOptions_SetDisconnectedCB(o, on_down, l);
    if (s == NATS_OK) s = natsOptions_SetReconnectedCB(o, on_up, l);
    if (s == NATS_OK) s = natsOptions_SetClosedCB(o, on_closed, l);
    if (s == NATS_OK && d->creds) s = natsOptions_SetUserCredentialsFromFiles(o, d->creds, NULL);
    if (s != NATS_OK) {
        natsOptions_Destroy(o);
        free(l);
        return core_fail(err, CORE_EINVAL, "bus: NATS options for %s: %s", d->url, natsStatus_GetText(s));
    }
    /* a first attempt without retries: a server that is up but refuses this client (its
     * authorization, a bad credentials file, TLS) is an error now, not a silent retry; only a
     * server that is not up yet is waited for, in the background */
    s = natsConnection_Connect(out, o);
    if (s == NATS_NO_SERVER || s == NATS_TIMEOUT) {
        s = natsOptions_SetRetryOnFailedConnect(o, true, on_up, l);
        if (s == NATS_OK) s = natsConnection_Connect(out, o);
    }
    natsOptions_Destroy(o);
    if (s == NATS_NOT_YET_CONNECTED) {
        core_log(CORE_LOG_WARN, "bus", "NATS at %s is not up yet; connecting in the background", d->url);
        return CORE_OK;
    }
    if (s != NATS_OK) {
        if (*out) natsConnection_Destroy(*out);
        else free(l);
        *out = NULL;
        const char *last = last_error();
        if (s == NATS_CONNECTION_AUTH_FAILED)
            return core_fail(err, CORE_EIO, "bus: NATS at %s refused this client (%s%s%s): check %s%s", d->url,
                             natsStatus_GetText(s), *last ? ": " : "", last,
                             d->creds ? "the credentials file " : "the user:password@ or token@ of the URL",
                             d->creds ? d->creds : "");
        return core_fail(err, CORE_EIO, "bus: cannot connect to NATS at %s: %s%s%s", d->url, natsStatus_GetText(s),
                         *last ? ": " : "", last);
    }
    return CORE_OK;
}

static void sub_done(void *closure) { atomic_fetch_add((atomic_int *)closure, 1); }

void bus_close(natsConnection *nc, natsSubscription **subs, int n)
{
    /* closing a subscription posts a message to the delivery thread; the library must not shut
     * down before that thread took every one (it would leak them): wait for each subscription's
     * completion callback, which runs once it has */
    atomic_int done = 0;
    int want = 0;
    for (int i = 0; i < n; i++)
        if (subs[i] && natsSubscription_SetOnCompleteCB(subs[i], sub_done, &done) == NATS_OK) want++;
    if (nc) {
        natsConnection_FlushTimeout(nc, 1000);
        natsConnection_Close(nc);
    }
    for (int t = 0; t < 400 && atomic_load(&done) < want; t++) nats_Sleep(5);
    for (int i = 0; i < n; i++)
        if (subs[i]) natsSubscription_Destroy(subs[i]);
    if (nc) natsConnection_Destroy(nc);
    nats_CloseAndWait(2000);
}

bool bus_room_subject(char *out, size_t cap, const char *room, const char *leaf)
{
    int n = snprintf(out, cap, BUS_PREFIX ".room.%s.%s", room, leaf);
    return n > 0 && (size_t)n < cap;
}

core_status bus_publish(natsConnection *nc, const char *subj, const char *const *headers, const void *data, size_t len,
                        core_err *err)
{
    return bus_request(nc, subj, NULL, headers, data, len, err);
}

core_status bus_request(natsConnection *nc, const char *subj, const char *reply, const char *const *headers,
                        const void *data, size_t len, core_err *err)
{
    natsMsg *m = NULL;
    natsStatus s = natsMsg_Create(&m, subj, reply, data, (int)len);
    for (const char *const *h = headers; s == NATS_OK && h && h[0]; h += 2) s = natsMsgHeader_Set(m, h[0], h[1]);
    if (s == NATS_OK) s = natsConnection_PublishMsg(nc, m);
    natsMsg_Destroy(m);
    if (s == NATS_NO_SERVER_SUPPORT && natsConnection_Status(nc) != NATS_CONN_STATUS_CONNECTED)
        return core_fail(err, CORE_ESTATE, "bus: publish on %s: not connected to NATS yet", subj);
    if (s != NATS_OK) return core_fail(err, CORE_EIO, "bus: publish on %s: %s", subj, natsStatus_GetText(s));
    return CORE_OK;
}

const char *bus_header(natsMsg *m, const char *key)
{
    const char *v = NULL;
    return natsMsgHeader_Get(m, key, &v) == NATS_OK ? v : NULL;
}

uint64_t bus_header_u64(natsMsg *m, const char *key, uint64_t def)
{
    const char *v = bus_header(m, key);
    if (!v || !*v) return def;
    char *end;
    unsigned long long u = strtoull(v, &end, 10);
    return *end ? def : (uint64_t)u;
}
