/* app: each client's control-message budget, a token bucket: APP_RATE_PER_S messages a second
 * sustained, APP_RATE_BURST at once after a quiet spell (a slider dragged at 120 Hz, or motion
 * at a 144 Hz display, uses under a third; both at once, two thirds). Past it a request is
 * answered rate_limited.
 * Net thread only; owns its table. */
#ifndef APP_RATE_H
#define APP_RATE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "core/core.h"

#define APP_RATE_PER_S 400.0
#define APP_RATE_BURST 128.0 /* the replies to a full burst fit a client's text queue (NET_DEFAULT_TEXT_QUEUE) */

typedef struct app_rate_slot {
    uint32_t client;          /* 0: empty (client ids start at 1) */
    double tokens;
    unsigned long long t_ns;  /* when tokens was last brought up to date */
} app_rate_slot;

/* An open-addressed table of the connected clients' buckets. */
typedef struct app_rates {
    app_rate_slot *v;
    size_t n, cap;            /* cap: a power of two, or 0 */
} app_rates;

/* A full bucket for a new client; CORE_ENOMEM (the client is then not limited). */
core_status app_rates_open(app_rates *r, uint32_t client, unsigned long long now_ns);
/* Forgets a client. */
void app_rates_close(app_rates *r, uint32_t client);
/* Takes one message from the client's bucket at time now_ns: false when it is empty (the
 * message is over budget). Unknown clients are not limited. */
bool app_rates_take(app_rates *r, uint32_t client, unsigned long long now_ns);
void app_rates_free(app_rates *r);

#endif
