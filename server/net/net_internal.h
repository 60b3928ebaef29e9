/* net: internal state shared by the net module's files (server, sessions, HTTP, buffers). */
#ifndef NET_NET_INTERNAL_H
#define NET_NET_INTERNAL_H

#include <libwebsockets.h>
#include <pthread.h>
#include <stdatomic.h>

#include "net.h"

/* Frames longer than this go out as WebSocket fragments of at most this many bytes, one per
 * WRITEABLE: lws copies what the socket does not take of a write, so a client that reads
 * slowly (or never) holds at most one fragment, not a whole keyframe. */
#define NET_FRAME_CHUNK (16 * 1024)

struct net_buf {
    atomic_int refs;
    size_t len;
    unsigned char mem[]; /* LWS_PRE bytes of headroom, then len bytes of data */
};

typedef enum net_ev_kind { NET_EV_TEXT, NET_EV_START, NET_EV_SUBSCRIBE, NET_EV_FRAME, NET_EV_DROP, NET_EV_CLOSE } net_ev_kind;

/* One post from another thread, applied in order on the net thread. */
typedef struct net_event {
    struct net_event *next;
    net_ev_kind kind;
    uint32_t client;   /* TEXT, START, SUBSCRIBE, CLOSE */
    uint32_t stream;   /* START, SUBSCRIBE, FRAME, DROP */
    unsigned flags;    /* TEXT; CLOSE: the close code */
    double max_rate;   /* START, SUBSCRIBE */
    net_buf *buf;      /* TEXT, START (hello), FRAME, CLOSE (the reason) */
    uint64_t seq;      /* FRAME */
    bool key;          /* FRAME */
    uint32_t merged;   /* FRAME: older frames this one replaced in the inbox (never sent) */
} net_event;

/* A stream's newest frame and its retained keyframe (net thread only). */
typedef struct net_stream {
    net_buf *latest, *key;
    uint64_t latest_seq, latest_key_seq, key_seq;
    uint64_t count;       /* frames published on the stream; the latest is number `count` */
    uint64_t key_count;   /* the retained keyframe's number */
} net_stream;

/* One WebSocket connection (lws per-session data, net thread only). */
typedef struct net_session {
    struct net_session *next, *prev;
    struct lws *wsi;
    uint32_t client;
    bool ready;           /* got its hello: receives broadcasts and frames */
    bool closing;         /* close with close_code at the next WRITEABLE */
    int close_code;
    const char *close_reason;
    bool linger;          /* closing: its queued text goes out first (net_close_client) */
    char close_text[NET_MAX_CLOSE_REASON + 1]; /* net_close_client's reason */
    /* text queue (ring of qcap) */
    net_buf **q;
    unsigned char *qflags;
    int qcap, qhead, qlen;
    /* frames */
    uint32_t stream;
    double max_rate;
    uint64_t next_due_ns;
    uint64_t last_count;  /* count of the last frame sent from its stream; 0 = none */
    bool has_key;
    uint64_t key_seq;     /* seq of the keyframe it holds */
    /* a frame over NET_FRAME_CHUNK bytes being written in fragments (nothing else is sent
     * to this client until its last fragment is out) */
    net_buf *tx;
    size_t tx_off;
    /* receive reassembly */
    char *rx;
    size_t rx_len, rx_cap;
} net_session;

/* HTTP per-request data (the /metrics body, or a blob being sent). */
typedef struct net_http {
    char *body;
    size_t len;
    net_buf *blob;        /* a reference held until the last chunk is written */
    size_t off;           /* blob bytes written */
} net_http;

/* A blob served from memory (guarded by net.lock). */
typedef struct net_blob {
    char path[NET_MAX_BLOB_PATH];
    char etag[NET_MAX_ETAG + 3]; /* quoted */
    net_buf *body;
} net_blob;

struct net {
    struct lws_context *ctx;
    struct lws_vhost *vhost;
    net_desc desc;
    char *listen, *web_dir, *subprotocol;
    char origins[NET_MAX_ORIGINS][NET_MAX_ORIGIN]; /* allowed browser origins */
    int norigins;                                  /* 0: any */
    lws_retry_bo_t retry;
    struct lws_protocols protocols[3];
    struct lws_http_mount mounts[3 + NET_MAX_BLOBS]; /* /metrics, files, the blobs, the page prefix */
    char page_prefix[NET_MAX_BLOB_PATH];  /* desc.page_prefix ("" = none) */
    net_blob blobs[NET_MAX_BLOBS];     /* guarded by lock */
    int nblobs;
    net_blob *page_blobs;              /* NET_MAX_PAGE_BLOBS paths under the page prefix; guarded by lock */
    int npage_blobs;
    struct lws_protocol_vhost_options mimes[12];
    int port;
    atomic_bool stop;

    pthread_mutex_t lock;              /* guards the inbox */
    net_event *in_head, *in_tail;
    size_t in_count;
    net_event *pending_frame[NET_MAX_STREAMS]; /* newest non-key frame event still in the inbox */

    /* net thread only */
    unsigned char *scratch;            /* LWS_PRE + NET_FRAME_CHUNK bytes: the fragment being written */
    net_session *sessions;
    uint32_t next_client;
    net_stream streams[NET_MAX_STREAMS];
    lws_sorted_usec_list_t shutdown_sul;
    bool shutting_down;

    atomic_uint_fast64_t clients, frames_sent, frames_skipped, bytes_sent, text_sent, text_dropped, text_coalesced, clients_refused;
    atomic_size_t text_queued_bytes; /* bytes of the text messages queued for every client now */
    atomic_uint_fast64_t messages_in, protocol_closes, http_requests;
};

/* lws protocol callbacks. */
int net_ws_callback(struct lws *wsi, enum lws_callback_reasons reason, void *user, void *in, size_t len);
int net_http_callback(struct lws *wsi, enum lws_callback_reasons reason, void *user, void *in, size_t len);

/* The raw-socket callbacks (RAW_RX, RAW_WRITEABLE, RAW_CLOSE) of a request whose method the
 * server does not implement: answers 501 with the reason (400 for bytes that are no request
 * line) and closes (net_method.c). */
int net_method_callback(struct lws *wsi, enum lws_callback_reasons reason, net_http *h, void *in, size_t len);

/* Checks desc.blobs and copies them into n->blobs. CORE_EINVAL for a bad path. */
core_status net_blobs_init(net *n, core_err *err);
/* Releases every blob body. */
void net_blobs_free(net *n);
/* True when path is a blob path under the page prefix that net_set_blob has added. */
bool net_page_blob_known(net *n, const char *path);
/* HTTP for a blob path: headers (200 or 304) or 404; the body follows in net_blob_write. */
int net_blob_headers(net *n, struct lws *wsi, net_http *h, const char *uri);
/* Writes the next chunk of the blob body (on HTTP_WRITEABLE). */
int net_blob_write(struct lws *wsi, net_http *h);

/* Applies every queued post (net thread), then asks for WRITEABLE where there is work. */
void net_drain(net *n);

/* Asks for WRITEABLE if the session has text or a newer frame to send (net thread). */
void net_session_kick(net *n, net_session *s);

/* Queues a text buffer (takes a reference) on a session, enforcing the queue bound. */
void net_session_enqueue(net *n, net_session *s, net_buf *b, unsigned flags);

/* Starts a server-side close of s with a WebSocket close code (net thread). */
void net_session_close(net_session *s, int code, const char *reason);

/* True when the comma-separated list (blanks around items ignored) contains token. Pure. */
bool net_token_listed(const char *list, const char *token);

#endif
