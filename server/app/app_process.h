/* app: the process plumbing the daemon and the edge relay share: stop signals and the net thread. */
#ifndef APP_APP_PROCESS_H
#define APP_APP_PROCESS_H

#include <signal.h>
#include <stdbool.h>
#include <time.h>

#include "net/net.h"

/* Blocks SIGINT and SIGTERM on the calling thread (and so on the threads it starts after) into
 * *set, the mask before in *old (restore it with pthread_sigmask), and ignores SIGPIPE. Call on
 * the main thread before starting any other. */
void app_process_block_signals(sigset_t *set, sigset_t *old);

/* Waits up to `tick` for SIGINT or SIGTERM of set (blocked by app_process_block_signals): true
 * when one came (logged as `who`'s shutdown) or the wait failed, false when the tick passed.
 * Main thread. */
bool app_process_stop_signal(const sigset_t *set, struct timespec tick, const char *who);

/* The net thread's body: names the thread "sc-net" (strandbench fanout splits CPU time by thread
 * name) and runs net_run(arg) until net_stop. arg: the net server, owned by the caller. */
void *app_process_net_main(void *arg);

#endif
