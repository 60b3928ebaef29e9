/* wsc: a small synchronous WebSocket client on libwebsockets (many connections, one thread), for
 * strandcastc, the integration tests and strandbench fanout. Every call is made on the one thread
 * that owns the wsc; nothing here is shared with the daemon's net module. */
#ifndef WSC_WSC_H
#define WSC_WSC_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef struct wsc wsc;
typedef struct wsc_conn wsc_conn;

/* Called for every complete binary message (data valid during the call). */
typedef void (*wsc_binary_fn)(wsc_conn *c, const uint8_t *data, size_t len, void *user);

/* A client context; NULL on failure. */
wsc *wsc_new(void);
/* Closes every connection and frees everything. */
void wsc_free(wsc *w);

/* Starts a connection to 127.0.0.1:port asking for subprotocol (NULL = none); on_binary (may be
 * NULL) gets user. The wsc owns the connection (freed by wsc_free). NULL when out of memory. */
wsc_conn *wsc_connect(wsc *w, int port, const char *subprotocol, wsc_binary_fn on_binary, void *user);
/* The same to host (an IP address or a name) at the request path ("/rooms/NAME"; NULL = "/");
 * both strings must outlive the connection attempt. */
wsc_conn *wsc_connect_host(wsc *w, const char *host, int port, const char *path, const char *subprotocol,
                           wsc_binary_fn on_binary, void *user);

/* wsc_connect to the request path ("/rooms/NAME"; the string must outlive the connection attempt). */
wsc_conn *wsc_connect_path(wsc *w, int port, const char *path, const char *subprotocol, wsc_binary_fn on_binary, void *user);

/* wsc_connect over TLS (wss://), accepting any certificate (self-signed test certificates). */
wsc_conn *wsc_connect_tls(wsc *w, int port, const char *subprotocol, wsc_binary_fn on_binary, void *user);

/* Runs the event loop until pred(arg) is true or timeout_ms passes; returns pred's last value. */
bool wsc_until(wsc *w, bool (*pred)(void *arg), void *arg, int timeout_ms);
/* Runs the event loop for ms milliseconds. */
void wsc_run(wsc *w, int ms);
/* Waits until c is open (true) or failed/closed/timed out (false). */
bool wsc_wait_open(wsc *w, wsc_conn *c, int timeout_ms);
/* Waits until c is closed by the peer; returns the close code (0 if none, -1 on timeout). */
int wsc_wait_closed(wsc *w, wsc_conn *c, int timeout_ms);

/* Queues a text message (copied). */
void wsc_send_text(wsc_conn *c, const char *text);
/* Queues raw bytes as one WebSocket frame: binary or text, and whether it ends the message
 * (a non-final text frame is followed by continuation frames queued with text = false
 * and continuation = true). */
void wsc_send_frame(wsc_conn *c, const void *data, size_t len, bool binary, bool continuation, bool fin);

/* Stops (false) or resumes (true) reading from the socket. */
void wsc_read_enable(wsc_conn *c, bool on);

/* Shrinks the socket's receive buffer (so a client that stops reading backs up the server). */
void wsc_small_rcvbuf(wsc_conn *c, int bytes);

/* Received text messages in order; *count set. Owned by the connection. */
char *const *wsc_texts(wsc_conn *c, size_t *count);
/* The last text message c received (what a server said before refusing it), or "" when none;
 * owned by c. */
const char *wsc_last_text(wsc_conn *c);
/* Waits for the next unread text message whose "type" is type, consuming the unread messages
 * before it; returns it (owned by c) or NULL on timeout. */
const char *wsc_next_of_type(wsc *w, wsc_conn *c, const char *type, int timeout_ms);

/* An HTTP GET (wsc_http_get). Zero means the default. */
typedef struct wsc_http_desc {
    const char *host;   /* an IP address or a name; NULL: 127.0.0.1 */
    int port;           /* required */
    bool tls;           /* https://, accepting any certificate (as wsc_connect_tls) */
    const char *path;   /* "/groom.bin"; NULL: "/" */
    size_t max_bytes;   /* the largest body taken; default WSC_HTTP_MAX_BYTES */
    int timeout_ms;     /* the whole exchange; default 5000 */
} wsc_http_desc;

#define WSC_HTTP_MAX_BYTES ((size_t)64 << 20)

/* A GET's answer: the status and the body (malloc'd, owned by the caller: wsc_http_reply_free). */
typedef struct wsc_http_reply {
    int status;        /* 200, 404, ...; 0 when no response came */
    uint8_t *body;     /* len bytes, NULL when empty */
    size_t len;
    char error[192];   /* why wsc_http_get failed ("" when it did not) */
} wsc_http_reply;

/* GETs d->path from d->host:d->port on its own connection and runs w's event loop (every other
 * connection of w is served meanwhile) until the whole response is in. True with any status
 * (the caller judges it) and the body; false, with the reason in r->error and no body, when the
 * connection fails, the response is cut short, its body (by Content-Length or as it arrives)
 * would exceed max_bytes, or timeout_ms passes. r is overwritten. Not to be called from inside
 * a callback of w (an on_binary): use a second wsc there. */
bool wsc_http_get(wsc *w, const wsc_http_desc *d, wsc_http_reply *r);
/* Frees r's body and zeroes r. */
void wsc_http_reply_free(wsc_http_reply *r);

uint64_t wsc_binary_count(const wsc_conn *c);
bool wsc_is_open(const wsc_conn *c);
bool wsc_failed(const wsc_conn *c);
int wsc_close_code(const wsc_conn *c);
const char *wsc_close_reason(const wsc_conn *c);

#endif
