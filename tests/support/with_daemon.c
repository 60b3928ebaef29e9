/* with_daemon: runs a command against a fresh strandcastd on a free loopback port, for ctest.
 *   with_daemon STRANDCASTD [--exit N] [--expect TEXT]... [--daemon FLAG]... -- CMD ARG...
 * starts STRANDCASTD with the test flags (port 0, cpu backend, 128 x 8 strands, one thread,
 * --min-step-rate 0) plus each --daemon FLAG, replaces "{port}" in the command's arguments with
 * its port, runs the command with its output passed through, and stops the daemon. Exits 0 when
 * the command exited N (default 0) and its output holds every TEXT, 1 otherwise, 2 for bad use. */
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "support/daemon.h"

#define MAX_ARGS 64
#define MAX_OUT (1 << 20)

/* Runs argv with stdout and stderr into out (cap bytes, NUL-terminated; also echoed); returns
 * its exit status (128 + signal when killed, -1 when it could not start). */
static int run_capture(char *const argv[], char *out, size_t cap)
{
    int fds[2];
    if (pipe(fds) != 0) return -1;
    pid_t pid = fork();
    if (pid < 0) return -1;
    if (pid == 0) {
        dup2(fds[1], 1);
        dup2(fds[1], 2);
        close(fds[0]);
        execv(argv[0], argv);
        _exit(127);
    }
    close(fds[1]);
    size_t len = 0;
    ssize_t r;
    char buf[4096];
    while ((r = read(fds[0], buf, sizeof buf)) > 0) {
        fwrite(buf, 1, (size_t)r, stdout);
        size_t n = (size_t)r < cap - 1 - len ? (size_t)r : cap - 1 - len;
        memcpy(out + len, buf, n);
        len += n;
    }
    out[len] = '\0';
    close(fds[0]);
    int status;
    if (waitpid(pid, &status, 0) < 0) return -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

int main(int argc, char **argv)
{
    if (argc < 4) {
        fprintf(stderr, "usage: with_daemon STRANDCASTD [--exit N] [--expect TEXT]... [--daemon FLAG]... -- CMD ARG...\n");
        return 2;
    }
    int want_exit = 0, nexpect = 0, i = 2;
    const char *expect[MAX_ARGS];
    char *dargv[MAX_ARGS] = { argv[1], "--port", "0", "--backend", "cpu", "--strands", "128", "--verts", "8",
                              "--threads", "1", "--min-step-rate", "0", NULL };
    int dargc = 13;
    for (; i < argc && strcmp(argv[i], "--"); i += 2) {
        if (i + 1 >= argc || nexpect == MAX_ARGS || dargc + 1 >= MAX_ARGS) {
            fprintf(stderr, "with_daemon: %s needs a value\n", argv[i]);
            return 2;
        }
        if (!strcmp(argv[i], "--exit")) want_exit = atoi(argv[i + 1]);
        else if (!strcmp(argv[i], "--expect")) expect[nexpect++] = argv[i + 1];
        else if (!strcmp(argv[i], "--daemon")) dargv[dargc++] = argv[i + 1];
        else {
            fprintf(stderr, "with_daemon: unknown option %s\n", argv[i]);
            return 2;
        }
    }
    dargv[dargc] = NULL;
    if (i + 1 >= argc || argc - i > MAX_ARGS) {
        fprintf(stderr, "with_daemon: no command after --\n");
        return 2;
    }
    daemon_proc d;
    if (daemon_start(&d, argv[1], dargv, 30000) != 0) {
        fprintf(stderr, "with_daemon: %s did not start\n", argv[1]);
        return 1;
    }
    char port[16];
    snprintf(port, sizeof port, "%d", d.port);
    char *cargv[MAX_ARGS];
    int n = 0;
    for (int j = i + 1; j < argc; j++) cargv[n++] = strcmp(argv[j], "{port}") ? argv[j] : port;
    cargv[n] = NULL;
    static char out[MAX_OUT];
    int rc = run_capture(cargv, out, sizeof out);
    int drc = daemon_stop(&d, SIGTERM, 15000);
    int failed = 0;
    if (rc != want_exit) {
        fprintf(stderr, "with_daemon: %s exited %d, want %d\n", cargv[0], rc, want_exit);
        failed = 1;
    }
    for (int k = 0; k < nexpect; k++)
        if (!strstr(out, expect[k])) {
            fprintf(stderr, "with_daemon: the output does not hold \"%s\"\n", expect[k]);
            failed = 1;
        }
    if (drc != 0) {
        fprintf(stderr, "with_daemon: strandcastd exited %d after SIGTERM\n", drc);
        failed = 1;
    }
    return failed;
}
