/* net: the libwebsockets server: sessions, frame broadcast, text queues, static files, /metrics. */
#ifndef NET_NET_H
#define NET_NET_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "../core/core.h"

/* Threads: one thread (the net thread) calls net_run, and every lws call happens inside it.
 * Functions marked "any thread" only take a mutex and call lws_cancel_service().
 * Clients are numbered from 1 in connection order; NET_ALL addresses every ready client. */
#define NET_ALL 0u
#define NET_PORT_ANY (-1)          /* net_desc.port: let the kernel pick a free port */
#define NET_MAX_STREAMS 32         /* frame streams (one per distinct subscription) */
#define NET_DEFAULT_PORT 7681
#define NET_DEFAULT_MAX_MESSAGE (64 * 1024)
#define NET_DEFAULT_TEXT_QUEUE 256
#define NET_DEFAULT_MAX_CLIENTS 128
#define NET_DEFAULT_PING_S 20
#define NET_DEFAULT_HANGUP_EXTRA_S 10 /* default hangup_s = ping_s + this */
#define NET_MAX_HANGUP_S 65535     /* lws keeps both times as uint16 seconds */
#define NET_DEFAULT_SNDBUF (256 * 1024)
#define NET_INBOX_MAX 8192         /* pending posts from other threads before posting fails */
#define NET_MAX_ORIGINS 16         /* net_desc.allow_origins entries */
#define NET_MAX_ORIGIN 256         /* longest origin, bytes */
#define NET_MAX_BLOBS 4            /* byte blobs served over HTTP from memory (net_set_blob) */
#define NET_MAX_BLOB_PATH 96       /* longest blob path, bytes */
#define NET_MAX_PAGE_BLOBS 192     /* blobs under desc.page_prefix (net_set_blob adds them) */
#define NET_MAX_ETAG 64            /* longest blob version tag, bytes */

typedef struct net net;

/* A refcounted, immutable-once-posted byte buffer (a binary frame or a text message) with
 * the headroom lws needs in front of it. Any thread. */
typedef struct net_buf net_buf;

/* Allocates len bytes (refcount 1); NULL when out of memory. */
net_buf *net_buf_new(size_t len);
unsigned char *net_buf_data(net_buf *b);
size_t net_buf_len(const net_buf *b);
void net_buf_ref(net_buf *b);
/* Drops one reference; frees on the last. NULL is ignored. */
void net_buf_unref(net_buf *b);

/* Called on the net thread. text is a complete, UTF-8-valid text message of at most
 * max_message bytes, valid only during the call; path is the WebSocket request's path (without
 * the query), valid only during the call. */
typedef struct net_callbacks {
    void *user;
    void (*on_open)(void *user, uint32_t client, const char *path);
    void (*on_text)(void *user, uint32_t client, const char *text, size_t len);
    void (*on_close)(void *user, uint32_t client);
    /* Appends Prometheus text lines for /metrics to buf (at most cap bytes); returns the count
     * written. May be NULL. */
    size_t (*metrics)(void *user, char *buf, size_t cap);
} net_callbacks;

/* Zero means default for every field. */
typedef struct net_desc {
    const char *listen;        /* address to bind; default "127.0.0.1"; "0.0.0.0" or "*" = all */
    int port;                  /* default NET_DEFAULT_PORT; NET_PORT_ANY = a free port */
    const char *web_dir;       /* folder served at "/"; NULL = no static files */
    const char *subprotocol;   /* the WebSocket subprotocol clients must ask for (required) */
    size_t max_message;        /* largest client text message; default 64 KiB (bigger: close 1009) */
    int text_queue;            /* queued text messages per client; default NET_DEFAULT_TEXT_QUEUE */
    int max_clients;           /* WebSocket clients at once; default NET_DEFAULT_MAX_CLIENTS; more: 503 */
    int ping_s;                /* seconds without a pong before the server pings; default 20, max 65534 */
    int hangup_s;              /* seconds without a pong before the client is dropped; > ping_s,
                                * max 65535; default ping_s + 10 (at most 65535) */
    int sndbuf;                /* kernel send buffer per client (SO_SNDBUF), bytes; default 256 KiB */
    /* Paths ("/collider.bin": '/' then letters, digits, '.', '_', '-'; under NET_MAX_BLOB_PATH
     * bytes; NULL ends the list early) served from memory: GET gives the bytes net_set_blob
     * last handed over (application/octet-stream, ETag, Cache-Control: no-cache; 304 for a
     * matching If-None-Match), or 404 while there are none. */
    const char *blobs[NET_MAX_BLOBS];
    /* Browser origins ("https://host:port", exact match) a WebSocket upgrade with an Origin
     * header must come from (403 otherwise); NULL-terminated, at most NET_MAX_ORIGINS; NULL =
     * any. An upgrade without Origin (not a browser) is not checked. */
    const char *const *allow_origins;
    /* PEM certificate and key: serve TLS only (https, wss); NULL = plain. Read at net_create. */
    const char *tls_cert, *tls_key;
    /* A path prefix ("/rooms/"; '/' first and last) under which every GET is answered with the
     * web folder's index.html (pages that one viewer serves under many names); NULL = none. */
    const char *page_prefix;
    net_callbacks cb;
} net_desc;

/* Creates the lws context and binds the port (so net_port works at once). The caller owns
 * *out and frees it with net_destroy. Any thread, before net_run. */
core_status net_create(net **out, const net_desc *d, core_err *err);

/* The bound TCP port. */
int net_port(const net *n);

/* The net thread's loop: serves until net_stop, then closes every client (1001 "server
 * shutting down") and returns. Call once. */
void net_run(net *n);

/* Asks net_run to return. Any thread (also from a signal-handling thread, not a handler). */
void net_stop(net *n);

/* Frees the context and everything queued. After net_run returned (or was never called). */
void net_destroy(net *n);

enum {
    NET_TEXT_DROPPABLE = 1 /* may be dropped when the client's queue is full (e.g. stats) */
};
/* Flag of an announcement of kind k (1..15) where only the latest matters (it carries the whole
 * current value): queueing one for a client drops that client's older queued message of the
 * same kind, and the new one goes to the back of the queue. */
#define NET_TEXT_LATEST(k) ((unsigned)(k) << 4)
#define NET_TEXT_KIND(flags) (((unsigned)(flags) >> 4) & 15u)

/* Queues a copy of text (len bytes) for one client or NET_ALL (ready clients only).
 * flags: NET_TEXT_DROPPABLE, NET_TEXT_LATEST(kind). A client whose queue is full loses its
 * oldest droppable message; with none to drop it is closed (1008, "send queue overflow").
 * Unknown or closed clients are ignored. Any thread.
 * Fails only when out of memory or the inbox is full. */
core_status net_send_text(net *n, uint32_t client, const char *text, size_t len, unsigned flags);

/* Makes a client ready: queues its first message (the hello), then delivers broadcasts and the
 * frames of `stream` to it, at most max_rate frames per second (0 = every frame). Any thread. */
core_status net_start_client(net *n, uint32_t client, const char *hello, size_t len, uint32_t stream, double max_rate);

#define NET_MAX_CLOSE_REASON 123 /* bytes of a close reason (a close frame's payload is at most 125) */

/* Closes a client once the text queued for it before this call has gone out (a message queued
 * after it is dropped, and it gets no more frames), with close code (1000..4999) and reason
 * (copied; cut to NET_MAX_CLOSE_REASON bytes at a UTF-8 boundary). Unknown clients are ignored.
 * Any thread. Fails only when out of memory or the inbox is full. */
core_status net_close_client(net *n, uint32_t client, int code, const char *reason);

/* Moves a ready client to another stream and/or rate; it gets that stream's keyframe first.
 * Any thread. */
core_status net_subscribe(net *n, uint32_t client, uint32_t stream, double max_rate);

/* Publishes a frame on stream (< NET_MAX_STREAMS), taking over the caller's reference.
 * seq must grow across every publish of the process. A keyframe replaces the stream's
 * retained keyframe; any other frame must decode given that keyframe. Each client is sent the
 * newest frame of its stream it has not seen (preceded by the keyframe when it lacks it);
 * older frames are skipped. Any thread. */
void net_publish(net *n, uint32_t stream, net_buf *frame, uint64_t seq, bool key);

/* Serves body at path (one of desc.blobs, or PAGE_PREFIX "SEGMENT/NAME" under desc.page_prefix:
 * such a path is added on its first use, up to NET_MAX_PAGE_BLOBS, and is served instead of the
 * page) from now on, taking over the caller's reference (NULL = 404 from now on), with etag (a version tag of the bytes, at most NET_MAX_ETAG bytes
 * of letters, digits, '.', '_', '-'; sent quoted). A request already being answered finishes
 * with the bytes it started with. CORE_EINVAL (the reference is dropped) for an unknown path
 * or a bad tag. Any thread; net knows nothing of what the bytes mean. */
core_status net_set_blob(net *n, const char *path, net_buf *body, const char *etag);

/* Forgets a stream's retained frames (after its last subscriber left). Any thread. */
void net_drop_stream(net *n, uint32_t stream);

/* Counters (monotonic) kept by the net thread; read from any thread. */
typedef struct net_stats {
    uint64_t clients;          /* connected WebSocket clients now */
    uint64_t frames_sent, frames_skipped, bytes_sent, text_sent, text_dropped;
    uint64_t text_coalesced;   /* announcements superseded in a client's queue by a newer one */
    uint64_t clients_refused;  /* upgrades answered 503 at max_clients */
    uint64_t text_queued_bytes; /* text bytes queued for all clients now (shared broadcasts counted per client) */
    uint64_t messages_in, protocol_closes, http_requests;
} net_stats;
void net_get_stats(net *n, net_stats *out);

#endif
