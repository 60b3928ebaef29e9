/* bus: the NATS connection of simulation nodes and edge relays (libnats): connect with reconnects
 * and credentials, room subjects, messages with small headers. Knows nothing of strands. */
#ifndef BUS_BUS_H
#define BUS_BUS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include <nats/nats.h>

#include "../core/core.h"

#define BUS_PREFIX "strandcast"   /* every subject starts with this token */
#define BUS_MAX_SUBJECT 160
#define BUS_BEAT_MS 1000          /* a node's heartbeat period on its room's beat subject */
#define BUS_BEAT_TIMEOUT_MS 3000  /* silence after which a node (or an edge) counts as gone */
#define BUS_RECONNECT_WAIT_MS 250 /* between reconnect attempts after NATS went away (forever) */

/* Zero means default for every field. */
typedef struct bus_desc {
    const char *url;          /* nats://[user:pass@|token@]host:port (required) */
    const char *creds;        /* a NATS .creds file (JWT and NKey seed); NULL = none */
    const char *name;         /* the connection's name shown by the server; NULL = "strandcastd" */
    /* Called on a libnats thread when the connection is lost and when it is back (subscriptions
     * are restored by libnats); may be NULL. */
    void (*on_link)(void *user, bool up);
    void *user;
} bus_desc;

/* Connects (retrying in the background when the server is not up yet: the call then returns
 * CORE_OK and the connection comes up later) and arranges that every subscription callback of the
 * process runs on one libnats delivery thread, in the order the messages arrived. The caller owns
 * *out (bus_close). Any thread. */
core_status bus_connect(natsConnection **out, const bus_desc *d, core_err *err);

/* Checks that path reads as a NATS credentials file (a user JWT and an NKey user seed, as nsc
 * writes them: what libnats reads at each connect) without connecting: CORE_EIO when it cannot be
 * read, CORE_EINVAL when it holds no JWT or no seed, with the reason (no path) in err. Signatures
 * and the seed's checksum are the server's and libnats' to check. Any thread. */
core_status bus_creds_check(const char *path, core_err *err);

/* Flushes and closes the connection (which ends its subscriptions), waits (up to 2 s) until the
 * delivery thread has finished with each of the n subscriptions in subs (NULL entries skipped),
 * destroys them and the connection, then releases libnats' threads (once per process, for its
 * last connection). nc NULL: only the latter. */
void bus_close(natsConnection *nc, natsSubscription **subs, int n);

/* "strandcast.room.ROOM.LEAF" (leaf may hold dots: "stream.3"); false when it does not fit. */
bool bus_room_subject(char *out, size_t cap, const char *room, const char *leaf);

/* A message to subj with headers (NULL-terminated key, value pairs; NULL = none) and data,
 * published on nc. CORE_ESTATE (err may be NULL) before the first connection is up (a message
 * with headers needs the server's word that it takes them), CORE_EIO when libnats refuses it
 * otherwise (the connection is closed; while it reconnects libnats buffers). Any thread. */
core_status bus_publish(natsConnection *nc, const char *subj, const char *const *headers, const void *data, size_t len,
                        core_err *err);
/* As bus_publish, as a NATS request: the message carries reply, the subject its receiver answers
 * on (its msg->reply). Not natsConnection_Request: nothing waits here and the receiver may answer
 * any number of times; the caller subscribes to reply. Any thread. */
core_status bus_request(natsConnection *nc, const char *subj, const char *reply, const char *const *headers,
                        const void *data, size_t len, core_err *err);

/* Header key of m as text (NULL when absent); as an unsigned number (def when absent or bad). */
const char *bus_header(natsMsg *m, const char *key);
uint64_t bus_header_u64(natsMsg *m, const char *key, uint64_t def);

#endif
