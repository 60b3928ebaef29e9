/* app: the net-thread side: parse client text into commands, reply to rejects, /metrics lines. */
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "app_internal.h"

void app_send(app *a, uint32_t client, char *text, unsigned flags)
{
    if (!text) {
        core_log(CORE_LOG_ERROR, "app", "out of memory building a message for client %u", client);
        return;
    }
    if (a->net && net_send_text(a->net, client, text, strlen(text), flags) != CORE_OK)
        core_log(CORE_LOG_WARN, "app", "message to client %u dropped (net inbox full)", client);
    proto_free(text);
}

void app_reply_error(app *a, uint32_t client, const proto_id *id, const proto_error *e)
{
    atomic_fetch_add(&a->rejected, 1);
    app_send(a, client, proto_build_error(id, e), 0);
}

/* Queues c, or answers busy when the mailbox is full; true when queued. */
static bool post(app *a, const app_cmd *c, const proto_id *id)
{
    if (app_mailbox_post(&a->mb, c) == CORE_OK) return true;
    proto_error e;
    proto_fail(&e, PROTO_ERR_BUSY, "", "the server's command queue is full; retry later");
    app_reply_error(a, c->client, id, &e);
    return false;
}

/* Opens and closes must not be lost (a client would get no hello, or keep its stream alive):
 * when the mailbox is full, wait for the sim thread to make room. */
static void post_essential(app *a, const app_cmd *c)
{
    while (app_mailbox_post(&a->mb, c) != CORE_OK && !atomic_load(&a->sim_done)) {
        struct timespec ms = { 0, 1000000 };
        app_mailbox_wake(&a->mb);
        nanosleep(&ms, NULL);
    }
}

void app_on_open(void *user, uint32_t client)
{
    app_cmd c = { .kind = APP_CMD_OPEN, .client = client };
    post_essential(user, &c);
}

void app_on_close(void *user, uint32_t client)
{
    app_cmd c = { .kind = APP_CMD_CLOSE, .client = client };
    post_essential(user, &c);
}

void app_on_text(void *user, uint32_t client, const char *text, size_t len)
{
    app *a = user;
    app_cmd c = { .kind = APP_CMD_MSG, .client = client };
    proto_error e;
    if (proto_parse(&a->parser, text, len, &c.msg, &e) != CORE_OK) {
        app_reply_error(a, client, &c.msg.id, &e);
        return;
    }
    if (c.msg.type != PROTO_SET_GROOM) {
        post(a, &c, &c.msg.id);
        return;
    }
    /* a groom change rebuilds the simulation on the sim thread (up to ~0.3 s for the largest):
     * one at a time, so that no client can queue up seconds of stalls for everyone */
    if (atomic_fetch_add(&a->grooms_pending, 1) > 0) {
        atomic_fetch_sub(&a->grooms_pending, 1);
        proto_fail(&e, PROTO_ERR_BUSY, "", "a groom change is already in progress; retry after its groom message");
        app_reply_error(a, client, &c.msg.id, &e);
        return;
    }
    if (!post(a, &c, &c.msg.id)) atomic_fetch_sub(&a->grooms_pending, 1);
}

size_t app_metrics(void *user, char *buf, size_t cap)
{
    app *a = user;
    pthread_mutex_lock(&a->stats_mu);
    app_stats s = a->stats;
    pthread_mutex_unlock(&a->stats_mu);
    int w = snprintf(buf, cap,
                     "# HELP strandcast_steps_per_second Simulation steps per second (last second).\n"
                     "# TYPE strandcast_steps_per_second gauge\nstrandcast_steps_per_second %.3f\n"
                     "# HELP strandcast_step_seconds Mean wall time of one simulation step (last second).\n"
                     "# TYPE strandcast_step_seconds gauge\nstrandcast_step_seconds %.6f\n"
                     "# HELP strandcast_steps_total Simulation steps run since the daemon started.\n"
                     "# TYPE strandcast_steps_total counter\nstrandcast_steps_total %llu\n"
                     "# HELP strandcast_sim_steps Steps of the current simulation (since start, reset or groom change).\n"
                     "# TYPE strandcast_sim_steps gauge\nstrandcast_sim_steps %llu\n"
                     "# HELP strandcast_sim_time_seconds Simulated time since start or reset.\n"
                     "# TYPE strandcast_sim_time_seconds gauge\nstrandcast_sim_time_seconds %.6f\n"
                     "# HELP strandcast_encode_seconds Mean wall time to encode one frame round, all streams (last second).\n"
                     "# TYPE strandcast_encode_seconds gauge\nstrandcast_encode_seconds %.6f\n"
                     "# HELP strandcast_frames_encoded_total Frames encoded (once per stream, shared by its clients).\n"
                     "# TYPE strandcast_frames_encoded_total counter\nstrandcast_frames_encoded_total %llu\n"
                     "# HELP strandcast_encoded_bytes_total Bytes of encoded frames.\n"
                     "# TYPE strandcast_encoded_bytes_total counter\nstrandcast_encoded_bytes_total %llu\n"
                     "# HELP strandcast_nan_resets_total Strands restored to rest after a non-finite value, since the daemon started.\n"
                     "# TYPE strandcast_nan_resets_total counter\nstrandcast_nan_resets_total %llu\n"
                     "# HELP strandcast_control_messages_total Client control messages by outcome.\n"
                     "# TYPE strandcast_control_messages_total counter\n"
                     "strandcast_control_messages_total{result=\"accepted\"} %llu\n"
                     "strandcast_control_messages_total{result=\"rejected\"} %llu\n",
                     s.steps_per_s, s.step_ms / 1e3, (unsigned long long)s.steps_run, (unsigned long long)s.steps,
                     s.sim_time, s.encode_ms / 1e3, (unsigned long long)s.frames_encoded,
                     (unsigned long long)s.encode_bytes, (unsigned long long)s.nan_resets_run, (unsigned long long)atomic_load(&a->accepted),
                     (unsigned long long)atomic_load(&a->rejected));
    if (w < 0) return 0;
    return (size_t)w < cap ? (size_t)w : cap - 1;
}
