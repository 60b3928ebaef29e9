/* net: the HTTP side: subprotocol check on upgrade (400 with a reason), /metrics, blob routing. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <stdbool.h>
#include <strings.h>

#include "net_internal.h"

#define METRICS_MAX (32 * 1024)

/* A WebSocket upgrade (the Upgrade token compared case-insensitively, RFC 7230) is refused
 * with a reason: 400 without the subprotocol, 503 when the server has its maximum of clients. */
static int confirm_upgrade(net *n, struct lws *wsi, const char *upgrade)
{
    if (!upgrade || strcasecmp(upgrade, "websocket") != 0) return 0;
    /* RFC 6455 4.1/4.2: a Host header, and version 13 (426 with the version this server speaks) */
    char version[16] = "";
    int vlen = lws_hdr_total_length(wsi, WSI_TOKEN_VERSION);
    if (vlen > 0 && vlen < (int)sizeof version) lws_hdr_copy(wsi, version, sizeof version, WSI_TOKEN_VERSION);
    if (strcmp(version, "13") != 0) {
        atomic_fetch_add(&n->protocol_closes, 1);
        return lws_return_http_status(wsi, 426, "unsupported or missing Sec-WebSocket-Version: this server speaks 13")
                   ? -1 : 1;
    }
    if (lws_hdr_total_length(wsi, WSI_TOKEN_HOST) <= 0) {
        atomic_fetch_add(&n->protocol_closes, 1);
        return lws_return_http_status(wsi, HTTP_STATUS_BAD_REQUEST, "a WebSocket upgrade needs a Host header") ? -1 : 1;
    }
    char list[256] = "";
    int len = lws_hdr_total_length(wsi, WSI_TOKEN_PROTOCOL);
    if (len > 0 && len < (int)sizeof list) lws_hdr_copy(wsi, list, sizeof list, WSI_TOKEN_PROTOCOL);
    if (len > 0 && len < (int)sizeof list && net_token_listed(list, n->subprotocol)) {
        char origin[NET_MAX_ORIGIN + 1] = "";
        int olen = lws_hdr_total_length(wsi, WSI_TOKEN_ORIGIN);
        if (n->norigins && olen > 0) {
            if (olen < (int)sizeof origin) lws_hdr_copy(wsi, origin, sizeof origin, WSI_TOKEN_ORIGIN);
            bool listed = false;
            for (int i = 0; i < n->norigins && !listed; i++) listed = strcmp(origin, n->origins[i]) == 0;
            if (!listed) {
                char why[NET_MAX_ORIGIN + 96];
                for (char *c = origin; *c; c++)
                    if (*c == '<' || *c == '>' || *c == '&') *c = '?';
                snprintf(why, sizeof why, "origin %s is not allowed to connect (strandcastd --allow-origin)",
                         origin[0] ? origin : "(too long)");
                atomic_fetch_add(&n->protocol_closes, 1);
                return lws_return_http_status(wsi, HTTP_STATUS_FORBIDDEN, why) ? -1 : 1;
            }
        }
        if (atomic_load(&n->clients) < (uint64_t)n->desc.max_clients) return 0;
        char busy[160];
        snprintf(busy, sizeof busy, "the server has its maximum of %d clients (--max-clients); try again later",
                 n->desc.max_clients);
        atomic_fetch_add(&n->clients_refused, 1);
        return lws_return_http_status(wsi, HTTP_STATUS_SERVICE_UNAVAILABLE, busy) ? -1 : 1;
    }
    char body[384];
    char shown[64];
    snprintf(shown, sizeof shown, "%.60s", len <= 0 ? "(none)" : len < (int)sizeof list ? list : "(too long)");
    for (char *c = shown; *c; c++)
        if (*c == '<' || *c == '>' || *c == '&') *c = '?';
    snprintf(body, sizeof body,
             "unsupported WebSocket subprotocol %s: this server speaks \"%s\" "
             "(send Sec-WebSocket-Protocol: %s)",
             shown, n->subprotocol, n->subprotocol);
    atomic_fetch_add(&n->protocol_closes, 1);
    if (lws_return_http_status(wsi, HTTP_STATUS_BAD_REQUEST, body)) return -1;
    return 1;
}

static void metrics_body(net *n, net_http *h)
{
    h->body = malloc(METRICS_MAX);
    if (!h->body) return;
    size_t used = 0;
    if (n->desc.cb.metrics) used = n->desc.cb.metrics(n->desc.cb.user, h->body, METRICS_MAX);
    if (used > METRICS_MAX) used = METRICS_MAX;
    net_stats st;
    net_get_stats(n, &st);
    int w = snprintf(h->body + used, METRICS_MAX - used,
                     "# HELP strandcast_clients Connected WebSocket clients.\n# TYPE strandcast_clients gauge\n"
                     "strandcast_clients %llu\n"
                     "# HELP strandcast_frames_sent_total Binary frames written to clients.\n"
                     "# TYPE strandcast_frames_sent_total counter\nstrandcast_frames_sent_total %llu\n"
                     "# HELP strandcast_frames_skipped_total Frames a client never got because a newer one replaced it.\n"
                     "# TYPE strandcast_frames_skipped_total counter\nstrandcast_frames_skipped_total %llu\n"
                     "# HELP strandcast_bytes_sent_total WebSocket payload bytes written (frames and text).\n"
                     "# TYPE strandcast_bytes_sent_total counter\nstrandcast_bytes_sent_total %llu\n"
                     "# HELP strandcast_text_sent_total Text messages written to clients.\n"
                     "# TYPE strandcast_text_sent_total counter\nstrandcast_text_sent_total %llu\n"
                     "# HELP strandcast_text_dropped_total Droppable text messages dropped from full client queues.\n"
                     "# TYPE strandcast_text_dropped_total counter\nstrandcast_text_dropped_total %llu\n"
                     "# HELP strandcast_client_queued_bytes Bytes of text messages queued for the clients now (memory held for them).\n"
                     "# TYPE strandcast_client_queued_bytes gauge\nstrandcast_client_queued_bytes %llu\n"
                     "# HELP strandcast_clients_refused_total WebSocket upgrades answered 503 at --max-clients.\n"
                     "# TYPE strandcast_clients_refused_total counter\nstrandcast_clients_refused_total %llu\n"
                     "# HELP strandcast_text_coalesced_total Announcements (params, state, groom) replaced in a client queue by a newer one.\n"
                     "# TYPE strandcast_text_coalesced_total counter\nstrandcast_text_coalesced_total %llu\n"
                     "# HELP strandcast_messages_received_total Complete client text messages received.\n"
                     "# TYPE strandcast_messages_received_total counter\nstrandcast_messages_received_total %llu\n"
                     "# HELP strandcast_protocol_closes_total Connections refused or closed for protocol violations.\n"
                     "# TYPE strandcast_protocol_closes_total counter\nstrandcast_protocol_closes_total %llu\n",
                     (unsigned long long)st.clients, (unsigned long long)st.frames_sent,
                     (unsigned long long)st.frames_skipped, (unsigned long long)st.bytes_sent,
                     (unsigned long long)st.text_sent, (unsigned long long)st.text_dropped,
                     (unsigned long long)st.text_queued_bytes, (unsigned long long)st.clients_refused, (unsigned long long)st.text_coalesced, (unsigned long long)st.messages_in, (unsigned long long)st.protocol_closes);
    if (w > 0) used += (size_t)w < METRICS_MAX - used ? (size_t)w : METRICS_MAX - used - 1;
    h->len = used;
}

/* A page under desc.page_prefix: the web folder's index.html. */
static int page(net *n, struct lws *wsi)
{
    char path[4096];
    int k = snprintf(path, sizeof path, "%s/index.html", n->web_dir);
    if (k < 0 || (size_t)k >= sizeof path)
        return lws_return_http_status(wsi, HTTP_STATUS_NOT_FOUND, "not found") || lws_http_transaction_completed(wsi) ? -1 : 0;
    int r = lws_serve_http_file(wsi, path, "text/html; charset=utf-8", NULL, 0);
    return r < 0 || (r > 0 && lws_http_transaction_completed(wsi)) ? -1 : 0;
}

static int metrics_headers(net *n, struct lws *wsi, net_http *h)
{
    char uri[NET_MAX_BLOB_PATH + 8] = "";
    size_t np = strlen(n->page_prefix);
    int ulen = lws_hdr_total_length(wsi, WSI_TOKEN_GET_URI);
    if (np && ulen > 0) { /* a page path may be longer than uri holds */
        char *full = malloc((size_t)ulen + 1);
        bool under = full && lws_hdr_copy(wsi, full, ulen + 1, WSI_TOKEN_GET_URI) > 0 && strncmp(full, n->page_prefix, np) == 0;
        bool blob = under && net_page_blob_known(n, full);
        int rc = blob ? net_blob_headers(n, wsi, h, full) : 0;
        free(full);
        if (blob) return rc;
        if (under && n->web_dir) return page(n, wsi);
    }
    if (lws_hdr_copy(wsi, uri, sizeof uri, WSI_TOKEN_GET_URI) > 0 && strcmp(uri, "/metrics") != 0)
        return net_blob_headers(n, wsi, h, uri);
    if (strcmp(uri, "/metrics") != 0)
        return lws_return_http_status(wsi, HTTP_STATUS_NOT_FOUND, "not found") || lws_http_transaction_completed(wsi) ? -1 : 0;
    metrics_body(n, h);
    if (!h->body) return lws_return_http_status(wsi, HTTP_STATUS_INTERNAL_SERVER_ERROR, "out of memory") ? -1 : 0;
    unsigned char buf[LWS_PRE + 512], *start = buf + LWS_PRE, *p = start, *end = buf + sizeof buf;
    if (lws_add_http_common_headers(wsi, HTTP_STATUS_OK, "text/plain; version=0.0.4; charset=utf-8", h->len, &p, end) ||
        lws_add_http_header_by_token(wsi, WSI_TOKEN_HTTP_CACHE_CONTROL, (unsigned char *)"no-store", 8, &p, end) ||
        lws_finalize_write_http_header(wsi, start, &p, end))
        return -1;
    lws_callback_on_writable(wsi);
    return 0;
}

static int metrics_write(struct lws *wsi, net_http *h)
{
    if (!h->body) return 0;
    unsigned char *out = malloc(LWS_PRE + h->len);
    if (!out) return -1;
    memcpy(out + LWS_PRE, h->body, h->len);
    int w = lws_write(wsi, out + LWS_PRE, h->len, LWS_WRITE_HTTP_FINAL);
    free(out);
    free(h->body);
    h->body = NULL;
    if (w < (int)h->len) return -1;
    return lws_http_transaction_completed(wsi) ? -1 : 0;
}

int net_http_callback(struct lws *wsi, enum lws_callback_reasons reason, void *user, void *in, size_t len)
{
    net *n = lws_context_user(lws_get_context(wsi));
    net_http *h = user;
    switch (reason) {
    case LWS_CALLBACK_HTTP_CONFIRM_UPGRADE: return confirm_upgrade(n, wsi, in);
    case LWS_CALLBACK_HTTP:
        /* the /metrics callback mount, or any URL when no web folder is mounted */
        return metrics_headers(n, wsi, h);
    case LWS_CALLBACK_HTTP_WRITEABLE: return h && h->blob ? net_blob_write(wsi, h) : metrics_write(wsi, h);
    case LWS_CALLBACK_HTTP_DROP_PROTOCOL:
    case LWS_CALLBACK_CLOSED_HTTP:
        if (h) {
            free(h->body);
            h->body = NULL;
            net_buf_unref(h->blob);
            h->blob = NULL;
        }
        return 0;
    case LWS_CALLBACK_FILTER_HTTP_CONNECTION: atomic_fetch_add(&n->http_requests, 1); return 0;
    case LWS_CALLBACK_RAW_ADOPT: return 0;
    case LWS_CALLBACK_RAW_RX:
    case LWS_CALLBACK_RAW_WRITEABLE:
    case LWS_CALLBACK_RAW_CLOSE: return net_method_callback(wsi, reason, h, in, len);
    default: return lws_callback_http_dummy(wsi, reason, user, in, len);
    }
}
