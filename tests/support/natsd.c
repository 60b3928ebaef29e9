/* Test support: nats-server as a child process. */
#include "natsd.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

const char *natsd_exe(void)
{
    const char *e = getenv("NATSD_EXE");
    if (e && access(e, X_OK) == 0) return e;
    static const char *const paths[] = { "/usr/sbin/nats-server", "/usr/bin/nats-server", "/usr/local/bin/nats-server" };
    for (size_t i = 0; i < sizeof paths / sizeof paths[0]; i++)
        if (access(paths[i], X_OK) == 0) return paths[i];
    return NULL;
}

int natsd_free_port(void)
{
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in a = { .sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
    socklen_t len = sizeof a;
    int port = -1;
    if (fd >= 0 && bind(fd, (struct sockaddr *)&a, sizeof a) == 0 && getsockname(fd, (struct sockaddr *)&a, &len) == 0)
        port = ntohs(a.sin_port);
    if (fd >= 0) close(fd);
    return port;
}

static bool accepts(int port)
{
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in a = { .sin_family = AF_INET, .sin_port = htons((uint16_t)port), .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
    bool ok = fd >= 0 && connect(fd, (struct sockaddr *)&a, sizeof a) == 0;
    if (fd >= 0) close(fd);
    return ok;
}

/* Starts exe with the listen flags, then token's (NULL: none) or conf's (NULL: none). */
static int start(natsd *n, int port, const char *token, const char *conf)
{
    const char *exe = natsd_exe();
    memset(n, 0, sizeof *n);
    if (!exe) return -1;
    n->port = port ? port : natsd_free_port();
    char ps[16];
    snprintf(ps, sizeof ps, "%d", n->port);
    if (token) snprintf(n->url, sizeof n->url, "nats://%s@127.0.0.1:%d", token, n->port);
    else snprintf(n->url, sizeof n->url, "nats://127.0.0.1:%d", n->port);
    pid_t pid = fork();
    if (pid < 0) return -1;
    if (pid == 0) {
        prctl(PR_SET_PDEATHSIG, SIGTERM);
        int devnull = open("/dev/null", O_WRONLY);
        if (devnull >= 0) {
            dup2(devnull, 1);
            dup2(devnull, 2);
        }
        const char *more = token ? "--auth" : conf ? "-c" : NULL;
        execl(exe, exe, "-a", "127.0.0.1", "-p", ps, more, token ? token : conf, (char *)NULL);
        _exit(127);
    }
    n->pid = pid;
    for (int i = 0; i < 100; i++) {
        if (accepts(n->port)) return 0;
        struct timespec ts = { 0, 50 * 1000 * 1000 };
        nanosleep(&ts, NULL);
    }
    natsd_stop(n);
    return -1;
}

int natsd_start(natsd *n, int port, const char *token) { return start(n, port, token, NULL); }

int natsd_start_conf(natsd *n, int port, const char *conf) { return start(n, port, NULL, conf); }

void natsd_stop(natsd *n)
{
    if (n->pid <= 0) return;
    kill(n->pid, SIGTERM);
    for (int i = 0; i < 40; i++) {
        if (waitpid(n->pid, NULL, WNOHANG) == n->pid) {
            n->pid = 0;
            return;
        }
        struct timespec ts = { 0, 50 * 1000 * 1000 };
        nanosleep(&ts, NULL);
    }
    kill(n->pid, SIGKILL);
    waitpid(n->pid, NULL, 0);
    n->pid = 0;
}
