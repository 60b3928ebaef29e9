/* app: the bounded command mailbox from the net thread to the sim thread (mutex + condvar).
 * Owns the queued commands (copies); depends on proto for the message type. */
#ifndef APP_MAILBOX_H
#define APP_MAILBOX_H

#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

#include "core/core.h"
#include "proto/proto.h"

#define APP_MAILBOX 256 /* queued commands from the net thread; more -> "busy" error */

typedef enum app_cmd_kind { APP_CMD_OPEN, APP_CMD_CLOSE, APP_CMD_MSG } app_cmd_kind;

/* One command: a client connected, left, or sent a parsed message. */
typedef struct app_cmd {
    app_cmd_kind kind;
    uint32_t client;
    proto_msg msg;
} app_cmd;

typedef struct app_mailbox {
    pthread_mutex_t mu;
    pthread_cond_t cv;        /* signalled on every post (CLOCK_MONOTONIC waits) */
    app_cmd *ring;
    int head, len;
    bool wake;                /* set by app_mailbox_wake */
    atomic_bool change;       /* a set_params, animate or reset is queued (app_mailbox_change_waiting) */
} app_mailbox;

/* An empty mailbox of APP_MAILBOX commands; CORE_ENOMEM. The caller owns it (app_mailbox_free). */
core_status app_mailbox_init(app_mailbox *m, core_err *err);
void app_mailbox_free(app_mailbox *m);
/* Queues a copy of *c; a motion replaces a motion without an id still at the tail (newest wins;
 * one with an id is kept, for its reply).
 * CORE_ENOMEM when full. Any thread. */
core_status app_mailbox_post(app_mailbox *m, const app_cmd *c);
/* True while a command that changes the simulation at once (set_params, animate, reset) is
 * queued: the sim thread may then abandon the step in progress to take it (sim_set_cancel).
 * Cleared when the mailbox is emptied. Lock-free; sim thread. */
bool app_mailbox_change_waiting(app_mailbox *m);
/* Takes the oldest command into *out; false when empty. Sim thread. */
bool app_mailbox_take(app_mailbox *m, app_cmd *out);
/* Blocks until a post, app_mailbox_wake, or the monotonic deadline (ns). Sim thread. */
void app_mailbox_wait(app_mailbox *m, unsigned long long deadline_ns);
/* Wakes app_mailbox_wait. Any thread. */
void app_mailbox_wake(app_mailbox *m);

#endif
