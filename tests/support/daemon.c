/* Test support: run strandcastd as a child process, and plain HTTP requests over a socket. */
#include "daemon.h"

#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

static long long now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (long long)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

int daemon_start(daemon_proc *d, const char *exe, char *const argv[], int timeout_ms)
{
    int fds[2];
    memset(d, 0, sizeof *d);
    if (pipe(fds) != 0) return -1;
    pid_t pid = fork();
    if (pid < 0) return -1;
    if (pid == 0) {
        prctl(PR_SET_PDEATHSIG, SIGTERM); /* never outlive a test killed by its timeout */
        dup2(fds[1], 1);
        close(fds[0]);
        close(fds[1]);
        execv(exe, argv);
        _exit(127);
    }
    close(fds[1]);
    d->pid = pid;
    d->out_fd = fds[0];
    char buf[1024];
    size_t len = 0;
    long long end = now_ms() + timeout_ms;
    while (now_ms() < end && len + 1 < sizeof buf) {
        struct pollfd p = { d->out_fd, POLLIN, 0 };
        if (poll(&p, 1, 50) <= 0) continue;
        ssize_t n = read(d->out_fd, buf + len, sizeof buf - 1 - len);
        if (n <= 0) break;
        len += (size_t)n;
        buf[len] = '\0';
        const char *u = strstr(buf, "open http");
        const char *host = u ? strstr(u, "://") : NULL; /* http:// or https:// */
        if (host) host += 3;
        const char *host_end = host && host[0] == '[' ? strchr(host, ']') : host; /* [v6]:port */
        const char *colon = host_end ? strchr(host_end, ':') : NULL;
        if (colon && strchr(colon, '/')) {
            d->port = atoi(colon + 1);
            return d->port > 0 ? 0 : -1;
        }
    }
    daemon_stop(d, SIGKILL, 2000);
    return -1;
}

int daemon_stop(daemon_proc *d, int sig, int timeout_ms)
{
    if (d->pid <= 0) return -1;
    kill(d->pid, sig);
    long long end = now_ms() + timeout_ms;
    int status = 0;
    for (;;) {
        pid_t r = waitpid(d->pid, &status, WNOHANG);
        if (r == d->pid) break;
        if (now_ms() > end) {
            kill(d->pid, SIGKILL);
            waitpid(d->pid, &status, 0);
            d->pid = 0;
            close(d->out_fd);
            return -1;
        }
        struct timespec ms = { 0, 10 * 1000 * 1000 };
        nanosleep(&ms, NULL);
    }
    d->pid = 0;
    close(d->out_fd);
    if (WIFEXITED(status)) return WEXITSTATUS(status);
    return 128 + WTERMSIG(status);
}

int http_exchange(int port, const char *request, http_reply *r, int timeout_ms)
{
    memset(r, 0, sizeof *r);
    int s = socket(AF_INET, SOCK_STREAM, 0);
    if (s < 0) return -1;
    struct sockaddr_in a = { 0 };
    a.sin_family = AF_INET;
    a.sin_port = htons((uint16_t)port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (connect(s, (struct sockaddr *)&a, sizeof a) != 0 || write(s, request, strlen(request)) != (ssize_t)strlen(request)) {
        close(s);
        return -1;
    }
    size_t cap = 4096, len = 0;
    char *buf = malloc(cap);
    long long end = now_ms() + timeout_ms;
    while (now_ms() < end) {
        struct pollfd p = { s, POLLIN, 0 };
        if (poll(&p, 1, 50) <= 0) continue;
        if (len + 1024 > cap) buf = realloc(buf, cap *= 2);
        ssize_t n = read(s, buf + len, cap - len - 1);
        if (n <= 0) break;
        len += (size_t)n;
    }
    close(s);
    buf[len] = '\0';
    r->raw = buf;
    if (sscanf(buf, "HTTP/1.%*d %d", &r->status) != 1) return -1;
    char *hdr_end = strstr(buf, "\r\n\r\n");
    if (!hdr_end) return -1;
    for (char *line = strstr(buf, "\r\n"); line && line < hdr_end; line = strstr(line + 2, "\r\n")) {
        if (strncasecmp(line + 2, "content-type:", 13) == 0) {
            const char *v = line + 15;
            while (*v == ' ') v++;
            size_t n = strcspn(v, "\r");
            snprintf(r->content_type, sizeof r->content_type, "%.*s", (int)n, v);
        }
    }
    r->body_len = len - (size_t)(hdr_end + 4 - buf);
    r->body = malloc(r->body_len + 1);
    memcpy(r->body, hdr_end + 4, r->body_len);
    r->body[r->body_len] = '\0';
    return 0;
}

int http_get(int port, const char *path, http_reply *r)
{
    char req[512];
    snprintf(req, sizeof req, "GET %s HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n", path);
    return http_exchange(port, req, r, 5000);
}

void http_reply_free(http_reply *r)
{
    free(r->body);
    free(r->raw);
    memset(r, 0, sizeof *r);
}
