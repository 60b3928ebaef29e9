/* app: the net thread's side: client text parsed into commands for the sim thread (replies
 * to what cannot be parsed or queued go out at once), connection events, /metrics text. */
#ifndef APP_NET_H
#define APP_NET_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#include "app_mailbox.h"
#include "app_record.h"
#include "app_outbox.h"
#include "app_peers.h"
#include "app_stats.h"

/* What the net callbacks need; borrowed from app_run.c, which outlives the net thread. */
typedef struct app_gate {
    const proto_parser *parser;
    app_mailbox *mb;
    app_outbox *out;
    app_stats_board *board;
    atomic_uint *grooms_pending;  /* set_groom requests queued or being carried out (at most 1) */
    const atomic_bool *sim_done;  /* the sim thread has stopped: opens and closes are not waited for */
    const char *token;            /* NULL: every client is a writer */
    const char *room;             /* the room served: a client whose path names another is refused */
    app_peers peers;              /* owned: each client's budget and access */
    app_record *rec;              /* --record's counters for /metrics; NULL = not recording */
    struct app_nats *bus;         /* --nats: its counters for /metrics; NULL = none */
} app_gate;

/* Net-thread callbacks (net_callbacks.user = the app_gate). app_gate_free releases the peers
 * table once the net thread has stopped. */
void app_on_open(void *user, uint32_t client, const char *path);
void app_on_text(void *user, uint32_t client, const char *text, size_t len);
void app_on_close(void *user, uint32_t client);
size_t app_metrics(void *user, char *buf, size_t cap);
void app_gate_free(app_gate *g);

#endif
