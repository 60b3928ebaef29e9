/* Test support: a raw-socket WebSocket client for protocol-violation tests (exact frames on the wire). */
#ifndef TESTS_RAWWS_H
#define TESTS_RAWWS_H

#include <stdbool.h>
#include <stddef.h>

/* Connects and upgrades with Sec-WebSocket-Protocol: subprotocol; returns the socket or -1. */
int rawws_open(int port, const char *subprotocol);
/* The same with a receive buffer of rcvbuf bytes set before connecting (so the TCP window is
 * small from the start: a client that does not read stalls the server's writes at once). */
int rawws_open_rcvbuf(int port, const char *subprotocol, int rcvbuf);
/* Sends one masked frame (opcode 1 text, 2 binary, 0 continuation). Returns 0 on success. */
int rawws_send(int fd, int opcode, const void *payload, size_t len, bool fin);
/* Writes bytes as they are (a hand-made frame, e.g. an unmasked one). Returns 0 on success. */
int rawws_send_bytes(int fd, const void *bytes, size_t len);
/* Reads frames until a close frame (returns its code, 1005 when it has none), EOF/error (0) or
 * timeout (-1). */
int rawws_close_code(int fd, int timeout_ms);
/* Reads whole frames, skipping data frames, until a control frame arrives: returns its opcode
 * (8 close, with its code in *close_code, 1005 when it has none; 9 ping; 10 pong), 0 on EOF or a
 * reset, -1 when no frame started within timeout_ms (the stream stays in step: a frame that has
 * started is read to its end) or a started frame did not end within 5 s more. Reads no byte past
 * the control frame. */
int rawws_next_control(int fd, int timeout_ms, int *close_code);
void rawws_free(int fd);

#endif
