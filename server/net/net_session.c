/* net: WebSocket sessions: receive reassembly with a cap, text queues, newest-frame-wins sending
 * (large frames in fragments). */
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>

#include "../core/utf8.h"
#include "net_internal.h"

static net *net_of(struct lws *wsi) { return lws_context_user(lws_get_context(wsi)); }

void net_session_close(net_session *s, int code, const char *reason)
{
    if (s->closing) return;
    s->closing = true;
    s->close_code = code;
    s->close_reason = reason;
    lws_callback_on_writable(s->wsi);
}

/* A protocol violation seen while receiving: the close goes out from WRITEABLE (after lws has
 * flushed any partly written message; closing from the receive callback would drop the close
 * frame when output is buffered), and whatever else arrives meanwhile is ignored. */
static int close_now(net *n, net_session *s, int code, const char *reason)
{
    atomic_fetch_add(&n->protocol_closes, 1);
    net_session_close(s, code, reason);
    return 0;
}

/* Removes the k-th queued message (0 = the oldest), keeping the order of the others. */
static void queue_remove(net *n, net_session *s, int k)
{
    net_buf *b = s->q[(s->qhead + k) % s->qcap];
    atomic_fetch_sub(&n->text_queued_bytes, net_buf_len(b));
    net_buf_unref(b);
    for (int i = k; i + 1 < s->qlen; i++) {
        int a = (s->qhead + i) % s->qcap, b = (s->qhead + i + 1) % s->qcap;
        s->q[a] = s->q[b];
        s->qflags[a] = s->qflags[b];
    }
    s->qlen--;
}

void net_session_enqueue(net *n, net_session *s, net_buf *b, unsigned flags)
{
    if (s->closing || !s->q) return;
    unsigned kind = NET_TEXT_KIND(flags);
    for (int i = 0; kind && i < s->qlen; i++)
        if (NET_TEXT_KIND(s->qflags[(s->qhead + i) % s->qcap]) == kind) { /* superseded */
            queue_remove(n, s, i);
            atomic_fetch_add(&n->text_coalesced, 1);
            break;
        }
    if (s->qlen == s->qcap) {
        /* full: drop the oldest droppable message, or give up on this client */
        int victim = -1;
        for (int i = 0; i < s->qlen && victim < 0; i++)
            if (s->qflags[(s->qhead + i) % s->qcap] & NET_TEXT_DROPPABLE) victim = i;
        if (victim < 0 && (flags & NET_TEXT_DROPPABLE)) {
            atomic_fetch_add(&n->text_dropped, 1);
            return;
        }
        if (victim < 0) {
            net_session_close(s, LWS_CLOSE_STATUS_POLICY_VIOLATION, "send queue overflow");
            return;
        }
        queue_remove(n, s, victim);
        atomic_fetch_add(&n->text_dropped, 1);
    }
    int at = (s->qhead + s->qlen) % s->qcap;
    net_buf_ref(b);
    atomic_fetch_add(&n->text_queued_bytes, net_buf_len(b));
    s->q[at] = b;
    s->qflags[at] = (unsigned char)flags;
    s->qlen++;
}

static bool frame_pending(net *n, const net_session *s)
{
    return s->ready && s->stream < NET_MAX_STREAMS && n->streams[s->stream].latest && n->streams[s->stream].count > s->last_count;
}

void net_session_kick(net *n, net_session *s)
{
    if (s->closing ? s->close_code != 0 || s->tx : s->tx || s->qlen > 0 || frame_pending(n, s)) lws_callback_on_writable(s->wsi);
}

static void session_open(net *n, net_session *s, struct lws *wsi)
{
    memset(s, 0, sizeof *s);
    s->wsi = wsi;
    s->client = n->next_client++;
    s->qcap = n->desc.text_queue;
    s->q = calloc((size_t)s->qcap, sizeof *s->q);
    s->qflags = calloc((size_t)s->qcap, 1);
    /* a fixed kernel send buffer bounds what a stalled client can hold (no autotuning) */
    setsockopt(lws_get_socket_fd(wsi), SOL_SOCKET, SO_SNDBUF, &n->desc.sndbuf, sizeof n->desc.sndbuf);
    s->next = n->sessions;
    if (n->sessions) n->sessions->prev = s;
    n->sessions = s;
    atomic_fetch_add(&n->clients, 1);
    if (n->shutting_down) {
        net_session_close(s, LWS_CLOSE_STATUS_GOINGAWAY, "server shutting down");
        return;
    }
    if (!s->q || !s->qflags) {
        net_session_close(s, LWS_CLOSE_STATUS_UNEXPECTED_CONDITION, "out of memory");
        return;
    }
    int plen = lws_hdr_total_length(wsi, WSI_TOKEN_GET_URI);
    char *path = malloc(plen > 0 ? (size_t)plen + 1 : 1);
    if (!path) {
        net_session_close(s, LWS_CLOSE_STATUS_UNEXPECTED_CONDITION, "out of memory");
        return;
    }
    if (plen <= 0 || lws_hdr_copy(wsi, path, plen + 1, WSI_TOKEN_GET_URI) < 0) path[0] = '\0';
    if (n->desc.cb.on_open) n->desc.cb.on_open(n->desc.cb.user, s->client, path);
    free(path);
}

static void session_closed(net *n, net_session *s)
{
    if (!s->wsi) return; /* never opened */
    if (s->prev) s->prev->next = s->next;
    else n->sessions = s->next;
    if (s->next) s->next->prev = s->prev;
    while (s->qlen > 0) queue_remove(n, s, 0);
    free(s->q);
    free(s->qflags);
    free(s->rx);
    net_buf_unref(s->tx);
    s->tx = NULL;
    atomic_fetch_sub(&n->clients, 1);
    if (n->desc.cb.on_close && !n->shutting_down) n->desc.cb.on_close(n->desc.cb.user, s->client);
    s->wsi = NULL;
}

static int session_receive(net *n, net_session *s, struct lws *wsi, const void *in, size_t len)
{
    if (s->closing) return 0;
    if (lws_frame_is_binary(wsi))
        return close_now(n, s, LWS_CLOSE_STATUS_UNACCEPTABLE_OPCODE, "binary messages are not accepted; send JSON text");
    if (lws_is_first_fragment(wsi)) s->rx_len = 0;
    if (len > n->desc.max_message - s->rx_len)
        return close_now(n, s, LWS_CLOSE_STATUS_MESSAGE_TOO_LARGE, "message over the size limit");
    if (s->rx_len + len > s->rx_cap) {
        size_t cap = s->rx_cap ? s->rx_cap : 1024;
        while (cap < s->rx_len + len) cap *= 2;
        if (cap > n->desc.max_message) cap = n->desc.max_message;
        char *rx = realloc(s->rx, cap);
        if (!rx) return close_now(n, s, LWS_CLOSE_STATUS_UNEXPECTED_CONDITION, "out of memory");
        s->rx = rx;
        s->rx_cap = cap;
    }
    if (len) memcpy(s->rx + s->rx_len, in, len);
    s->rx_len += len;
    if (!lws_is_final_fragment(wsi) || lws_remaining_packet_payload(wsi) > 0) return 0;
    if (!core_utf8_valid(s->rx, s->rx_len))
        return close_now(n, s, LWS_CLOSE_STATUS_INVALID_PAYLOAD, "text message is not valid UTF-8");
    atomic_fetch_add(&n->messages_in, 1);
    if (n->desc.cb.on_text) n->desc.cb.on_text(n->desc.cb.user, s->client, s->rx ? s->rx : "", s->rx_len);
    s->rx_len = 0;
    return 0;
}

static int write_buf(net *n, struct lws *wsi, net_buf *b, enum lws_write_protocol kind)
{
    int w = lws_write(wsi, net_buf_data(b), b->len, kind);
    if (w < (int)b->len) return -1;
    atomic_fetch_add(&n->bytes_sent, b->len);
    return 0;
}

/* Writes the next fragment of s->tx (through the scratch buffer: lws writes the header in
 * front of what it sends, which must not touch a buffer other clients share); drops s->tx
 * after the last. */
static int write_fragment(net *n, net_session *s, struct lws *wsi)
{
    size_t len = net_buf_len(s->tx), k = len - s->tx_off < NET_FRAME_CHUNK ? len - s->tx_off : NET_FRAME_CHUNK;
    bool first = s->tx_off == 0, last = s->tx_off + k == len;
    int kind = (first ? LWS_WRITE_BINARY : LWS_WRITE_CONTINUATION) | (last ? 0 : LWS_WRITE_NO_FIN);
    memcpy(n->scratch + LWS_PRE, net_buf_data(s->tx) + s->tx_off, k);
    int w = lws_write(wsi, n->scratch + LWS_PRE, k, (enum lws_write_protocol)kind);
    if (w < (int)k) return -1;
    atomic_fetch_add(&n->bytes_sent, k);
    s->tx_off += k;
    if (last) {
        net_buf_unref(s->tx);
        s->tx = NULL;
    }
    return 0;
}

/* Starts sending frame b: whole when it is small, else its first fragment (the others follow
 * on the next WRITEABLEs). */
static int write_frame(net *n, net_session *s, struct lws *wsi, net_buf *b)
{
    atomic_fetch_add(&n->frames_sent, 1);
    if (net_buf_len(b) <= NET_FRAME_CHUNK) return write_buf(n, wsi, b, LWS_WRITE_BINARY);
    net_buf_ref(b);
    s->tx = b;
    s->tx_off = 0;
    return write_fragment(n, s, wsi);
}

/* Sends the newest frame the session lacks (its keyframe first when needed). */
static int send_frame(net *n, net_session *s, struct lws *wsi)
{
    net_stream *sl = &n->streams[s->stream];
    uint64_t now = core_now_ns();
    if (s->max_rate > 0 && s->next_due_ns && now < s->next_due_ns) {
        lws_set_timer_usecs(wsi, (lws_usec_t)((s->next_due_ns - now) / 1000 + 1));
        return 0;
    }
    uint64_t sent;
    if (!s->has_key || s->key_seq != sl->latest_key_seq) {
        if (!sl->key || sl->key_seq != sl->latest_key_seq) return 0; /* undecodable until the next keyframe */
        if (write_frame(n, s, wsi, sl->key)) return -1;
        s->has_key = true;
        s->key_seq = sl->key_seq;
        if (sl->latest_seq != sl->key_seq && s->max_rate <= 0) {
            lws_callback_on_writable(wsi); /* the newest frame follows at once */
            return 0;
        }
        /* the keyframe is the newest, or (rate-capped client) it is this slot's frame: the
         * newest frame waits for the next slot, so the cap holds */
        sent = sl->key_count;
    } else {
        if (write_frame(n, s, wsi, sl->latest)) return -1;
        sent = sl->count;
    }
    if (s->last_count && sent > s->last_count + 1) atomic_fetch_add(&n->frames_skipped, sent - s->last_count - 1);
    if (sent > s->last_count) s->last_count = sent;
    if (s->max_rate > 0) {
        uint64_t period = (uint64_t)(1e9 / s->max_rate);
        /* keep the average rate; after a stall start afresh rather than burst */
        s->next_due_ns = !s->next_due_ns || s->next_due_ns + period < now ? now + period : s->next_due_ns + period;
    }
    return 0;
}

static int session_writeable(net *n, net_session *s, struct lws *wsi)
{
    /* a lingering close first finishes the frame being written and the text queued before it */
    if (s->closing && !(s->linger && s->close_code && (s->tx || s->qlen > 0))) {
        if (!s->close_code) return 0; /* lws is already closing it */
        const char *r = s->close_reason ? s->close_reason : "";
        lws_close_reason(wsi, (enum lws_close_status)s->close_code, (unsigned char *)r, strlen(r));
        s->close_code = 0;
        return -1;
    }
    if (s->tx) {
        if (write_fragment(n, s, wsi)) return -1;
    } else if (s->qlen > 0) {
        net_buf *b = s->q[s->qhead];
        s->qhead = (s->qhead + 1) % s->qcap;
        s->qlen--;
        atomic_fetch_sub(&n->text_queued_bytes, net_buf_len(b));
        int rc = write_buf(n, wsi, b, LWS_WRITE_TEXT);
        net_buf_unref(b);
        if (rc) return -1;
        atomic_fetch_add(&n->text_sent, 1);
    } else if (frame_pending(n, s)) {
        if (send_frame(n, s, wsi)) return -1;
    }
    if (s->tx || s->qlen > 0 || s->closing) lws_callback_on_writable(wsi);
    else if (frame_pending(n, s) && !(s->max_rate > 0 && core_now_ns() < s->next_due_ns)) lws_callback_on_writable(wsi);
    else if (frame_pending(n, s)) lws_set_timer_usecs(wsi, (lws_usec_t)((s->next_due_ns - core_now_ns()) / 1000 + 1));
    return 0;
}

/* The peer's close frame, before lws echoes it (RFC 6455 5.5.1, 7.4, 8.1): a 1-byte payload
 * cannot hold a status code (close 1002) and a reason must be UTF-8 (close 1007); lws would
 * echo either. Returning -1 from here makes lws send the close set by lws_close_reason (the
 * connection is still open: lws marks it closing only after this callback). */
static int peer_close(net *n, struct lws *wsi, const unsigned char *in, size_t len)
{
    const char *why = NULL;
    enum lws_close_status code = LWS_CLOSE_STATUS_PROTOCOL_ERR;
    if (len == 1) {
        why = "a close payload of 1 byte: a status code takes 2";
    } else if (len > 2 && !core_utf8_valid((const char *)in + 2, len - 2)) {
        code = LWS_CLOSE_STATUS_INVALID_PAYLOAD;
        why = "close reason is not valid UTF-8";
    }
    if (!why) return 0;
    atomic_fetch_add(&n->protocol_closes, 1);
    lws_close_reason(wsi, code, (unsigned char *)why, strlen(why));
    return -1;
}

int net_ws_callback(struct lws *wsi, enum lws_callback_reasons reason, void *user, void *in, size_t len)
{
    net *n = net_of(wsi);
    net_session *s = user;
    switch (reason) {
    case LWS_CALLBACK_EVENT_WAIT_CANCELLED: net_drain(n); return 0;
    case LWS_CALLBACK_ESTABLISHED: session_open(n, s, wsi); return 0;
    case LWS_CALLBACK_CLOSED: session_closed(n, s); return 0;
    case LWS_CALLBACK_RECEIVE: return session_receive(n, s, wsi, in, len);
    case LWS_CALLBACK_WS_PEER_INITIATED_CLOSE: return peer_close(n, wsi, in, len);
    case LWS_CALLBACK_SERVER_WRITEABLE: return s->wsi ? session_writeable(n, s, wsi) : 0;
    case LWS_CALLBACK_TIMER:
        if (s->wsi) lws_callback_on_writable(wsi);
        return 0;
    default: return 0;
    }
}
