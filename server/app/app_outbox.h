/* app: the way out to clients: sends text messages through net and counts the control
 * messages accepted and rejected (for /metrics). Borrows the net handle (NULL with --no-net);
 * any thread. */
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

typedef struct app_outbox {
    net *net;                           /* NULL: messages are dropped (--no-net) */
    atomic_uint_fast64_t accepted, rejected;
} app_outbox;

/* Sends text (freed here) to a client or NET_ALL; ignores NULL (out of memory: logged). */
void app_send(app_outbox *o, uint32_t client, char *text, unsigned flags);
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
