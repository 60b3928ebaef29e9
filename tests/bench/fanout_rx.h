/* strandbench fanout: many lean loopback WebSocket receivers on one thread (raw sockets, epoll),
 * so the bench's own CPU per client frame is close to the kernel's copy and the measured
 * machine's cores are left to the server. */
#ifndef BENCH_FANOUT_RX_H
#define BENCH_FANOUT_RX_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef struct fanout_rx fanout_rx;

/* What one receiver has taken in so far. */
typedef struct fanout_rx_count {
    uint64_t frames; /* complete binary messages (strand frames) */
    uint64_t bytes;  /* their payload bytes */
    bool closed;     /* the server closed or reset the connection */
} fanout_rx_count;

/* Opens n connections to the daemon on 127.0.0.1:port with the subprotocol, sends each the text
 * message sub (e.g. a subscribe), and returns the set, or NULL (with a line on stderr) when a
 * connection fails. The caller owns the set (fanout_rx_free). One thread. */
fanout_rx *fanout_rx_open(int port, const char *subprotocol, int n, const char *sub);

/* Reads every connection for ms milliseconds: counts binary messages, answers pings with pongs,
 * skips text. */
void fanout_rx_run(fanout_rx *r, int ms);

/* The counts of connection i (0 <= i < n). */
const fanout_rx_count *fanout_rx_count_of(const fanout_rx *r, int i);

/* Closes every connection and frees the set; NULL is fine. */
void fanout_rx_free(fanout_rx *r);

#endif
