/* net: requests whose method the server does not implement (CONNECT, or a token lws does not
 * know) get 501 with a reason, bytes that are no request line 400: lws hands such connections
 * over as raw sockets (the vhost's listen-accept fallback) with the bytes read so far, and
 * they are answered and closed here. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "net_internal.h"

#define MAX_METHOD 16 /* longest method name shown in the reason */

/* The method at the start of the request bytes (letters up to a space), or "" when they do
 * not start with one. */
static void method_of(const char *in, size_t len, char out[MAX_METHOD + 1])
{
    size_t k = 0;
    while (k < len && k < MAX_METHOD && in[k] >= 'A' && in[k] <= 'Z') k++;
    if (k == 0 || k >= len || in[k] != ' ') k = 0;
    memcpy(out, in, k);
    out[k] = '\0';
}

/* Prepares the answer (501 naming the method, or 400) in h->body on the first bytes, then
 * waits for WRITEABLE. */
static int answer(net *n, struct lws *wsi, net_http *h, const char *in, size_t len)
{
    if (h->body) return 0; /* already answered: the rest of the request is ignored */
    char method[MAX_METHOD + 1], body[256];
    method_of(in, len, method);
    int b = method[0] ? snprintf(body, sizeof body,
                                 "method %s is not implemented: this server answers GET and HEAD (files, /metrics, "
                                 "/groom.bin, /collider.bin) and WebSocket upgrades\n",
                                 method)
                      : snprintf(body, sizeof body, "not an HTTP/1.1 request line (METHOD SP target SP HTTP/1.1)\n");
    char head[192];
    int hl = snprintf(head, sizeof head,
                      "HTTP/1.1 %s\r\nContent-Type: text/plain; charset=utf-8\r\nContent-Length: %d\r\n"
                      "Connection: close\r\n\r\n",
                      method[0] ? "501 Not Implemented" : "400 Bad Request", b);
    h->body = malloc(LWS_PRE + (size_t)hl + (size_t)b);
    if (!h->body) return -1;
    memcpy(h->body + LWS_PRE, head, (size_t)hl);
    memcpy(h->body + LWS_PRE + hl, body, (size_t)b);
    h->len = (size_t)hl + (size_t)b;
    atomic_fetch_add(&n->http_requests, 1);
    lws_callback_on_writable(wsi);
    return 0;
}

int net_method_callback(struct lws *wsi, enum lws_callback_reasons reason, net_http *h, void *in, size_t len)
{
    net *n = lws_context_user(lws_get_context(wsi));
    switch (reason) {
    case LWS_CALLBACK_RAW_RX: return h ? answer(n, wsi, h, in, len) : -1;
    case LWS_CALLBACK_RAW_WRITEABLE:
        if (!h || !h->body) return 0;
        /* lws sends what the socket does not take before it closes */
        lws_write(wsi, (unsigned char *)h->body + LWS_PRE, h->len, LWS_WRITE_RAW);
        return -1;
    case LWS_CALLBACK_RAW_CLOSE:
        if (h) {
            free(h->body);
            h->body = NULL;
        }
        return 0;
    default: return 0;
    }
}
