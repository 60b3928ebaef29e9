/* app: what the net thread keeps per client: whether it may change shared state (after auth,
 * when the server has a token), and its control-message budget, a token bucket: APP_RATE_PER_S messages a second
 * sustained, APP_RATE_BURST at once after a quiet spell (a slider dragged at 120 Hz, or motion
 * at a 144 Hz display, uses under a third; both at once, two thirds). Past it a request is
 * answered rate_limited.
 * Net thread only; owns its table. */
#ifndef APP_PEERS_H
#define APP_PEERS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "core/core.h"
#include "proto/proto.h"

#define APP_RATE_PER_S 400.0
#define APP_RATE_BURST 128.0 /* the replies to a full burst fit a client's text queue (NET_DEFAULT_TEXT_QUEUE) */

typedef struct app_peer {
    uint32_t client;          /* 0: empty (client ids start at 1) */
    bool writer;              /* may change shared state */
    double tokens;
    unsigned long long t_ns;  /* when tokens was last brought up to date */
} app_peer;

/* An open-addressed table of the connected clients. */
typedef struct app_peers {
    app_peer *v;
    size_t n, cap;            /* cap: a power of two, or 0 */
} app_peers;

/* A new client with a full bucket, a writer or not; CORE_ENOMEM (the client is then neither
 * limited nor known: app_peers_find gives NULL). */
core_status app_peers_open(app_peers *r, uint32_t client, bool writer, unsigned long long now_ns);
/* The client's entry, or NULL. */
app_peer *app_peers_find(app_peers *r, uint32_t client);
/* Forgets a client. */
void app_peers_close(app_peers *r, uint32_t client);
/* Takes one message from the client's bucket at time now_ns: false when it is empty (the
 * message is over budget). Unknown clients are not limited. */
bool app_peers_take(app_peers *r, uint32_t client, unsigned long long now_ns);
void app_peers_free(app_peers *r);
/* The rate_limited error for a message over the budget (its id echoed when p can read one; the
 * text is not otherwise judged), for the caller to send and proto_free; NULL when out of memory.
 * Used wherever the budget is enforced (a daemon's own clients, an edge relay's). */
char *app_peers_limited(const proto_parser *p, const char *text, size_t len);

#endif
