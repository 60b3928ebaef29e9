/* app: the connected clients as the sim thread sees them: their stream and subscription
 * settings and the newest motion time each sent. Sim thread only; owns its array. */
#ifndef APP_CLIENTS_H
#define APP_CLIENTS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "proto/proto.h"

typedef struct app_client {
    uint32_t id;
    int stream;               /* index into app_streams, or -1 */
    proto_source source;      /* what the stream carries: strands or the hair mesh */
    int32_t stride;           /* of the strands (kept while on the hair mesh) */
    double max_error, max_rate;
    bool has_t;
    double last_t;            /* newest motion timestamp from this client */
} app_client;

typedef struct app_clients {
    app_client *v;
    size_t n, cap;
} app_clients;

/* A new zeroed entry for id (stream -1), or NULL when out of memory. The pointer holds until
 * the next add or remove. */
app_client *app_clients_add(app_clients *cs, uint32_t id);
/* id's entry, or NULL. */
app_client *app_clients_find(app_clients *cs, uint32_t id);
/* Drops id's entry (order not kept). */
void app_clients_remove(app_clients *cs, uint32_t id);
void app_clients_free(app_clients *cs);

#endif
