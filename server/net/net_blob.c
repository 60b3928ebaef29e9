/* net: byte blobs the application hands over (any thread), served over HTTP with an ETag. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "net_internal.h"

#define CHUNK (64 * 1024) /* blob bytes per lws_write */

static bool name_chars(const char *s)
{
    for (; *s; s++)
        if (!((*s >= 'a' && *s <= 'z') || (*s >= 'A' && *s <= 'Z') || (*s >= '0' && *s <= '9') || *s == '.' || *s == '_' ||
              *s == '-'))
            return false;
    return true;
}

core_status net_blobs_init(net *n, core_err *err)
{
    n->nblobs = 0;
    for (int i = 0; i < NET_MAX_BLOBS && n->desc.blobs[i]; i++) {
        const char *p = n->desc.blobs[i];
        if (p[0] != '/' || !p[1] || strlen(p) >= NET_MAX_BLOB_PATH || !name_chars(p + 1) || strcmp(p, "/metrics") == 0)
            return core_fail(err, CORE_EINVAL, "net: blob path \"%.80s\" is not \"/NAME\" (letters, digits, '.', '_', '-')", p);
        snprintf(n->blobs[i].path, sizeof n->blobs[i].path, "%s", p);
        n->nblobs = i + 1;
    }
    return CORE_OK;
}

void net_blobs_free(net *n)
{
    for (int i = 0; i < n->nblobs; i++) {
        net_buf_unref(n->blobs[i].body);
        n->blobs[i].body = NULL;
    }
    for (int i = 0; i < n->npage_blobs; i++) net_buf_unref(n->page_blobs[i].body);
    free(n->page_blobs);
    n->page_blobs = NULL;
    n->npage_blobs = 0;
}

/* The blob at path (lock held), or NULL. */
static net_blob *find(net *n, const char *path)
{
    for (int i = 0; i < n->nblobs; i++)
        if (strcmp(n->blobs[i].path, path) == 0) return &n->blobs[i];
    for (int i = 0; i < n->npage_blobs; i++)
        if (strcmp(n->page_blobs[i].path, path) == 0) return &n->page_blobs[i];
    return NULL;
}

/* PAGE_PREFIX "SEGMENT/NAME", both of letters, digits, '.', '_', '-', under NET_MAX_BLOB_PATH bytes. */
static bool page_blob_path(const net *n, const char *path)
{
    size_t k = strlen(n->page_prefix);
    if (!k || strncmp(path, n->page_prefix, k) != 0 || strlen(path) >= NET_MAX_BLOB_PATH) return false;
    char seg[NET_MAX_BLOB_PATH], name[NET_MAX_BLOB_PATH];
    const char *slash = strchr(path + k, '/');
    if (!slash || slash == path + k || !slash[1]) return false;
    snprintf(seg, sizeof seg, "%.*s", (int)(slash - (path + k)), path + k);
    snprintf(name, sizeof name, "%s", slash + 1);
    return name_chars(seg) && name_chars(name);
}

bool net_page_blob_known(net *n, const char *path)
{
    pthread_mutex_lock(&n->lock);
    bool known = false;
    for (int i = 0; i < n->npage_blobs && !known; i++) known = strcmp(n->page_blobs[i].path, path) == 0;
    pthread_mutex_unlock(&n->lock);
    return known;
}

/* The blob at path, added under the page prefix when new (lock held); NULL when path is neither. */
static net_blob *find_or_add(net *n, const char *path)
{
    net_blob *b = find(n, path);
    if (b || !page_blob_path(n, path) || n->npage_blobs == NET_MAX_PAGE_BLOBS) return b;
    if (!n->page_blobs && !(n->page_blobs = calloc(NET_MAX_PAGE_BLOBS, sizeof *n->page_blobs))) return NULL;
    b = &n->page_blobs[n->npage_blobs++];
    snprintf(b->path, sizeof b->path, "%s", path);
    return b;
}

core_status net_set_blob(net *n, const char *path, net_buf *body, const char *etag)
{
    if (body && (!etag || !*etag || strlen(etag) > NET_MAX_ETAG || !name_chars(etag))) {
        net_buf_unref(body);
        return CORE_EINVAL;
    }
    pthread_mutex_lock(&n->lock);
    net_blob *b = find_or_add(n, path);
    if (!b) {
        pthread_mutex_unlock(&n->lock);
        net_buf_unref(body);
        return CORE_EINVAL;
    }
    net_buf *old = b->body;
    b->body = body;
    snprintf(b->etag, sizeof b->etag, "\"%s\"", body ? etag : "");
    pthread_mutex_unlock(&n->lock);
    net_buf_unref(old);
    return CORE_OK;
}

/* True when the If-None-Match header lists etag (or is "*"). */
static bool not_modified(struct lws *wsi, const char *etag)
{
    char inm[256] = "";
    int len = lws_hdr_total_length(wsi, WSI_TOKEN_HTTP_IF_NONE_MATCH);
    if (len <= 0 || len >= (int)sizeof inm || lws_hdr_copy(wsi, inm, sizeof inm, WSI_TOKEN_HTTP_IF_NONE_MATCH) <= 0) return false;
    return net_token_listed(inm, etag) || net_token_listed(inm, "*");
}

int net_blob_headers(net *n, struct lws *wsi, net_http *h, const char *uri)
{
    char etag[NET_MAX_ETAG + 3];
    pthread_mutex_lock(&n->lock);
    net_blob *b = find(n, uri);
    net_buf *body = b ? b->body : NULL;
    if (body) {
        net_buf_ref(body);
        snprintf(etag, sizeof etag, "%s", b->etag);
    }
    pthread_mutex_unlock(&n->lock);
    if (!body)
        return lws_return_http_status(wsi, HTTP_STATUS_NOT_FOUND, "not found") || lws_http_transaction_completed(wsi) ? -1 : 0;
    bool same = not_modified(wsi, etag);
    unsigned char buf[LWS_PRE + 512], *start = buf + LWS_PRE, *p = start, *end = buf + sizeof buf;
    int code = same ? HTTP_STATUS_NOT_MODIFIED : HTTP_STATUS_OK;
    if (lws_add_http_common_headers(wsi, (unsigned)code, "application/octet-stream", same ? 0 : net_buf_len(body), &p, end) ||
        lws_add_http_header_by_token(wsi, WSI_TOKEN_HTTP_ETAG, (unsigned char *)etag, (int)strlen(etag), &p, end) ||
        lws_add_http_header_by_token(wsi, WSI_TOKEN_HTTP_CACHE_CONTROL, (unsigned char *)"no-cache", 8, &p, end) ||
        lws_finalize_write_http_header(wsi, start, &p, end)) {
        net_buf_unref(body);
        return -1;
    }
    if (same || net_buf_len(body) == 0) {
        net_buf_unref(body);
        return lws_http_transaction_completed(wsi) ? -1 : 0;
    }
    h->blob = body;
    h->off = 0;
    lws_callback_on_writable(wsi);
    return 0;
}

int net_blob_write(struct lws *wsi, net_http *h)
{
    size_t len = net_buf_len(h->blob), n = len - h->off < CHUNK ? len - h->off : CHUNK;
    bool last = h->off + n == len;
    unsigned char *out = malloc(LWS_PRE + n);
    if (!out) return -1;
    memcpy(out + LWS_PRE, net_buf_data(h->blob) + h->off, n);
    int w = lws_write(wsi, out + LWS_PRE, n, last ? LWS_WRITE_HTTP_FINAL : LWS_WRITE_HTTP);
    free(out);
    if (w < (int)n) return -1;
    h->off += n;
    if (!last) {
        lws_callback_on_writable(wsi);
        return 0;
    }
    net_buf_unref(h->blob);
    h->blob = NULL;
    return lws_http_transaction_completed(wsi) ? -1 : 0;
}
