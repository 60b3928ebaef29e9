/* Test support: run strandcastd as a child process, and plain HTTP requests over a socket. */
#ifndef TESTS_DAEMON_H
#define TESTS_DAEMON_H

#include <stddef.h>
#include <sys/types.h>

typedef struct daemon_proc {
    pid_t pid;
    int out_fd;   /* the child's stdout */
    int port;     /* parsed from "open http://ADDR:PORT/" (or https) */
} daemon_proc;

/* Starts exe with argv (NULL-terminated, argv[0] included) and waits up to timeout_ms for the
 * printed URL. Returns 0 on success. */
int daemon_start(daemon_proc *d, const char *exe, char *const argv[], int timeout_ms);

/* Sends sig (0: none, just wait) and waits up to timeout_ms; returns the exit status, 128+signal when killed by a
 * signal, or -1 on timeout (the child is then killed). */
int daemon_stop(daemon_proc *d, int sig, int timeout_ms);

/* A finished HTTP exchange. */
typedef struct http_reply {
    int status;
    char content_type[128];
    char *body;        /* NUL-terminated, malloc'd */
    size_t body_len;
    char *raw;         /* the whole response */
} http_reply;

/* Sends request (a full HTTP/1.1 request text) to 127.0.0.1:port and reads the reply until the
 * server closes or timeout_ms. Returns 0 on success. */
int http_exchange(int port, const char *request, http_reply *r, int timeout_ms);
/* GET path with Connection: close. */
int http_get(int port, const char *path, http_reply *r);
void http_reply_free(http_reply *r);

#endif
