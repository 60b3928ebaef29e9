/* net: the lws context (one vhost: files, /metrics, blobs, WebSocket), its loop, and the ordered inbox. */
#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "net_internal.h"

static void lws_log_to_core(int level, const char *line)
{
    size_t n = strlen(line);
    while (n && (line[n - 1] == '\n' || line[n - 1] == '\r')) n--;
    core_log(level == LLL_ERR ? CORE_LOG_ERROR : CORE_LOG_WARN, "lws", "%.*s", (int)n, line);
}

static char *dup_or_null(const char *s)
{
    if (!s) return NULL;
    size_t n = strlen(s) + 1;
    char *d = malloc(n);
    if (d) memcpy(d, s, n);
    return d;
}

/* The listen address must be an IP literal of this machine (lws would otherwise fall back to
 * every interface, or to not listening at all). */
static core_status check_listen(const char *addr, core_err *err)
{
    struct sockaddr_storage ss;
    memset(&ss, 0, sizeof ss);
    socklen_t len;
    int family;
    if (inet_pton(AF_INET, addr, &((struct sockaddr_in *)&ss)->sin_addr) == 1) {
        family = AF_INET;
        len = sizeof(struct sockaddr_in);
    } else if (inet_pton(AF_INET6, addr, &((struct sockaddr_in6 *)&ss)->sin6_addr) == 1) {
        family = AF_INET6;
        len = sizeof(struct sockaddr_in6);
    } else {
        return core_fail(err, CORE_EINVAL, "net: listen address \"%s\" is not an IPv4 or IPv6 address", addr);
    }
    ss.ss_family = (sa_family_t)family;
    int fd = socket(family, SOCK_STREAM, 0);
    if (fd < 0) return core_fail(err, CORE_EIO, "net: cannot open a socket: %s", strerror(errno));
    int rc = bind(fd, (struct sockaddr *)&ss, len);
    int e = errno;
    close(fd);
    if (rc != 0) return core_fail(err, CORE_EIO, "net: cannot listen on %s: %s", addr, strerror(e));
    return CORE_OK;
}

static void setup_mounts(net *n)
{
    static const char *const mime[][2] = {
        { ".html", "text/html; charset=utf-8" }, { ".js", "text/javascript; charset=utf-8" },
        { ".mjs", "text/javascript; charset=utf-8" }, { ".wasm", "application/wasm" },
        { ".json", "application/json" }, { ".css", "text/css; charset=utf-8" },
        { ".svg", "image/svg+xml" }, { ".png", "image/png" }, { ".bin", "application/octet-stream" },
        { ".md", "text/markdown; charset=utf-8" }, { ".txt", "text/plain; charset=utf-8" },
        { "*", "application/octet-stream" },
    };
    size_t nm = sizeof mime / sizeof mime[0];
    for (size_t i = 0; i < nm; i++) {
        n->mimes[i].next = i + 1 < nm ? &n->mimes[i + 1] : NULL;
        n->mimes[i].name = mime[i][0];
        n->mimes[i].value = mime[i][1];
    }
    struct lws_http_mount *metrics = &n->mounts[0], *files = &n->mounts[1];
    metrics->mountpoint = "/metrics";
    metrics->mountpoint_len = 8;
    metrics->origin = "http";
    metrics->origin_protocol = LWSMPRO_CALLBACK;
    struct lws_http_mount *last = metrics;
    for (int i = 0; i < n->nblobs; i++) { /* the blob paths: the same callback as /metrics */
        struct lws_http_mount *b = &n->mounts[2 + i];
        b->mountpoint = n->blobs[i].path;
        b->mountpoint_len = (unsigned char)strlen(n->blobs[i].path);
        b->origin = "http";
        b->origin_protocol = LWSMPRO_CALLBACK;
        last->mount_next = b;
        last = b;
    }
    if (n->page_prefix[0]) { /* the pages and blobs under the prefix: also that callback */
        struct lws_http_mount *p = &n->mounts[2 + NET_MAX_BLOBS];
        p->mountpoint = n->page_prefix;
        p->mountpoint_len = (unsigned char)(strlen(n->page_prefix) - 1); /* without its last '/' */
        p->origin = "http";
        p->origin_protocol = LWSMPRO_CALLBACK;
        last->mount_next = p;
        last = p;
    }
    if (n->web_dir) {
        last->mount_next = files;
        files->mountpoint = "/";
        files->mountpoint_len = 1;
        files->origin = n->web_dir;
        files->def = "index.html";
        files->origin_protocol = LWSMPRO_FILE;
        files->extra_mimetypes = &n->mimes[0];
        files->cache_max_age = 0;
        files->cache_revalidate = 1;
    }
}

core_status net_create(net **out, const net_desc *d, core_err *err)
{
    *out = NULL;
    if (!d->subprotocol || !*d->subprotocol) return core_fail(err, CORE_EINVAL, "net: a subprotocol name is required");
    if (d->port < NET_PORT_ANY || d->port > 65535)
        return core_fail(err, CORE_EINVAL, "net: port %d is outside [0, 65535]", d->port);
    const char *listen = d->listen && *d->listen ? d->listen : "127.0.0.1";
    if (strcmp(listen, "localhost") == 0) listen = "127.0.0.1";
    if (strcmp(listen, "0.0.0.0") == 0 || strcmp(listen, "*") == 0) listen = NULL;
    if (d->ping_s < 0 || d->ping_s >= NET_MAX_HANGUP_S)
        return core_fail(err, CORE_EINVAL, "net: ping interval %d s is outside [1, %d]", d->ping_s, NET_MAX_HANGUP_S - 1);
    int ping_s = d->ping_s ? d->ping_s : NET_DEFAULT_PING_S;
    int hangup_s = d->hangup_s;
    if (!hangup_s) {
        hangup_s = ping_s + NET_DEFAULT_HANGUP_EXTRA_S;
        if (hangup_s > NET_MAX_HANGUP_S) hangup_s = NET_MAX_HANGUP_S;
    }
    /* lws asserts hangup > ping: past the ping it waits hangup - ping more seconds for a pong */
    if (hangup_s <= ping_s || hangup_s > NET_MAX_HANGUP_S)
        return core_fail(err, CORE_EINVAL,
                         "net: hangup time %d s must be longer than the ping interval (%d s) and at most %d s", hangup_s,
                         ping_s, NET_MAX_HANGUP_S);
    core_status st = listen ? check_listen(listen, err) : CORE_OK;
    if (st != CORE_OK) return st;
    net *n = calloc(1, sizeof *n);
    if (!n) return core_fail(err, CORE_ENOMEM, "net: out of memory");
    n->desc = *d;
    if (!n->desc.max_message) n->desc.max_message = NET_DEFAULT_MAX_MESSAGE;
    if (n->desc.text_queue <= 0) n->desc.text_queue = NET_DEFAULT_TEXT_QUEUE;
    if (n->desc.max_clients <= 0) n->desc.max_clients = NET_DEFAULT_MAX_CLIENTS;
    n->desc.ping_s = ping_s;
    n->desc.hangup_s = hangup_s;
    if (n->desc.sndbuf <= 0) n->desc.sndbuf = NET_DEFAULT_SNDBUF;
    n->listen = dup_or_null(listen);
    n->web_dir = dup_or_null(d->web_dir);
    n->subprotocol = dup_or_null(d->subprotocol);
    n->scratch = malloc(LWS_PRE + NET_FRAME_CHUNK);
    if ((listen && !n->listen) || (d->web_dir && !n->web_dir) || !n->subprotocol || !n->scratch) {
        net_destroy(n);
        return core_fail(err, CORE_ENOMEM, "net: out of memory");
    }
    n->desc.listen = n->listen;
    n->desc.web_dir = n->web_dir;
    n->desc.subprotocol = n->subprotocol;
    n->desc.allow_origins = NULL;
    n->desc.tls_cert = n->desc.tls_key = NULL;
    for (const char *const *o = d->allow_origins; o && *o; o++) {
        if (n->norigins == NET_MAX_ORIGINS || strlen(*o) >= NET_MAX_ORIGIN) {
            net_destroy(n);
            return core_fail(err, CORE_EINVAL, "net: at most %d allowed origins of under %d bytes", NET_MAX_ORIGINS,
                             NET_MAX_ORIGIN);
        }
        snprintf(n->origins[n->norigins++], NET_MAX_ORIGIN, "%s", *o);
    }
    if (d->page_prefix) {
        size_t k = strlen(d->page_prefix);
        if (k < 3 || k >= sizeof n->page_prefix || d->page_prefix[0] != '/' || d->page_prefix[k - 1] != '/') {
            net_destroy(n);
            return core_fail(err, CORE_EINVAL, "net: page prefix \"%s\" must be /NAME/ (under %zu bytes)", d->page_prefix,
                             sizeof n->page_prefix);
        }
        memcpy(n->page_prefix, d->page_prefix, k + 1);
    }
    n->desc.page_prefix = NULL;
    pthread_mutex_init(&n->lock, NULL);
    n->next_client = 1;
    if ((st = net_blobs_init(n, err)) != CORE_OK) {
        net_destroy(n);
        return st;
    }

    lws_set_log_level(LLL_ERR | LLL_WARN, lws_log_to_core);
    n->retry.secs_since_valid_ping = (uint16_t)n->desc.ping_s;
    n->retry.secs_since_valid_hangup = (uint16_t)n->desc.hangup_s;
    n->protocols[0] = (struct lws_protocols){ "http", net_http_callback, sizeof(net_http), 0, 0, NULL, 0 };
    n->protocols[1] = (struct lws_protocols){ n->subprotocol, net_ws_callback, sizeof(net_session), 4096, 0, NULL, 0 };
    setup_mounts(n);

    struct lws_context_creation_info info;
    memset(&info, 0, sizeof info);
    info.port = d->port == NET_PORT_ANY ? 0 : d->port ? d->port : NET_DEFAULT_PORT;
    info.iface = n->listen;
    info.protocols = n->protocols;
    info.mounts = &n->mounts[0];
    info.user = n;
    info.retry_and_idle_policy = &n->retry;
    /* UTF-8 is checked per reassembled message in net_session.c (so the close is counted) */
    info.options = LWS_SERVER_OPTION_EXPLICIT_VHOSTS;
    /* an IPv4 address on lws' IPv6 socket ends up bound to every interface: use an IPv4 socket */
    if (n->listen && !strchr(n->listen, ':')) info.options |= LWS_SERVER_OPTION_DISABLE_IPV6;
    info.vhost_name = "strandcast";
    /* a request with a method lws cannot parse (or CONNECT, which lws turns raw) becomes a raw
     * socket of the "http" protocol, answered 501 by net_method.c instead of 403 or silence */
    info.options |= LWS_SERVER_OPTION_FALLBACK_TO_APPLY_LISTEN_ACCEPT_CONFIG;
    info.listen_accept_role = "raw-skt";
    info.listen_accept_protocol = "http";
    if (d->tls_cert) {
        info.options |= LWS_SERVER_OPTION_DO_SSL_GLOBAL_INIT;
        info.ssl_cert_filepath = d->tls_cert;
        info.ssl_private_key_filepath = d->tls_key;
    }
    info.timeout_secs = 10;
    n->ctx = lws_create_context(&info);
    if (!n->ctx) {
        net_destroy(n);
        return core_fail(err, CORE_EIO, "net: could not create the libwebsockets context");
    }
    n->vhost = lws_create_vhost(n->ctx, &info);
    if (!n->vhost) {
        net_destroy(n);
        if (d->tls_cert)
            return core_fail(err, CORE_EIO, "net: could not listen with TLS on %s port %d (certificate %s or key %s "
                             "unreadable or not a matching PEM pair, or the port is in use)",
                             listen ? listen : "*", info.port, d->tls_cert, d->tls_key);
        return core_fail(err, CORE_EIO, "net: could not listen on %s port %d (in use, or no such address?)",
                         listen ? listen : "*", info.port);
    }
    n->port = lws_get_vhost_listen_port(n->vhost);
    if (n->port <= 0) {
        net_destroy(n);
        return core_fail(err, CORE_EIO, "net: not listening on %s (port %d)", listen ? listen : "*", info.port);
    }
    *out = n;
    return CORE_OK;
}

int net_port(const net *n) { return n->port; }

/* Re-arms itself every 50 ms while shutting down so net_run can check its deadline. */
static void shutdown_tick(lws_sorted_usec_list_t *sul)
{
    net *n = lws_container_of(sul, net, shutdown_sul);
    lws_sul_schedule(n->ctx, 0, &n->shutdown_sul, shutdown_tick, 50 * LWS_US_PER_MS);
}

void net_run(net *n)
{
    while (!atomic_load(&n->stop))
        if (lws_service(n->ctx, 0) < 0) break;
    /* close every client with 1001, give them up to a second to go */
    n->shutting_down = true;
    for (net_session *s = n->sessions; s; s = s->next) net_session_close(s, LWS_CLOSE_STATUS_GOINGAWAY, "server shutting down");
    unsigned long long deadline = core_now_ns() + 1000000000ull;
    shutdown_tick(&n->shutdown_sul);
    while (n->sessions && core_now_ns() < deadline)
        if (lws_service(n->ctx, 0) < 0) break;
    lws_sul_cancel(&n->shutdown_sul);
}

void net_stop(net *n)
{
    atomic_store(&n->stop, true);
    if (n->ctx) lws_cancel_service(n->ctx);
}

static void free_events(net_event *e)
{
    while (e) {
        net_event *next = e->next;
        net_buf_unref(e->buf);
        free(e);
        e = next;
    }
}

void net_destroy(net *n)
{
    if (!n) return;
    if (n->ctx) lws_context_destroy(n->ctx);
    free_events(n->in_head);
    for (int i = 0; i < NET_MAX_STREAMS; i++) {
        net_buf_unref(n->streams[i].latest);
        net_buf_unref(n->streams[i].key);
    }
    net_blobs_free(n);
    pthread_mutex_destroy(&n->lock);
    free(n->listen);
    free(n->web_dir);
    free(n->subprotocol);
    free(n->scratch);
    free(n);
}

/* Appends e to the inbox (or fails when full) and wakes the net thread. */
static core_status post(net *n, net_event *e)
{
    pthread_mutex_lock(&n->lock);
    if (n->in_count >= NET_INBOX_MAX) {
        pthread_mutex_unlock(&n->lock);
        net_buf_unref(e->buf);
        free(e);
        return CORE_ENOMEM;
    }
    if (n->in_tail) n->in_tail->next = e;
    else n->in_head = e;
    n->in_tail = e;
    n->in_count++;
    pthread_mutex_unlock(&n->lock);
    lws_cancel_service(n->ctx);
    return CORE_OK;
}

static net_event *new_event(net_ev_kind kind, uint32_t client, const char *text, size_t len)
{
    net_event *e = calloc(1, sizeof *e);
    if (!e) return NULL;
    e->kind = kind;
    e->client = client;
    if (text) {
        e->buf = net_buf_new(len);
        if (!e->buf) {
            free(e);
            return NULL;
        }
        memcpy(net_buf_data(e->buf), text, len);
    }
    return e;
}

core_status net_send_text(net *n, uint32_t client, const char *text, size_t len, unsigned flags)
{
    net_event *e = new_event(NET_EV_TEXT, client, text, len);
    if (!e) return CORE_ENOMEM;
    e->flags = flags;
    return post(n, e);
}

core_status net_start_client(net *n, uint32_t client, const char *hello, size_t len, uint32_t stream, double max_rate)
{
    net_event *e = new_event(NET_EV_START, client, hello, len);
    if (!e) return CORE_ENOMEM;
    e->stream = stream;
    e->max_rate = max_rate;
    return post(n, e);
}

core_status net_close_client(net *n, uint32_t client, int code, const char *reason)
{
    size_t len = strlen(reason);
    if (len > NET_MAX_CLOSE_REASON) {
        len = NET_MAX_CLOSE_REASON;
        while (len && ((unsigned char)reason[len] & 0xC0) == 0x80) len--; /* not inside a character */
    }
    net_event *e = new_event(NET_EV_CLOSE, client, reason, len);
    if (!e) return CORE_ENOMEM;
    e->flags = (unsigned)code;
    return post(n, e);
}

core_status net_subscribe(net *n, uint32_t client, uint32_t stream, double max_rate)
{
    net_event *e = new_event(NET_EV_SUBSCRIBE, client, NULL, 0);
    if (!e) return CORE_ENOMEM;
    e->stream = stream;
    e->max_rate = max_rate;
    return post(n, e);
}

void net_publish(net *n, uint32_t stream, net_buf *frame, uint64_t seq, bool key)
{
    if (stream >= NET_MAX_STREAMS) {
        net_buf_unref(frame);
        return;
    }
    pthread_mutex_lock(&n->lock);
    net_event *pend = n->pending_frame[stream];
    if (pend && !key) {
        /* the net thread has not taken the previous frame yet: the newest wins */
        net_buf_unref(pend->buf);
        pend->buf = frame;
        pend->seq = seq;
        pend->merged++;
        pthread_mutex_unlock(&n->lock);
        lws_cancel_service(n->ctx);
        return;
    }
    pthread_mutex_unlock(&n->lock);
    net_event *e = calloc(1, sizeof *e);
    if (!e) {
        net_buf_unref(frame);
        return;
    }
    e->kind = NET_EV_FRAME;
    e->stream = stream;
    e->buf = frame;
    e->seq = seq;
    e->key = key;
    pthread_mutex_lock(&n->lock);
    /* frames are bounded by the pending slot; they never fail for a full inbox */
    if (n->in_tail) n->in_tail->next = e;
    else n->in_head = e;
    n->in_tail = e;
    n->in_count++;
    n->pending_frame[stream] = key ? NULL : e;
    pthread_mutex_unlock(&n->lock);
    lws_cancel_service(n->ctx);
}

void net_drop_stream(net *n, uint32_t stream)
{
    net_event *e = new_event(NET_EV_DROP, 0, NULL, 0);
    if (!e || stream >= NET_MAX_STREAMS) {
        free(e);
        return;
    }
    e->stream = stream;
    pthread_mutex_lock(&n->lock);
    if (n->in_tail) n->in_tail->next = e;
    else n->in_head = e;
    n->in_tail = e;
    n->in_count++;
    n->pending_frame[stream] = NULL;
    pthread_mutex_unlock(&n->lock);
    lws_cancel_service(n->ctx);
}

void net_get_stats(net *n, net_stats *out)
{
    out->clients = atomic_load(&n->clients);
    out->frames_sent = atomic_load(&n->frames_sent);
    out->frames_skipped = atomic_load(&n->frames_skipped);
    out->bytes_sent = atomic_load(&n->bytes_sent);
    out->text_sent = atomic_load(&n->text_sent);
    out->text_dropped = atomic_load(&n->text_dropped);
    out->text_coalesced = atomic_load(&n->text_coalesced);
    out->clients_refused = atomic_load(&n->clients_refused);
    out->text_queued_bytes = atomic_load(&n->text_queued_bytes);
    out->messages_in = atomic_load(&n->messages_in);
    out->protocol_closes = atomic_load(&n->protocol_closes);
    out->http_requests = atomic_load(&n->http_requests);
}

static net_session *find_session(net *n, uint32_t client)
{
    for (net_session *s = n->sessions; s; s = s->next)
        if (s->client == client) return s;
    return NULL;
}

static void set_stream(net_session *s, uint32_t stream, double max_rate)
{
    if (stream != s->stream) {
        s->stream = stream;
        s->has_key = false;
        s->last_count = 0;
    }
    s->max_rate = max_rate;
    s->next_due_ns = 0;
}

static void apply_frame(net *n, net_event *e)
{
    net_stream *sl = &n->streams[e->stream];
    sl->count += 1u + e->merged; /* the merged frames count as published, so as skipped by every client */
    if (e->key) {
        net_buf_unref(sl->key);
        net_buf_ref(e->buf);
        sl->key = e->buf;
        sl->key_seq = e->seq;
        sl->key_count = sl->count;
    }
    net_buf_unref(sl->latest);
    sl->latest = e->buf;
    e->buf = NULL;
    sl->latest_seq = e->seq;
    sl->latest_key_seq = sl->key_seq;
}

static void apply(net *n, net_event *e)
{
    net_session *s;
    switch (e->kind) {
    case NET_EV_TEXT:
        if (e->client == NET_ALL) {
            for (s = n->sessions; s; s = s->next)
                if (s->ready) net_session_enqueue(n, s, e->buf, e->flags);
        } else if ((s = find_session(n, e->client))) {
            net_session_enqueue(n, s, e->buf, e->flags);
        }
        break;
    case NET_EV_START:
        if ((s = find_session(n, e->client))) {
            net_session_enqueue(n, s, e->buf, 0);
            s->ready = true;
            set_stream(s, e->stream, e->max_rate);
        }
        break;
    case NET_EV_SUBSCRIBE:
        if ((s = find_session(n, e->client))) set_stream(s, e->stream, e->max_rate);
        break;
    case NET_EV_CLOSE:
        if ((s = find_session(n, e->client)) && !s->closing) {
            size_t len = net_buf_len(e->buf);
            memcpy(s->close_text, net_buf_data(e->buf), len);
            s->close_text[len] = '\0';
            s->linger = true;
            s->ready = false; /* no more frames or broadcasts */
            net_session_close(s, (int)e->flags, s->close_text);
        }
        break;
    case NET_EV_FRAME: apply_frame(n, e); break;
    case NET_EV_DROP:
        net_buf_unref(n->streams[e->stream].latest);
        net_buf_unref(n->streams[e->stream].key);
        n->streams[e->stream].latest = n->streams[e->stream].key = NULL;
        break;
    }
}

void net_drain(net *n)
{
    pthread_mutex_lock(&n->lock);
    net_event *e = n->in_head;
    n->in_head = n->in_tail = NULL;
    n->in_count = 0;
    memset(n->pending_frame, 0, sizeof n->pending_frame);
    pthread_mutex_unlock(&n->lock);
    if (!e) return;
    for (net_event *it = e; it; it = it->next) apply(n, it);
    free_events(e);
    for (net_session *s = n->sessions; s; s = s->next) net_session_kick(n, s);
}
