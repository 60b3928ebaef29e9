/* app: the bounded command mailbox from the net thread to the sim thread (mutex + condvar). */
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "app_mailbox.h"

core_status app_mailbox_init(app_mailbox *m, core_err *err)
{
    memset(m, 0, sizeof *m);
    m->ring = calloc(APP_MAILBOX, sizeof *m->ring);
    if (!m->ring) return core_fail(err, CORE_ENOMEM, "out of memory for the command mailbox");
    pthread_condattr_t ca;
    pthread_condattr_init(&ca);
    pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
    pthread_cond_init(&m->cv, &ca);
    pthread_condattr_destroy(&ca);
    pthread_mutex_init(&m->mu, NULL);
    return CORE_OK;
}

void app_mailbox_free(app_mailbox *m)
{
    if (!m->ring) return;
    pthread_mutex_destroy(&m->mu);
    pthread_cond_destroy(&m->cv);
    free(m->ring);
    memset(m, 0, sizeof *m);
}

/* Commands a step in progress may be abandoned for: the changes a tuning user waits to see. A
 * motion is not one (clients stream them every frame; they take the next step). */
static bool is_change(const app_cmd *c)
{
    if (c->kind != APP_CMD_MSG) return false;
    return c->msg.type == PROTO_SET_PARAMS || c->msg.type == PROTO_ANIMATE || c->msg.type == PROTO_RESET;
}

core_status app_mailbox_post(app_mailbox *m, const app_cmd *c)
{
    bool motion = c->kind == APP_CMD_MSG && c->msg.type == PROTO_MOTION;
    pthread_mutex_lock(&m->mu);
    if (motion && m->len > 0) {
        app_cmd *tail = &m->ring[(m->head + m->len - 1) % APP_MAILBOX];
        /* only a motion that expects no reply may be replaced */
        if (tail->kind == APP_CMD_MSG && tail->msg.type == PROTO_MOTION && tail->msg.id.kind == PROTO_ID_NONE) {
            *tail = *c;
            pthread_mutex_unlock(&m->mu);
            return CORE_OK;
        }
    }
    if (m->len == APP_MAILBOX) {
        pthread_mutex_unlock(&m->mu);
        return CORE_ENOMEM;
    }
    m->ring[(m->head + m->len) % APP_MAILBOX] = *c;
    m->len++;
    if (is_change(c)) atomic_store(&m->change, true);
    pthread_cond_signal(&m->cv);
    pthread_mutex_unlock(&m->mu);
    return CORE_OK;
}

bool app_mailbox_change_waiting(app_mailbox *m) { return atomic_load(&m->change); }

bool app_mailbox_take(app_mailbox *m, app_cmd *out)
{
    pthread_mutex_lock(&m->mu);
    bool got = m->len > 0;
    if (got) {
        *out = m->ring[m->head];
        m->head = (m->head + 1) % APP_MAILBOX;
        m->len--;
    }
    if (m->len == 0) atomic_store(&m->change, false);
    pthread_mutex_unlock(&m->mu);
    return got;
}

void app_mailbox_wait(app_mailbox *m, unsigned long long deadline_ns)
{
    struct timespec ts = { (time_t)(deadline_ns / 1000000000ull), (long)(deadline_ns % 1000000000ull) };
    pthread_mutex_lock(&m->mu);
    while (m->len == 0 && !m->wake && core_now_ns() < deadline_ns)
        if (pthread_cond_timedwait(&m->cv, &m->mu, &ts) != 0) break;
    m->wake = false;
    pthread_mutex_unlock(&m->mu);
}

void app_mailbox_wake(app_mailbox *m)
{
    pthread_mutex_lock(&m->mu);
    m->wake = true;
    pthread_cond_signal(&m->cv);
    pthread_mutex_unlock(&m->mu);
}
