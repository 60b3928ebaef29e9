/* Test support: a raw-socket WebSocket client for protocol-violation tests (exact frames on the wire). */
#include "rawws.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <errno.h>
#include <poll.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

static long long now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (long long)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

int rawws_open(int port, const char *subprotocol) { return rawws_open_rcvbuf(port, subprotocol, 0); }

int rawws_open_rcvbuf(int port, const char *subprotocol, int rcvbuf)
{
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    if (fd < 0) return -1;
    if (rcvbuf > 0) setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
    struct sockaddr_in a = { 0 };
    a.sin_family = AF_INET;
    a.sin_port = htons((uint16_t)port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    char req[512];
    int n = snprintf(req, sizeof req,
                     "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                     "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
                     "Sec-WebSocket-Protocol: %s\r\n\r\n",
                     subprotocol);
    if (connect(fd, (struct sockaddr *)&a, sizeof a) != 0 || write(fd, req, (size_t)n) != n) {
        close(fd);
        return -1;
    }
    /* read the 101 response headers byte by byte so no frame data is consumed */
    char hdr[2048];
    size_t len = 0;
    long long end = now_ms() + 5000;
    while (len + 1 < sizeof hdr && now_ms() < end) {
        struct pollfd p = { fd, POLLIN, 0 };
        if (poll(&p, 1, 50) <= 0) continue;
        if (read(fd, hdr + len, 1) != 1) break;
        len++;
        hdr[len] = '\0';
        if (len >= 4 && memcmp(hdr + len - 4, "\r\n\r\n", 4) == 0) {
            if (strncmp(hdr, "HTTP/1.1 101", 12) == 0) return fd;
            break;
        }
    }
    close(fd);
    return -1;
}

int rawws_send_bytes(int fd, const void *bytes, size_t len)
{
    size_t sent = 0;
    while (sent < len) {
        ssize_t w = send(fd, (const unsigned char *)bytes + sent, len - sent, MSG_NOSIGNAL);
        if (w <= 0) return -1;
        sent += (size_t)w;
    }
    return 0;
}

int rawws_send(int fd, int opcode, const void *payload, size_t len, bool fin)
{
    unsigned char *f = malloc(len + 14);
    size_t h = 0;
    f[h++] = (unsigned char)((fin ? 0x80 : 0) | opcode);
    if (len < 126) {
        f[h++] = (unsigned char)(0x80 | len);
    } else if (len < 65536) {
        f[h++] = 0x80 | 126;
        f[h++] = (unsigned char)(len >> 8);
        f[h++] = (unsigned char)len;
    } else {
        f[h++] = 0x80 | 127;
        for (int i = 7; i >= 0; i--) f[h++] = (unsigned char)((uint64_t)len >> (8 * i));
    }
    static const unsigned char mask[4] = { 0x37, 0xfa, 0x21, 0x3d };
    memcpy(f + h, mask, 4);
    h += 4;
    for (size_t i = 0; i < len; i++) f[h + i] = ((const unsigned char *)payload)[i] ^ mask[i % 4];
    int rc = rawws_send_bytes(fd, f, h + len);
    free(f);
    return rc;
}

int rawws_close_code(int fd, int timeout_ms)
{
    unsigned char *buf = NULL;
    size_t len = 0, cap = 0;
    long long end = now_ms() + timeout_ms;
    int code = -1;
    while (now_ms() < end) {
        /* parse complete frames */
        size_t i = 0;
        while (len - i >= 2) {
            size_t plen = buf[i + 1] & 127, off = 2;
            if (plen == 126) {
                if (len - i < 4) break;
                plen = ((size_t)buf[i + 2] << 8) | buf[i + 3];
                off = 4;
            } else if (plen == 127) {
                if (len - i < 10) break;
                plen = 0;
                for (int k = 0; k < 8; k++) plen = (plen << 8) | buf[i + 2 + k];
                off = 10;
            }
            if (len - i < off + plen) break;
            if ((buf[i] & 15) == 8) {
                code = plen >= 2 ? (buf[i + off] << 8) | buf[i + off + 1] : 1005;
                free(buf);
                return code;
            }
            i += off + plen;
        }
        if (i) {
            memmove(buf, buf + i, len - i);
            len -= i;
        }
        struct pollfd p = { fd, POLLIN, 0 };
        if (poll(&p, 1, 50) <= 0) continue;
        if (len + 65536 > cap) buf = realloc(buf, cap = len + 65536);
        ssize_t r = read(fd, buf + len, cap - len);
        if (r <= 0) {
            fprintf(stderr, "rawws: read %zd (%s) with %zu bytes pending\n", r, r < 0 ? strerror(errno) : "eof", len);
            code = 0;
            break;
        }
        len += (size_t)r;
    }
    free(buf);
    return code;
}

/* Reads exactly n bytes before the deadline: 1 done, 0 EOF/error, -1 timeout. */
static int read_exact(int fd, unsigned char *buf, size_t n, long long end)
{
    size_t got = 0;
    while (got < n) {
        long long left = end - now_ms();
        if (left <= 0) return -1;
        struct pollfd p = { fd, POLLIN, 0 };
        if (poll(&p, 1, (int)(left < 50 ? left : 50)) <= 0) continue;
        ssize_t r = read(fd, buf + got, n - got);
        if (r <= 0) return 0;
        got += (size_t)r;
    }
    return 1;
}

int rawws_next_control(int fd, int timeout_ms, int *close_code)
{
    long long start_by = now_ms() + timeout_ms;
    unsigned char h[8], skip[4096];
    for (;;) {
        int rc = read_exact(fd, h, 1, start_by);
        if (rc <= 0) return rc;
        long long end = now_ms() + 5000;
        if ((rc = read_exact(fd, h + 1, 1, end)) <= 0) return rc;
        int opcode = h[0] & 15;
        uint64_t plen = h[1] & 127;
        if (plen >= 126) {
            size_t ext = plen == 126 ? 2 : 8;
            if ((rc = read_exact(fd, h, ext, end)) <= 0) return rc;
            plen = 0;
            for (size_t k = 0; k < ext; k++) plen = (plen << 8) | h[k];
        }
        unsigned char first[2] = { 0, 0 };
        for (uint64_t done = 0; done < plen;) {
            size_t n = plen - done < sizeof skip ? (size_t)(plen - done) : sizeof skip;
            if ((rc = read_exact(fd, skip, n, end)) <= 0) return rc;
            if (done == 0) memcpy(first, skip, n < 2 ? n : 2);
            done += n;
        }
        if (opcode == 8 && close_code) *close_code = plen >= 2 ? (first[0] << 8) | first[1] : 1005;
        if (opcode >= 8) return opcode;
    }
}

void rawws_free(int fd)
{
    if (fd >= 0) close(fd);
}
