/* wsc: a small synchronous WebSocket client on libwebsockets (many connections, one thread). */
#include "wsc.h"

#include <libwebsockets.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>

typedef struct wsc_out {
    struct wsc_out *next;
    size_t len;
    int kind;
    unsigned char *buf; /* LWS_PRE + len */
} wsc_out;

struct wsc_conn {
    struct wsc_conn *next;
    wsc *w;
    struct lws *wsi;
    bool open, failed, closed;
    int close_code;
    char close_reason[128];
    wsc_out *out_head, *out_tail;
    unsigned char *rx;
    size_t rx_len, rx_cap;
    bool rx_binary;
    char **texts;
    size_t ntexts, cap_texts, read_at;
    uint64_t nbinary;
    wsc_binary_fn on_binary;
    void *user;
};

struct wsc {
    struct lws_context *ctx;
    struct lws_protocols protocols[3];
    wsc_conn *conns;
    lws_sorted_usec_list_t sul;
};

static void push_text(wsc_conn *c, const unsigned char *data, size_t len)
{
    if (c->ntexts == c->cap_texts) {
        c->cap_texts = c->cap_texts ? 2 * c->cap_texts : 64;
        c->texts = realloc(c->texts, c->cap_texts * sizeof *c->texts);
    }
    char *t = malloc(len + 1);
    memcpy(t, data, len);
    t[len] = '\0';
    c->texts[c->ntexts++] = t;
}

static int callback(struct lws *wsi, enum lws_callback_reasons reason, void *user, void *in, size_t len)
{
    (void)user;
    wsc_conn *c = lws_get_opaque_user_data(wsi);
    switch (reason) {
    case LWS_CALLBACK_CLIENT_ESTABLISHED:
        if (c) {
            c->open = true;
            if (c->out_head) lws_callback_on_writable(wsi);
        }
        return 0;
    case LWS_CALLBACK_CLIENT_CONNECTION_ERROR:
        if (c) {
            c->failed = true;
            c->wsi = NULL;
            snprintf(c->close_reason, sizeof c->close_reason, "%s", in ? (const char *)in : "connection error");
        }
        return 0;
    case LWS_CALLBACK_WS_PEER_INITIATED_CLOSE:
        if (c && len >= 2) {
            const unsigned char *p = in;
            c->close_code = (p[0] << 8) | p[1];
            snprintf(c->close_reason, sizeof c->close_reason, "%.*s", (int)(len - 2), (const char *)p + 2);
        }
        return 0;
    case LWS_CALLBACK_CLIENT_CLOSED:
        if (c) {
            c->closed = true;
            c->open = false;
            c->wsi = NULL;
        }
        return 0;
    case LWS_CALLBACK_CLIENT_RECEIVE:
        if (!c) return 0;
        if (lws_is_first_fragment(wsi)) {
            c->rx_len = 0;
            c->rx_binary = lws_frame_is_binary(wsi);
        }
        if (c->rx_len + len > c->rx_cap) {
            c->rx_cap = (c->rx_len + len) * 2;
            c->rx = realloc(c->rx, c->rx_cap);
        }
        memcpy(c->rx + c->rx_len, in, len);
        c->rx_len += len;
        if (!lws_is_final_fragment(wsi) || lws_remaining_packet_payload(wsi)) return 0;
        if (c->rx_binary) {
            c->nbinary++;
            if (c->on_binary) c->on_binary(c, c->rx, c->rx_len, c->user);
        } else {
            push_text(c, c->rx, c->rx_len);
        }
        c->rx_len = 0;
        return 0;
    case LWS_CALLBACK_CLIENT_WRITEABLE: {
        if (!c || !c->out_head) return 0;
        wsc_out *o = c->out_head;
        c->out_head = o->next;
        if (!c->out_head) c->out_tail = NULL;
        int w = lws_write(wsi, o->buf + LWS_PRE, o->len, (enum lws_write_protocol)o->kind);
        free(o->buf);
        free(o);
        if (w < 0) return -1;
        if (c->out_head) lws_callback_on_writable(wsi);
        return 0;
    }
    default: return 0;
    }
}

/* One GET in progress (wsc_http_get): the connection's opaque user data until the exchange
 * ends, when the connection is detached from it (wsi NULL) and left to lws to close. */
typedef struct http_get {
    wsc_http_reply *r;
    size_t max;
    struct lws *wsi;
    bool done; /* the response is complete, or the exchange failed (r->error set) */
} http_get;

static void http_fail(http_get *g, const char *msg)
{
    if (g->done) return;
    snprintf(g->r->error, sizeof g->r->error, "%s", msg);
    g->done = true;
}

/* Ends the exchange on g's side: lws may close or free the connection from now on. Returns
 * the callback's answer: -1 closes the connection. */
static int http_detach(http_get *g, int rc)
{
    if (g->wsi) lws_set_opaque_user_data(g->wsi, NULL);
    g->wsi = NULL;
    g->done = true;
    return rc;
}

/* Appends a piece of the body; false (the GET failed) past the cap. */
static bool http_take(http_get *g, const void *in, size_t len)
{
    wsc_http_reply *r = g->r;
    char msg[96];
    if (len > g->max - r->len) {
        snprintf(msg, sizeof msg, "the body exceeds the %zu-byte limit", g->max);
        http_fail(g, msg);
        return false;
    }
    uint8_t *b = realloc(r->body, r->len + len);
    if (!b) {
        snprintf(msg, sizeof msg, "out of memory for a %zu-byte body", r->len + len);
        http_fail(g, msg);
        return false;
    }
    memcpy(b + r->len, in, len);
    r->body = b;
    r->len += len;
    return true;
}

static int http_callback(struct lws *wsi, enum lws_callback_reasons reason, void *user, void *in, size_t len)
{
    (void)user;
    http_get *g = lws_get_opaque_user_data(wsi);
    char msg[160];
    switch (reason) {
    case LWS_CALLBACK_CLIENT_CONNECTION_ERROR:
        if (!g) return 0;
        snprintf(msg, sizeof msg, "cannot connect: %s", in ? (const char *)in : "connection error");
        http_fail(g, msg);
        return http_detach(g, 0);
    case LWS_CALLBACK_ESTABLISHED_CLIENT_HTTP: {
        if (!g) return -1;
        g->r->status = (int)lws_http_client_http_response(wsi);
        char cl[32];
        if (lws_hdr_copy(wsi, cl, sizeof cl, WSI_TOKEN_HTTP_CONTENT_LENGTH) > 0) {
            unsigned long long n = strtoull(cl, NULL, 10);
            if (n > g->max) {
                snprintf(msg, sizeof msg, "Content-Length %llu exceeds the %zu-byte limit", n, g->max);
                http_fail(g, msg);
                return http_detach(g, -1);
            }
        }
        return 0;
    }
    case LWS_CALLBACK_RECEIVE_CLIENT_HTTP_READ:
        if (!g) return -1;
        return http_take(g, in, len) ? 0 : http_detach(g, -1);
    case LWS_CALLBACK_RECEIVE_CLIENT_HTTP: {
        char buf[LWS_PRE + 16384], *p = buf + LWS_PRE;
        int n = sizeof buf - LWS_PRE;
        return lws_http_client_read(wsi, &p, &n) < 0 ? -1 : 0;
    }
    case LWS_CALLBACK_COMPLETED_CLIENT_HTTP:
        return g ? http_detach(g, -1) : -1; /* one request per connection: no keep-alive */
    case LWS_CALLBACK_CLOSED_CLIENT_HTTP:
        if (!g) return 0;
        http_fail(g, "the server closed the connection before the response was complete");
        return http_detach(g, 0);
    default: return 0;
    }
}

wsc *wsc_new(void)
{
    wsc *w = calloc(1, sizeof *w);
    lws_set_log_level(LLL_ERR, NULL);
    w->protocols[0] = (struct lws_protocols){ "wsc", callback, 0, 65536, 0, NULL, 0 };
    w->protocols[1] = (struct lws_protocols){ "wsc-http", http_callback, 0, 0, 0, NULL, 0 };
    struct lws_context_creation_info info;
    memset(&info, 0, sizeof info);
    info.port = CONTEXT_PORT_NO_LISTEN;
    info.options = LWS_SERVER_OPTION_DO_SSL_GLOBAL_INIT; /* wss:// (wsc_connect_tls) */
    info.protocols = w->protocols;
    w->ctx = lws_create_context(&info);
    if (!w->ctx) {
        free(w);
        return NULL;
    }
    return w;
}

static void free_conn(wsc_conn *c)
{
    while (c->out_head) {
        wsc_out *o = c->out_head;
        c->out_head = o->next;
        free(o->buf);
        free(o);
    }
    for (size_t i = 0; i < c->ntexts; i++) free(c->texts[i]);
    free(c->texts);
    free(c->rx);
    free(c);
}

void wsc_free(wsc *w)
{
    if (!w) return;
    lws_sul_cancel(&w->sul);
    for (wsc_conn *c = w->conns; c; c = c->next)
        if (c->wsi) lws_set_opaque_user_data(c->wsi, NULL);
    lws_context_destroy(w->ctx);
    while (w->conns) {
        wsc_conn *c = w->conns;
        w->conns = c->next;
        free_conn(c);
    }
    free(w);
}

wsc_conn *wsc_connect(wsc *w, int port, const char *subprotocol, wsc_binary_fn on_binary, void *user)
{
    return wsc_connect_host(w, "127.0.0.1", port, NULL, subprotocol, on_binary, user);
}

/* A connection to host:port at path, over TLS when tls (any certificate accepted: tests only). */
static wsc_conn *connect_to(wsc *w, const char *host, int port, const char *path, bool tls, const char *subprotocol,
                            wsc_binary_fn on_binary, void *user)
{
    wsc_conn *c = calloc(1, sizeof *c);
    if (!c) return NULL;
    c->w = w;
    c->on_binary = on_binary;
    c->user = user;
    c->next = w->conns;
    w->conns = c;
    struct lws_client_connect_info ci;
    memset(&ci, 0, sizeof ci);
    ci.context = w->ctx;
    ci.address = host;
    ci.port = port;
    ci.path = path;
    ci.host = host;
    ci.origin = host;
    ci.protocol = subprotocol;
    ci.local_protocol_name = "wsc";
    ci.opaque_user_data = c;
    ci.pwsi = &c->wsi;
    if (tls) ci.ssl_connection = LCCSCF_USE_SSL | LCCSCF_ALLOW_SELFSIGNED | LCCSCF_SKIP_SERVER_CERT_HOSTNAME_CHECK;
    if (!lws_client_connect_via_info(&ci)) c->failed = true;
    return c;
}

wsc_conn *wsc_connect_host(wsc *w, const char *host, int port, const char *path, const char *subprotocol,
                           wsc_binary_fn on_binary, void *user)
{
    return connect_to(w, host, port, path ? path : "/", false, subprotocol, on_binary, user);
}

wsc_conn *wsc_connect_path(wsc *w, int port, const char *path, const char *subprotocol, wsc_binary_fn on_binary, void *user)
{
    return connect_to(w, "127.0.0.1", port, path, false, subprotocol, on_binary, user);
}

wsc_conn *wsc_connect_tls(wsc *w, int port, const char *subprotocol, wsc_binary_fn on_binary, void *user)
{
    return connect_to(w, "127.0.0.1", port, "/", true, subprotocol, on_binary, user);
}

static unsigned long long now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (unsigned long long)ts.tv_sec * 1000ull + (unsigned long long)ts.tv_nsec / 1000000ull;
}

static void wake(lws_sorted_usec_list_t *sul) { (void)sul; }

bool wsc_until(wsc *w, bool (*pred)(void *arg), void *arg, int timeout_ms)
{
    unsigned long long end = now_ms() + (unsigned long long)timeout_ms;
    for (;;) {
        if (pred && pred(arg)) return true;
        unsigned long long t = now_ms();
        if (t >= end) return pred ? pred(arg) : true;
        unsigned long long wait = end - t < 20 ? end - t : 20;
        lws_sul_schedule(w->ctx, 0, &w->sul, wake, (lws_usec_t)wait * 1000);
        lws_service(w->ctx, 0);
    }
}

void wsc_run(wsc *w, int ms) { wsc_until(w, NULL, NULL, ms); }

static bool open_or_done(void *arg)
{
    wsc_conn *c = arg;
    return c->open || c->failed || c->closed;
}

bool wsc_wait_open(wsc *w, wsc_conn *c, int timeout_ms)
{
    wsc_until(w, open_or_done, c, timeout_ms);
    return c->open;
}

static bool is_closed(void *arg)
{
    wsc_conn *c = arg;
    return c->closed || c->failed;
}

int wsc_wait_closed(wsc *w, wsc_conn *c, int timeout_ms)
{
    if (!wsc_until(w, is_closed, c, timeout_ms)) return -1;
    return c->close_code;
}

static void queue(wsc_conn *c, const void *data, size_t len, int kind)
{
    wsc_out *o = calloc(1, sizeof *o);
    o->buf = malloc(LWS_PRE + len + 1);
    memcpy(o->buf + LWS_PRE, data, len);
    o->len = len;
    o->kind = kind;
    if (c->out_tail) c->out_tail->next = o;
    else c->out_head = o;
    c->out_tail = o;
    if (c->wsi && c->open) lws_callback_on_writable(c->wsi);
}

void wsc_send_text(wsc_conn *c, const char *text) { queue(c, text, strlen(text), LWS_WRITE_TEXT); }

void wsc_send_frame(wsc_conn *c, const void *data, size_t len, bool binary, bool continuation, bool fin)
{
    int kind = continuation ? LWS_WRITE_CONTINUATION : binary ? LWS_WRITE_BINARY : LWS_WRITE_TEXT;
    if (!fin) kind |= LWS_WRITE_NO_FIN;
    queue(c, data, len, kind);
}

void wsc_read_enable(wsc_conn *c, bool on)
{
    if (c->wsi) lws_rx_flow_control(c->wsi, on ? 1 : 0);
}

void wsc_small_rcvbuf(wsc_conn *c, int bytes)
{
    if (c->wsi) setsockopt(lws_get_socket_fd(c->wsi), SOL_SOCKET, SO_RCVBUF, &bytes, sizeof bytes);
}

char *const *wsc_texts(wsc_conn *c, size_t *count)
{
    *count = c->ntexts;
    return c->texts;
}

const char *wsc_last_text(wsc_conn *c)
{
    return c->ntexts ? c->texts[c->ntexts - 1] : "";
}

typedef struct find_arg {
    wsc_conn *c;
    const char *type;
    const char *found;
} find_arg;

static bool find_type(void *arg)
{
    find_arg *f = arg;
    char pat[96];
    snprintf(pat, sizeof pat, "\"type\":\"%s\"", f->type);
    while (f->c->read_at < f->c->ntexts) {
        const char *t = f->c->texts[f->c->read_at++];
        if (strstr(t, pat)) {
            f->found = t;
            return true;
        }
    }
    return false;
}

const char *wsc_next_of_type(wsc *w, wsc_conn *c, const char *type, int timeout_ms)
{
    find_arg f = { c, type, NULL };
    wsc_until(w, find_type, &f, timeout_ms);
    return f.found;
}

static bool http_done(void *arg) { return ((const http_get *)arg)->done; }

bool wsc_http_get(wsc *w, const wsc_http_desc *d, wsc_http_reply *r)
{
    memset(r, 0, sizeof *r);
    http_get g = { r, d->max_bytes ? d->max_bytes : WSC_HTTP_MAX_BYTES, NULL, false };
    const char *host = d->host ? d->host : "127.0.0.1";
    int timeout = d->timeout_ms > 0 ? d->timeout_ms : 5000;
    char msg[160];
    struct lws_client_connect_info ci;
    memset(&ci, 0, sizeof ci);
    ci.context = w->ctx;
    ci.address = host;
    ci.port = d->port;
    ci.path = d->path ? d->path : "/";
    ci.host = host;
    ci.origin = host;
    ci.method = "GET";
    ci.alpn = "http/1.1";
    ci.local_protocol_name = "wsc-http";
    ci.opaque_user_data = &g;
    ci.pwsi = &g.wsi;
    if (d->tls) ci.ssl_connection = LCCSCF_USE_SSL | LCCSCF_ALLOW_SELFSIGNED | LCCSCF_SKIP_SERVER_CERT_HOSTNAME_CHECK;
    if (!lws_client_connect_via_info(&ci)) {
        g.wsi = NULL; /* scrubbed by lws */
        snprintf(msg, sizeof msg, "cannot connect to %s:%d", host, d->port);
        http_fail(&g, msg);
    }
    if (!wsc_until(w, http_done, &g, timeout)) {
        snprintf(msg, sizeof msg, "no complete response from %s:%d%s in %d ms", host, d->port, ci.path, timeout);
        http_fail(&g, msg);
    }
    if (g.wsi) { /* timed out with the connection open: it must not reach g once this returns */
        lws_set_opaque_user_data(g.wsi, NULL);
        lws_set_timeout(g.wsi, PENDING_TIMEOUT_CLOSE_SEND, LWS_TO_KILL_ASYNC);
    }
    if (!r->error[0]) return true;
    free(r->body);
    r->body = NULL;
    r->len = 0;
    return false;
}

void wsc_http_reply_free(wsc_http_reply *r)
{
    free(r->body);
    memset(r, 0, sizeof *r);
}

uint64_t wsc_binary_count(const wsc_conn *c) { return c->nbinary; }
bool wsc_is_open(const wsc_conn *c) { return c->open; }
bool wsc_failed(const wsc_conn *c) { return c->failed; }
int wsc_close_code(const wsc_conn *c) { return c->close_code; }
const char *wsc_close_reason(const wsc_conn *c) { return c->close_reason; }
