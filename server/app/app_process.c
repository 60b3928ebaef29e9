/* app: the process plumbing the daemon and the edge relay share: stop signals and the net thread. */
#include "app_process.h"

#include <errno.h>
#include <pthread.h>
#include <sys/prctl.h>

#include "core/core.h"

void app_process_block_signals(sigset_t *set, sigset_t *old)
{
    sigemptyset(set);
    sigaddset(set, SIGINT);
    sigaddset(set, SIGTERM);
    pthread_sigmask(SIG_BLOCK, set, old);
    signal(SIGPIPE, SIG_IGN);
}

bool app_process_stop_signal(const sigset_t *set, struct timespec tick, const char *who)
{
    int sig = sigtimedwait(set, NULL, &tick);
    if (sig == SIGINT || sig == SIGTERM) {
        core_log(CORE_LOG_INFO, who, "%s: shutting down", sig == SIGINT ? "SIGINT" : "SIGTERM");
        return true;
    }
    return sig < 0 && errno != EAGAIN && errno != EINTR;
}

void *app_process_net_main(void *arg)
{
    prctl(PR_SET_NAME, "sc-net");
    net_run(arg);
    return NULL;
}
