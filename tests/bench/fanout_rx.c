/* strandbench fanout: lean raw-socket WebSocket receivers driven by one epoll loop. */
#include "fanout_rx.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <unistd.h>

#include "core/core.h"
#include "support/rawws.h"

#define RX_BUF (256 * 1024)

typedef struct rx_conn {
    int fd;
    uint8_t hdr[14];  /* the frame header being read */
    size_t hlen;      /* header bytes held */
    uint64_t left;    /* payload bytes of the current frame still to come */
    int opcode;       /* opcode of the current frame */
    int msg_opcode;   /* opcode of the message the current frame belongs to */
    bool fin;
    uint8_t ping[125];
    size_t ping_len;
    uint64_t msg_bytes;
    fanout_rx_count count;
} rx_conn;

struct fanout_rx {
    int epfd, n;
    rx_conn *c;
    uint8_t *buf;
};

/* Bytes of header needed once the first two are known (2, 4 or 10; no mask from a server). */
static size_t header_size(const uint8_t *h)
{
    size_t l = h[1] & 127;
    return l == 126 ? 4 : l == 127 ? 10 : 2;
}

static void frame_done(rx_conn *c)
{
    if (c->opcode == 9) rawws_send(c->fd, 10, c->ping, c->ping_len, true); /* pong */
    if (c->opcode == 8) c->count.closed = true;
    if (c->opcode < 8 && c->fin) {
        if (c->msg_opcode == 2) {
            c->count.frames++;
            c->count.bytes += c->msg_bytes;
        }
        c->msg_bytes = 0;
    }
}

/* Walks the bytes just read through the frame headers and payloads. */
static void take(rx_conn *c, const uint8_t *p, size_t n)
{
    while (n > 0) {
        if (c->left == 0 && (c->hlen < 2 || c->hlen < header_size(c->hdr))) {
            c->hdr[c->hlen++] = *p++, n--;
            if (c->hlen < 2 || c->hlen < header_size(c->hdr)) continue;
            uint64_t len = c->hdr[1] & 127;
            if (len == 126) len = (uint64_t)c->hdr[2] << 8 | c->hdr[3];
            if (len == 127) {
                len = 0;
                for (int i = 2; i < 10; i++) len = len << 8 | c->hdr[i];
            }
            c->opcode = c->hdr[0] & 15;
            c->fin = c->hdr[0] & 128;
            if (c->opcode == 1 || c->opcode == 2) c->msg_opcode = c->opcode;
            c->ping_len = 0;
            c->hlen = 0;
            c->left = len;
            if (len == 0) frame_done(c);
            continue;
        }
        size_t k = n < c->left ? n : (size_t)c->left;
        if (c->opcode == 9 && c->ping_len + k <= sizeof c->ping) {
            memcpy(c->ping + c->ping_len, p, k);
            c->ping_len += k;
        }
        if (c->opcode < 8) c->msg_bytes += k;
        p += k, n -= k, c->left -= k;
        if (c->left == 0) frame_done(c);
    }
}

fanout_rx *fanout_rx_open(int port, const char *subprotocol, int n, const char *sub)
{
    fanout_rx *r = calloc(1, sizeof *r);
    if (!r) return NULL;
    r->c = calloc((size_t)(n > 0 ? n : 1), sizeof *r->c);
    r->buf = malloc(RX_BUF);
    r->epfd = epoll_create1(0);
    for (int i = 0; i < n; i++) r->c[i].fd = -1;
    r->n = n;
    if (!r->c || !r->buf || r->epfd < 0) {
        fprintf(stderr, "fanout: out of memory or epoll for %d receivers\n", n);
        fanout_rx_free(r);
        return NULL;
    }
    for (int i = 0; i < n; i++) {
        rx_conn *c = &r->c[i];
        c->fd = rawws_open(port, subprotocol);
        if (c->fd < 0 || rawws_send(c->fd, 1, sub, strlen(sub), true) != 0) {
            fprintf(stderr, "fanout: receiver %d could not connect to port %d\n", i, port);
            fanout_rx_free(r);
            return NULL;
        }
        fcntl(c->fd, F_SETFL, fcntl(c->fd, F_GETFL) | O_NONBLOCK);
        struct epoll_event ev = { .events = EPOLLIN, .data.ptr = c };
        epoll_ctl(r->epfd, EPOLL_CTL_ADD, c->fd, &ev);
    }
    return r;
}

void fanout_rx_run(fanout_rx *r, int ms)
{
    const unsigned long long end = core_now_ns() + (unsigned long long)ms * 1000000ull;
    struct epoll_event ev[64];
    for (unsigned long long t = core_now_ns(); t < end; t = core_now_ns()) {
        int k = epoll_wait(r->epfd, ev, 64, (int)((end - t + 999999ull) / 1000000ull));
        for (int i = 0; i < k; i++) {
            rx_conn *c = ev[i].data.ptr;
            ssize_t got = read(c->fd, r->buf, RX_BUF);
            if (got > 0) {
                take(c, r->buf, (size_t)got);
            } else if (got == 0 || (errno != EAGAIN && errno != EINTR)) {
                c->count.closed = true;
                epoll_ctl(r->epfd, EPOLL_CTL_DEL, c->fd, NULL);
            }
        }
    }
}

const fanout_rx_count *fanout_rx_count_of(const fanout_rx *r, int i) { return &r->c[i].count; }

void fanout_rx_free(fanout_rx *r)
{
    if (!r) return;
    for (int i = 0; i < r->n; i++)
        if (r->c && r->c[i].fd >= 0) close(r->c[i].fd);
    if (r->epfd >= 0) close(r->epfd);
    free(r->c);
    free(r->buf);
    free(r);
}
