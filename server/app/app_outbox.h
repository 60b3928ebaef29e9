/* app: the way out to clients: sends text messages, starts, moves and closes clients through net
 * (WebSocket clients) or the NATS bridge (remote clients of edge relays, app_nats.h), and counts
 * the control messages accepted and rejected (for /metrics). Borrows both; any thread. */
#ifndef APP_OUTBOX_H
#define APP_OUTBOX_H

#include <stdatomic.h>
#include <stdint.h>

#include "net/net.h"
#include "proto/proto.h"

/* Announcements to every client whose latest carries the whole current value: a client's queue
 * keeps only the newest of each kind, so a burst of changes from one client cannot fill the
 * queues of the others (net coalesces them). */
#define APP_ANNOUNCE_PARAMS NET_TEXT_LATEST(1)
#define APP_ANNOUNCE_STATE NET_TEXT_LATEST(2)
#define APP_ANNOUNCE_GROOM NET_TEXT_LATEST(3)

struct app_nats;

typedef struct app_outbox {
    net *net;                           /* NULL: messages are dropped (--no-net) */
    struct app_nats *bus;               /* NULL: no remote clients (no --nats) */
    atomic_uint_fast64_t accepted, rejected;
} app_outbox;

/* Sends text (freed here) to a client or NET_ALL (WebSocket and remote clients); ignores NULL
 * (out of memory: logged). */
void app_send(app_outbox *o, uint32_t client, char *text, unsigned flags);
/* net_start_client / net_subscribe / net_close_client for a WebSocket or a remote client. */
void app_out_start(app_outbox *o, uint32_t client, const char *hello, uint32_t stream, double max_rate);
void app_out_subscribe(app_outbox *o, uint32_t client, uint32_t stream, double max_rate);
void app_out_close(app_outbox *o, uint32_t client, int code, const char *reason);
/* An error reply to one client; counts a rejection. */
void app_reply_error(app_outbox *o, uint32_t client, const proto_id *id, const proto_error *e);
/* app_reply_error of (code, field, msg). */
void app_reply_fail(app_outbox *o, uint32_t client, const proto_id *id, proto_code code, const char *field,
                    const char *msg);
/* An ok reply to m, with the step from which its change to the simulation shows (step < 0: m
 * changes no simulation, no step field); counts an acceptance. */
void app_reply_ok(app_outbox *o, uint32_t client, const proto_msg *m, int64_t step);
/* Counts an acceptance that has no reply of its own (a motion without id, a subscribe). */
void app_count_accepted(app_outbox *o);

#endif
