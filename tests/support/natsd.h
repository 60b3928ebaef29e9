/* Test support: a nats-server child process on loopback (for simulation nodes and edge relays). */
#ifndef TESTS_NATSD_H
#define TESTS_NATSD_H

#include <stdbool.h>
#include <sys/types.h>

typedef struct natsd {
    pid_t pid;
    int port;
    char url[128];   /* nats://[token@]127.0.0.1:port */
} natsd;

/* The nats-server binary (NATSD_EXE, else nats-server on the PATH or /usr/sbin/nats-server), or
 * NULL when there is none. */
const char *natsd_exe(void);
/* A free loopback TCP port (bound, read and released). */
int natsd_free_port(void);
/* Starts nats-server on 127.0.0.1:port (0 = a free one) requiring token (NULL = none) and waits up
 * to 5 s until it accepts connections. 0 on success. */
int natsd_start(natsd *n, int port, const char *token);
/* As natsd_start, with nats-server's configuration file conf (-c) and no token. */
int natsd_start_conf(natsd *n, int port, const char *conf);
/* Stops it (SIGTERM, then SIGKILL after 2 s) and reaps it. */
void natsd_stop(natsd *n);

#endif
